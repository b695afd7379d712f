"""The FlexArm plant: a 6-joint arm with gear compliance under motor-side PID, at 1 kHz
(paper 002, sections 2 and 5.1): the closed loop, the true dynamics with their mismatch against
the nominal model, and the sensors. The nominal feedforward structure (F1, F2, tau_nl,0 of eqs.
9-15) is ``nominal.py``, the Gymnasium env ``env.py``.

What one run does, per sample k (Ts = 1 ms):

1. The motor encoders read the motor angles, quantized to ``encoder_counts`` per motor turn.
2. The PID of each joint (motor side, ``PIDGains``) acts on e = q_mr - q_m,measured with motor
   reference q_mr = N q_lr + ``motor_offset`` (q_lr the load-side reference); the derivative is
   low-passed (first order, ``f_d`` Hz). u = fb + feedforward, saturated at +-``u_max``.
3. u is held over [t_k, t_{k+1}); the true flexible-joint dynamics (``dynamics.
   flexible_derivatives``, eqs. 1-2, the same equations as the model) advance by ``substeps``
   classical RK4 steps (default 4: 0.25 ms, omega h below 0.3 for the stiffest default joint
   mode; tests/test_plant_flexarm.py shows the trajectory converging as the step shrinks).

True versus nominal: the plant runs ``true_arm`` and ``true_drive``; controllers get the nominal
``dynamics.ArmParameters()`` and ``DriveParameters()``. ``default_true_arm`` and
``default_true_drive`` hold FlexArm-v0's hidden effects: an unmodelled 12 kg payload (a block, its
centre of mass 8 cm beyond the flange), joint stiffness 15 % lower and joint damping 40 % lower
than nominal, motor and load Coulomb friction 30 % higher, motor inertia 5 % higher.

FlexArm-v1 (``VERSIONS``, ``true_arm_v1``, ``true_drive_v1``) puts paper 002's methods where the
paper measured them (section 5.3, Table 6): Basic leaves a model-following error and vibration
after stops, and one LCS iteration lowers the joint, end-effector acceleration and TCP errors in
moving and static periods alike. Its payload is a 12 kg tool 40 cm long, centre of mass 20 cm
beyond the flange, the stiffness of the main axes (joints 1-3) is 3 % below nominal, the wrist's
15 %, and the Coulomb friction of motors and loads 15 % below nominal; damping and motor inertia
as v0. Why these values, and what they were chosen on: docs/machines/flexarm.md, "Versions".

Sensors recorded per sample: the quantized motor angles, an accelerometer fixed to the flange
(``dynamics.specific_force`` at ``accel_offset``, plus a constant bias and white noise), the
TCP position (forward kinematics of the true load angles, ground truth) and the true load angles.
The run starts in static balance: motors at the first reference sample, the load sagging by the
joint torsion that gravity causes (what r_q of eq. 11 compensates, when given as ``motor_offset``),
PID integrators carrying the gravity torque; it holds that for ``preroll`` s before recording.
With ``settled_start`` the integrators carry only the part of it that the feedforward's first
sample does not: a feedforward with gravity in it (Basic's) then starts settled instead of adding
its gravity to the integrators'. That start is meant for FlexArm-v1; the default, False, is the
present machine's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...data import Trial
from ...physics import effects as fx
from ...physics import linalg, plant_effects
from ...physics.compiled import Kernels
from ...references import Reference
from ..runs import remembered
from ..system import SimulationDiverged
from . import dynamics as arm


def default_true_arm() -> arm.ArmParameters:
    """The true arm: the nominal one with an unmodelled 12 kg payload (a 20 x 20 x 15 cm block)
    8 cm beyond the flange."""
    return arm.ArmParameters().with_payload(12.0, com=(0.0, 0.0, 0.08), inertia_com=arm._box(12.0, 0.2, 0.2, 0.15))


def default_true_drive() -> arm.DriveParameters:
    """The true drives: stiffness -15 %, joint damping -40 %, Coulomb friction +30 %, Jm +5 %."""
    return scaled_drive(stiffness=(0.85,) * 6)


def scaled_drive(stiffness: tuple[float, ...], damping: float = 0.6, friction: float = 1.3,
                 motor_inertia: float = 1.05) -> arm.DriveParameters:
    """The nominal drives with the joint stiffness K_J scaled per joint by ``stiffness`` (6,), the
    joint damping D_J by ``damping``, motor and load Coulomb friction by ``friction`` and J_m by
    ``motor_inertia``; gear ratios, motor and load viscous friction as nominal."""
    nom = arm.DriveParameters()
    scale = lambda name, f: tuple(a * b for a, b in zip(getattr(nom, name), f, strict=True))  # noqa: E731
    return arm.DriveParameters(N=nom.N, Jm=scale("Jm", (motor_inertia,) * 6), Dm=nom.Dm, Fmc=scale("Fmc", (friction,) * 6),
                               KJ=scale("KJ", stiffness), DJ=scale("DJ", (damping,) * 6), Dl=nom.Dl,
                               Flc=scale("Flc", (friction,) * 6))


def true_arm_v1() -> arm.ArmParameters:
    """FlexArm-v1's true arm: the nominal one with an unmodelled 12 kg tool, 40 cm long (10 x 10 x
    40 cm), its centre of mass 20 cm beyond the flange."""
    return arm.ArmParameters().with_payload(12.0, com=(0.0, 0.0, 0.20), inertia_com=arm._box(12.0, 0.1, 0.1, 0.4))


def true_drive_v1() -> arm.DriveParameters:
    """FlexArm-v1's true drives: stiffness -3 % on the main axes (joints 1-3), -15 % on the wrist;
    Coulomb friction (motor and load) 15 % below nominal; joint damping -40 %, Jm +5 % as v0."""
    return scaled_drive(stiffness=(0.97, 0.97, 0.97, 0.85, 0.85, 0.85), friction=0.85)


@dataclass(frozen=True)
class PIDGains:
    """Motor-side PID per joint: kp [N m/rad], ki [N m/(rad s)], kd [N m s/rad] (motor angle), and
    the derivative low-pass corner f_d [Hz]. ``tuned`` places each loop at ``bandwidth`` Hz for the
    nominal motor + reflected load inertia at the home pose."""

    kp: tuple[float, ...]
    ki: tuple[float, ...]
    kd: tuple[float, ...]
    f_d: float = 200.0

    @classmethod
    def tuned(cls, bandwidth: float = 5.0, zeta: float = 0.7) -> PIDGains:
        nominal, drive = arm.ArmParameters(), arm.DriveParameters()
        M = arm.mass_matrix(nominal.dh.table(), nominal.vector(), HOME)
        J = np.asarray(drive.Jm) + np.diag(M) / np.asarray(drive.N) ** 2
        w = 2 * math.pi * bandwidth
        return cls(tuple(J * w * w), tuple(J * w**3 / 8), tuple(2 * zeta * J * w))


HOME = arm.HOME


VERSIONS = {"v0": {}, "v1": {"settled_start": True, "true_arm": true_arm_v1(), "true_drive": true_drive_v1()}}
"""FlexArm versions: the ``FlexArmPlant`` arguments that make each (``FlexArmPlant.of_version``)."""


@dataclass
class FlexArmPlant:
    """Closed-loop FlexArm simulator; see the module docstring. fs [Hz]; u_max [N m] per motor;
    encoder_counts per motor turn; accel_offset [m] in frame 6; accel_bias [m/s^2] (3,);
    accel_noise [m/s^2] RMS per axis; seed for the noise; max_error [rad] of any load angle
    from its reference before the run counts as diverged; friction_eps [rad/s]: the Coulomb
    frictions' sgn is tanh(v / friction_eps). A much smaller value makes the friction of the light
    wrist joints a stiff damper (Flc / eps over a small inertia) that RK4 at the default step
    cannot integrate: the wrist then chatters. effects: hidden effects of the library on the joints
    (axes j1-j6) whose torque depends on the load angle and velocity (``Effect.plant_kind``
    but the load-dependent friction), in motor N m like the model's input; they act on the load side
    (a bearing's friction, a cable's spring), N times their torque; the default step suits effects no
    stiffer than the drives' own friction."""

    true_arm: arm.ArmParameters = field(default_factory=default_true_arm)
    true_drive: arm.DriveParameters = field(default_factory=default_true_drive)
    gains: PIDGains = field(default_factory=PIDGains.tuned)
    fs: float = 1000.0
    substeps: int = 4
    u_max: float = 40.0
    encoder_counts: int = 2**17
    accel_offset: tuple[float, float, float] = (0.0, 0.05, 0.04)
    accel_bias: tuple[float, float, float] = (0.05, -0.03, 0.02)
    accel_noise: float = 0.02
    preroll: float = 0.5
    max_error: float = 0.2
    friction_eps: float = 0.01
    seed: int = 0
    settled_start: bool = False
    effects: tuple[fx.Effect, ...] = ()

    axes = arm.AXES

    @classmethod
    def of_version(cls, version: str, **overrides) -> FlexArmPlant:
        """The plant of FlexArm-``version`` ("v0": the defaults of this class; "v1": the settled
        start), with ``overrides``."""
        if version not in VERSIONS:
            raise ValueError(f"unknown FlexArm version {version!r}; available: {', '.join(VERSIONS)}")
        return cls(**{**VERSIONS[version], **overrides})

    def __post_init__(self):
        if self.substeps < 1 or self.fs <= 0 or self.encoder_counts < 0:
            raise ValueError(f"need substeps >= 1, fs > 0, encoder_counts >= 0 (got {self.substeps}, {self.fs}, "
                             f"{self.encoder_counts})")
        self.effects = tuple(self.effects)
        fx.check_unique(self.effects)
        for e in self.effects:
            if not isinstance(e, fx.Effect):
                raise TypeError(f"hidden effects must be lcgym effects (physics.effects), got {type(e).__name__}")
            if not plant_effects.has_plant_kind(e) or isinstance(e, fx.LoadFriction):
                why = ("reads the gravity torque, which the FlexArm's kernel does not compute apart"
                       if isinstance(e, fx.LoadFriction) else plant_effects.refusal(type(e)))
                raise ValueError(f"{e.key}: the FlexArm plant simulates effects of the joint angle and velocity only; "
                                 f"{e.name} {why}")
        self._records = plant_effects.pack([e.bound(self.axes) for e in self.effects], len(self.axes))

    def drive_table(self) -> np.ndarray:
        """What the kernel reads as the drives (``dynamics.flexible_derivatives``): the true drives'
        table, with the hidden effects' records below it (one column per joint) when there are any."""
        table = self.true_drive.table()
        return np.vstack([table, self._records.T]) if self.effects else table

    def kernel_config(self) -> np.ndarray:
        """The kernel's settings: sample time, substeps, u_max, encoder resolution [rad], derivative
        filter pole, max_error, pre-roll samples, friction_eps, settled_start (1.0 or 0.0)."""
        res = 2 * math.pi / self.encoder_counts if self.encoder_counts else 0.0
        return np.array([1.0 / self.fs, self.substeps, self.u_max, res, math.exp(-2 * math.pi * self.gains.f_d / self.fs),
                         self.max_error, int(round(self.preroll * self.fs)), self.friction_eps,
                         1.0 if self.settled_start else 0.0])

    def reference_feedback(self, positions) -> np.ndarray:
        """What the feedback outputs (T, 6) [N m] when the joints follow ``positions`` exactly: zero,
        since each PID acts on the motor's tracking error alone (``urdf_plant.URDFPlant.reference_feedback``
        for a loop that differentiates the measurement)."""
        return np.zeros_like(np.asarray(positions, dtype=float))

    def learning_law(self, base: str, config):
        """The FlexArm's laws (``flexarm/learning.py``): paper 002's eq. 16 on "basic", else learning
        from the encoders and the accelerometer on the base."""
        from .learning import learning_law

        return learning_law(self, base, config)

    @property
    def deterministic(self) -> bool:
        """A run is a function of its inputs: the accelerometer's noise is drawn from a stream seeded
        anew (``seed``) for every run."""
        return True

    def run_with_offset(self, reference: Reference, feedforward, offset) -> Trial:
        """``run`` with a load-side reference offset (T, 6) [rad] (a learner's: the load's reference
        moved by it, ``methods.bases.closed_loop``), given to the motors as N times it."""
        return self.run(reference, feedforward, np.asarray(self.true_drive.N) * np.asarray(offset, dtype=float))

    @remembered  # inside the benchmark's cells: a run made before is not made again (``systems.runs``)
    def run(self, reference: Reference, feedforward=None, motor_offset=None) -> Trial:
        """Run one reference (load-side joint angles (T, 6) [rad]); ``feedforward`` motor torques
        (T, 6) [N m] and ``motor_offset`` (T, 6) [rad of the motor] default to zero."""
        q_ref = np.ascontiguousarray(reference.positions, dtype=float)
        T = q_ref.shape[0]
        if q_ref.ndim != 2 or q_ref.shape[1] != 6 or not np.all(np.isfinite(q_ref)):
            raise ValueError(f"{reference.name}: reference must be finite with shape (T, 6), got {q_ref.shape}")
        ff = np.zeros((T, 6)) if feedforward is None else np.ascontiguousarray(feedforward, dtype=float)
        off = np.zeros((T, 6)) if motor_offset is None else np.ascontiguousarray(motor_offset, dtype=float)
        for label, a in (("feedforward", ff), ("motor_offset", off)):
            if a.shape != (T, 6) or not np.all(np.isfinite(a)):
                raise ValueError(f"{reference.name}: {label} must be finite with shape ({T}, 6)")
        g = self.gains
        C = np.array([g.kp, g.ki, g.kd], dtype=float)
        cfg = self.kernel_config()
        sig = np.zeros((T, N_SIG))
        fail = simulate(q_ref, ff, off, self.true_arm.dh.table(), self.true_arm.vector(), self.drive_table(), C, cfg,
                        np.asarray(self.accel_offset, dtype=float), sig)
        if fail >= 0:
            raise SimulationDiverged(f"{reference.name}: the FlexArm left its safe range at t = {fail / self.fs:.3f} s "
                                     f"(sample {fail}): load angles {np.degrees(sig[fail, S_QL:S_QL + 6]).round(2).tolist()} deg")
        return self.trial_from_signals(reference, sig, ff, np.random.default_rng(self.seed))

    def trial_from_signals(self, reference: Reference, sig: np.ndarray, ff: np.ndarray, rng: np.random.Generator) -> Trial:
        """The Trial of the kernel's signals sig (n, N_SIG) (n <= reference length): motor angles
        (``pos`` = motor / N), torques, and as extras the motor angles, the accelerometer (plus
        bias and white noise drawn from ``rng``), the TCP and the true load angles."""
        n = sig.shape[0]
        acc = sig[:, S_ACC : S_ACC + 3] + np.asarray(self.accel_bias) + self.accel_noise * rng.standard_normal((n, 3))
        motor = sig[:, S_QM : S_QM + 6]
        extra = {f"motor_{a}": motor[:, i] for i, a in enumerate(self.axes)}
        extra.update({f"acc_{c}": acc[:, i] for i, c in enumerate("xyz")})
        extra.update({f"tcp_{c}": sig[:, S_TCP + i] for i, c in enumerate("xyz")})
        extra.update({f"load_{a}": sig[:, S_QL + i] for i, a in enumerate(self.axes)})
        return Trial(t=np.arange(n) / self.fs, ref=reference.positions[:n], pos=motor / np.asarray(self.true_drive.N),
                     u=sig[:, S_U : S_U + 6], axes=self.axes, ff=ff[:n], extra=extra,
                     meta={"system": "flexarm", "reference": reference.name})


def load_error(trial: Trial) -> np.ndarray:
    """q_lr - q_l (T, 6) [rad]: reference minus the true load angle of a FlexArm trial (what the
    benchmark scores; the encoders sit on the motors and cannot see it)."""
    return trial.ref - np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])


# per-sample signals of the kernel
S_QM, S_U, S_QL, S_ACC, S_TCP = 0, 6, 12, 18, 21
N_SIG = 24


njit = Kernels(__file__, arm.__file__, fx.__file__, plant_effects.__file__, linalg.__file__)


@njit
def _rk4(x, u, dh, pi, drive, h, n, eps, k1_first):
    """n RK4 steps of h [s] from x (in place) under the held input u; ``k1_first`` is the
    derivative at x (the caller has it: the sample's recorded load acceleration)."""
    y = np.empty_like(x)  # the stage's state, written in place (elementwise as x + c h k)
    for step in range(n):
        k1 = k1_first if step == 0 else arm.flexible_derivatives(dh, pi, drive, x, u, arm.GRAVITY, eps)
        for j in range(x.shape[0]):
            y[j] = x[j] + 0.5 * h * k1[j]
        k2 = arm.flexible_derivatives(dh, pi, drive, y, u, arm.GRAVITY, eps)
        for j in range(x.shape[0]):
            y[j] = x[j] + 0.5 * h * k2[j]
        k3 = arm.flexible_derivatives(dh, pi, drive, y, u, arm.GRAVITY, eps)
        for j in range(x.shape[0]):
            y[j] = x[j] + h * k3[j]
        k4 = arm.flexible_derivatives(dh, pi, drive, y, u, arm.GRAVITY, eps)
        for j in range(x.shape[0]):
            x[j] = x[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    return x


# closed-loop state: plant x (24), then per joint the PID integral, previous error, filtered derivative
N_LOOP = 24 + 18
I_INT, I_EPREV, I_DF = 24, 30, 36


@njit
def _measure(x, i, res):
    qm = x[12 + i]
    return math.floor(qm / res + 0.5) * res if res > 0.0 else qm


@njit
def loop_start(st, q0, off0, ff0, dh, pi, drive, C, cfg):
    """Static balance at the reference sample q0: the motors at their reference, the load sagging
    until the joint springs carry gravity, K_J (q_mr / N - q_l) = G(q_l) (fixed point), and the PID
    integrators holding the gravity torque (with cfg[8], settled_start: less the feedforward ff0
    of the first sample)."""
    N, KJ = drive[0], drive[4]
    q_mr0 = N * q0 + off0
    ql = q0.copy()
    for _ in range(20):
        grav = arm.bias_torques(dh, pi, ql, np.zeros(6), arm.GRAVITY)
        ql = q_mr0 / N - grav / KJ
    grav = arm.bias_torques(dh, pi, ql, np.zeros(6), arm.GRAVITY)
    st[:] = 0.0
    st[:6] = ql
    st[12:18] = q_mr0
    for i in range(6):
        e = q_mr0[i] - _measure(st, i, cfg[3])
        hold = grav[i] / N[i]
        if cfg[8] != 0.0:
            hold -= ff0[i]
        st[I_INT + i] = (hold - C[0, i] * e) / C[1, i]
        st[I_EPREV + i] = e


@njit
def loop_sample(st, q_ref_k, q_ref_next, ff_k, off_k, dh, pi, drive, C, cfg, accel_offset, sig_row, record):
    """One 1 ms sample in place on st: encoders, PID + feedforward, (signals into sig_row if
    ``record``), integration over the sample. Returns True if the state left the safe range."""
    ts, sub, umax, res, alpha, max_err, eps = cfg[0], int(cfg[1]), cfg[2], cfg[3], cfg[4], cfg[5], cfg[7]
    N = drive[0]
    u = np.empty(6)
    for i in range(6):
        meas = _measure(st, i, res)
        e = N[i] * q_ref_k[i] + off_k[i] - meas
        st[I_DF + i] = alpha * st[I_DF + i] + (1.0 - alpha) * (e - st[I_EPREV + i]) / ts
        st[I_INT + i] += e * ts
        st[I_EPREV + i] = e
        u[i] = min(max(C[0, i] * e + C[1, i] * st[I_INT + i] + C[2, i] * st[I_DF + i] + ff_k[i], -umax), umax)
        if record:
            sig_row[S_QM + i] = meas
            sig_row[S_U + i] = u[i]
            sig_row[S_QL + i] = st[i]
    x = st[:24]
    dx = arm.flexible_derivatives(dh, pi, drive, x, u, arm.GRAVITY, eps)
    if record:
        a = arm.specific_force(dh, x[:6], x[6:12], dx[6:12], accel_offset, arm.GRAVITY)
        Rw, pw = arm.forward_kinematics(dh, x[:6])
        for c in range(3):
            sig_row[S_ACC + c] = a[c]
            sig_row[S_TCP + c] = pw[5, c]
    st[:24] = _rk4(x.copy(), u, dh, pi, drive, ts / sub, sub, eps, dx)
    for j in range(24):
        if not math.isfinite(st[j]):
            return True
    for i in range(6):
        if abs(st[i] - q_ref_next[i]) > max_err:
            return True
    return False


@njit(nogil=True)  # nogil: references run in parallel threads (bench.py)
def simulate(q_ref, ff, off, dh, pi, drive, C, cfg, accel_offset, sig):
    """Closed loop over the reference after a pre-roll of cfg[6] samples at its first sample;
    fills sig (T, N_SIG); returns -1, or the sample where the state left the safe range."""
    T = q_ref.shape[0]
    st = np.empty(N_LOOP)
    loop_start(st, q_ref[0], off[0], ff[0], dh, pi, drive, C, cfg)
    for _ in range(int(cfg[6])):
        if loop_sample(st, q_ref[0], q_ref[0], ff[0], off[0], dh, pi, drive, C, cfg, accel_offset, sig[0], False):
            return 0
    for k in range(T):
        if loop_sample(st, q_ref[k], q_ref[min(k + 1, T - 1)], ff[k], off[k], dh, pi, drive, C, cfg, accel_offset,
                       sig[k], True):
            return k
    return -1
