"""The FlexArm's motor-side model (systems/flexarm/motor.py) and its least-squares fit (systems/flexarm/model.py)."""

import numpy as np
import pytest
import torch

from lcgym import systems
from lcgym.data import read_trials, write_trials
from lcgym.systems.flexarm import FLEXARM as ARM
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm import motor as arm_motor
from lcgym.systems.flexarm.model import ArmModel
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant, default_true_arm
from lcgym.systems.flexarm.references import arm_reference_set
from lcgym.systems.system import REGRESSOR_MIN_ROWS

rng = np.random.default_rng(3)


def _kinematics(n=20):
    return (rng.uniform(-1, 1, (n, 6)), rng.uniform(-1, 1, (n, 6)), rng.uniform(-3, 3, (n, 6)))


def test_motor_torque_composes_rigid_body_and_drives():
    """u = tau_l / N + Jm N qdd + b qd + c sgn(qd), with tau_l from RNEA with the same pi."""
    p = arm_motor.ArmMotorParameters()
    q, qd, qdd = _kinematics()
    u = arm_motor.inverse_dynamics(p.to_vector(), q, qd, qdd)
    N = np.asarray(arm.DriveParameters().N)
    tau_l = arm.inverse_dynamics(p.arm(), q, qd, qdd)
    expected = tau_l / N + np.asarray(p.Jm) * N * qdd + np.asarray(p.b) * qd + np.asarray(p.c) * np.tanh(qd / arm_motor.EPS)
    np.testing.assert_allclose(u, expected, rtol=1e-10, atol=1e-10)
    # the nominal b, c are the drive's motor + reflected load friction
    d = arm.DriveParameters()
    np.testing.assert_allclose(p.b, np.asarray(d.Dm) * N + np.asarray(d.Dl) / N)
    np.testing.assert_allclose(p.c, np.asarray(d.Fmc) + np.asarray(d.Flc) / N)


def test_torch_path_is_linear_in_the_parameters():
    """Autograd of u_i in p is the regressor row: u = X p exactly (Lemma 1's structure)."""
    q, qd, qdd = _kinematics(3)
    p = torch.tensor(arm_motor.ArmMotorParameters().to_vector(), dtype=torch.float64, requires_grad=True)
    u = arm_motor.inverse_dynamics(p, q, qd, qdd)
    X = arm_motor.regressor(None, q, qd, qdd)
    (grad,) = torch.autograd.grad(u[1, 2], p)
    np.testing.assert_allclose(grad.numpy(), X[1, 2], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(u.detach().numpy(), X @ p.detach().numpy(), rtol=1e-12)


def test_mass_matrix_is_rigid_inertia_plus_reflected_motors():
    p = arm_motor.ArmMotorParameters()
    q = rng.uniform(-1, 1, (4, 6))
    M = arm_motor.mass_matrix(p.to_vector(), q)
    N = np.asarray(arm.DriveParameters().N)
    for k in range(4):
        expected = arm.mass_matrix(arm.DH().table(), p.arm().vector(), q[k]) + np.diag(np.asarray(p.Jm) * N**2)
        np.testing.assert_allclose(M[k], expected, rtol=1e-10, atol=1e-10)
        assert np.allclose(M[k], M[k].T) and np.linalg.eigvalsh(M[k]).min() > 0
    Mt = arm_motor.mass_matrix(torch.tensor(p.to_vector()), torch.tensor(q))
    np.testing.assert_allclose(Mt.numpy(), M, rtol=1e-12, atol=1e-12)


def test_parameters_round_trip_and_system_bundle():
    p = arm_motor.ArmMotorParameters()
    assert arm_motor.ArmMotorParameters.from_vector(p.to_vector()) == p
    assert ARM.fully_linear and ARM.n_linear == 78 and len(ARM.param_names) == 78
    assert p.drive().Dm == pytest.approx(arm.DriveParameters().Dm)  # nominal b, c map back to nominal Dm, Fmc
    with pytest.raises(ValueError, match="60"):
        arm_motor.ArmMotorParameters.from_vector(np.zeros(77))


@pytest.fixture(scope="module")
def feedback_trials():
    plant = FlexArmPlant()
    return plant, [plant.run(r) for r in arm_reference_set("train", 0, 2)]


def test_fit_takes_up_the_hidden_payload(feedback_trials):
    """Fitted on feedback-only runs of the plant (12 kg payload unknown to the nominal model), the
    model's holding torques on validation poses come close to the true arm's; the nominal's do not."""
    _, trials = feedback_trials
    model = ArmModel(ARM).fit(trials)
    q = arm_reference_set("validation", 0, 1)[0].positions[::200]
    zero = np.zeros_like(q)
    N = np.asarray(arm.DriveParameters().N)
    truth = arm.inverse_dynamics(default_true_arm(), q, zero, zero) / N
    err_fit = np.abs(model.torque(q, zero, zero) - truth).max(axis=0)
    err_nom = np.abs(ArmModel(ARM).torque(q, zero, zero) - truth).max(axis=0)
    # joints 2, 3 carry the payload's weight (measured: 0.17 / 0.87 and 0.13 / 0.59 N m); with the tool
    # hanging straight down joint 5 carries none
    assert np.all(err_fit[1:3] < 0.3 * err_nom[1:3]), (err_fit, err_nom)
    assert err_fit[4] < 0.01
    assert model.fit_info_["residual_rms"] < 0.2  # N m, after the 5 Hz low-pass
    # what the data cannot see keeps its nominal value: link 1 turns about the vertical and never moves
    np.testing.assert_allclose(model.params_.pi[:10], arm_motor.ArmMotorParameters().pi[:10], atol=1e-9)


def test_reference_offset_is_the_joint_torsion(feedback_trials):
    """At rest the offset is the gravity torque over the joint stiffness; with it the load holds
    its reference instead of sagging."""
    plant, _ = feedback_trials
    model = ArmModel(ARM, params=arm_motor.ArmMotorParameters(pi=tuple(default_true_arm().pi)))
    ref = arm_reference_set("validation", 0, 1)[0]
    off = model.reference_offset(ref)
    d = arm.DriveParameters()
    q0 = ref.positions[:1]
    gravity = arm.inverse_dynamics(default_true_arm(), q0, 0 * q0, 0 * q0)
    np.testing.assert_allclose(off[0], gravity[0] / np.asarray(d.KJ), atol=1e-9)
    N = np.asarray(d.N)
    sag = [np.abs((ref.positions - _load(plant.run(ref, model.predict(ref), o)))[:300, 1:3].mean(axis=0))
           for o in (None, N * off)]  # mean load error of joints 2, 3 over the first 0.3 s (at rest)
    # measured: 0.079 -> 0.003 deg (joint 2), 0.045 -> 0.016 deg (joint 3); the true joints are 15 %
    # softer than the nominal K_J and the load's Coulomb friction lets it rest anywhere in a small band
    assert np.all(sag[1] < 0.4 * sag[0]), sag


def _load(trial):
    return np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])


def test_arm_trials_round_trip_through_the_measurement_format(tmp_path, feedback_trials):
    """Motor angles, torques, accelerometer, TCP, true load angles and e_pl survive a file."""
    plant, _ = feedback_trials
    trial = BasicFeedforward().run(plant, arm_reference_set("validation", 0, 1)[0])
    for suffix in (".csv", ".parquet"):
        path = write_trials(tmp_path / f"arm{suffix}", [trial])
        (back,) = read_trials(path, axes=ARM)
        tol = {"rtol": 1e-9, "atol": 1e-12} if suffix == ".csv" else {"rtol": 0, "atol": 0}  # CSV keeps 10 digits
        for name in ("t", "ref", "pos", "u", "ff"):
            np.testing.assert_allclose(getattr(back, name), getattr(trial, name), **tol)
        expected = {*(f"motor_{a}" for a in arm.AXES), *(f"load_{a}" for a in arm.AXES), "acc_x", "tcp_z",
                    *(f"e_pl_{a}" for a in arm.AXES)}
        assert expected <= set(back.extra)
        for k, v in trial.extra.items():
            np.testing.assert_allclose(back.extra[k], v, **tol)
        assert systems.get(back.meta["system"]) is ARM and back.meta["reference"] == trial.meta["reference"]


def test_regressor_cache_lives_only_inside_its_block():
    q, qd, qdd = _kinematics(REGRESSOR_MIN_ROWS)
    assert arm_motor.regressor(None, q, qd, qdd) is not arm_motor.regressor(None, q, qd, qdd)
    with arm_motor.cached_regressors():
        X = arm_motor.regressor(None, q, qd, qdd)
        assert arm_motor.regressor(None, q.copy(), qd, qdd) is X and not X.flags.writeable
        assert arm_motor.regressor(None, q + 1e-9, qd, qdd) is not X  # keyed by the values
        batch = tuple(x[:10] for x in (q, qd, qdd))  # a training batch: computed, not kept
        assert arm_motor.regressor(None, *batch) is not arm_motor.regressor(None, *batch)
    assert arm_motor._memo()._store is None  # nothing kept after the block


def test_a_cache_block_keeps_as_many_as_it_is_told():
    """A benchmark cell keeps one regressor per reference (``System.caching(size)``), then the
    machine's own number again."""
    kin = [_kinematics(REGRESSOR_MIN_ROWS) for _ in range(arm_motor.CACHE_SIZE + 2)]
    with arm_motor.cached_regressors(size=len(kin)):
        first = [arm_motor.regressor(None, *k) for k in kin]
        assert all(arm_motor.regressor(None, *k) is X for k, X in zip(kin, first, strict=True))
    assert arm_motor._memo().size == arm_motor.CACHE_SIZE
    with arm_motor.cached_regressors():
        first = [arm_motor.regressor(None, *k) for k in kin]
        assert arm_motor.regressor(None, *kin[0]) is not first[0]  # the oldest dropped
