"""Load-side joint acceleration of the FlexArm from the flange accelerometer and the motor encoders
(paper 002, section 2.2: "the estimate from the end-effector accelerometer measurements using the
inverse differential kinematics technique").

Per sample, with the joint angles and velocities taken from the motor encoders (q = q_m / N),
the accelerometer's reading is linear in the joint accelerations:

    f = f(q, qd, 0) + A(q) qdd,   A(q)[:, j] = f(q, 0, e_j) - f(q, 0, 0)

with f = ``arm.specific_force`` (the sensor's own model: no second implementation). For the
moving joints the estimate solves

    min_x || A_m x - (f_meas - f(q, qd, 0) - A_s qdd_motor,s) ||^2 + lam^2 || x - qdd_motor,m ||^2

(m: moving joints, s: the others, taken from the motors): least squares on the accelerometer,
pulled toward the motor-side acceleration (qdd_m / N) only where the accelerometer cannot tell
(a 3-axis accelerometer sees three components; a planar motion gives two independent ones).
On the TCP lines the moving joints 2, 3, 5 turn in one plane: the sensor point's acceleration has
two independent components there for three joints, so one combination (a turn about the sensor
point, mostly joint 5) comes from the motors; a gyroscope would resolve it. Measured on a
validation line (tests/test_flexarm_sensors.py): RMS error 3.5 %, 4 % and 25 % of the RMS load
acceleration for joints 2, 3, 5 (motor side alone: 6 %, 5 %, 26 %).

Before that, the accelerometer's constant bias is removed: the mean reading over the first
``rest`` seconds (the arm at rest) minus the model's reading there. Motor velocities and
accelerations are central differences of the encoder angles, low-passed at ``cutoff`` Hz (zero
phase), as is the result.
"""

from __future__ import annotations

import numpy as np

from ...physics.compiled import Kernels
from ...physics.kinematics import lowpass_zero_phase
from . import dynamics as arm


def estimate_load_acceleration(trial, arm_params: arm.ArmParameters, drive: arm.DriveParameters,
                               offset=(0.0, 0.05, 0.04), moving=(1, 2, 4), lam: float = 0.1,
                               cutoff: float = 50.0, rest: float = 0.3) -> np.ndarray:
    """Estimated load-side joint accelerations (T, 6) [rad/s^2] of a FlexArm trial (extras
    ``motor_j*`` [rad] and ``acc_x/y/z`` [m/s^2]); ``offset`` [m] the accelerometer on link 6."""
    N = np.asarray(drive.N, dtype=float)
    motor = np.column_stack([trial.extra[f"motor_{a}"] for a in trial.axes])
    f_meas = np.column_stack([trial.extra[f"acc_{c}"] for c in "xyz"])
    fs = trial.fs
    q = lowpass_zero_phase(motor / N, fs, cutoff)
    qd = np.gradient(q, 1 / fs, axis=0)
    qdd_m = np.gradient(qd, 1 / fs, axis=0)
    dh, o = arm_params.dh.table(), np.asarray(offset, dtype=float)
    m = list(moving)
    s = [j for j in range(6) if j not in m]
    n_rest = max(1, int(rest * fs))
    f_rest, A, f_qd = _sensor_model(dh, q, qd, o, arm.GRAVITY)
    bias = (f_meas[:n_rest] - f_rest[:n_rest]).mean(axis=0)
    # per sample k: b = f_meas - bias - f(q, qd, 0) - A_s qdd_s, then the regularized normal equations
    b = f_meas - bias - f_qd - (A[:, :, s] @ qdd_m[:, s, None])[:, :, 0]
    Am = A[:, :, m]
    AmT = np.ascontiguousarray(Am.transpose(0, 2, 1))
    lhs = AmT @ Am + lam**2 * np.eye(len(m))
    rhs = (AmT @ b[:, :, None])[:, :, 0] + lam**2 * qdd_m[:, m]
    out = qdd_m.copy()
    out[:, m] = np.linalg.solve(lhs, rhs[:, :, None])[:, :, 0]
    return lowpass_zero_phase(out, fs, cutoff)


njit = Kernels(__file__, arm.__file__)


@njit
def _sensor_model(dh, q, qd, offset, gravity):
    """The accelerometer's model along a trajectory: f(q, 0, 0) (T, 3), the columns
    A[:, :, j] = f(q, 0, e_j) - f(q, 0, 0) (T, 3, 6) and f(q, qd, 0) (T, 3) [m/s^2]."""
    T = q.shape[0]
    zero = np.zeros(6)
    f0 = np.empty((T, 3))
    A = np.empty((T, 3, 6))
    f_qd = np.empty((T, 3))
    for k in range(T):
        f0[k] = arm.specific_force_compiled(dh, q[k], zero, zero, offset, gravity)
        for j in range(6):
            e = np.zeros(6)
            e[j] = 1.0
            A[k, :, j] = arm.specific_force_compiled(dh, q[k], zero, e, offset, gravity) - f0[k]
        f_qd[k] = arm.specific_force_compiled(dh, q[k], qd[k], zero, offset, gravity)
    return f0, A, f_qd


@njit
def specific_forces(dh, q, qd, qdd, offset, gravity):
    """``arm.specific_force`` at every sample of a trajectory (T, 6) each: (T, 3) [m/s^2]."""
    out = np.empty((q.shape[0], 3))
    for k in range(q.shape[0]):
        out[k] = arm.specific_force_compiled(dh, q[k], qd[k], qdd[k], offset, gravity)
    return out


def true_load_acceleration(trial, cutoff: float = 50.0) -> np.ndarray:
    """The simulation's true load-side joint accelerations (T, 6) [rad/s^2]: the load angles (extras
    ``load_j*`` [rad]) differentiated twice, zero-phase low-passed at ``cutoff`` [Hz] as the
    accelerometer estimate is."""
    ql = np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])
    dt = 1.0 / trial.fs
    return lowpass_zero_phase(np.gradient(np.gradient(ql, dt, axis=0), dt, axis=0), trial.fs, cutoff)
