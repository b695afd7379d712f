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

The plant (``systems.flexarm.plant``) takes the motor-reference offset qbar_mr - N q_lr and the total
feedforward tau_ff,0 = tau_ln + tau_nl,0. ``model_following_error`` gives e_pl = P_lu mu - qdd_l
(eq. 16's error) with mu = u - tau_nl - F2(r_q) = u - tau_ff + F2(q_mr): the inner plant's input
(eq. 20) less the torque F2 adds for r_q. r_q is the torsion the *nonlinear* load torque causes, which tau_nl pays for; the
linear model does not produce it, so without that term a plant the nominal model matches would
show e_pl = P_lu F2(r_q) != 0, the fixed point of eq. (16) would not be Basic there, and the
learning would shake the load (eq. 21's e_pl vanishes there). For any method on the arm, tau_ff
is its feedforward (its split into tau_ln and tau_nl does not enter). ``BasicFeedforward.run`` runs the
plant with Basic and records e_pl, ``load_response`` is P_lu on a frequency grid (what the learning
methods invert). ``FLEXARM.nominal`` is this structure: the start of the methods of paper 002.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from scipy import signal

from ...physics.kinematics import reference_kinematics
from ...physics.lti import lsim
from . import dynamics as arm

HOME = arm.HOME  # where M_n is taken


@dataclass
class BasicFeedforward:
    """Nominal feedforward of Fig. 1 for the nominal ``arm`` and ``drive``; ``eps`` [rad/s] smooths
    sgn as tanh(v / eps). ``compute(q_lr, fs)`` returns a dict of (T, 6) arrays: ``motor_offset``
    [rad, motor] = qbar_mr - N q_lr, ``tau_ff``, ``tau_ln``, ``tau_nl`` [N m, motor side],
    ``r_q`` [rad, motor], ``f2_q_mr`` [N m, motor side] = F2(q_mr), ``tau_lr`` [N m, load side]."""

    arm_params: arm.ArmParameters = field(default_factory=arm.ArmParameters)
    drive: arm.DriveParameters = field(default_factory=arm.DriveParameters)
    eps: float = 0.01
    name: ClassVar[str] = "basic"  # the FlexArm env's base_feedforward option for this structure

    def reference_offset(self, reference) -> np.ndarray:
        """The motor reference offset of F1 and r_q,0 as a load-side angle (T, 6) [rad] for a Reference."""
        return self.compute(reference.positions, reference.fs)["reference_offset"]

    def load_response(self, n: int, fs: float) -> np.ndarray:
        """P_lu (e^{i w Ts}) (n_freq, 6) [rad/s^2 per N m] on the rfft grid of n samples: the nominal
        linear model from motor torque to load acceleration per joint (``load_model``), discretized
        with a zero-order hold. The zero-frequency bin is 0: a constant torque ends in a constant
        velocity against the dampers (``load_model`` has no free integrator, so z = 1 is regular)."""
        ts = 1.0 / fs
        z = np.exp(1j * 2 * math.pi * np.fft.rfftfreq(n, ts) * ts)
        out = np.empty((z.size, 6), dtype=complex)
        for i in range(6):
            A, B, C = self.load_model(i)
            Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, np.zeros((1, 1))), ts, method="zoh")
            x = np.linalg.solve(z[:, None, None] * np.eye(A.shape[0]) - Ad, np.broadcast_to(Bd, (z.size, *Bd.shape)))
            out[:, i] = (Cd @ x)[:, 0, 0] + Dd[0, 0]
        return out

    def run(self, plant, reference, tau_nl_update=None):
        """Run ``reference`` on ``plant`` (a ``FlexArmPlant``) with this feedforward ("Basic", plus an
        optional update of tau_nl (T, 6) [N m]) and add the model-following error to the trial's
        extras: ``e_pl_<joint>`` [rad/s^2] from the accelerometer-based load acceleration (what the
        paper's learning uses) and ``e_pl_true_<joint>`` from the simulation's true load acceleration."""
        from .sensors import estimate_load_acceleration, true_load_acceleration

        basic = self.compute(reference.positions, reference.fs)
        update = 0.0 if tau_nl_update is None else np.asarray(tau_nl_update, dtype=float)
        feedforward = basic["tau_ff"] + update
        trial = plant.run(reference, feedforward, basic["motor_offset"])
        qdd_est = estimate_load_acceleration(trial, self.arm_params, self.drive, offset=plant.accel_offset)
        for label, qdd in (("e_pl", qdd_est), ("e_pl_true", true_load_acceleration(trial))):
            e = model_following_error(trial, feedforward, basic, self, qdd)
            trial.extra.update({f"{label}_{a}": e[:, i] for i, a in enumerate(trial.axes)})
        trial.meta["controller"] = "basic"
        return trial

    @property
    def Mn(self) -> np.ndarray:  # noqa: N802 (the paper's name)
        return np.diag(arm.mass_matrix(self.arm_params.dh.table(), self.arm_params.vector(), HOME)).copy()

    def compute(self, q_lr: np.ndarray, fs: float) -> dict:
        d = self.drive
        N, Jm, Dm, Fmc, KJ, DJ, Dl, Flc = (np.asarray(getattr(d, n), dtype=float) for n in arm.DRIVE_FIELDS)
        q, qd, qdd = reference_kinematics(q_lr, fs)
        Mn = self.Mn
        sgn = lambda v: np.tanh(v / self.eps)  # noqa: E731
        tau_lr = arm.load_torque(self.arm_params, d, q, qd, qdd, self.eps)  # eq. (14)
        linear_load = Mn * qdd + Dl * qd
        delta = np.column_stack([_lsim(([1.0], [DJ[i], KJ[i]]), linear_load[:, i], fs) for i in range(6)])
        q_mr = N * (q + delta)  # F1, eq. (9)
        r_q = N / KJ * (tau_lr - linear_load)  # eq. (11)
        qbar = q_mr + r_q
        _, qbd, qbdd = reference_kinematics(qbar, fs)
        tau_ln = self._f2(qbar, fs)  # eq. (10)
        tau_ff = Jm * qbdd + Dm * qbd + Fmc * sgn(qbd) + tau_lr / N  # eqs. (13), (15)
        return {"motor_offset": qbar - N * q, "reference_offset": (qbar - N * q) / N, "tau_ff": tau_ff, "tau_ln": tau_ln,
                "tau_nl": tau_ff - tau_ln, "r_q": r_q, "f2_q_mr": self._f2(q_mr, fs), "tau_lr": tau_lr}

    def _f2(self, y: np.ndarray, fs: float) -> np.ndarray:
        """F2 = P_mu^-1 (eq. 10): the linear model's motor torque (T, 6) [N m] for motor motions y (T, 6) [rad]."""
        _, yd, ydd = reference_kinematics(y, fs)
        return np.column_stack([self._motor_torque(i, y[:, i], yd[:, i], ydd[:, i], fs) for i in range(6)])

    def _motor_torque(self, i, y, yd, ydd, fs):
        """P_mu^-1 y of joint i: the load answers the motor motion y through the joint spring."""
        d = self.drive
        N, Jm, Dm, KJ, DJ, Dl = d.N[i], d.Jm[i], d.Dm[i], d.KJ[i], d.DJ[i], d.Dl[i]
        Mn = self.Mn[i]
        num, den = [DJ / N, KJ / N], [Mn, Dl + DJ, KJ]
        ql = _lsim((num, den), y, fs, x0_output=y[0] / N)
        qld = np.gradient(ql, np.arange(len(ql)) / fs)
        tau_s = KJ * (y / N - ql) + DJ * (yd / N - qld)
        return Jm * ydd + Dm * yd + tau_s / N

    def load_acceleration(self, mu: np.ndarray, fs: float) -> np.ndarray:
        """P_lu mu: the nominal linear model's load acceleration (T, 6) [rad/s^2] for inner-plant
        torques mu (T, 6) [N m], starting in the steady state of mu's first sample held since
        before the trial, x0 = -A^-1 B mu_0 (the plant holds its first sample through the pre-roll;
        P_lu's zero-frequency gain is 0, so that state's load acceleration is 0). Started at rest
        with the spring unloaded instead, a torque the feedback holds at t = 0 (an unmodelled
        weight) would set the model ringing at its joint mode and e_pl would show a transient the
        arm never made (Basic on FlexArm-v1's first seed-0 validation line, largest |e_pl| in the
        0.5 s before it moves: 0.80 / 1.72 rad/s^2 on joints 2 / 3 from rest, 0.017 / 0.029 from the
        held state)."""
        out = np.empty_like(mu, dtype=float)
        for i in range(6):
            A, B, C = self.load_model(i)
            x0 = -np.linalg.solve(A, B[:, 0] * mu[0, i])
            out[:, i] = lsim(A, B, C, np.zeros((1, 1)), mu[:, i], fs, x0)[0]
        return out

    def load_model(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A, B, C) of joint i's nominal linear model P_lu (eqs. 3-4): states [phi, qd_l, qd_m] with
        phi = q_m / N - q_l the joint's torsion [rad] (the common position of motor and load is no
        state: the load acceleration does not depend on it), input the motor torque [N m], output
        the load acceleration qdd_l [rad/s^2]."""
        d = self.drive
        N, Jm, Dm, KJ, DJ, Dl = d.N[i], d.Jm[i], d.Dm[i], d.KJ[i], d.DJ[i], d.Dl[i]
        Mn = self.Mn[i]
        A = np.array([[0, -1, 1 / N],
                      [KJ / Mn, -(DJ + Dl) / Mn, DJ / (N * Mn)],
                      [-KJ / (N * Jm), DJ / (N * Jm), -(Dm + DJ / (N * N)) / Jm]])
        B = np.array([[0.0], [0.0], [1.0 / Jm]])
        return A, B, A[1:2].copy()  # C: the qdd_l row


def _lsim(system, u, fs: float, x0_output: float = 0.0) -> np.ndarray:
    """Response of a SISO transfer function (num, den) to u sampled at fs [Hz], starting in steady state at the
    output value ``x0_output`` (a constant input that held the output there)."""
    ss = signal.StateSpace(*signal.tf2ss(*system))
    dc = float(np.polyval(system[0], 0.0) / np.polyval(system[1], 0.0))
    u0 = x0_output / dc if dc != 0 else 0.0
    x0 = np.linalg.solve(ss.A, -ss.B[:, 0] * u0) if np.linalg.matrix_rank(ss.A) == ss.A.shape[0] else None
    return np.asarray(lsim(ss.A, ss.B, ss.C, ss.D, u, fs, x0)[0], dtype=float)


def model_following_error(trial, feedforward: np.ndarray, basic: dict, nominal: BasicFeedforward,
                          qdd_l: np.ndarray) -> np.ndarray:
    """e_pl = P_lu mu - qdd_l (T, 6) [rad/s^2] with mu = u - tau_ff + F2(q_mr) (eq. 16's error; the
    module docstring says why F2(r_q) is taken out). ``feedforward`` (T, 6) [N m] is the torque fed
    forward in the run (Basic's tau_ff plus any update of tau_nl), ``basic`` is ``nominal.compute``
    of the reference, and ``qdd_l`` is the load-side joint acceleration (true, or estimated from the
    accelerometer)."""
    mu = trial.u - feedforward + basic["f2_q_mr"]
    return nominal.load_acceleration(mu, trial.fs) - qdd_l
