"""FlexArm plant: integration accuracy, static balance, sensors and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from lcgym.references import Reference
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.plant import HOME, FlexArmPlant, PIDGains
from lcgym.systems.flexarm.references import arm_reference_set
from lcgym.systems.ix.plant import SimulationDiverged


@pytest.fixture(scope="module")
def line():
    return arm_reference_set("validation", seed=0, n_references=1)[0]


def _load(trial):
    return np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])


def test_integration_converges_as_the_step_shrinks(line):
    """Without quantization and noise: the load trajectory with 1, 2, 4 RK4 steps per sample
    against 16; the error falls with the step and the default (4) is within 0.005 deg."""
    runs = {n: _load(FlexArmPlant(substeps=n, encoder_counts=0, accel_noise=0.0).run(line)) for n in (1, 2, 4, 16)}
    err = [np.degrees(np.abs(runs[n] - runs[16]).max()) for n in (1, 2, 4)]
    assert err[0] > err[1] > err[2]
    assert err[2] < 0.005


def test_rest_holds_the_static_balance_and_the_accelerometer_reads_gravity():
    T = 1000
    ref = Reference("rest", 1000.0, np.tile(HOME, (T, 1)), np.zeros((T, 6)), np.zeros((T, 6)), axes=arm.AXES)
    plant = FlexArmPlant(accel_noise=0.0)
    tr = plant.run(ref)
    ql = _load(tr)
    assert np.degrees(np.abs(ql - ql[0]).max()) < 1e-3  # at rest (encoder dither only)
    # static balance by hand: the joint springs carry gravity, K_J (q_m / N - q_l) = G(q_l)
    dh, pi = plant.true_arm.dh.table(), plant.true_arm.vector()
    drive = plant.true_drive
    torsion = np.asarray(drive.KJ) * (tr.pos[-1] - ql[-1])
    np.testing.assert_allclose(torsion, arm.bias_torques(dh, pi, ql[-1], np.zeros(6), arm.GRAVITY), atol=0.05 * 260 / 100)
    Rw, pw = arm.forward_kinematics(dh, ql[-1])
    acc = np.column_stack([tr.extra[f"acc_{c}"] for c in "xyz"])
    expected = Rw[5].T @ np.array([0.0, 0.0, arm.GRAVITY]) + np.asarray(plant.accel_bias)
    np.testing.assert_allclose(acc.mean(axis=0), expected, atol=1e-3)
    tcp = np.column_stack([tr.extra[f"tcp_{c}"] for c in "xyz"])
    np.testing.assert_allclose(tcp.mean(axis=0), pw[5], atol=1e-5)
    motor = np.column_stack([tr.extra[f"motor_{a}"] for a in tr.axes])
    np.testing.assert_allclose(tr.pos * np.asarray(plant.true_drive.N), motor)


@pytest.mark.fault
@pytest.mark.bad_input
def test_bad_feedforward_and_divergence_fail_clearly(line):
    plant = FlexArmPlant()
    ff = np.zeros((line.n_samples, 6))
    ff[10, 2] = np.nan
    with pytest.raises(ValueError, match="feedforward must be finite"):
        plant.run(line, ff)
    g = plant.gains
    unstable = FlexArmPlant(gains=PIDGains(tuple(-k for k in g.kp), g.ki, g.kd))  # positive feedback
    with pytest.raises(SimulationDiverged, match="safe range"):
        unstable.run(line)


def test_settled_start_leaves_gravity_to_a_feedforward_that_carries_it():
    """With Basic's feedforward (gravity in it), the default start has the integrators hold gravity
    as well, so the motors jump at t = 0 (over 0.1 rad of the motor); ``settled_start`` makes the
    integrators hold only what the first feedforward sample lacks. Without a feedforward both
    starts are the same run."""
    from lcgym.systems.flexarm.nominal import BasicFeedforward

    ref = arm_reference_set("validation", 0, 1)[0]
    nom = BasicFeedforward()
    b = nom.compute(ref.positions, ref.fs)
    N = np.asarray(nom.drive.N)
    start_error = {}
    for settled in (False, True):
        tr = FlexArmPlant(settled_start=settled).run(ref, b["tau_ff"], b["motor_offset"])
        motor = np.column_stack([tr.extra[f"motor_{a}"] for a in tr.axes])
        start_error[settled] = np.abs(N * ref.positions[0] + b["motor_offset"][0] - motor[0]).max()
    assert start_error[False] > 0.1 and start_error[True] < 0.005, start_error
    plain = [FlexArmPlant(settled_start=s).run(ref) for s in (False, True)]
    np.testing.assert_array_equal(plain[0].u, plain[1].u)
