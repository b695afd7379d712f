"""Candidate effects: what the diagnosis tries to add to a model, with the grids of their
nonlinear parameters, and the registry users add their own effects to.

A candidate is an ``Effect`` class of ``physics.effects`` (or a user's) plus, for each of its
nonlinear parameters, the values the search tries. Grids are given in physical units, either
as fixed values or as a function of the data (``Data``: e.g. cable-spring onsets at quantiles of
the axis's measured angles). Periodic effects take their period from the peaks of the
residual's spectrum over the axis angle (``diagnose.search``), not from a fixed grid: a period
must be known to a fraction of a percent to fit a harmonic over tens of cycles.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..data import SYSTEM_AXES
from ..physics import effects as fx

DEG = math.pi / 180.0


@dataclass(frozen=True)
class Candidate:
    """An effect family member the diagnosis can add: ``effect`` (an Effect subclass),
    ``family`` (friction, spring, inertia, periodic, gravity, user) and ``grid``: for each
    nonlinear parameter, a tuple of values or a function ``(q, qd, axis_index) -> values``.
    ``period``: the name of a nonlinear parameter that is a period over the axis angle [rad],
    found from the spectrum of the residual (not gridded), or None."""

    effect: type[fx.Effect]
    family: str
    grid: dict[str, tuple | Callable] = field(default_factory=dict)
    period: str | None = None

    @property
    def name(self) -> str:
        return self.effect.name

    @property
    def n_params(self) -> int:
        """Linear plus searched nonlinear parameters: the tie-break prefers fewer."""
        return len(self.effect.linear) + len(self.grid) + (self.period is not None)

    def settings(self, q: np.ndarray, qd: np.ndarray, index: int) -> list[dict]:
        """Every combination of grid values for an axis (the data give data-dependent grids)."""
        combos = [{}]
        for name, values in self.grid.items():
            vals = values(q, qd, index) if callable(values) else values
            combos = [{**c, name: float(v)} for c in combos for v in vals]
        return combos

    def build(self, axis: str, **nonlinear) -> fx.Effect:
        return self.effect(axis=axis, **nonlinear)


def _angle_quantiles(q, qd, i, n=9):
    """Onsets of a one-sided spring: quantiles 5 %..95 % of the axis angle [rad]."""
    return np.quantile(q[:, i], np.linspace(0.05, 0.95, n))


CANDIDATES: dict[str, Candidate] = {}


def candidates_for(system: str) -> list[Candidate]:
    """The registered candidates whose effect applies to ``system`` (``Effect.systems``)."""
    return [c for c in CANDIDATES.values() if system in c.effect.systems]


def register_effect(effect, family: str = "user", grid: dict | None = None, period: str | None = None,
                    name: str | None = None, n_coefficients: int = 1) -> Candidate:
    """Add a candidate effect to the diagnosis (it is ranked with the built-in ones).

    ``effect`` is an ``Effect`` subclass (see ``physics.effects``: ``linear`` names its
    coefficients, ``nonlinear`` the parameters ``grid`` searches, ``_columns`` its regressor), or
    a plain function ``f(q, qd, qdd, **nonlinear) -> (T, n_coefficients)`` of the axis's own
    angle [rad], velocity [rad/s] and acceleration [rad/s^2] returning basis functions [input
    unit per coefficient]; a function needs ``name``. ``grid`` gives values to try for nonlinear
    parameters; ``period`` names one that is a period over the axis angle [rad]. It is also registered in the effect
    vocabulary, so that ``--add NAME@AXIS`` and ``PhysicalModel.with_effect`` accept it.
    """
    grid = dict(grid or {})
    if not isinstance(effect, type):
        if not callable(effect) or not name:
            raise TypeError("register_effect: give an Effect subclass, or a function and its name")
        effect = _function_effect(effect, name, n_coefficients, tuple(grid))
    if not issubclass(effect, fx.Effect) or not effect.name:
        raise TypeError(f"register_effect: {effect!r} is not an Effect subclass with a name")
    if effect.plant_only:
        raise ValueError(f"{effect.name} is plant-only: a static model cannot add it")
    missing = [p for p in (*grid, *([period] if period else [])) if p not in effect.nonlinear]
    if missing:
        raise ValueError(f"{effect.name}: grid names {missing}, which are not nonlinear parameters {effect.nonlinear}")
    fx.EFFECTS[effect.name] = effect
    cand = Candidate(effect, family, grid, period)
    CANDIDATES[effect.name] = cand
    return cand


def _function_effect(function, name: str, n_coefficients: int, nonlinear: tuple[str, ...]) -> type[fx.Effect]:
    """An Effect subclass whose columns are ``function`` of the axis's own kinematics."""

    def _columns(self, q, qd, qdd, base):
        i = self.index
        kw = {p: getattr(self, p) for p in nonlinear}
        cols = np.asarray(function(q[..., i], qd[..., i], qdd[..., i], **kw), dtype=float)
        cols = cols.reshape(q.shape[0], -1)
        if cols.shape[1] != n_coefficients:
            raise ValueError(f"{name}: the function returned {cols.shape[1]} columns, expected {n_coefficients}")
        return tuple(cols.T)

    linear = tuple(f"c{k}" for k in range(n_coefficients))
    fields = [(p, float, dataclasses.field(default=0.0)) for p in linear + nonlinear]
    namespace = {"name": name, "linear": linear, "nonlinear": nonlinear, "_columns": _columns,
                 "systems": tuple(SYSTEM_AXES)}  # a function of the axis's own kinematics fits any system
    return dataclasses.make_dataclass(f"UserEffect_{name}", fields, bases=(fx.Effect,), frozen=True, namespace=namespace)


for _cand in (
    Candidate(fx.CoulombFriction, "friction", {"eps": tuple(np.array([0.05, 0.2, 0.5, 1.0, 2.0]) * DEG)}),
    # Stribeck velocities stop at 8 deg/s: a wider bump is Coulomb friction over the IX's speed range
    Candidate(fx.StribeckFriction, "friction", {"vs": tuple(np.geomspace(0.1, 8.0, 20) * DEG),
                                                "eps": (0.05 * DEG, 0.2 * DEG)}),
    Candidate(fx.PositionDependentFriction, "friction", {"eps": tuple(np.array([0.05, 0.5, 2.0]) * DEG)}),
    Candidate(fx.CableSpring, "spring", {"q0": _angle_quantiles, "width": (1 * DEG, 5 * DEG), "side": (-1.0, 1.0)}),
    Candidate(fx.CableInertia, "inertia", {"q0": lambda q, qd, i: _angle_quantiles(q, qd, i, 5), "width": (5 * DEG, 15 * DEG)}),
    Candidate(fx.GearHarmonic, "periodic", period="period"),
    Candidate(fx.TorqueRipple, "periodic", period="period"),
    Candidate(fx.CableDrape, "gravity"),
    Candidate(fx.Payload, "inertia"),
):
    CANDIDATES[_cand.name] = _cand
