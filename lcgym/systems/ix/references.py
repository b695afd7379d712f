"""The IX's references: third-order point-to-point setpoints and the seeded reference sets.

Sets (all seeded):

* ``"calibration"``: paper 000, V-A: each axis swept over its range and back, at several speeds,
  for several positions of the other axis (the default sizes give about 1e6 samples, the
  paper's data set size).
* ``"train"``, ``"validation"``, ``"test"``: random point-to-point moves of both axes at random
  fractions of the speed limits with random dwells, from one distribution and disjoint random
  streams, so that validation and test references are "new but similar" to the training ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ...references import AxisLimits, AxisProfile, Reference, sample, stream

DEG = math.pi / 180.0
AXES = ("propeller", "roll")

IX_LIMITS = (
    AxisLimits(-60 * DEG, 60 * DEG, 15 * DEG, 30 * DEG, 200 * DEG),  # propeller
    AxisLimits(-90 * DEG, 90 * DEG, 20 * DEG, 40 * DEG, 300 * DEG),  # roll
)


def random_moves(
    name: str, rng: np.random.Generator, duration: float = 40.0, fs: float = 500.0,
    limits: Sequence[AxisLimits] = IX_LIMITS, margin: float = 5 * DEG,
) -> Reference:
    """Both axes move point to point between random positions in their range, at random
    fractions (0.4-1) of their limits, with random dwells (0.3-2 s), for about ``duration`` s."""
    profiles = []
    for lim in limits:
        lo, hi = lim.low + margin, lim.high - margin
        p = AxisProfile(rng.uniform(lo, hi)).dwell(1.0)
        while p.end_time < duration:
            target = rng.uniform(lo, hi)
            if abs(target - p.x) < 2 * DEG:
                continue
            f = rng.uniform(0.4, 1.0, size=3)
            p.move(target, f[0] * lim.v, f[1] * lim.a, f[2] * lim.j).dwell(rng.uniform(0.3, 2.0))
        profiles.append(p)
    return sample(name, profiles, fs, axes=AXES)


def calibration_sweeps(
    rng: np.random.Generator, n_positions: int = 7, speeds: Sequence[float] = (1.0, 0.75, 0.5, 0.25),
    fs: float = 500.0, limits: Sequence[AxisLimits] = IX_LIMITS, margin: float = 2 * DEG,
) -> list[Reference]:
    """Paper 000, V-A: each axis swept over its range and back at each speed fraction, with the
    other axis parked at ``n_positions`` positions across its range (one reference per park)."""
    refs = []
    for swept in range(len(limits)):
        parked = 1 - swept
        lp, ls = limits[parked], limits[swept]
        for k, pos in enumerate(np.linspace(lp.low + margin, lp.high - margin, n_positions)):
            pos = float(np.clip(pos + rng.normal(0, 1 * DEG), lp.low, lp.high))
            lo, hi = ls.low + margin, ls.high - margin
            sw = AxisProfile(lo).dwell(1.0)
            pk = AxisProfile(pos)
            for s in speeds:
                sw.move(hi, s * ls.v, s * ls.a, ls.j).dwell(0.5).move(lo, s * ls.v, s * ls.a, ls.j).dwell(0.5)
            pk.dwell(sw.end_time)
            profiles = [sw, pk] if swept == 0 else [pk, sw]
            refs.append(sample(f"calibration-{AXES[swept]}-sweep-{k}", profiles, fs, axes=AXES))
    return refs


def reference_set(
    name: str, seed: int = 0, n_references: int | None = None, duration: float = 40.0, fs: float = 500.0,
) -> list[Reference]:
    """A named, seeded set: "train" (default 8 references), "validation" (4), "test" (4) of
    random moves of ``duration`` s, or "calibration" (14 sweeps, about 1e6 samples)."""
    rng = stream(name, seed)
    if not duration > 0:
        raise ValueError(f"duration must be > 0 s, got {duration}")
    if name == "calibration":
        return calibration_sweeps(rng, fs=fs)
    n = n_references if n_references is not None else {"train": 8, "validation": 4, "test": 4}[name]
    if n < 1:
        raise ValueError(f"n_references must be >= 1, got {n}")
    return [random_moves(f"{name}-{seed}-{i}", rng, duration, fs) for i in range(n)]
