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

from ...references import AxisLimits, Reference, limit_fractions, random_profile, sample, stream, sweeps

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
    profiles = [random_profile(rng, lim.low + margin, lim.high - margin, duration, limit_fractions(lim), start_dwell=1.0,
                               min_step=2 * DEG, dwells=(0.3, 2.0)) for lim in limits]
    return sample(name, profiles, fs, axes=AXES)


def calibration_sweeps(
    rng: np.random.Generator, n_positions: int = 7, speeds: Sequence[float] = (1.0, 0.75, 0.5, 0.25),
    fs: float = 500.0, limits: Sequence[AxisLimits] = IX_LIMITS, margin: float = 2 * DEG,
) -> list[Reference]:
    """Paper 000, V-A: each axis swept over its range and back at each speed fraction, with the
    other axis parked at ``n_positions`` positions across its range (one reference per park;
    ``references.sweeps``)."""
    return sweeps(rng, limits, AXES, fs, n_positions, speeds, margin)


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
