"""The FlexArm's nominal feedforward structure (paper 002, section 2.2, Fig. 1: "Basic").

Per joint, the nominal *linear* model of eqs. (3)-(4) with the decoupled load inertia
M_n = diag M_l(q_home) (the coupling, gravity and friction go into the disturbance d):

    J_m qdd_m + D_m qd_m = u - tau_s / N,        M_n qdd_l + D_l qd_l = tau_s,
    tau_s = K_J (q_m / N - q_l) + D_J (qd_m / N - qd_l)

From the load reference q_lr it gives (all nominal values):

- F1 (eq. 9), the motor reference that makes the linear model's load follow q_lr:
  q_mr = N (q_lr + delta) with K_J delta + D_J ddelta/dt = M_n qdd_lr + D_l qd_lr;
- r_q,0 (eq. 11) = N K_J^-1 (tau_lr - M_n qdd_lr - D_l qd_lr), the torsion the nonlinear load
  torque tau_lr (eq. 14: rigid body + D_l qd + F_lc sgn qd) adds;
- F2 (eq. 10): tau_ln = the linear model's motor torque for the motor motion qbar_mr = q_mr + r_q;
- tau_ff,0 = J_m qddbar_mr + D_m qdbar_mr + F_mc sgn(qdbar_mr) + tau_lr / N (eqs. 13, 15) and
  tau_nl,0 = tau_ff,0 - tau_ln (eq. 12).

The plant (``envs.flexarm``) takes the motor-reference offset qbar_mr - N q_lr and the total
feedforward tau_ff,0 = tau_ln + tau_nl,0. ``model_following_error`` gives e_pl = P_lu mu - qdd_l
(eq. 16's error), with mu = u - tau_nl the inner plant's input.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from . import arm
from .kinematics import reference_kinematics

HOME = arm.HOME  # where M_n is taken


@dataclass
class BasicFeedforward:
    """Nominal feedforward of Fig. 1 for the nominal ``arm`` and ``drive``; ``eps`` [rad/s] smooths
    sgn as tanh(v / eps). ``compute(q_lr, fs)`` returns a dict of (T, 6) arrays: ``motor_offset``
    [rad, motor] = qbar_mr - N q_lr, ``tau_ff``, ``tau_ln``, ``tau_nl`` [N m, motor side],
    ``r_q`` [rad, motor], ``tau_lr`` [N m, load side]."""

    arm_params: arm.ArmParameters = field(default_factory=arm.ArmParameters)
    drive: arm.DriveParameters = field(default_factory=arm.DriveParameters)
    eps: float = 0.01

    @property
    def Mn(self) -> np.ndarray:  # noqa: N802 (the paper's name)
        return np.diag(arm.mass_matrix(self.arm_params.dh.table(), self.arm_params.vector(), HOME)).copy()

    def compute(self, q_lr: np.ndarray, fs: float) -> dict:
        d = self.drive
        N, Jm, Dm, Fmc, KJ, DJ, Dl, Flc = (np.asarray(getattr(d, n), dtype=float) for n in arm.DRIVE_FIELDS)
        q, qd, qdd = reference_kinematics(q_lr, fs)
        t = np.arange(q.shape[0]) / fs
        Mn = self.Mn
        sgn = lambda v: np.tanh(v / self.eps)  # noqa: E731
        tau_lr = arm.load_torque(self.arm_params, d, q, qd, qdd, self.eps)  # eq. (14)
        linear_load = Mn * qdd + Dl * qd
        delta = np.column_stack([_lsim(([1.0], [DJ[i], KJ[i]]), linear_load[:, i], t) for i in range(6)])
        q_mr = N * (q + delta)  # F1, eq. (9)
        r_q = N / KJ * (tau_lr - linear_load)  # eq. (11)
        qbar = q_mr + r_q
        _, qbd, qbdd = reference_kinematics(qbar, fs)
        tau_ln = np.column_stack([self._motor_torque(i, qbar[:, i], qbd[:, i], qbdd[:, i], t) for i in range(6)])  # F2
        tau_ff = Jm * qbdd + Dm * qbd + Fmc * sgn(qbd) + tau_lr / N  # eqs. (13), (15)
        return {"motor_offset": qbar - N * q, "reference_offset": (qbar - N * q) / N, "tau_ff": tau_ff, "tau_ln": tau_ln,
                "tau_nl": tau_ff - tau_ln, "r_q": r_q, "tau_lr": tau_lr}

    def _motor_torque(self, i, y, yd, ydd, t):
        """P_mu^-1 y of joint i: the load answers the motor motion y through the joint spring."""
        d = self.drive
        N, Jm, Dm, KJ, DJ, Dl = d.N[i], d.Jm[i], d.Dm[i], d.KJ[i], d.DJ[i], d.Dl[i]
        Mn = self.Mn[i]
        num, den = [DJ / N, KJ / N], [Mn, Dl + DJ, KJ]
        ql = _lsim((num, den), y, t, x0_output=y[0] / N)
        qld = np.gradient(ql, t)
        tau_s = KJ * (y / N - ql) + DJ * (yd / N - qld)
        return Jm * ydd + Dm * yd + tau_s / N

    def load_acceleration(self, mu: np.ndarray, fs: float, q0: np.ndarray) -> np.ndarray:
        """P_lu mu: the nominal linear model's load acceleration (T, 6) [rad/s^2] for inner-plant
        torques mu (T, 6) [N m], starting at rest at q0 (the spring unloaded)."""
        t = np.arange(mu.shape[0]) / fs
        out = np.empty_like(mu, dtype=float)
        for i in range(6):
            A, B, C = self.load_model(i)
            N = self.drive.N[i]
            _, y, _ = signal.lsim((A, B, C, np.zeros((1, 1))), mu[:, i], t, X0=[q0[i], 0.0, N * q0[i], 0.0])
            out[:, i] = y
        return out

    def load_model(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A, B, C) of joint i's nominal linear model P_lu (eqs. 3-4): states [q_l, qd_l, q_m, qd_m],
        input the motor torque [N m], output the load acceleration qdd_l [rad/s^2]."""
        d = self.drive
        N, Jm, Dm, KJ, DJ, Dl = d.N[i], d.Jm[i], d.Dm[i], d.KJ[i], d.DJ[i], d.Dl[i]
        Mn = self.Mn[i]
        A = np.array([[0, 1, 0, 0],
                      [-KJ / Mn, -(DJ + Dl) / Mn, KJ / (N * Mn), DJ / (N * Mn)],
                      [0, 0, 0, 1],
                      [KJ / (N * Jm), DJ / (N * Jm), -KJ / (N * N * Jm), -(Dm + DJ / (N * N)) / Jm]])
        B = np.array([[0.0], [0.0], [0.0], [1.0 / Jm]])
        return A, B, A[1:2].copy()  # C: the qdd_l row


def _lsim(system, u, t, x0_output: float = 0.0) -> np.ndarray:
    """Response of a SISO transfer function (num, den) to u over t, starting in steady state at the
    output value ``x0_output`` (a constant input that held the output there)."""
    ss = signal.StateSpace(*signal.tf2ss(*system))
    dc = float(np.polyval(system[0], 0.0) / np.polyval(system[1], 0.0))
    u0 = x0_output / dc if dc != 0 else 0.0
    x0 = np.linalg.solve(ss.A, -ss.B[:, 0] * u0) if np.linalg.matrix_rank(ss.A) == ss.A.shape[0] else None
    _, y, _ = signal.lsim(ss, u, t, X0=x0)
    return np.asarray(y, dtype=float)


def model_following_error(trial, basic: dict, nominal: BasicFeedforward, qdd_l: np.ndarray) -> np.ndarray:
    """e_pl = P_lu mu - qdd_l (T, 6) [rad/s^2] with mu = u - tau_nl (eq. 16's error); ``qdd_l`` the
    load-side joint acceleration (true, or estimated from the accelerometer)."""
    mu = trial.u - basic["tau_nl"]
    return nominal.load_acceleration(mu, trial.fs, trial.ref[0]) - qdd_l
