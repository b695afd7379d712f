"""PhysicalModel: least-squares fit, variable projection over the CoM coordinates, effects."""

import math

import numpy as np
import pytest

from lcgym.data import Trial
from lcgym.physics import effects as fx
from lcgym.physics.kinematics import reference_kinematics
from lcgym.physics.model import PhysicalModel, QuadraticDesign
from lcgym.systems.ix import IX, compiled
from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.references import random_moves
from lcgym.systems.system import NonlinearStructure

TRUE = ix.IXParameters(m2=1.8, m3=2.6, J2yy=0.6, J3xx=0.75, J3yy=0.45, J3zz=0.42, J3xy=0.01, J3xz=-0.02,
                       J3yz=0.02, d2=1.5, d3=0.8, x2=0.02, z2=0.08, x3=0.03, y3=0.05, z3=-0.04)


def synthetic_trials(effects=(), n=3, seed=0, duration=20.0):
    """Trials whose input is exactly the true model's torque (no plant, no noise)."""
    rng = np.random.default_rng(seed)
    model = PhysicalModel(IX, params=TRUE, effects=effects)
    trials = []
    for i in range(n):
        r = random_moves(f"s{i}", rng, duration=duration)
        u = model.predict(r)
        trials.append(Trial(t=r.t, ref=r.positions, pos=r.positions, u=u, axes=ix.AXES))
    return trials


def test_fit_recovers_the_input_map_from_nominal_start():
    trials = synthetic_trials()
    model = PhysicalModel(IX).fit(trials)  # starts at the spec's nominal values, far from TRUE
    assert model.fit_info_["residual_rms"] < 1e-6
    new = random_moves("new", np.random.default_rng(99), duration=20)
    true_f = PhysicalModel(IX, params=TRUE).predict(new)
    np.testing.assert_allclose(model.predict(new), true_f, atol=2e-5)
    # identifiable physical quantities come back: damping, roll inertia about its axis
    p = model.params_
    assert p.d2 == pytest.approx(TRUE.d2, rel=1e-4) and p.d3 == pytest.approx(TRUE.d3, rel=1e-4)
    m33 = lambda q: q.J3xx + q.m3 * (q.y3**2 + q.z3**2)  # noqa: E731
    assert m33(p) == pytest.approx(m33(TRUE), rel=1e-5)


def test_unidentifiable_combination_keeps_nominal_split():
    """J2yy enters only as J2yy + (J3yy + J3zz) in combination: the fit keeps the nominal split."""
    q, qd, qdd = np.random.default_rng(1).normal(size=(3, 100, 2))
    X = ix.regressor(ix.IXParameters().to_vector()[ix.N_LINEAR:], q, qd, qdd)
    names = ix.ZETA_L
    combo = X[..., names.index("J2yy")] - X[..., names.index("J3yy")] - X[..., names.index("J3zz")]
    np.testing.assert_allclose(combo, 0, atol=1e-12)


def test_fit_with_effect_recovers_coefficients():
    spring = fx.CableSpring("roll", k=0.3, q0=20 * math.pi / 180)
    gear = fx.GearHarmonic.from_amplitudes("propeller", 0.1, 0.5, 0.04, 1.0, velocity_gain=0.5)
    trials = synthetic_trials(effects=(spring, gear))
    model = PhysicalModel(IX, params=TRUE).with_effect(fx.CableSpring("roll", q0=spring.q0)).with_effect(
        fx.GearHarmonic("propeller"))
    model.fit(trials)
    fitted = {e.key: e for e in model.effects_}
    assert fitted["cable_spring@roll"].k == pytest.approx(0.3, rel=1e-3)
    np.testing.assert_allclose(fitted["gear_harmonic@propeller"].coefficients(), gear.coefficients(), atol=1e-3)


def test_ripple_fit_first_order():
    ripple = fx.TorqueRipple.from_amplitude("roll", 0.03, 2.4 * math.pi / 180, 1.0)
    rng = np.random.default_rng(3)
    trials = []
    for i in range(2):
        r = random_moves(f"r{i}", rng, duration=20)
        tau = PhysicalModel(IX, params=TRUE).predict(r)
        q, _, _ = reference_kinematics(r.positions, 500.0, 1.5)
        s, c = fx.periodic_basis(q[:, 1], ripple.period)
        u = tau.copy()
        u[:, 1] = tau[:, 1] / (1 + ripple.a_sin * s + ripple.a_cos * c)  # exact inverse of the plant's ripple
        trials.append(Trial(t=r.t, ref=r.positions, pos=r.positions, u=u, axes=ix.AXES))
    model = PhysicalModel(IX, params=TRUE, effects=(fx.TorqueRipple("roll", period=ripple.period),)).fit(trials)
    np.testing.assert_allclose(model.effects_[0].coefficients(), ripple.coefficients(), atol=2e-3)


def test_quadratic_design_is_exact():
    rng = np.random.default_rng(2)
    q, qd, qdd = rng.normal(size=(3, 40, 2))
    design = QuadraticDesign(lambda zn: compiled.regressor(zn, q, qd, qdd), 5)
    reduced = QuadraticDesign(lambda zn: ix.regressor(zn, q, qd, qdd), 5, reduce=lambda A: np.cumsum(A, axis=0)[::3])
    for _ in range(3):
        zn = rng.normal(0, 0.1, 5)
        np.testing.assert_allclose(design(zn), ix.regressor(zn, q, qd, qdd), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(reduced(zn), np.cumsum(ix.regressor(zn, q, qd, qdd), axis=0)[::3], rtol=1e-9, atol=1e-9)
    n_filtered = sum(0 if t is None else t[0].size for t in [design.c, *design.b, *design.a.values()])
    assert n_filtered < 40  # sparse: most coefficient columns are zero (21 x 22 if dense)


def test_quadratic_design_of_the_nonlinear_columns_only_is_the_same_bit_for_bit(monkeypatch):
    """The IX's columns other than ``IX.nonlinear.columns`` do not depend on zeta_n at all, and the
    design built from evaluations of those columns only (in blocks of rows on two threads) is the
    dense one's, bit for bit."""
    import numba

    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)  # the blocks' path also in one-thread test workers
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.normal(size=(3, 250_000, 2))
    others = np.setdiff1d(np.arange(ix.N_LINEAR), IX.nonlinear.columns)
    base = compiled.regressor(np.zeros(5), q, qd, qdd)
    for zn in rng.normal(0, 0.1, (3, 5)):
        full = compiled.regressor(zn, q, qd, qdd)
        assert np.array_equal(full[:, :, others], base[:, :, others])
        assert np.array_equal(compiled.regressor(zn, q, qd, qdd, columns=IX.nonlinear.columns),
                              full[:, :, list(IX.nonlinear.columns)])
    monkeypatch.setattr(numba, "get_num_threads", lambda: 1)
    assert np.array_equal(compiled.regressor(zn, q, qd, qdd), full)  # one call: the same numbers
    k = slice(None, 5000)
    dense = QuadraticDesign(lambda zn: compiled.regressor(zn, q[k], qd[k], qdd[k]), 5)
    sparse = QuadraticDesign(lambda zn, columns=None: compiled.regressor(zn, q[k], qd[k], qdd[k], columns=columns), 5,
                              columns=IX.nonlinear.columns)
    for zn in rng.normal(0, 0.1, (3, 5)):
        assert np.array_equal(sparse(zn), dense(zn))


def test_compiled_regressor_equals_numpy():
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.normal(size=(3, 50, 2))
    zn = rng.normal(0, 0.1, 5)
    np.testing.assert_allclose(compiled.regressor(zn, q, qd, qdd), ix.regressor(zn, q, qd, qdd), rtol=1e-12, atol=1e-12)


@pytest.mark.bad_input
def test_plant_only_effects_rejected_in_model():
    with pytest.raises(ValueError, match="plants only"):
        PhysicalModel(IX, effects=(fx.Stiction("roll"),))
    with pytest.raises(ValueError, match="already has"):
        PhysicalModel(IX, effects=(fx.CableSpring("roll"),)).with_effect("cable_spring@roll")


@pytest.mark.bad_input
def test_effect_labels():
    e = fx.make_effect("coulomb_friction@roll", Fc=0.05)
    assert e.key == "coulomb_friction@roll" and e.Fc == 0.05
    with pytest.raises(ValueError, match="ix has no axis 'tilt'"):
        IX.effect("coulomb_friction@tilt")
    for bad, msg in [("coulomb_friction", "NAME@AXIS"), ("friction@roll", "unknown effect")]:
        with pytest.raises(ValueError, match=msg):
            fx.make_effect(bad)


@pytest.mark.parametrize("columns", [(ix.N_LINEAR,), (-1,)])
def test_nonlinear_columns_out_of_range_rejected(columns):
    import dataclasses

    with pytest.raises(ValueError, match="nonlinear columns"):
        dataclasses.replace(IX, nonlinear=NonlinearStructure(True, columns))
    with pytest.raises(ValueError, match="nonlinear columns"):
        NonlinearStructure(False, (0,))
