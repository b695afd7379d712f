"""The errors paper 002 reports (section 5.3, Table 6), per sample of a FlexArm trial:

- ``joint``: the model-following error e_pl of joints 2, 3 and 5 (eq. 16's error with the true
  load acceleration, ``nominal.model_following_error``) [rad/s^2];
- ``ee_acc``: the end-effector acceleration error, the accelerometer's reading less its known bias
  less the specific force the reference would give at the sensor (T, 3) [m/s^2];
- ``tcp``: the TCP position error |p_tcp - p_tcp,ref| [mm];

and the periods the paper splits them into: ``dynamic`` (the reference moves) and ``static``.
"""

from __future__ import annotations

import numpy as np

from ...metrics import PERIODS
from . import dynamics as arm
from .nominal import BasicFeedforward, model_following_error
from .references import MOVING, tcp_positions
from .sensors import specific_forces, true_load_acceleration


def paper_errors(plant, trial, reference, feedforward: np.ndarray | None = None,
                 nominal: BasicFeedforward | None = None) -> dict[str, np.ndarray]:
    """{"joint": (T, 3) [rad/s^2], "ee_acc": (T, 3) [m/s^2], "tcp": (T, 1) [mm]} of a trial on
    ``plant`` (a ``FlexArmPlant``: its true kinematics, sensor offset and bias) for ``reference``.
    ``feedforward`` (T, 6) [N m]: the torque the run fed forward; without it the trial must come
    from ``BasicFeedforward.run``, which stored e_pl (extras ``e_pl_true_<joint>``). ``nominal``: the
    nominal structure e_pl is taken against (default: ``BasicFeedforward()``)."""
    dh, offset = plant.true_arm.dh, np.asarray(plant.accel_offset)
    f_ref = specific_forces(dh.table(), *(np.ascontiguousarray(x, dtype=float) for x in
                                          (reference.positions, reference.velocities, reference.accelerations)),
                            offset, arm.GRAVITY)
    acc = np.column_stack([trial.extra[f"acc_{c}"] for c in "xyz"]) - np.asarray(plant.accel_bias)
    if feedforward is None:
        joint = np.column_stack([trial.extra[f"e_pl_true_{trial.axes[j]}"] for j in MOVING])
    else:
        nominal = nominal or BasicFeedforward()
        basic = nominal.compute(reference.positions, reference.fs)
        e = model_following_error(trial, np.asarray(feedforward, dtype=float), basic, nominal, true_load_acceleration(trial))
        joint = e[:, list(MOVING)]
    return {"joint": joint, "ee_acc": acc - f_ref, "tcp": tcp_error(trial, dh)[:, None]}


def tcp_error(trial, dh: arm.DH) -> np.ndarray:
    """|TCP - TCP of the reference| (T,) [mm]: the trial's true TCP (extras ``tcp_x/y/z`` [m]) against
    the forward kinematics ``dh`` of its reference ``trial.ref``."""
    tcp = np.column_stack([trial.extra[f"tcp_{c}"] for c in "xyz"])
    return 1000.0 * np.linalg.norm(tcp - tcp_positions(trial.ref, dh), axis=1)


def period_mask(reference, period: str) -> np.ndarray:
    """(T,) bool: the samples of ``period`` ("all", "dynamic": any joint's reference moving, "static")."""
    if period not in PERIODS:
        raise ValueError(f"period must be one of {', '.join(PERIODS)}, got {period!r}")
    moving = np.any(np.abs(reference.velocities) > 1e-6, axis=1)
    return {"all": np.ones_like(moving), "dynamic": moving, "static": ~moving}[period]
