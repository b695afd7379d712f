"""Candidate effects: what the diagnosis may add to a model, with the grids of their nonlinear
parameters (``diagnose.search`` tries every combination).

A candidate is an ``Effect`` class plus, for each of its nonlinear parameters, the values the
search tries. Grid values are fixed numbers, ``Scaled`` numbers (fractions of the axis's speed or
position scale: ``systems.Axis.speed_scale`` / ``position_scale``, or, where a machine leaves them
unset, its data's), or a function of the data ``(q, qd, axis_index) -> values`` (e.g. spring
onsets at quantiles of the axis's measured positions). Periodic effects take their period from
the peaks of the residual's spectrum over the axis position (``diagnose.search``), not from a
grid: a period must be known to a fraction of a percent to fit a harmonic over tens of cycles.

The fractions below were chosen on the IX, whose axes declare the scales 20 deg/s and 100 deg,
so that there they are the grids the diagnosis was developed with (Coulomb smoothing 0.05-2
deg/s, spring widths 1 and 5 deg, ...). On a machine without declared scales they follow its data:
a friction smoothing of 0.25 % to 10 % of the axis's top speed is as sharp on a robot joint
turning at 2 rad/s as on the IX at 20 deg/s, and on a linear axis in m/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import effects as fx

DEG = math.pi / 180.0


@dataclass(frozen=True)
class Scaled:
    """Grid values as fractions of an axis scale: ``by`` "speed" [rad/s or m/s] or "position" [rad or m]."""

    fractions: tuple[float, ...]
    by: str = "speed"

    def __post_init__(self):
        if self.by not in ("speed", "position"):
            raise ValueError(f"Scaled: by must be 'speed' or 'position', got {self.by!r}")

    def values(self, scale: dict) -> np.ndarray:
        return np.asarray(self.fractions, dtype=float) * scale[self.by]


@dataclass(frozen=True)
class Candidate:
    """An effect family member the diagnosis can add: ``effect`` (an Effect subclass),
    ``family`` (friction, spring, inertia, periodic, gravity, user) and ``grid``: for each
    nonlinear parameter, a tuple of values, a ``Scaled`` or a function ``(q, qd, axis_index) ->
    values``. ``period``: the name of a nonlinear parameter that is a period over the axis position,
    found from the spectrum of the residual (not gridded), or None. ``extends``: the names of
    simpler candidates whose form this one contains (asymmetric friction contains Coulomb friction):
    it is taken only where its extra parameters pass the significance rule against what the best
    simpler one leaves (``diagnose.search``). ``shape_free``: a curve of no set shape (a spline):
    where a library effect of its axis passes too, the best of those is named first, and this one is
    then tried in its place where it extends that effect (its shape refined). ``fixed``: nonlinear
    parameters the search takes from the grid and does not refine (a spline's knot range).
    ``above_rest``: speeds of a shape that acts at low speed (a Stribeck velocity), tried only from
    twice the axis's rest speed up (``scale["rest"]``: the samples below it are left out of the fit)."""

    effect: type[fx.Effect]
    family: str
    grid: dict[str, tuple | Scaled | Callable] = field(default_factory=dict)
    period: str | None = None
    extends: tuple[str, ...] = ()
    shape_free: bool = False
    fixed: tuple[str, ...] = ()
    above_rest: tuple[str, ...] = ()

    def __post_init__(self):
        if isinstance(self.extends, str):
            object.__setattr__(self, "extends", (self.extends,))

    @property
    def name(self) -> str:
        return self.effect.name

    @property
    def n_params(self) -> int:
        """Linear plus searched nonlinear parameters: the tie-break prefers fewer."""
        return len(self.effect.linear) + len(self.grid) + (self.period is not None)

    def settings(self, q: np.ndarray, qd: np.ndarray, index: int, scale: dict) -> list[dict]:
        """Every combination of grid values for an axis; ``scale`` {"speed", "position"} of the axis."""
        combos = [{}]
        for name, values in self.grid.items():
            if isinstance(values, Scaled):
                vals = values.values(scale)
            else:
                vals = values(q, qd, index) if callable(values) else values
            if name in self.above_rest and scale.get("rest"):
                vals = [v for v in vals if v >= 2 * scale["rest"]] or [max(vals)]
            combos = [{**c, name: float(v)} for c in combos for v in vals]
        return combos

    def build(self, axis: str, **nonlinear) -> fx.Effect:
        return self.effect(axis=axis, **nonlinear)


def angle_quantiles(q, qd, i, n=9):
    """Onsets of a one-sided spring: quantiles 5 %..95 % of the axis position [rad or m]."""
    return np.quantile(q[:, i], np.linspace(0.05, 0.95, n))


def position_low(q, qd, i):
    """The low end of a position map's knots: the axis position's 0.5 % quantile [rad or m]."""
    return [float(np.quantile(q[:, i], 0.005))]


def position_high(q, qd, i):
    """The high end of a position map's knots: the axis position's 99.5 % quantile [rad or m]."""
    return [float(np.quantile(q[:, i], 0.995))]


FRICTION_FORMS = ("coulomb_friction", "asymmetric_friction", "stribeck_friction")


LIBRARY: tuple[Candidate, ...] = (
    Candidate(fx.CoulombFriction, "friction", {"eps": Scaled((0.0025, 0.01, 0.025, 0.05, 0.1))}),
    # Stribeck velocities stop at 40 % of the speed scale: a wider bump is Coulomb friction
    Candidate(fx.StribeckFriction, "friction", {"vs": Scaled(tuple(np.geomspace(0.005, 0.4, 20))),
                                                "eps": Scaled((0.0025, 0.01))},
              extends=("coulomb_friction",), above_rest=("vs",)),
    Candidate(fx.AsymmetricFriction, "friction", {"eps": Scaled((0.0025, 0.01, 0.025, 0.05, 0.1))},
              extends=("coulomb_friction",)),
    Candidate(fx.LoadFriction, "friction", {"eps": Scaled((0.0025, 0.01, 0.025, 0.05, 0.1))},
              extends=("coulomb_friction",)),
    Candidate(fx.FrictionCurve, "friction", {"eps": Scaled((0.0025, 0.01, 0.05)), "v_top": Scaled((1.0,))},
              extends=FRICTION_FORMS, shape_free=True, fixed=("v_top",)),
    Candidate(fx.Offset, "offset"),
    Candidate(fx.CableSpring, "spring", {"q0": angle_quantiles, "width": Scaled((0.01, 0.05), "position"),
                                         "side": (-1.0, 1.0)}),
    Candidate(fx.CableInertia, "inertia", {"q0": lambda q, qd, i: angle_quantiles(q, qd, i, 5),
                                           "width": Scaled((0.05, 0.15), "position")}),
    Candidate(fx.RotorInertia, "inertia"),
    Candidate(fx.GearHarmonic, "periodic", period="period"),
    Candidate(fx.TorqueRipple, "periodic", period="period"),
    Candidate(fx.CableDrape, "gravity"),
    Candidate(fx.PositionMap, "position", {"lo": position_low, "hi": position_high},
              extends=("offset", "cable_spring", "cable_drape"), shape_free=True, fixed=("lo", "hi")),
)
"""The library's candidates, in the order the diagnosis tries them."""

REGISTERED: dict[str, Candidate] = {}
"""The candidates users registered (``diagnose.register_effect``; ``diagnose.CANDIDATES`` is this
dict), by name."""


def candidates_of(system) -> list[Candidate]:
    """The candidates of a machine (a ``systems.System``): the library's, its own
    (``System.candidates``) and the registered ones, limited to ``System.candidate_names`` where the
    machine sets them (registered ones stay) and to those whose formula applies to one of its axes at
    least (``Effect.applies_to``). What the diagnosis tries, ``--add`` accepts and a machine's model
    may carry (``System.model_effects``, a machine file's ``[[model]]`` tables)."""
    pool = {c.name: c for c in (*LIBRARY, *system.candidates, *REGISTERED.values())}
    if system.candidate_names is not None:
        pool = {n: c for n, c in pool.items() if n in system.candidate_names or n in REGISTERED}
    return [c for c in pool.values() if any(c.effect.applies_to(a) for a in system.axes)]


def axis_scale(axis, q: np.ndarray, qd: np.ndarray) -> dict:
    """The {"speed" [rad/s or m/s], "position" [rad or m]} scales of the candidates' grids on one
    axis (a ``systems.Axis``, with its positions q and velocities qd (T,)): the axis's declared ones,
    else the data's (the 99th percentile of |qd|, the range of q), else 1."""
    speed = axis.speed_scale or float(np.quantile(np.abs(qd), 0.99)) or 1.0
    position = axis.position_scale or float(np.ptp(q)) or 1.0
    return {"speed": speed, "position": position}


def refinement(cand: Candidate, grid: list[dict], start: dict, span: float = 0.05
               ) -> tuple[list[str], list[bool], np.ndarray, list[tuple[float, float]]]:
    """What a refinement of the setting ``start`` of candidate ``cand`` (one of ``grid``, its
    ``settings``) moves, for the diagnosis's (``diagnose.search.refine``) and a model's
    (``physics.shapes``) Nelder-Mead alike: (names, logged, x0, bounds). The continuous nonlinear
    parameters (those its grid spans as a range or takes from the data, and a period that ``start``
    has; not a grid of fixed values such as a spring's side, nor those the candidate keeps
    ``fixed``); positive ones (widths, smoothing speeds, periods) in log space (``logged``), an onset
    position as is; bounded within the grid's span widened by 2x (log) or by half the span on
    either side, a period (or a parameter the grid lacks) within ``span`` (5 %) of its start."""
    names = [n for n, g in cand.grid.items() if not isinstance(g, tuple) and n not in cand.fixed]
    names += [cand.period] if cand.period and cand.period in start else []
    logged = [n != "q0" for n in names]  # every continuous parameter but an onset position is > 0
    x0 = np.array([math.log(start[n]) if lg else start[n] for n, lg in zip(names, logged, strict=True)])
    bounds = []
    for n, lg, x in zip(names, logged, x0, strict=True):
        values = [g[n] for g in grid if n in g]
        if n == cand.period or not values:
            bounds.append((x - span, x + span) if lg else (x - span * abs(x), x + span * abs(x)))
        elif lg:
            bounds.append((math.log(min(values) / 2), math.log(max(values) * 2)))
        else:
            half = 0.5 * (max(values) - min(values))
            bounds.append((min(values) - half, max(values) + half))
    return names, logged, x0, bounds


def refined_setting(start: dict, names: list[str], logged: list[bool], x) -> dict:
    """``start`` with the parameters ``names`` at the point ``x`` of ``refinement``'s space."""
    return {**start, **{n: float(math.exp(v) if lg else v) for n, v, lg in zip(names, x, logged, strict=True)}}


def period_peaks(r: np.ndarray, q: np.ndarray, weight: np.ndarray | None, n_peaks: int = 3,
                 shortest: float = 1 * DEG) -> list[float]:
    """Periods [rad or m] of the strongest peaks of |sum_k r_k w_k exp(-2 pi i q_k / P)|^2.

    Frequencies (cycles per rad or m) on a grid of 1/(4 x position range), from the longest period
    that repeats three times within the range (at least 3 x ``shortest``) to ``shortest``; each
    peak refined by parabolic interpolation.
    """
    travel = float(np.ptp(q))
    if travel < 3 * shortest:
        return []
    df = 1.0 / (4.0 * travel)
    freqs = np.arange(1.0 / max(3 * shortest, travel / 3), 1.0 / shortest, df)
    x = r * (weight if weight is not None else 1.0)
    x = x - x.mean()
    # the transform block by block of 32 frequencies: the exponentials of one block are those of the
    # block before times exp(-2 pi i q 32 df) (a product costs a fraction of an exponential)
    block = 32
    phase = np.exp(-2j * np.pi * np.outer(q, freqs[0] + df * np.arange(block)))
    step = np.exp(-2j * np.pi * q * df * block)[:, None]
    acc = np.empty(freqs.size, dtype=complex)
    for start in range(0, freqs.size, block):
        n = min(block, freqs.size - start)
        acc[start : start + n] = x @ phase[:, :n]
        phase *= step
    power = np.abs(acc) ** 2
    peaks = [k for k in range(1, freqs.size - 1) if power[k] >= power[k - 1] and power[k] > power[k + 1]]
    peaks = sorted(peaks, key=lambda k: -power[k])[:n_peaks]
    out = []
    for k in peaks:
        a, b, c = power[k - 1], power[k], power[k + 1]
        shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else 0.0
        out.append(1.0 / (freqs[k] + shift * df))
    return out
