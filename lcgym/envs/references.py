"""Reference trajectories for the IX: third-order point-to-point setpoints and reference sets.

Third-order (jerk-limited) setpoints after Lambrechts, Boerlage and Steinbuch (2005): a move of
distance d under limits on velocity v, acceleration a and jerk j is a sequence of seven phases
of constant jerk (+j, 0, -j, 0, -j, 0, +j); phases shrink when a limit cannot be reached. A
reference strings moves and dwells together per axis; position, velocity and acceleration are
evaluated exactly (piecewise cubic) at the sample times.

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
from dataclasses import dataclass

import numpy as np

DEG = math.pi / 180.0
AXES = ("propeller", "roll")


@dataclass(frozen=True)
class AxisLimits:
    """Range [rad] and setpoint limits: velocity [rad/s], acceleration [rad/s^2], jerk [rad/s^3]."""

    low: float
    high: float
    v: float
    a: float
    j: float


IX_LIMITS = (
    AxisLimits(-60 * DEG, 60 * DEG, 15 * DEG, 30 * DEG, 200 * DEG),  # propeller
    AxisLimits(-90 * DEG, 90 * DEG, 20 * DEG, 40 * DEG, 300 * DEG),  # roll
)


def third_order_phases(distance: float, v: float, a: float, j: float) -> tuple[list[float], list[float]]:
    """Durations [s] and jerks [rad/s^3] of the seven phases of a move of ``distance`` [rad].

    The peak velocity, acceleration and jerk never exceed v, a, j.
    """
    if min(v, a, j) <= 0:
        raise ValueError(f"setpoint limits must be positive, got v={v}, a={a}, j={j}")
    d = abs(distance)
    if d == 0:
        return [], []
    tj = min(a / j, math.sqrt(v / j))
    ta = v / (j * tj) - tj  # constant-acceleration time at peak acceleration j*tj
    reach = v * (2 * tj + ta)  # distance of accelerating to v and back
    if d >= reach:
        tv = (d - reach) / v
    else:
        tv = 0.0
        vp = 0.5 * a * (-a / j + math.sqrt((a / j) ** 2 + 4 * d / a))  # peak velocity with a reached
        if vp >= a * a / j:
            tj, ta = a / j, vp / a - a / j
        else:
            vp = (d * d * j / 4) ** (1 / 3)  # peak velocity when a is not reached either
            tj, ta = math.sqrt(vp / j), 0.0
    s = math.copysign(1.0, distance)
    ta = max(ta, 0.0)  # round-off can leave -1e-16 where the acceleration limit is just reached
    durations = [tj, ta, tj, tv, tj, ta, tj]
    jerks = [s * j, 0.0, -s * j, 0.0, -s * j, 0.0, s * j]
    return durations, jerks


class AxisProfile:
    """Piecewise-constant-jerk trajectory of one axis, built move by move."""

    def __init__(self, start: float):
        self.t0: list[float] = []
        self.state: list[tuple[float, float, float]] = []  # (x, v, a) at each piece start
        self.jerk: list[float] = []
        self.end_time = 0.0
        self.x = start

    def _piece(self, duration: float, jerk: float, x: float, v: float, a: float):
        self.t0.append(self.end_time)
        self.state.append((x, v, a))
        self.jerk.append(jerk)
        self.end_time += duration

    def move(self, target: float, v: float, a: float, j: float) -> AxisProfile:
        durations, jerks = third_order_phases(target - self.x, v, a, j)
        x, vel, acc = self.x, 0.0, 0.0
        for dur, jk in zip(durations, jerks, strict=True):
            if dur <= 0:
                continue
            self._piece(dur, jk, x, vel, acc)
            x += vel * dur + acc * dur**2 / 2 + jk * dur**3 / 6
            vel += acc * dur + jk * dur**2 / 2
            acc += jk * dur
        self.x = target  # snap: removes round-off of the phase sums
        return self

    def dwell(self, duration: float) -> AxisProfile:
        if duration > 0:
            self._piece(duration, 0.0, self.x, 0.0, 0.0)
        return self

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x, v, a) at times t [s]; after the last piece the axis rests at its final position."""
        t = np.asarray(t, dtype=float)
        if not self.t0:
            return np.full_like(t, self.x), np.zeros_like(t), np.zeros_like(t)
        t0 = np.array(self.t0)
        st = np.array(self.state)
        jk = np.array(self.jerk)
        i = np.clip(np.searchsorted(t0, t, side="right") - 1, 0, len(t0) - 1)
        dt = t - t0[i]
        x0, v0, a0, j = st[i, 0], st[i, 1], st[i, 2], jk[i]
        x = x0 + v0 * dt + a0 * dt**2 / 2 + j * dt**3 / 6
        v = v0 + a0 * dt + j * dt**2 / 2
        a = a0 + j * dt
        after = t >= self.end_time
        x[after], v[after], a[after] = self.x, 0.0, 0.0
        return x, v, a


@dataclass
class Reference:
    """A sampled reference: positions, velocities, accelerations (T, 2) in rad, rad/s, rad/s^2."""

    name: str
    fs: float
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    axes: tuple[str, ...] = AXES

    @property
    def n_samples(self) -> int:
        return self.positions.shape[0]

    @property
    def t(self) -> np.ndarray:
        return np.arange(self.n_samples) / self.fs


def references_of(trials) -> list[Reference]:
    """The references of measured trials (what a method's ``fit`` gets), with velocities and
    accelerations by ``physics.kinematics.reference_kinematics``; named by the trial's
    ``meta["reference"]``, else ``training-<i>``."""
    from ..physics.kinematics import reference_kinematics

    refs = []
    for i, tr in enumerate(trials):
        _, qd, qdd = reference_kinematics(tr.ref, tr.fs)
        refs.append(Reference(tr.meta.get("reference", f"training-{i}"), tr.fs, tr.ref, qd, qdd, axes=tuple(tr.axes)))
    return refs


def sample(name: str, profiles: Sequence[AxisProfile], fs: float, tail: float = 1.0) -> Reference:
    """Sample axis profiles at fs over their common duration plus ``tail`` seconds of rest."""
    duration = max(p.end_time for p in profiles) + tail
    t = np.arange(int(math.ceil(duration * fs)) + 1) / fs
    xva = [p.evaluate(t) for p in profiles]
    return Reference(name, fs, *(np.column_stack([e[k] for e in xva]) for k in range(3)))


def _stream(set_name: str, seed: int) -> np.random.Generator:
    ids = {"train": 1, "validation": 2, "test": 3, "calibration": 4}
    if set_name not in ids:
        raise ValueError(f"unknown reference set {set_name!r}; choose one of {sorted(ids)}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    return np.random.default_rng([seed, ids[set_name]])


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
    return sample(name, profiles, fs)


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
            refs.append(sample(f"calibration-{('propeller', 'roll')[swept]}-sweep-{k}", profiles, fs))
    return refs


def reference_set(
    name: str, seed: int = 0, n_references: int | None = None, duration: float = 40.0, fs: float = 500.0,
) -> list[Reference]:
    """A named, seeded set: "train" (default 8 references), "validation" (4), "test" (4) of
    random moves of ``duration`` s, or "calibration" (14 sweeps, about 1e6 samples)."""
    rng = _stream(name, seed)
    if not duration > 0:
        raise ValueError(f"duration must be > 0 s, got {duration}")
    if name == "calibration":
        return calibration_sweeps(rng, fs=fs)
    n = n_references if n_references is not None else {"train": 8, "validation": 4, "test": 4}[name]
    if n < 1:
        raise ValueError(f"n_references must be >= 1, got {n}")
    return [random_moves(f"{name}-{seed}-{i}", rng, duration, fs) for i in range(n)]
