"""How the diagnosis searches an effect: ``Search``, which an effect class declares as its
``search`` (``physics.effects``), and the grids of its nonlinear parameters.

Grid values are fixed numbers, ``Scaled`` numbers (fractions of the axis's speed or position
scale: ``systems.Axis.speed_scale`` / ``position_scale``, or, where a machine leaves them unset,
its data's), or a function of the data ``(q, qd, axis_index) -> values`` (e.g. spring onsets at
quantiles of the axis's measured positions). Periodic effects take their period from the peaks of
the residual's spectrum over the axis position (``diagnose.search``), not from a grid: a period
must be known to a fraction of a percent to fit a harmonic over tens of cycles.

The fractions the library's effects declare were chosen on the IX, whose axes declare the scales
20 deg/s and 100 deg, so that there they are the grids the diagnosis was developed with (Coulomb
smoothing 0.05-2 deg/s, spring widths 1 and 5 deg, ...). On a machine without declared scales they
follow its data: a friction smoothing of 0.25 % to 10 % of the axis's top speed is as sharp on a
robot joint turning at 2 rad/s as on the IX at 20 deg/s, and on a linear axis in m/s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


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
class Search:
    """How the diagnosis searches an effect.

    ``family``: friction, spring, inertia, periodic, gravity, position, offset or user. ``grid``:
    for each nonlinear parameter, a tuple of values, a ``Scaled`` or a function ``(q, qd,
    axis_index) -> values``. ``period``: the name of a nonlinear parameter that is a period over
    the axis position, found from the spectrum of the residual (not gridded), or None.
    ``extends``: the names of simpler effects whose form this one contains (asymmetric friction
    contains Coulomb friction): it is taken only where its extra parameters pass the significance
    rule against what the best simpler one leaves (``diagnose.search``). ``shape_free``: a curve of
    no set shape (a spline): where a library effect of its axis passes too, the best of those is
    named first, and this one is then tried in its place where it extends that effect (its shape
    refined). ``fixed``: nonlinear parameters taken from the grid and not refined (a spline's knot
    range). ``above_rest``: speeds of a shape that acts at low speed (a Stribeck velocity), tried
    only from twice the axis's rest speed up (``scale["rest"]``: the samples below it are left out
    of the fit)."""

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


SMOOTHING = Scaled((0.0025, 0.01, 0.025, 0.05, 0.1))
"""A friction's smoothing speeds eps: 0.25 % to 10 % of the axis's speed scale."""


def angle_quantiles(q, qd, i, n=9):
    """Onsets of a one-sided spring: quantiles 5 %..95 % of the axis position [rad or m]."""
    return np.quantile(q[:, i], np.linspace(0.05, 0.95, n))


def five_angle_quantiles(q, qd, i):
    """Onsets of a cable's inertia: quantiles 5 %..95 % of the axis position in five steps [rad or m]."""
    return angle_quantiles(q, qd, i, 5)


def position_low(q, qd, i):
    """The low end of a position map's knots: the axis position's 0.5 % quantile [rad or m]."""
    return [float(np.quantile(q[:, i], 0.005))]


def position_high(q, qd, i):
    """The high end of a position map's knots: the axis position's 99.5 % quantile [rad or m]."""
    return [float(np.quantile(q[:, i], 0.995))]
