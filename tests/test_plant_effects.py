"""One effect, one place: every plant adds the library's effects through ``physics.plant_effects``.

The compiled torque of each plant kind is checked against the effect class's own ``torque`` (the
model side), its slopes against finite differences, and each plant's wiring against an independent
route to the same physics: a viscous friction effect against the rigid body's own viscous term (the
IX), a Coulomb friction effect against the drives' own load friction (the FlexArm).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from lcgym.physics import effects as fx
from lcgym.physics import plant_effects as pe
from lcgym.references import Reference
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.plant import HOME, FlexArmPlant
from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import random_moves

AXES = ("a", "b")
RNG = np.random.default_rng(3)

ONE_OF_EACH = [
    fx.ViscousFriction("b", d=0.7),
    fx.CableSpring("b", k=3.0, q0=0.2, width=0.05, side=-1.0),
    fx.GearHarmonic.from_amplitudes("b", 0.4, 0.3, 0.2, 1.1, velocity_gain=0.5, period=0.3, v_ref=0.5),
    fx.CableDrape("b", s=0.8, c=-0.3),
    fx.TabulatedForce.from_function("b", "velocity", lambda v: np.tanh(4 * v) + 0.2 * v**2, -1.0, 1.0, points=33),
    fx.TabulatedForce.from_function("b", "position", lambda q: np.sin(3 * q), -1.5, 1.5, points=65),
    fx.AsymmetricFriction("b", Fc_pos=0.5, Fc_neg=0.3, dFv=0.1, eps=0.05),
    fx.Offset("b", c=-0.4),
    fx.CoulombFriction("b", Fc=0.6, eps=0.02),
    fx.StribeckFriction("b", dF=0.5, vs=0.1, eps=0.03),
    fx.LoadFriction("b", Fc=0.2, mu=0.05, eps=0.04),
]


def kinematics(n=400):
    return RNG.uniform(-2, 2, (n, 2)), RNG.normal(0, 0.5, (n, 2)), RNG.normal(0, 1, (n, 2)), RNG.normal(0, 20, (n, 2))


def plant_torque(effect, q, qd, load):
    row = pe.pack([effect.bound(AXES)], 2)[1]
    return np.array([pe.axis_torque(row, q[k, 1], qd[k, 1], load[k, 1], 0.0) for k in range(q.shape[0])])


def test_every_effect_of_the_library_is_a_plant_kind_or_says_why_not():
    """A class of ``physics.effects`` is a plant kind (a code of its own), or says why not (an
    effect of structure some plants carry, or a shape of the diagnosis); one test effect of every
    kind is below."""
    kinds = [cls.plant_kind for cls in fx.EFFECTS.values() if cls.plant_kind]
    assert len(kinds) == len(set(kinds)) and all(k > 0 for k in kinds), kinds
    for cls in fx.EFFECTS.values():
        assert bool(cls.plant_kind) + bool(cls.no_plant_kind) == 1, cls.name
        assert pe.has_plant_kind(cls) == bool(cls.plant_kind), cls.name
    assert {type(e) for e in ONE_OF_EACH} == set(pe.PLANT_KINDS.values())


def test_a_new_effect_without_a_plant_kind_is_refused_by_name():
    """The control: an effect class the plants do not know is refused, naming where kinds live."""

    @dataclass(frozen=True)
    class Cubic(fx.Effect):
        k3: float = 0.0
        name: ClassVar[str] = "cubic_spring"
        linear: ClassVar[tuple[str, ...]] = ("k3",)

        def _columns(self, q, qd, qdd, loads):
            return (self._q(q) ** 3,)

    with pytest.raises(ValueError, match=r"cubic_spring@b: cubic_spring has no plant kind \(Effect.plant_kind\)"):
        pe.pack([Cubic("b", k3=1.0).bound(AXES)], 2)
    with pytest.raises(ValueError, match="stiction@b: stiction has internal state"):
        pe.pack([fx.Stiction("b").bound(AXES)], 2)


@pytest.mark.parametrize("effect", ONE_OF_EACH, ids=lambda e: f"{e.name}-{getattr(e, 'variable', '')}")
def test_plant_torque_is_the_models_torque(effect):
    """The compiled torque a plant adds equals the class's own torque (columns times coefficients,
    the physical model's and the diagnosis's), at random states."""
    q, qd, qdd, g = kinematics()
    if effect.plant_only:
        expected = effect.force(q[:, 1] if effect.variable == "position" else qd[:, 1])
    else:
        expected = effect.bound(AXES).torque(q, qd, qdd, fx.Loads(gravity=g))[:, 1]
    np.testing.assert_allclose(plant_torque(effect, q, qd, g), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("effect", ONE_OF_EACH, ids=lambda e: f"{e.name}-{getattr(e, 'variable', '')}")
def test_slopes_bound_the_torques_derivatives(effect):
    """``slopes`` (what sets a plant's step) is at least the steepest finite-difference slope of the
    torque in qd and in q over states within the gear harmonic's speed range."""
    n, h = 4000, 1e-6
    q, qd = RNG.uniform(-2, 2, (n, 2)), RNG.uniform(-1, 1, (n, 2))
    g = np.full((n, 2), 20.0)
    dv, dq = effect.bound(AXES).slopes(20.0)
    shift = np.zeros((n, 2))
    shift[:, 1] = h
    tau = plant_torque(effect, q, qd, g)
    assert np.max(np.abs(plant_torque(effect, q, qd + shift, g) - tau)) / h <= dv * (1 + 1e-3) + 1e-6
    assert np.max(np.abs(plant_torque(effect, q + shift, qd, g) - tau)) / h <= dq * (1 + 1e-3) + 1e-6


def test_records_are_summed_in_one_order_whatever_the_users():
    effects = [e.bound(AXES) for e in ONE_OF_EACH[:4] + ONE_OF_EACH[6:9]]
    np.testing.assert_array_equal(pe.pack(effects, 2), pe.pack(effects[::-1], 2))
    assert not pe.pack([], 2).any()  # a row of zeros: no effects


def test_ix_plant_adds_a_viscous_friction_like_its_rigid_body():
    """The IX: a viscous friction effect d on the roll axis (through the shared records) and the
    rigid body's own viscous coefficient D3 + d give the same run."""
    ref = random_moves("move", np.random.default_rng(1), duration=4)
    rigid = ix.IXParameters()
    by_effect = IXPlant(effects=(fx.ViscousFriction("roll", d=0.3),), encoder_resolution=(0, 0)).run(ref)
    by_rigid = IXPlant(rigid=dataclasses.replace(rigid, d3=rigid.d3 + 0.3), effects=(), encoder_resolution=(0, 0)).run(ref)
    np.testing.assert_allclose(by_effect.extra["load_roll"], by_rigid.extra["load_roll"], atol=1e-10)
    np.testing.assert_allclose(by_effect.u, by_rigid.u, atol=1e-8)
    with pytest.raises(ValueError, match="load_friction@roll: the IX plant does not simulate a load-dependent friction"):
        IXPlant(effects=(fx.LoadFriction("roll", Fc=0.1, mu=0.01),))


def test_flexarm_plant_adds_a_coulomb_friction_like_its_load_friction():
    """The FlexArm: a Coulomb friction Fc [motor N m] on joint 2, on the load side, and the drive's
    own load Coulomb friction raised by N Fc give the same run; without effects the drive table is
    the drives' alone (the kernel's path unchanged)."""
    T = 800
    t = np.arange(T) / 1000.0
    q = HOME + np.outer(0.3 * np.sin(2 * math.pi * 0.8 * t), np.ones(6))
    ref = Reference("wave", 1000.0, q, np.gradient(q, 1e-3, axis=0), np.zeros((T, 6)), axes=arm.AXES)
    base = FlexArmPlant(encoder_counts=0, accel_noise=0.0)
    Fc = 2.0
    by_effect = dataclasses.replace(base, effects=(fx.CoulombFriction("j2", Fc=Fc, eps=base.friction_eps),)).run(ref)
    drive = base.true_drive
    flc = tuple(f + (drive.N[1] * Fc if i == 1 else 0.0) for i, f in enumerate(drive.Flc))
    by_drive = dataclasses.replace(base, true_drive=dataclasses.replace(drive, Flc=flc)).run(ref)
    load = lambda tr: np.column_stack([tr.extra[f"load_{a}"] for a in tr.axes])  # noqa: E731
    # the two routes differ in round-off only, which the wrist's stiff friction near standstill
    # amplifies (to 3e-8 rad with Fc = 0.4); the friction itself moves the joints by 1e-4 to 6e-3 rad
    effect = np.abs(load(by_effect) - load(base.run(ref))).max()
    assert effect > 1e-3
    assert np.abs(load(by_effect) - load(by_drive)).max() < 1e-6 * effect
    np.testing.assert_array_equal(base.drive_table(), drive.table())
    with pytest.raises(ValueError, match="stiction@j1: the FlexArm plant simulates effects of the joint angle"):
        FlexArmPlant(effects=(fx.Stiction("j1"),))
