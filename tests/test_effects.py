"""Effect library: formulas checked against independent derivations and limits."""

import dataclasses
import math

import numpy as np
import pytest
import torch

from lcgym.physics import effects as fx
from lcgym.physics.candidates import library
from lcgym.references import AxisProfile, sample
from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.effects import PositionDependentFriction
from lcgym.systems.ix.plant import IX_GAINS, IXPlant

DEG = math.pi / 180
AXES = ix.AXES  # effects act on the IX's axes here (bound with ``.bound(AXES)``)
RNG = np.random.default_rng(0)
NO_GRAVITY = ix.IXParameters(x2=0.0, z2=0.0, x3=0.0, y3=0.0, z3=0.0)  # CoMs on the axes


def kin(n=200):
    q = RNG.uniform(-1.5, 1.5, (n, 2))
    qd = RNG.normal(0, 0.3, (n, 2))
    qdd = RNG.normal(0, 0.5, (n, 2))
    return q, qd, qdd


def test_torque_is_columns_times_coefficients_on_own_axis():
    q, qd, qdd = kin()
    for e in [fx.CoulombFriction("roll", Fc=0.1), fx.GearHarmonic.from_amplitudes("propeller", 0.1, 0.3, 0.05, 1.0, 0.5),
              fx.CableSpring("roll", k=0.2), PositionDependentFriction("propeller", 0.1, 0.02, 0.03)]:
        e = e.bound(AXES)
        tau = e.torque(q, qd, qdd)
        assert np.all(tau[:, 1 - e.index] == 0)
        np.testing.assert_allclose(tau[:, e.index], e.columns(q, qd, qdd) @ e.coefficients())


def test_asymmetric_friction_levels_by_direction():
    """Well above eps: Fc_pos + (d + dFv) qd moving forward, -Fc_neg + (d - dFv) qd backward (with
    the model's viscous d); equal levels and dFv = 0 are the Coulomb friction; the levels' mean and
    half difference are a Coulomb friction plus an offset (the form spans a constant input)."""
    q, qd, qdd = kin()
    e = fx.AsymmetricFriction("roll", Fc_pos=0.2, Fc_neg=0.15, dFv=0.03, eps=1e-4).bound(AXES)
    tau, v = e.torque(q, qd, qdd)[:, 1], qd[:, 1]
    fast = np.abs(v) > 0.01
    d = 0.1
    expected = np.where(v > 0, 0.2 + (d + 0.03) * v, -0.15 + (d - 0.03) * v)
    np.testing.assert_allclose((tau + d * v)[fast], expected[fast], atol=1e-12)
    same = fx.AsymmetricFriction("roll", Fc_pos=0.1, Fc_neg=0.1, eps=0.01).bound(AXES)
    coulomb = fx.CoulombFriction("roll", Fc=0.1, eps=0.01).bound(AXES)
    np.testing.assert_allclose(same.torque(q, qd, qdd), coulomb.torque(q, qd, qdd), atol=1e-15)
    split = fx.AsymmetricFriction("roll", Fc_pos=0.3, Fc_neg=0.1, eps=0.01).bound(AXES).torque(q, qd, qdd)
    parts = (fx.CoulombFriction("roll", Fc=0.2, eps=0.01).bound(AXES).torque(q, qd, qdd)
             + fx.Offset("roll", c=0.1).bound(AXES).torque(q, qd, qdd))
    np.testing.assert_allclose(split, parts, atol=1e-15)
    offset = fx.Offset("propeller", c=-0.05).bound(AXES).torque(q, qd, qdd)
    assert np.all(offset[:, 0] == -0.05) and np.all(offset[:, 1] == 0)


def test_cable_inertia_is_euler_lagrange_of_its_kinetic_energy():
    """T = 1/2 J(q) qd^2 with J = dJ sigmoid((q - q0)/w): d/dt dT/dqd - dT/dq by autograd."""
    e = fx.CableInertia("roll", dJ=0.06, q0=20 * DEG, width=10 * DEG).bound(AXES)
    q, qd, qdd = kin(20)
    for k in range(20):
        qt = torch.tensor(q[k, 1], dtype=torch.float64, requires_grad=True)
        qdt = torch.tensor(qd[k, 1], dtype=torch.float64, requires_grad=True)
        T = 0.5 * e.dJ * torch.sigmoid((qt - e.q0) / e.width) * qdt**2
        p = torch.autograd.grad(T, qdt, create_graph=True)[0]  # generalized momentum J(q) qd
        dp_dq, dp_dqd = torch.autograd.grad(p, (qt, qdt), retain_graph=True)
        dT_dq = torch.autograd.grad(T, qt)[0]
        expected = float(dp_dq * qd[k, 1] + dp_dqd * qdd[k, 1] - dT_dq)
        assert e.torque(q[k : k + 1], qd[k : k + 1], qdd[k : k + 1])[0, 1] == pytest.approx(expected, rel=1e-10)


def test_cable_spring_is_one_sided_and_a_potential_force():
    e = fx.CableSpring("roll", k=0.22, q0=20 * DEG, width=3 * DEG).bound(AXES)
    q = np.zeros((3, 2))
    q[:, 1] = [-30 * DEG, 20 * DEG, 80 * DEG]
    tau = e.torque(q, np.zeros_like(q), np.zeros_like(q))[:, 1]
    assert abs(tau[0]) < 1e-6  # slack below q0
    assert tau[2] == pytest.approx(0.22 * 60 * DEG, rel=1e-6)  # linear far beyond q0
    # side = -1 mirrors it
    mirrored = fx.CableSpring("roll", k=0.22, q0=-20 * DEG, width=3 * DEG, side=-1.0).bound(AXES)
    assert mirrored.torque(-q, q * 0, q * 0)[2, 1] == pytest.approx(-tau[2], rel=1e-9)


def test_gear_harmonic_amplitude_form():
    e = fx.GearHarmonic.from_amplitudes("propeller", 0.14, 0.7, 0.06, 2.0, velocity_gain=0.5, period=5 * DEG,
                                        v_ref=15 * DEG).bound(AXES)
    q, qd, qdd = kin()
    x = 2 * math.pi * q[:, 0] / (5 * DEG)
    expected = 0.14 * (1 + 0.5 * np.abs(qd[:, 0]) / (15 * DEG)) * np.sin(x + 0.7) + 0.06 * np.sin(2 * x + 2.0)
    np.testing.assert_allclose(e.torque(q, qd, qdd)[:, 0], expected, atol=1e-12)


def test_stribeck_limits():
    e = fx.StribeckFriction("roll", dF=0.09, vs=0.4 * DEG, eps=1e-4).bound(AXES)
    v = np.array([1e-2 * DEG, 0.4 * DEG, 20 * DEG])
    qd = np.column_stack([np.zeros(3), v])
    tau = e.torque(np.zeros((3, 2)), qd, np.zeros((3, 2)))[:, 1]
    np.testing.assert_allclose(tau, 0.09 * np.exp(-((v / (0.4 * DEG)) ** 2)) * np.tanh(v / 1e-4))
    assert tau[2] < 1e-12  # gone at speed


def _open_loop_roll(effects, ff_roll, duration=8.0):
    """Gravity-free plant, no feedback: a constant roll torque ff_roll from standstill."""
    profiles = [AxisProfile(0.0).dwell(duration), AxisProfile(0.0).dwell(duration)]
    ref = sample("hold", profiles, 500.0, tail=0.0)
    plant = IXPlant(rigid=NO_GRAVITY, effects=effects, gains=dataclasses.replace(IX_GAINS, kp=(0.0, 0.0), kd=(0.0, 0.0)),
                    encoder_resolution=(0.0, 0.0), preroll=0.0)
    ff = np.zeros_like(ref.positions)
    ff[:, 1] = ff_roll
    return plant.run(ref, ff).extra["load_roll"]


def test_stiction_holds_below_breakaway_and_slips_above():
    """LuGre: Coulomb 0.10 V, static 0.16 V. Under a 0.13 V torque the roll axis deflects (presliding,
    about 0.07 deg) and then stays; the static friction curve without stiction lets it creep on;
    0.20 V breaks it away."""
    friction = (fx.CoulombFriction("roll", Fc=0.10), fx.StribeckFriction("roll", dF=0.06, vs=0.4 * DEG))
    stuck = _open_loop_roll(friction + (fx.Stiction("roll", sigma0=1e4, sigma1=60.0),), 0.13)
    creeping = _open_loop_roll(friction, 0.13)
    sliding = _open_loop_roll(friction + (fx.Stiction("roll", sigma0=1e4, sigma1=60.0),), 0.20, duration=3.0)
    mid = len(stuck) // 2
    assert abs(stuck[-1]) < 0.2 * DEG
    assert abs(stuck[-1] - stuck[mid]) < 1e-6  # stuck: no motion in the second half
    assert creeping[-1] - creeping[mid] > 1e-3  # rad: without stiction it keeps moving
    assert sliding[-1] > 10 * DEG


def test_lugre_steady_state_is_the_stribeck_curve():
    """At constant speed the bristles settle and LuGre friction equals L + dF exp(-(v/vs)^2)."""
    v = 10 * DEG
    sw = AxisProfile(0.0).move(50 * DEG, v, 40 * DEG, 300 * DEG)
    ref = sample("ramp", [AxisProfile(0.0).dwell(sw.end_time), sw], 500.0)
    effects = (fx.CoulombFriction("roll", Fc=0.10), fx.StribeckFriction("roll", dF=0.06, vs=0.4 * DEG),
               fx.Stiction("roll"))
    tr = IXPlant(rigid=NO_GRAVITY, effects=effects, encoder_resolution=(0.0, 0.0)).run(ref)
    cruise = np.abs(ref.velocities[:, 1] - v) < 1e-9
    cruise &= np.roll(cruise, 500)  # at least 1 s into the constant-speed phase
    expected = 0.10 + 0.06 * math.exp(-((v / (0.4 * DEG)) ** 2)) + NO_GRAVITY.d3 * v
    assert np.mean(tr.u[cruise, 1]) == pytest.approx(expected, rel=2e-3)


GROWS_LIKE_THE_RIGID_BODY = {("cable_inertia", 1)}
"""(effect, variable) pairs that grow faster than linearly beyond the data, as physics demands: a
position-dependent inertia's 1/2 J'(q) qd^2 (Euler-Lagrange), like the rigid body's own centrifugal
terms, quadratic in the speed (and zero away from its onset)."""


@pytest.mark.parametrize("cand", library(), ids=lambda c: c.name)
def test_every_library_effect_grows_at_most_linearly_beyond_its_data(cand):
    """Issue 49: outside the data a fitted effect is extrapolated, so each of the diagnosis's
    candidates, with any coefficients and its data-set shape, stays bounded or grows at most
    linearly in position, velocity and acceleration (and in the load a load friction reads): over
    [0, 16 X] its largest torque is at most twice that over [0, 8 X], X beyond any shape's scale."""
    shape = {"lo": -1.0, "hi": 1.0, "v_top": 1.0}  # a shape-free curve's data range
    effect = cand.effect(axis="roll", **{n: v for n, v in shape.items() if n in cand.effect.nonlinear})
    rng = np.random.default_rng(7)
    effect = effect.with_coefficients(rng.uniform(0.5, 1.5, len(effect.linear))).bound(AXES)
    x = np.linspace(0.0, 16 * 20.0, 4001)
    for which in range(3):
        for sign in (1.0, -1.0):
            k = [np.full((x.size, 2), 0.3) for _ in range(3)]
            k[which] = np.stack([sign * x, np.zeros_like(x)], axis=1)
            load = np.stack([1.0 + 0.1 * x, np.zeros_like(x)], axis=1)  # a load torque growing linearly too
            loads = fx.Loads(torque=load, gravity=load)
            tau = np.abs(effect.torque(*k, loads)[:, 0])
            half = x <= 8 * 20.0
            if (cand.name, which) in GROWS_LIKE_THE_RIGID_BODY:
                assert tau.max() <= 4.0 * tau[half].max() + 1e-9
            else:
                assert tau.max() <= 2.0 * tau[half].max() + 1e-9, (cand.name, which, sign)
