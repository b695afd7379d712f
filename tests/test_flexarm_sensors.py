"""Load acceleration of the FlexArm from the accelerometer, against the simulation's truth."""

from __future__ import annotations

import numpy as np

from lcgym.physics.kinematics import lowpass_zero_phase
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set
from lcgym.systems.flexarm.sensors import estimate_load_acceleration


def test_accelerometer_estimate_matches_the_true_load_acceleration():
    """Documented tolerance (systems/flexarm/sensors.py): RMS error below 6 % of the RMS load
    acceleration for joints 2 and 3, below 30 % for joint 5 (not observable in the plane of motion
    from a 3-axis accelerometer); better than the motor side alone on joints 2 and 3."""
    ref = arm_reference_set("validation", seed=0, n_references=1)[0]
    plant = FlexArmPlant()
    basic = BasicFeedforward().compute(ref.positions, ref.fs)
    tr = plant.run(ref, basic["tau_ff"], basic["motor_offset"])
    ql = np.column_stack([tr.extra[f"load_{a}"] for a in tr.axes])
    true = lowpass_zero_phase(np.gradient(np.gradient(ql, 1 / tr.fs, axis=0), 1 / tr.fs, axis=0), tr.fs, 50.0)
    est = estimate_load_acceleration(tr, arm.ArmParameters(), arm.DriveParameters(), offset=plant.accel_offset)
    motor = np.column_stack([tr.extra[f"motor_{a}"] for a in tr.axes]) / np.asarray(plant.true_drive.N)
    q = lowpass_zero_phase(motor, tr.fs, 50.0)
    from_motor = lowpass_zero_phase(np.gradient(np.gradient(q, 1 / tr.fs, axis=0), 1 / tr.fs, axis=0), tr.fs, 50.0)
    rms = lambda x: np.sqrt(np.mean(x**2, axis=0))  # noqa: E731
    j = [1, 2, 4]
    rel = rms((est - true)[:, j]) / rms(true[:, j])
    assert rel[0] < 0.06 and rel[1] < 0.06 and rel[2] < 0.30, rel
    assert np.all(rms((est - true)[:, j[:2]]) < rms((from_motor - true)[:, j[:2]]))


def test_run_basic_stores_the_model_following_error():
    """e_pl from the accelerometer estimate follows e_pl from the truth (joints 2, 3)."""
    from lcgym.systems.flexarm.nominal import BasicFeedforward

    ref = arm_reference_set("validation", seed=0, n_references=1)[0]
    tr = BasicFeedforward().run(FlexArmPlant(), ref)
    for a in ("j2", "j3"):
        est, true = tr.extra[f"e_pl_{a}"], tr.extra[f"e_pl_true_{a}"]
        assert np.sqrt(np.mean((est - true) ** 2)) < 0.25 * np.sqrt(np.mean(true**2))
