"""The FlexArm's learning laws (``systems.learning``), which the learning methods reach through the
plant (``FlexArmPlant.learning_law``) and never import: ``ArmLaw`` on any base (the least-squares
physical model by default), and ``ModelFollowingLaw``, paper 002's eq. 16 on Basic. ``ArmLaw``'s
feedforward torque f and its reference
offset o are learned from what the machine measures, the motor encoders and the flange
accelerometer, never the simulation's true load angle.

The loop of each joint (nominal linear model of ``systems.flexarm.nominal``, eqs. 3-4, with the
load inertia ``inertia``; the plant's PID C(z) with its derivative low-pass; ZOH at fs):

    q_m = P_m u,   q_l = P_lm q_m / N,   u = C (r - q_m) + f,   r = N (q_lr + o)

P_m: motor torque -> motor angle [rad of the motor / N m], the load hanging on the joint spring;
P_lm = (D_J s + K_J) / (M s^2 + (D_l + D_J) s + K_J): motor angle / N -> load angle. The
true load error splits into what the encoders see and the torsion they do not:

    e_l = q_lr - q_l = e_m + (phi - o),   e_m = q_lr + o - q_m / N,   phi = q_m / N - q_l

The accelerometer sees e_l's second derivative, e_a = qdd_lr - qdd_l (``sensors.
estimate_load_acceleration``), but not its slow part: a static torsion error of 1e-4 rad tilts
the flange's gravity reading by 1e-3 m/s^2, under the sensor's 0.02 m/s^2 noise and absorbed by
the bias estimate at rest; below ``offset_hp_hz`` the double integral of e_a is noise and drift.

The update of one trial (``update``; the default ``torque="motor"``, ``offset=False``: Delta_o =
0, Q at 8 Hz, the loop model with the fitted arm's load inertia), per joint, f_0 the base's torque:

    Delta_o = g_o Q_o P_lm^-1 H_hp [-E_a / w^2]                       (offset, load side [rad])
    f'      = f_0 + Q [ f - f_0 + u_fb + g P_m^-1 N (e_m + Delta_o) ]  (torque [N m])
    o'      = o + Delta_o

The offset learned from the accelerometer (``offset=True``) diverged on FlexArm-v1 within five
trials: it is off by default (the figures: docs/methods/ilc.md).

u_fb = u - f is the measured feedback torque: (P_m S)^-1 e_m = C e_m + P_m^-1 e_m, and C e_m is
what the PID put out (with its integrator's start, which the settled start hands over to f), so
the DC pole of C needs no inversion. H_hp is a zero-phase high-pass (``offset_hp_hz``): the
offset learns only where the accelerometer sees the load; below it the base's offset stays. The
torque term P_m^-1 N Delta_o moves the motor onto the new reference in the same trial. Q, Q_o
are zero-phase Butterworth |B|^2 (``systems.learning.q_filter``); f, u_fb and e_m are padded with their edge
values (``systems.learning.frequency_update``'s ``hold_edges``: the arm holds gravity at rest).

Other laws for comparison (``torque``): ``"lcs"`` is paper 002's eq. (16) around the base,
f' = Q [f + P_lu^-1 e_pl] with e_pl = P_lu (u - f + F2(q_mr)) - qdd_l (the model-following error,
q_mr = N (q_lr + o)); ``"none"`` learns the offset only.

A trial is judged (``ArmLoop.measure``, ``systems.learning.best_trial``) by each scored joint's
measured load-error estimate (``measured_load_error``: the encoder error below ``offset_hp_hz``,
the doubly integrated accelerometer error above) and by the measured end-effector acceleration
error, a 7th column: the trial kept exceeds trial 0 on none of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ...physics.kinematics import lowpass_zero_phase, reference_kinematics
from ..learning import LearningLaw, LearningLoop, Measured, Signals, frequency_update, held_edges, q_filter, rms, true_error
from . import dynamics as arm
from .references import MOVING
from .sensors import estimate_load_acceleration, specific_forces, true_load_acceleration

ACC_CUTOFF = 50.0  # Hz: the accelerometer estimate's zero-phase low-pass (sensors.py); the reference's too
REST = 0.3  # s: the rest at the start over which the accelerometer's bias is taken (sensors.py)


@dataclass(frozen=True)
class ArmILCConfig:
    """trials: learning updates (plant trials: trials + 1, trial 0 the base); torque: "motor" (the
    encoder error through P_m S), "lcs" (eq. 16 around the base) or "none"; q_hz, q_order, gain:
    the torque's Q and gain; offset: learn the reference offset from the accelerometer;
    offset_q_hz, offset_hp_hz, offset_gain: its band and gain; offset_joints: the joints whose
    offset is learned (0-based; default the moving ones)."""

    trials: int = 8
    torque: str = "motor"
    q_hz: float = 8.0
    q_order: int = 4
    gain: float = 1.0
    offset: bool = False
    offset_q_hz: float = 8.0
    offset_hp_hz: float = 1.0
    offset_gain: float = 1.0
    offset_joints: tuple[int, ...] = MOVING

    def __post_init__(self):
        if self.torque not in ("motor", "lcs", "none"):
            raise ValueError(f"torque must be 'motor', 'lcs' or 'none', got {self.torque!r}")


# ----------------------------------------------------------------------------- loop model

def loop_responses(nominal, n: int, fs: float, inertia=None) -> dict[str, np.ndarray]:
    """{"P_m": torque -> motor angle [rad motor / N m], "P_l": torque -> load angle [rad / N m],
    "P_lm": P_l N / P_m [-]} (n_freq, 6) on the rfft grid of n samples: the nominal linear joint
    model (``nominal.load_model``'s states plus the motor angle) with load inertia ``inertia`` (6,)
    [kg m^2] (default the nominal structure's M_n), discretized with a zero-order hold. Bin 0 of
    P_m and P_l is infinite (a free integrator); P_lm's is 1."""
    d = nominal.drive
    M = np.asarray(nominal.Mn if inertia is None else inertia, dtype=float)
    ts = 1.0 / fs
    z = np.exp(1j * 2 * math.pi * np.fft.rfftfreq(n, ts) * ts)
    out = {k: np.empty((z.size, 6), dtype=complex) for k in ("P_m", "P_l")}
    for i in range(6):
        N, Jm, Dm, KJ, DJ, Dl = d.N[i], d.Jm[i], d.Dm[i], d.KJ[i], d.DJ[i], d.Dl[i]
        # states [phi, qd_l, qd_m, q_m]: phi = q_m / N - q_l the torsion (``nominal.load_model``)
        A = np.array([[0, -1, 1 / N, 0],
                      [KJ / M[i], -(DJ + Dl) / M[i], DJ / (N * M[i]), 0],
                      [-KJ / (N * Jm), DJ / (N * Jm), -(Dm + DJ / (N * N)) / Jm, 0],
                      [0, 0, 1, 0]])
        B = np.array([[0.0], [0.0], [1.0 / Jm], [0.0]])
        C = np.array([[0, 0, 0, 1.0], [-1.0, 0, 0, 1 / N]])  # q_m, q_l = q_m / N - phi
        Ad, Bd, Cd, _, _ = signal.cont2discrete((A, B, C, np.zeros((2, 1))), ts, method="zoh")
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.linalg.solve(z[1:, None, None] * np.eye(4) - Ad, np.broadcast_to(Bd, (z.size - 1, 4, 1)))
        y = Cd @ x
        out["P_m"][0, i] = out["P_l"][0, i] = np.inf
        out["P_m"][1:, i], out["P_l"][1:, i] = y[:, 0, 0], y[:, 1, 0]
    out["P_lm"] = np.ones_like(out["P_m"])
    out["P_lm"][1:] = out["P_l"][1:] * np.asarray(d.N)[None, :] / out["P_m"][1:]
    return out


def load_inertia(arm_params: arm.ArmParameters, positions: np.ndarray) -> np.ndarray:
    """diag M_l (6,) [kg m^2] of ``arm_params`` at the mean pose of ``positions`` (T, 6): the load
    inertia each joint's loop model takes (the fitted physical model's arm holds the payload)."""
    return np.diag(arm.mass_matrix(arm_params.dh.table(), arm_params.vector(), np.asarray(positions).mean(axis=0))).copy()


# ----------------------------------------------------------------------------- measurement

def measure(trial, reference, nominal, feedforward: np.ndarray, offset: np.ndarray, accel_offset,
            base_offset: np.ndarray | None = None, crossover_hz: float = 1.0,
            model_following: bool = True) -> dict[str, np.ndarray]:
    """What the machine measures in a trial, as the errors the update takes (all (T, 6) but ``ee``):

    - ``motor`` [rad, load side]: e_m = q_lr + o - q_m / N (encoders);
    - ``feedback`` [N m]: u - f (the torque the PID added);
    - ``acceleration`` [rad/s^2]: e_a = qdd_lr - qdd_l, qdd_l from the accelerometer and encoders
      (``sensors.estimate_load_acceleration``), qdd_lr low-passed as it is;
    - ``e_pl`` [rad/s^2]: eq. (16)'s model-following error around this trial's feedforward and
      motor reference (for ``torque="lcs"``; only with ``model_following``);
    - ``load`` [rad]: the measured estimate of the load error (``measured_load_error``);
    - ``ee`` (T,) [m/s^2]: |accelerometer - its bias (taken at rest) - the reference's specific force|
      with the nominal kinematics."""
    fs, q_lr = trial.fs, reference.positions[: trial.pos.shape[0]]
    o = np.zeros_like(q_lr) if offset is None else np.asarray(offset, dtype=float)
    f = np.asarray(feedforward, dtype=float)
    e_m = q_lr + o - trial.pos
    qdd_l = estimate_load_acceleration(trial, nominal.arm_params, nominal.drive, offset=accel_offset)
    qdd_lr = lowpass_zero_phase(reference_kinematics(q_lr, fs)[2], fs, ACC_CUTOFF)
    e_a = qdd_lr - qdd_l
    u_fb = trial.u - f
    o0 = o if base_offset is None else np.asarray(base_offset, dtype=float)
    load = measured_load_error(e_m - (o - o0), e_a, fs, crossover_hz)
    out = {"motor": e_m, "feedback": u_fb, "acceleration": e_a, "load": load,
           "ee": measured_ee_error(trial, reference, nominal, accel_offset)}
    if model_following:  # the nominal models' runs cost more than the rest together: only where used
        N = np.asarray(nominal.drive.N, dtype=float)
        out["e_pl"] = nominal.load_acceleration(u_fb + nominal._f2(N * (q_lr + o), fs), fs) - qdd_l
    return out


def measured_ee_error(trial, reference, nominal, accel_offset) -> np.ndarray:
    """|a_meas - bias - f(q_lr, qd_lr, qdd_lr)| (T,) [m/s^2] with the nominal kinematics and the bias
    taken over the first ``REST`` s (the arm at rest, as ``sensors.py`` does)."""
    dh, o = nominal.arm_params.dh.table(), np.asarray(accel_offset, dtype=float)
    q, qd, qdd = (np.ascontiguousarray(x[: trial.pos.shape[0]], dtype=float)
                  for x in (reference.positions, reference.velocities, reference.accelerations))
    f_ref = specific_forces(dh, q, qd, qdd, o, arm.GRAVITY)
    acc = np.column_stack([trial.extra[f"acc_{c}"] for c in "xyz"])
    n_rest = max(1, int(REST * trial.fs))
    bias = (acc[:n_rest] - f_ref[:n_rest]).mean(axis=0)
    return np.linalg.norm(lowpass_zero_phase(acc - bias - f_ref, trial.fs, ACC_CUTOFF), axis=1)


def measured_load_error(e_m: np.ndarray, e_a: np.ndarray, fs: float, crossover_hz: float) -> np.ndarray:
    """Complementary estimate of the load error (T, 6) [rad]: the encoder error e_m (load side, less
    the learned change of the offset) below ``crossover_hz`` and the double integral of the
    accelerometer's e_a above it (zero-phase 2nd-order split, H_lp + H_hp = 1). Below the
    crossover the torsion error phi - o is taken as the base's, which no sensor here measures."""
    T = e_m.shape[0]
    n = 2 * T
    w = 2 * math.pi * np.fft.rfftfreq(n, 1.0 / fs)
    hp = _highpass(w, crossover_hz)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        from_acc = np.where(w[:, None] > 0, -np.fft.rfft(e_a, n=n, axis=0) / w[:, None] ** 2, 0.0)
    E = (1 - hp) * np.fft.rfft(held_edges(e_m), n=n, axis=0) + hp * from_acc
    return np.fft.irfft(E, n=n, axis=0)[:T]


def _highpass(w: np.ndarray, hz: float, order: int = 2) -> np.ndarray:
    """Zero-phase high-pass 1 - |Butterworth low-pass|^2 at ``hz`` on the angular frequencies w."""
    x = (w / (2 * math.pi * hz)) ** (2 * order)
    return x / (1.0 + x)


# ----------------------------------------------------------------------------- the update

def update(nominal, f: np.ndarray, offset: np.ndarray | None, error: dict, fs: float, config: ArmILCConfig,
           inertia=None, base: np.ndarray | None = None, responses: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One learning update (module docstring): the next feedforward (T, 6) [N m] and reference
    offset (T, 6) [rad, load side] from the present ones and ``error``, a dict of (T, 6) signals as
    ``measure`` returns them (measured, or predicted by a model: eq. 17's use). Keys used:
    ``motor`` and ``feedback`` (torque "motor"), ``e_pl`` (torque "lcs"), ``acceleration`` (offset).
    The PID's own output needs no model: it is measured (``feedback``). ``inertia`` (6,) the
    loop model's load inertia (default the nominal M_n); ``responses``: ``loop_responses`` of those on
    the update's grid, where the caller has them (the same every trial of a reference)."""
    f = np.asarray(f, dtype=float)
    T = f.shape[0]
    f0 = np.zeros_like(f) if base is None else np.asarray(base, dtype=float)
    f = f - f0  # Q acts on the learned correction: the base's own content above Q's corner stays
    o = np.zeros_like(f) if offset is None else np.asarray(offset, dtype=float)
    n = 2 * T
    N = np.asarray(nominal.drive.N, dtype=float)
    resp = loop_responses(nominal, n, fs, inertia) if responses is None else responses
    w = 2 * math.pi * np.fft.rfftfreq(n, 1.0 / fs)
    d_o = np.zeros_like(o)
    D_o = np.zeros((w.size, 6), dtype=complex)
    if config.offset:
        q_o = q_filter(n, fs, config.offset_q_hz, config.q_order)[:, None] * _highpass(w, config.offset_hp_hz)[:, None]
        E_a = np.fft.rfft(np.asarray(error["acceleration"], dtype=float), n=n, axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            E_l = np.where(w[:, None] > 0, -E_a / w[:, None] ** 2, 0.0)
        mask = np.zeros(6)
        mask[list(config.offset_joints)] = 1.0
        D_o = config.offset_gain * mask * q_o * E_l / resp["P_lm"]
        d_o = np.fft.irfft(D_o, n=n, axis=0)[:T]
    q = q_filter(n, fs, config.q_hz, config.q_order)[:, None]
    if config.torque == "motor":
        inv_pm = np.zeros_like(resp["P_m"])
        inv_pm[1:] = 1.0 / resp["P_m"][1:]
        base = np.fft.rfft(held_edges(f + np.asarray(error["feedback"], dtype=float)), axis=0)
        E_m = np.fft.rfft(held_edges(N * np.asarray(error["motor"], dtype=float)), axis=0)
        F = q * (base + config.gain * inv_pm * (E_m + N * D_o))
    elif config.torque == "lcs":
        response = nominal.load_response(n, fs)
        inv = np.divide(1.0, response, out=np.zeros_like(response), where=np.abs(response) > 0.0)
        inv[0] = 0.0
        inv_pm = np.zeros_like(resp["P_m"])
        inv_pm[1:] = 1.0 / resp["P_m"][1:]
        E_pl = np.fft.rfft(np.asarray(error["e_pl"], dtype=float), n=n, axis=0)
        F = q * (np.fft.rfft(held_edges(f), axis=0) + config.gain * inv * E_pl) + inv_pm * N * D_o
    else:
        inv_pm = np.zeros_like(resp["P_m"])
        inv_pm[1:] = 1.0 / resp["P_m"][1:]
        F = np.fft.rfft(held_edges(f), axis=0) + inv_pm * N * D_o
    return f0 + np.fft.irfft(F, n=n, axis=0)[:T], o + d_o


# ----------------------------------------------------------------------------- the laws

def _row(load: np.ndarray, ee: np.ndarray) -> np.ndarray:
    return np.concatenate([rms(load), [float(np.sqrt(np.mean(np.square(ee))))]])


def _true_row(trial) -> np.ndarray:
    """RMS of the true load error (6) [rad] (reporting only; the EE column NaN: the true
    end-effector error costs a run of the nominal models, which reporting does not pay)."""
    return np.concatenate([rms(true_error(trial)), [np.nan]])


PREDICTED = ArmILCConfig(torque="lcs", q_hz=6.0)
"""The update a predicted error enters (the RBF expert on a base): eq. (16) around the base's
feedforward with the predicted model-following error, Q at 6 Hz, the base's offset kept."""


class ArmLaw(LearningLaw):
    """The FlexArm's law on a base (module docstring): learns the torque from the encoders' error
    through the loop model P_m S, and judges a trial by the measured load-error estimate of each
    joint and the measured end-effector acceleration error (a 7th history column). ``trials``: the
    learning updates; ``settings``: the law's own (``ArmILCConfig``; its ``trials`` unused here);
    ``nominal``: the nominal structure whose linear joint models the loop model takes (paper 002's
    Basic)."""

    def __init__(self, plant, nominal, trials: int, settings: ArmILCConfig = ArmILCConfig()):
        self.plant, self.nominal, self.trials, self.settings = plant, nominal, trials, settings

    def loop(self, reference, start: Signals, model=None) -> ArmLoop:
        """``model``: the base's fitted physical model; each joint's loop model then carries the load
        inertia of its fitted arm (payload included) at the reference's mean pose (the nominal M_n
        lacks the payload, and the static end-effector error rose with it)."""
        inertia = None if model is None else load_inertia(model.fitted_params.arm(), reference.positions)
        return ArmLoop(self, reference, start, inertia)


class ArmLoop(LearningLoop):
    """``ArmLaw``'s workspace of one reference; its state is (feedforward (T, 6) [N m], offset (T,
    6) [rad, load side])."""

    def __init__(self, law: ArmLaw, reference, start: Signals, inertia=None):
        self.law, self.reference, self.inertia = law, reference, inertia
        f0 = np.asarray(start.feedforward, dtype=float)
        self.start = (f0, np.zeros_like(f0) if start.offset is None else np.asarray(start.offset, dtype=float))
        self._responses = None

    def run(self, state):
        f, o = state
        return self.law.plant.run(self.reference, f, np.asarray(self.law.nominal.drive.N, dtype=float) * o)

    def measure(self, trial, state) -> Measured:
        law = self.law
        err = measure(trial, self.reference, law.nominal, *state, law.plant.accel_offset, self.start[1],
                      law.settings.offset_hp_hz, model_following=law.settings.torque == "lcs")
        return Measured(_row(err["load"], err["ee"]), _true_row(trial), err)

    def update(self, state, measured: Measured):
        law, f0 = self.law, self.start[0]
        fs = law.plant.fs
        if self._responses is None:  # the same every trial of the reference
            self._responses = loop_responses(law.nominal, 2 * f0.shape[0], fs, self.inertia)
        return update(law.nominal, *state, measured.error, fs, law.settings, self.inertia, base=f0,
                      responses=self._responses)

    def signals(self, state) -> Signals:
        return Signals(*state)

    def columns(self, scored) -> list[int]:
        return [*scored, self.start[0].shape[1]]  # and the end-effector column

    def model_error(self, trial, state) -> np.ndarray:
        """e_pl (T, 6) [rad/s^2] (``measure``'s): what the RBF expert's predictor learns."""
        return measure(trial, self.reference, self.law.nominal, *state, self.law.plant.accel_offset)["e_pl"]

    def predicted(self, error: np.ndarray) -> Signals:
        """Eq. (17) around the base: one ``PREDICTED`` update with the predicted e_pl (T, 6) [rad/s^2]."""
        law, (f0, o0) = self.law, self.start
        return Signals(*update(law.nominal, f0, o0, {"e_pl": error}, self.reference.fs, PREDICTED, base=f0))


class ModelFollowingLaw(LearningLaw):
    """Paper 002's learning on Basic (section 5.3, the LCS): tau_nl updated with the model-following
    error e_pl estimated from the accelerometer (``BasicFeedforward.run``), eq. (16),

        tau_nl,k+1 = Q_u [tau_nl,k + P_lu^-1 e_pl,k],

    P_lu the nominal linear model from motor torque to load acceleration (``nominal.load_response``),
    Q_u zero phase (``config.arm_q_hz``, the paper's 20 Hz; ``q_order``; gain ``arm_gain``), tau_nl
    padded with its edge values (it holds gravity at rest). ``config``: ``methods.ilc.ILCConfig``;
    ``trials``: its ``arm_trials``."""

    def __init__(self, plant, nominal, config):
        self.plant, self.nominal, self.config, self.trials = plant, nominal, config, config.arm_trials

    def loop(self, reference, start: Signals, model=None) -> ModelFollowingLoop:
        return ModelFollowingLoop(self, reference)


def nominal_update(nominal, tau_nl: np.ndarray, e_pl: np.ndarray, fs: float, config) -> np.ndarray:
    """Eq. (16) (and eq. (17) with a predicted e_pl): Q_u [tau_nl + P_lu^-1 e_pl] (T, n_axes) [N m],
    P_lu the ``nominal`` structure's load response. Its zero-frequency bin is 0 (a constant torque
    leaves no load acceleration), so a constant e_pl asks for no torque there: the inverse's bin is 0.
    ``config``: ``arm_q_hz``, ``q_order``, ``arm_gain``."""
    T = tau_nl.shape[0]
    response = nominal.load_response(2 * T, fs)
    inverse = np.divide(1.0, response, out=np.zeros_like(response), where=np.abs(response) > 0.0)
    inverse[0] = 0.0
    return frequency_update(tau_nl, e_pl, inverse, q_filter(2 * T, fs, config.arm_q_hz, config.q_order), config.arm_gain,
                            hold_edges=True)


class ModelFollowingLoop(LearningLoop):
    """``ModelFollowingLaw``'s workspace of one reference; its state is the update of tau_nl (T, 6)
    [N m] on Basic's (the start: zero)."""

    def __init__(self, law: ModelFollowingLaw, reference):
        self.law, self.reference = law, reference
        self.basic = law.nominal.compute(reference.positions, reference.fs)
        self.start = np.zeros(reference.positions.shape)

    def run(self, state):
        return self.law.nominal.run(self.law.plant, self.reference, state)

    def measure(self, trial, state) -> Measured:
        e_pl = np.column_stack([trial.extra[f"e_pl_{a}"] for a in trial.axes])
        return Measured(rms(e_pl), rms(np.column_stack([trial.extra[f"e_pl_true_{a}"] for a in trial.axes])), e_pl)

    def update(self, state, measured: Measured):
        tau_nl = self.basic["tau_nl"]
        return nominal_update(self.law.nominal, tau_nl + state, measured.error, self.law.plant.fs, self.law.config) - tau_nl

    def signals(self, state) -> Signals:
        return Signals(self.basic["tau_ff"] + state, self.basic["reference_offset"])

    def model_error(self, trial, state) -> np.ndarray:
        return self.measure(trial, state).error

    def predicted(self, error: np.ndarray) -> Signals:
        """Eq. (17) on Basic: tau_nl,1 = Q_u [tau_nl,0 + P_lu^-1 e_hat]."""
        basic = self.basic
        return Signals(basic["tau_ff"] - basic["tau_nl"] + nominal_update(self.law.nominal, basic["tau_nl"], error,
                                                                          self.reference.fs, self.law.config),
                       basic["reference_offset"])


def learning_law(plant, base: str, config) -> LearningLaw:
    """The FlexArm's law for a learner on ``base`` ("basic": paper 002's eq. 16; any other: ``ArmLaw``,
    ``config.arm_trials`` updates). ``config``: ``methods.ilc.ILCConfig``."""
    from .nominal import BasicFeedforward

    nominal = BasicFeedforward()
    if base == "basic":
        return ModelFollowingLaw(plant, nominal, config)
    return ArmLaw(plant, nominal, config.arm_trials)


__all__ = ["PREDICTED", "ArmILCConfig", "ArmLaw", "ArmLoop", "ModelFollowingLaw", "ModelFollowingLoop",
           "learning_law", "load_inertia", "loop_responses", "measure", "measured_ee_error", "measured_load_error",
           "nominal_update", "true_load_acceleration", "update"]
