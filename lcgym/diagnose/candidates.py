"""Candidate effects of a diagnosis on a machine, and how users add their own.

A candidate (``physics.candidates.Candidate``) is an ``Effect`` class with the grids of its
nonlinear parameters (the effect's ``search``). A machine's candidates are the library's
(``physics.candidates.library``) and its own (``System.diagnosis.candidates``: the IX's guidance friction,
the FlexArm's payload, a user's effect added by ``register_effect``), limited to
``System.diagnosis.candidate_names`` where the machine sets them and to the effects whose formula applies to
the axis kind (``Effect.applies_to``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import systems
from ..physics import effects as fx
from ..physics.candidates import Candidate, candidates_of
from ..physics.grids import Search


def candidates_for(system) -> list[Candidate]:
    """The candidates the diagnosis tries on ``system`` (a ``systems.System`` or what
    ``systems.get`` accepts; ``physics.candidates.candidates_of``)."""
    return candidates_of(systems.get(system))


@dataclass(frozen=True)
class State:
    """What a ``register_effect`` function with ``whole_state=True`` reads: the kinematics of every
    axis ``q`` [rad or m], ``qd`` [per s], ``qdd`` [per s^2] (T, n_axes), ``axis`` the index of the
    axis the effect acts on, and the fitted rigid-body model's torques [input unit] (T, n_axes):
    ``torque`` (M(q) qdd + h(q, qd) + D qd) and ``gravity`` (the same at rest, g(q))."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    axis: int
    torque: np.ndarray
    gravity: np.ndarray


def register_effect(system, effect, family: str = "user", grid: dict | None = None, period: str | None = None,
                    name: str | None = None, n_coefficients: int = 1, whole_state: bool = False) -> systems.System:
    """``system`` (a ``systems.System`` or what ``systems.get`` accepts) with one more candidate
    effect, ranked with the built-in ones; nothing else changes (no global registry: the machine
    returned is the registry).

    ``effect`` is an ``Effect`` subclass (see ``physics.effects``: ``linear`` names its
    coefficients, ``nonlinear`` the parameters ``grid`` searches, ``_columns`` its regressor), or
    a plain function returning basis functions (T, n_coefficients) [input unit per coefficient];
    a function needs ``name``. The function is ``f(q, qd, qdd, **nonlinear)`` of the axis's own
    angle [rad], velocity [rad/s] and acceleration [rad/s^2], or, with ``whole_state``,
    ``f(state, **nonlinear)`` of a ``State``: every axis's kinematics and the rigid-body model's
    torque and gravity torque (a friction growing with the joint's load, a coupling between
    axes). ``grid`` gives values to try for nonlinear parameters; ``period`` names one that is a
    period over the axis position. The returned machine knows the effect by name too, so that
    ``diagnose(..., add=["NAME@AXIS"])`` and its ``physical_model().with_effect`` accept it.
    """
    system = systems.get(system)
    grid = dict(grid or {})
    if not isinstance(effect, type):
        if not callable(effect) or not name:
            raise TypeError("register_effect: give an Effect subclass, or a function and its name")
        effect = _function_effect(effect, name, n_coefficients, tuple(grid), whole_state)
    if not issubclass(effect, fx.Effect) or not effect.name:
        raise TypeError(f"register_effect: {effect!r} is not an Effect subclass with a name")
    if effect.plant_only:
        raise ValueError(f"{effect.name} is plant-only: a static model cannot add it")
    missing = [p for p in (*grid, *([period] if period else [])) if p not in effect.nonlinear]
    if missing:
        raise ValueError(f"{effect.name}: grid names {missing}, which are not nonlinear parameters {effect.nonlinear}")
    candidate = Candidate.of(effect, Search(family, grid, period))
    settings = system.diagnosis
    names = settings.candidate_names
    diagnosis = dataclasses.replace(settings, candidates=(*[c for c in settings.candidates if c.name != effect.name],
                                                          candidate),
                                    candidate_names=None if names is None else (*names, effect.name))
    return dataclasses.replace(system, effects=(*[e for e in system.effects if e.name != effect.name], effect),
                               diagnosis=diagnosis)


def _function_effect(function, name: str, n_coefficients: int, nonlinear: tuple[str, ...],
                     whole_state: bool = False) -> type[fx.Effect]:
    """An Effect subclass whose columns are ``function`` of the axis's own kinematics (or of the
    whole ``State``)."""

    def _columns(self, q, qd, qdd, loads):
        i = self._i()
        kw = {p: getattr(self, p) for p in nonlinear}
        if whole_state:
            cols = function(State(q, qd, qdd, i, loads.torque, loads.gravity), **kw)
        else:
            cols = function(q[..., i], qd[..., i], qdd[..., i], **kw)
        cols = np.asarray(cols, dtype=float)
        cols = cols.reshape(q.shape[0], -1)
        if cols.shape[1] != n_coefficients:
            raise ValueError(f"{name}: the function returned {cols.shape[1]} columns, expected {n_coefficients}")
        return tuple(cols.T)

    linear = tuple(f"c{k}" for k in range(n_coefficients))
    fields = [(p, float, dataclasses.field(default=0.0)) for p in linear + nonlinear]
    namespace = {"name": name, "linear": linear, "nonlinear": nonlinear, "_columns": _columns,
                 "reads": ("torque", "gravity") if whole_state else ()}
    return dataclasses.make_dataclass(f"UserEffect_{name}", fields, bases=(fx.Effect,), frozen=True, namespace=namespace)
