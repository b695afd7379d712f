"""The library's effects inside a simulated plant: one compiled torque that every plant adds.

Every plant (the IX's kernel, the FlexArm's, a URDF machine's) adds the torque of its hidden
effects to its equation of motion through ``axis_torque`` below, so an effect of
``physics.effects`` is defined once (its formula function and its class) and simulated by every
plant the same way; the physical model and the diagnosis evaluate the same formula functions
through the class's ``columns``.

A plant packs the effects of each axis into one row of floats (``pack``): a record per effect,
``[kind, size, parameters...]`` (the parameters as ``Effect.plant_parameters`` gives them: the
linear coefficients then the nonlinear ones, in the class's order), records sorted by kind, a kind
of 0 ending the row; a row of zeros is an axis without effects. Sorting fixes the order in which
the torques are summed, so that a plant's results do not depend on the order the user listed
its effects in.

The kinds are the effects whose torque is a function of the axis's own position q and velocity
qd (and, for ``LoadFriction``, of the gravity torque ``load`` the plant passes): each declares its
code, ``Effect.plant_kind``. Effects that change the structure of the equation stay with the
plants that have that structure: stiction (bristle states), drivetrain flexibility (a motor
behind a spring), cable inertia (it adds to M(q)), torque ripple (it scales the input), a rotor
inertia (a URDF plant's armature) and a machine's own effects (the IX's guidance friction); the
shapes of no set form the diagnosis fits have no plant. Each of those says why
(``Effect.no_plant_kind``). One exception to the rule: the IX simulates Coulomb and Stribeck
friction in its own friction law, whose level its guidance friction raises and its stiction
scales (``systems.ix.plant.OWN_FRICTION_LAW``).

Adding an effect of q and qd: its class in ``physics.effects`` (with ``slopes`` and a new
``plant_kind``) and its branch in ``axis_torque``; ``tests/test_plant_effects.py`` checks every
plant kind against the class's own ``torque`` and fails on a library class that has neither a
kind nor a reason.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import effects as fx
from .compiled import FASTMATH, Kernels

PLANT_KINDS: dict[int, type[fx.Effect]] = dict(sorted((cls.plant_kind, cls) for cls in fx.EFFECTS.values() if cls.plant_kind))
"""The library's effects that every plant simulates, by their ``Effect.plant_kind`` (0 ends a row):
records are summed in the order of their kinds."""

# the kernel's names of the kinds (numba compiles module-level integers in as constants)
VISCOUS = fx.ViscousFriction.plant_kind
CABLE_SPRING = fx.CableSpring.plant_kind
GEAR_HARMONIC = fx.GearHarmonic.plant_kind
CABLE_DRAPE = fx.CableDrape.plant_kind
TABULATED = fx.TabulatedForce.plant_kind
ASYMMETRIC = fx.AsymmetricFriction.plant_kind
OFFSET = fx.Offset.plant_kind
COULOMB = fx.CoulombFriction.plant_kind
STRIBECK = fx.StribeckFriction.plant_kind
LOAD_FRICTION = fx.LoadFriction.plant_kind


def has_plant_kind(effect: fx.Effect | type[fx.Effect]) -> bool:
    """Whether every plant simulates ``effect`` (an effect or its class) through ``axis_torque``."""
    cls = effect if isinstance(effect, type) else type(effect)
    return PLANT_KINDS.get(cls.plant_kind) is cls


def pack(effects: Sequence[fx.Effect], n_rows: int, rows: Sequence[int] | None = None) -> np.ndarray:
    """The records (n_rows, width) of bound ``effects`` (``Effect.bound``), each in row
    ``rows[effect.index]`` (default: its axis index); refuses an effect without a plant kind."""
    per_row: list[list[fx.Effect]] = [[] for _ in range(n_rows)]
    for e in effects:
        if not has_plant_kind(e):
            raise ValueError(f"{e.key}: {e.name} {refusal(type(e))}")
        per_row[e.index if rows is None else rows[e.index]].append(e)
    records = [[v for e in sorted(row, key=lambda e: e.plant_kind) for v in _record(e)] for row in per_row]
    out = np.zeros((n_rows, max([len(r) for r in records] + [0]) + 1))  # + 1: the row ends on a 0 kind
    for i, r in enumerate(records):
        out[i, : len(r)] = r
    return out


def _record(e: fx.Effect) -> list[float]:
    p = [float(v) for v in e.plant_parameters()]
    return [float(e.plant_kind), float(len(p)), *p]


def refusal(cls: type[fx.Effect]) -> str:
    """Why effects of ``cls`` are not a plant kind (``Effect.no_plant_kind``)."""
    return cls.no_plant_kind or "has no plant kind (Effect.plant_kind)"


def slopes(effects: Sequence[fx.Effect], n_axes: int, load=0.0) -> tuple[np.ndarray, np.ndarray]:
    """Per axis (n_axes,), the summed largest |d tau / d qd| and |d tau / d q| of bound ``effects``
    (``Effect.slopes``; ``load``: per axis, the largest gravity torque a load-dependent friction
    reads): what sets a plant's integration step."""
    dv, dq = np.zeros(n_axes), np.zeros(n_axes)
    load = np.broadcast_to(np.asarray(load, dtype=float), (n_axes,))
    for e in effects:
        a, b = e.slopes(load[e.index])
        dv[e.index] += a
        dq[e.index] += b
    return dv, dq


njit = Kernels(__file__, fx.__file__)


@njit(fastmath=FASTMATH)
def axis_torque(row, q, v, load, tau):
    """``tau`` plus the torque [input unit] the packed effects ``row`` (``pack``) add to the input
    one axis needs, at its position q [rad or m], velocity v [per s] and gravity torque ``load``
    [input unit] (read by a load-dependent friction only). ``tau``: a plant's own terms to add them
    to (0.0 for none), so that the compiler may fuse each product into that sum."""
    j = 0
    while j < row.shape[0] and row[j] != 0.0:
        kind, size = int(row[j]), int(row[j + 1])
        c = row[j + 2 : j + 2 + size]
        if kind == VISCOUS:
            tau += c[0] * v
        elif kind == CABLE_SPRING:
            tau += c[0] * fx.cable_spring_basis(q, c[1], c[2], c[3])
        elif kind == GEAR_HARMONIC:
            b = fx.gear_harmonic_basis(q, v, c[6], c[7])
            tau += c[0] * b[0] + c[1] * b[1] + c[2] * b[2] + c[3] * b[3] + c[4] * b[4] + c[5] * b[5]
        elif kind == CABLE_DRAPE:
            s, co = fx.drape_basis(q)
            tau += c[0] * s + c[1] * co
        elif kind == TABULATED:
            x = q if c[0] > 0.0 else v
            tau += fx.table_lookup(x, c[1], c[2], c[3:])
        elif kind == ASYMMETRIC:
            b = fx.asymmetric_friction_basis(v, c[3])
            tau += c[0] * b[0] + c[1] * b[1] + c[2] * b[2]
        elif kind == OFFSET:
            tau += c[0]
        elif kind == COULOMB:
            tau += c[0] * fx.smooth_sign(v, c[1])
        elif kind == STRIBECK:
            tau += c[0] * fx.stribeck_shape(v, c[1]) * fx.smooth_sign(v, c[2])
        elif kind == LOAD_FRICTION:
            b = fx.load_friction_basis(v, load, c[2])
            tau += c[0] * b[0] + c[1] * b[1]
        j += 2 + size
    return tau
