"""Reference trajectories, machine-independent: the sampled ``Reference`` and third-order setpoints.

Third-order (jerk-limited) setpoints after Lambrechts, Boerlage and Steinbuch (2005): a move of
distance d under limits on velocity v, acceleration a and jerk j is a sequence of seven phases
of constant jerk (+j, 0, -j, 0, -j, 0, +j); phases shrink when a limit cannot be reached. A
reference strings moves and dwells together per axis; position, velocity and acceleration are
evaluated exactly (piecewise cubic) at the sample times. Units: rad (or m) and seconds.

Random point-to-point moves, the references of the machines' sets, are made here
(``random_profile``, with the rule that draws each move's limits: ``limit_fractions`` for the IX,
``speed_fraction`` for a URDF machine, ``random_moves`` for all its axes); the sets themselves
(seeded, split train / validation / test as in the papers) are the machines'
(``systems/ix/references.py``, ``systems/urdf_bench.py``; the FlexArm's are TCP lines through its
inverse kinematics, ``systems/flexarm/references.py``); ``stream`` gives each set its own random
stream.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

DEG = math.pi / 180.0


@dataclass(frozen=True)
class AxisLimits:
    """Range [rad] and setpoint limits: velocity [rad/s], acceleration [rad/s^2], jerk [rad/s^3]."""

    low: float
    high: float
    v: float
    a: float
    j: float


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
    """A sampled reference of the axes ``axes``: positions, velocities, accelerations (T, n_axes) in
    rad (or m), per second and per second squared; ``fs`` [Hz]."""

    name: str
    fs: float
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    axes: tuple[str, ...] = ()

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
    from .physics.kinematics import reference_kinematics

    refs = []
    for i, tr in enumerate(trials):
        _, qd, qdd = reference_kinematics(tr.ref, tr.fs)
        refs.append(Reference(tr.meta.get("reference", f"training-{i}"), tr.fs, tr.ref, qd, qdd, axes=tuple(tr.axes)))
    return refs


def sample(name: str, profiles: Sequence[AxisProfile], fs: float, tail: float = 1.0, axes: Sequence[str] = ()) -> Reference:
    """Sample axis profiles (one per axis, named ``axes``) at fs over their common duration plus
    ``tail`` seconds of rest."""
    duration = max(p.end_time for p in profiles) + tail
    t = np.arange(int(math.ceil(duration * fs)) + 1) / fs
    xva = [p.evaluate(t) for p in profiles]
    return Reference(name, fs, *(np.column_stack([e[k] for e in xva]) for k in range(3)), axes=tuple(axes))


def stream(set_name: str, seed: int) -> np.random.Generator:
    """The random stream of a named reference set and seed (sets draw from disjoint streams)."""
    ids = {"train": 1, "validation": 2, "test": 3, "calibration": 4}
    if set_name not in ids:
        raise ValueError(f"unknown reference set {set_name!r}; choose one of {sorted(ids)}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    return np.random.default_rng([seed, ids[set_name]])




def random_profile(rng: np.random.Generator, low: float, high: float, duration: float,
                   limits: Callable[[np.random.Generator], tuple[float, float, float]], start_dwell: float = 0.5,
                   min_step: float = 0.0, dwells: tuple[float, float] = (0.2, 1.0)) -> AxisProfile:
    """One axis's random point-to-point moves between ``low`` and ``high`` (rad or m) for at least
    ``duration`` s: a dwell of ``start_dwell`` s at a random start, then moves to random targets (at
    least ``min_step`` away) under the limits ``limits(rng)`` draws for each move (velocity,
    acceleration, jerk; ``limit_fractions``, ``speed_fraction``), each followed by a random dwell
    within ``dwells`` [s]. The machines' reference sets are made of these (the IX's, a URDF
    machine's); one random stream ``rng`` for all, in this order of draws."""
    p = AxisProfile(rng.uniform(low, high)).dwell(start_dwell)
    while p.end_time < duration:
        target = rng.uniform(low, high)
        if abs(target - p.x) < min_step:
            continue
        p.move(target, *limits(rng)).dwell(rng.uniform(*dwells))
    return p


def limit_fractions(limits: AxisLimits) -> Callable[[np.random.Generator], tuple[float, float, float]]:
    """A move's limits: random 0.4-1 fractions of the axis's velocity, acceleration and jerk limits,
    drawn independently (the IX's moves)."""

    def draw(rng):
        f = rng.uniform(0.4, 1.0, size=3)
        return f[0] * limits.v, f[1] * limits.a, f[2] * limits.j

    return draw


def speed_fraction(v_max: float, accel_time: float, jerk_time: float):
    """A move's limits: a random 0.4-1 of ``v_max``, the acceleration that reaches it in
    ``accel_time`` s and the jerk that reaches that in ``jerk_time`` s (a URDF machine's moves)."""

    def draw(rng):
        v = rng.uniform(0.4, 1.0) * v_max
        a = v / accel_time
        return v, a, a / jerk_time

    return draw


def random_moves(name: str, rng: np.random.Generator, low: Sequence[float], high: Sequence[float],
                 v_max: Sequence[float], duration: float, fs: float, axes: Sequence[str] = (), margin: float = 0.1,
                 accel_time: float = 0.2, jerk_time: float = 0.05) -> Reference:
    """A reference of random point-to-point moves of every axis (``random_profile`` with
    ``speed_fraction``, axis after axis from ``rng``), targets ``margin`` of each axis's range
    (``low`` to ``high``) inside its ends, sampled at ``fs`` with 0.5 s of rest at the end."""
    profiles = []
    for lo, hi, v in zip(low, high, v_max, strict=True):
        inset = margin * (hi - lo)
        lo, hi = lo + inset, hi - inset
        profiles.append(random_profile(rng, lo, hi, duration, speed_fraction(v, accel_time, jerk_time),
                                       min_step=0.05 * (hi - lo)))
    return sample(name, profiles, fs, tail=0.5, axes=axes)


def sweeps(rng: np.random.Generator, limits: Sequence[AxisLimits], axes: Sequence[str], fs: float,
           n_positions: int = 7, speeds: Sequence[float] = (1.0, 0.75, 0.5, 0.25), margin=2 * DEG,
           jitter=1 * DEG, name: str = "calibration") -> list[Reference]:
    """Calibration sweeps (paper 000, V-A): each axis in turn swept over its range (``margin``
    inside each limit, one value or one per axis) and back at each speed fraction of its velocity
    and acceleration limits, the other axes parked together at ``n_positions`` positions across
    their ranges (each position plus a normal draw of standard deviation ``jitter``, one value or one
    per axis, clipped into the range); one reference per park, ``<name>-<axis>-sweep-<k>``."""
    margins = np.broadcast_to(np.asarray(margin, dtype=float), (len(limits),))
    jitters = np.broadcast_to(np.asarray(jitter, dtype=float), (len(limits),))
    refs = []
    for swept, ls in enumerate(limits):
        lo, hi = ls.low + margins[swept], ls.high - margins[swept]
        parked = [i for i in range(len(limits)) if i != swept]
        parks = [np.linspace(limits[i].low + margins[i], limits[i].high - margins[i], n_positions) for i in parked]
        for k in range(n_positions):
            sw = AxisProfile(lo).dwell(1.0)
            for s in speeds:
                sw.move(hi, s * ls.v, s * ls.a, ls.j).dwell(0.5).move(lo, s * ls.v, s * ls.a, ls.j).dwell(0.5)
            profiles = {swept: sw}
            for i, park in zip(parked, parks, strict=True):
                pos = float(np.clip(park[k] + rng.normal(0, jitters[i]), limits[i].low, limits[i].high))
                profiles[i] = AxisProfile(pos).dwell(sw.end_time)
            refs.append(sample(f"{name}-{axes[swept]}-sweep-{k}", [profiles[i] for i in range(len(limits))], fs,
                               axes=axes))
    return refs
