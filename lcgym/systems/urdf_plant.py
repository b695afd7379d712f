"""A closed-loop simulator of a URDF machine, to make measurement data with effects the URDF lacks.

The plant's equation, per axis of the machine (``urdf.from_urdf``):

    M(q) qdd + h(q, qd) + sum of the hidden effects' torques(q, qd) = u

with M, h the rigid body of the reduced URDF model (or of ``parameters``, a true rigid body that
differs from the URDF's) and the effects of ``physics.effects`` bound to the axes. What one run
does, per sample k (Ts = 1 / fs):

1. The encoders read the axis positions y[k], quantized to ``encoder_resolution`` and with white
   ``noise_rms`` (seeded) added.
2. The PID of each axis (``FeedbackGains``) acts on e[k] = ref[k] - y[k]; its derivative is
   the backward difference of e (or of -y, ``FeedbackGains.derivative="measurement"``) low-passed
   at ``f_lp`` Hz (first order), or -(y[k] - y[k-2]) / (2 Ts) (``"measurement_fir2"``, the EMPS's
   controller); the integrator stops while the input saturates. u[k] = sat(ff[k] + fb[k],
   +-``u_max``).
3. u[k] is held over [t_k, t_{k+1}) (zero-order hold, no computation delay: the feedforward's
   kinematics are best evaluated half a sample ahead, ``System.advance`` = 0.5) while the dynamics
   advance by ``substeps`` classical RK4 steps, the accelerations from the rigid body's forward
   dynamics (``rigid_body.accelerations``: the URDF's model as pinocchio reads it, in arrays).

All of it runs in one compiled loop (``closed_loop``; ``ClosedLoopRun.advance`` runs any stretch of
samples, ``sample`` one, as the Gymnasium env steps it), at a few microseconds a sample.

The effects whose torque depends on q and qd (viscous, Coulomb, Stribeck and asymmetric friction,
offsets, cable springs and drapes, gear harmonics, tabulated forces: ``Effect.plant_kind``)
act through ``physics.plant_effects.axis_torque``, the one compiled torque every plant adds. A
load-dependent friction (``load_friction``) reads the plant's own gravity torque g(q) at each RK4
stage (``rigid_body.gravity_torque``). A rotor inertia J (``rotor_inertia``) is added to the model's
``armature`` of its joint, which adds to the diagonal of M(q). Effects with
internal state or that need qdd or the input otherwise (stiction, drivetrain flexibility, cable
inertia, torque ripple) are refused.

Step size: a smoothed Coulomb friction Fc tanh(qd / eps) is stiff near standstill (slope Fc / eps
against the axis's inertia). ``substeps=None`` picks the number of RK4 steps per sample so that
h times the fastest rate of the effects (velocity slope / inertia, plus sqrt(position slope /
inertia)) stays at or below ``STEP_RATE``, at least ``MIN_SUBSTEPS``.

Feedback: without given gains, ``tuned_gains`` puts every axis at 10 Hz with damping
0.7 (PD, no integral action) for the geometric mean of its inertia over the workspace, lowered
where the sampled loop would be unstable at the smallest or largest inertia.

Before recording, the plant holds the first reference sample (and the first feedforward sample)
for ``preroll`` s so that gravity sag and the integrators settle. If the state turns non-finite or
a tracking error exceeds ``max_error``, the run stops with ``SimulationDiverged``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..data import Trial
from ..physics import effects as fx
from ..physics import linalg, plant_effects
from ..physics.compiled import FASTMATH, NO_REFCOUNTS, Kernels
from ..physics.lti import rigid_axis
from ..references import Reference, random_moves
from . import rigid_body
from .feedback import FeedbackGains
from .plant import EncoderLoop
from .runs import remembered
from .system import SimulationDiverged, System
from .urdf import URDFRobot, urdf_robot

MIN_SUBSTEPS = 2
MAX_SUBSTEPS = 512  # beyond this the effects are too stiff for a sampled simulation: give substeps explicitly
STEP_RATE = 1.0  # h times the fastest effect rate (RK4's real-axis stability limit is 2.78)
INERTIA_SAMPLES = 64  # random configurations for the axis inertias (gains, step size)
DEFAULT_MAX_ERROR = {"revolute": 30 * math.pi / 180, "prismatic": 0.1}  # rad, m

# controller slots, one row per axis
KP, KD, KI, ALPHA, UMAX, RES, MAXERR, DERIV = range(8)
N_CTRL = 8
# workspace rows: state, input, stage state, net torque, RK4 stage derivatives, controller state, stage position
Q, V, U, VS, TAU, W0, A0, EPREV, EDOT, INTEG, QS, EPREV2, GRAV = 0, 1, 2, 3, 4, 5, 9, 13, 14, 15, 16, 17, 18
N_ROWS = 19
# what the derivative term differentiates (FeedbackGains.derivative), slot DERIV
D_ERROR, D_MEASUREMENT, D_FIR2 = 0.0, 1.0, 2.0
# per-sample outputs: measured position, applied input, true position
OUT_Y, OUT_U, OUT_Q = range(3)
# control status
OK, TOO_FAR, NOT_FINITE = range(3)

njit = Kernels(__file__, fx.__file__, plant_effects.__file__, rigid_body.__file__, linalg.__file__)


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def rk4_step(S, E, L, h, parent, kind, axis, rotation, translation, mass, com, inertia, armature, gravity,
             R, p, VV, AA, F, cm, cc, cI, M, hh, T):
    """One classical RK4 step of size h [s] of the state S[Q], S[V] with the input S[U] held: at each
    stage, the net torque S[TAU] = u - effects(q, qd) (E: their records, ``physics.plant_effects``;
    L: the load-dependent ones, at the stage's gravity torque S[GRAV]) and the rigid body's
    accelerations (``rigid_body.accelerations``; the arrays from parent on: the body and its scratch)."""
    n = S.shape[1]
    reads_load = False
    for i in range(n):
        reads_load = reads_load or L[i, 0] != 0.0
    for k in range(4):
        c = 0.0 if k == 0 else (0.5 * h if k < 3 else h)
        for i in range(n):
            qs, vs = S[Q, i], S[V, i]
            if k > 0:
                qs += c * S[W0 + k - 1, i]
                vs += c * S[A0 + k - 1, i]
            S[W0 + k, i] = vs
            S[VS, i] = vs
            S[QS, i] = qs
            S[TAU, i] = S[U, i] - plant_effects.axis_torque(E[i], qs, vs, 0.0, 0.0)
        if reads_load:
            rigid_body.gravity_torque(S[QS], parent, kind, axis, rotation, translation, mass, com, inertia, armature,
                                      gravity, R, p, VV, AA, F, cm, cc, cI, M, hh, T, S[GRAV])
            for i in range(n):
                if L[i, 0] != 0.0:
                    S[TAU, i] -= plant_effects.axis_torque(L[i], S[QS, i], S[VS, i], S[GRAV, i], 0.0)
        rigid_body.accelerations(S[QS], S[VS], S[TAU], parent, kind, axis, rotation, translation, mass, com, inertia,
                                 armature, gravity, R, p, VV, AA, F, cm, cc, cI, M, hh, T, S[A0 + k])
    for i in range(n):
        S[Q, i] += h / 6.0 * (S[W0, i] + 2.0 * S[W0 + 1, i] + 2.0 * S[W0 + 2, i] + S[W0 + 3, i])
        S[V, i] += h / 6.0 * (S[A0, i] + 2.0 * S[A0 + 1, i] + 2.0 * S[A0 + 2, i] + S[A0 + 3, i])


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def encoder(q, resolution, noise):
    """The encoder's reading of position q [rad or m]: quantized to ``resolution`` (0: exact), plus
    ``noise``."""
    return (math.floor(q / resolution + 0.5) * resolution if resolution > 0.0 else q) + noise


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def control(k, S, C, ref, ff, noise, out, ts):
    """Sample k: encoder reading, PID and saturation (module docstring); S[U] receives u[k], out[k]
    the measured position, the input and the true position. Returns OK, TOO_FAR (a tracking error
    over its limit) or NOT_FINITE."""
    status = OK
    for i in range(C.shape[0]):
        q = S[Q, i]
        if not (math.isfinite(q) and math.isfinite(S[V, i])):
            return NOT_FINITE
        y = encoder(q, C[i, RES], noise[k, i])
        e = ref[k, i] - y
        x = e if C[i, DERIV] == D_ERROR else -y  # what the derivative term differentiates
        if k == 0:
            S[EPREV, i] = x
            S[EPREV2, i] = x
        if C[i, DERIV] == D_FIR2:
            S[EDOT, i] = (x - S[EPREV2, i]) / (2.0 * ts)
            S[EPREV2, i] = S[EPREV, i]
        else:
            S[EDOT, i] = C[i, ALPHA] * S[EDOT, i] + (1.0 - C[i, ALPHA]) * (x - S[EPREV, i]) / ts
        S[EPREV, i] = x
        raw = ff[k, i] + C[i, KP] * e + C[i, KD] * S[EDOT, i] + C[i, KI] * S[INTEG, i]
        u = min(max(raw, -C[i, UMAX]), C[i, UMAX])
        if u == raw:  # conditional integration: no wind-up while saturated
            S[INTEG, i] += e * ts
        S[U, i] = u
        out[k, OUT_Y, i] = y
        out[k, OUT_U, i] = u
        out[k, OUT_Q, i] = q
        if abs(ref[k, i] - q) > C[i, MAXERR]:
            status = TOO_FAR
    return status


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def closed_loop(first, last, S, C, E, L, ref, ff, noise, out, ts, substeps, parent, kind, axis, rotation, translation,
                mass, com, inertia, armature, gravity, R, p, VV, AA, F, cm, cc, cI, M, hh, T):
    """Samples first .. last - 1 of a run (rows of ref, ff, noise, out; pre-roll included): the
    control of each sample (``control``), then ``substeps`` RK4 steps to the next. Returns (the
    sample reached, OK), or (the sample, status) of the first whose control was not OK (the state
    did not advance past it)."""
    h = ts / substeps
    for k in range(first, last):
        status = control(k, S, C, ref, ff, noise, out, ts)
        if status != OK:
            return k, status
        for _ in range(substeps):
            rk4_step(S, E, L, h, parent, kind, axis, rotation, translation, mass, com, inertia, armature, gravity,
                     R, p, VV, AA, F, cm, cc, cI, M, hh, T)
    return last, OK


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def exact_tracking_feedback(C, ref, zeros, out, S, ts):
    """The controller's output when every encoder reads the reference exactly, into out[:, OUT_U]:
    ``control`` run with the position set to ``ref[k]`` at each sample (C: controller rows without
    quantization, limits or error bound; ref, zeros (T, n) in the rows' order; S: a zeroed
    workspace). The loop's own reaction to the motion: zero where it acts on the tracking error
    alone, -kd times the (filtered) reference velocity where it differentiates the measurement."""
    for k in range(ref.shape[0]):
        for i in range(ref.shape[1]):
            S[Q, i] = ref[k, i]
        control(k, S, C, ref, zeros, zeros, out, ts)


# ---------------------------------------------------------------------------------------------
# Feedback
# ---------------------------------------------------------------------------------------------


def tuned_gains(system: System, bandwidth: float = 10.0, damping: float = 0.7, integral_time: float | None = None,
                fs: float = 1000.0, seed: int = 0) -> FeedbackGains:
    """Gains that put each axis, seen as a rigid inertia J, at ``bandwidth`` Hz with ``damping``:
    kp = J w^2, kd = 2 damping J w, ki = kp / integral_time (None: no integral action), the
    derivative low-pass at 10 x bandwidth. J is the geometric mean of the axis's smallest and
    largest inertia over seeded random configurations (``inertia_range``), so that bandwidth and
    damping vary by the same factor either way; where the loop sampled at ``fs`` would be
    unstable at either end (``loop_stable``), that axis's bandwidth is lowered in steps of 20 %."""
    if not (bandwidth > 0 and damping > 0 and fs > 0):
        raise ValueError(f"bandwidth, damping and fs must be > 0, got {bandwidth} Hz, {damping}, {fs} Hz")
    if integral_time is not None and not integral_time > 0:
        raise ValueError(f"integral_time must be > 0 s, got {integral_time}")
    lo, hi = inertia_range(urdf_robot(system), seed=seed)
    J = np.sqrt(lo * hi)
    gains = [_stable_axis(J[i], lo[i], hi[i], bandwidth, damping, integral_time, fs) for i in range(J.size)]
    kp, kd, ki = zip(*gains, strict=True)
    return FeedbackGains(kp, kd, ki, f_lp=10 * bandwidth, filtered="derivative")


def _stable_axis(J, lo, hi, bandwidth, damping, integral_time, fs) -> tuple[float, float, float]:
    """(kp, kd, ki) of one axis at the highest bandwidth, from ``bandwidth`` down in steps of 20 %,
    whose sampled loop is stable at both inertias lo and hi."""
    f = bandwidth
    while f > 1e-3 * bandwidth:
        w = 2 * math.pi * f
        gains = (J * w**2, 2 * damping * J * w, J * w**2 / integral_time if integral_time else 0.0)
        one = FeedbackGains(*((g,) for g in gains), f_lp=10 * bandwidth, filtered="derivative")
        if loop_stable(one, lo, fs)[0] and loop_stable(one, hi, fs)[0]:
            return gains
        f *= 0.8
    raise ValueError(f"no stable feedback found at {fs:g} Hz for an axis of inertia {lo:.3g} to {hi:.3g}")


def loop_stable(gains: FeedbackGains, inertia, fs: float) -> np.ndarray:
    """Per axis: whether the sampled loop (``gains``' PID with its low-passed or two-sample derivative, ``control``,
    at ``fs`` Hz, the input held over a sample) around a rigid inertia J (``inertia`` [kg m^2 or
    kg], per axis) is stable: the roots of its characteristic polynomial lie inside the unit circle.
    The plant 1 / (J s^2) behind a zero-order hold is Ts^2 / (2 J) (z + 1) / (z - 1)^2."""
    gains.require("derivative", "URDFPlant")
    ts = 1.0 / fs
    J = np.broadcast_to(np.asarray(inertia, dtype=float), (gains.n_axes,))
    out = np.zeros(gains.n_axes, dtype=bool)
    P = np.polynomial.polynomial
    for i, (kp, kd, ki, f_lp) in enumerate(zip(gains.kp, gains.kd, gains.ki, gains.f_lp, strict=True)):
        alpha = math.exp(-2 * math.pi * f_lp / fs)
        z_a, z_1 = np.array([-alpha, 1.0]), np.array([-1.0, 1.0])
        if gains.derivative == "measurement_fir2":  # kp + kd (z^2 - 1) / (2 Ts z^2)
            z_a = np.array([0.0, 0.0, 1.0])
            num, den = P.polyadd(kp * z_a, kd / (2 * ts) * np.array([-1.0, 0.0, 1.0])), z_a
        else:  # kp + kd (1 - alpha) (z - 1) / (Ts (z - alpha))
            num, den = P.polyadd(kp * z_a, kd * (1 - alpha) / ts * z_1), z_a
        if ki > 0:  # the integrator sums e up to the previous sample: Ts / (z - 1)
            num, den = P.polyadd(P.polymul(num, z_1), ki * ts * z_a), P.polymul(z_a, z_1)
        plant_num, plant_den = ts**2 / (2 * J[i]) * np.array([1.0, 1.0]), P.polymul(z_1, z_1)
        char = P.polyadd(P.polymul(den, plant_den), P.polymul(num, plant_num))
        out[i] = bool(np.all(np.abs(P.polyroots(char)) < 1.0))
    return out


def gravity_bound(robot: URDFRobot, model=None, seed: int = 0) -> np.ndarray:
    """The largest |g(q)| per row of pinocchio's velocity order [N m or N] over the seeded random
    configurations of ``inertia_range`` (a load-dependent friction's level, for the step size)."""
    model = model or robot.model
    data = model.createData()
    q = robot.sample_kinematics(INERTIA_SAMPLES, np.random.default_rng(seed))[0]
    return np.max([np.abs(pin.computeGeneralizedGravity(model, data, cfg)) for cfg in robot.configuration(q)], axis=0)


def inertia_range(robot: URDFRobot, model=None, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(smallest, largest) inertia of each axis (axis order) [kg m^2 or kg] over
    ``INERTIA_SAMPLES`` seeded random configurations within the joint limits: 1 / max (M^-1)_ii
    (the axis with the others free) and max M_ii (the others held). ``model``: another rigid body
    on the robot's joints (default the robot's)."""
    model = model or robot.model
    data = model.createData()
    q = robot.sample_kinematics(INERTIA_SAMPLES, np.random.default_rng(seed))[0]
    big, inverse = np.zeros(robot.n_axes), np.zeros(robot.n_axes)
    for cfg in robot.configuration(q):
        M = pin.crba(model, data, cfg)
        M = np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle
        if np.linalg.cond(M) > 1e12:
            still = np.abs(np.linalg.eigh(M)[1][:, 0])[robot.v_index]  # the motion that takes no force
            joint = robot.names[int(np.argmax(still))]
            raise ValueError(f"{robot.name}: joint {joint} moves no mass (the mass matrix is singular at q = "
                             f"{np.round(cfg, 3).tolist()}, pinocchio's configuration), and the plant cannot integrate "
                             f"it: give the links it moves an <inertial> with a mass and an inertia")
        big = np.maximum(big, np.diag(M)[robot.v_index])
        inverse = np.maximum(inverse, np.diag(np.linalg.inv(M))[robot.v_index])
    return 1.0 / inverse, big


# ---------------------------------------------------------------------------------------------
# Effects
# ---------------------------------------------------------------------------------------------


def bind_effects(effects: Sequence[fx.Effect], system: System) -> list[fx.Effect]:
    """``effects`` bound to the machine's axes; refuses effects the plant cannot simulate (module
    docstring)."""
    fx.check_unique(effects)
    bound = []
    for effect in effects:
        if not isinstance(effect, fx.Effect):
            raise TypeError(f"hidden effects must be lcgym effects (physics.effects), got {type(effect).__name__}")
        if not plant_effects.has_plant_kind(effect) and not isinstance(effect, fx.RotorInertia):
            names = ", ".join([cls.name for cls in plant_effects.PLANT_KINDS.values()] + [fx.RotorInertia.name])
            raise ValueError(f"{effect.key}: URDFPlant simulates effects whose torque depends on q and qd only "
                             f"({names}); {effect.name} {plant_effects.refusal(type(effect))}")
        if isinstance(effect, fx.RotorInertia) and effect.J < 0:
            raise ValueError(f"{effect.key}: a rotor inertia must be >= 0, got {effect.J}")
        bound.append(system.effect(effect))  # checks the axis and binds it to the machine's axis order
    return bound


def with_viscous(bound: Sequence[fx.Effect], viscous: np.ndarray, system: System) -> list[fx.Effect]:
    """``bound`` effects with the rigid body's true ``viscous`` coefficients (axis order) added to the
    viscous friction of their axis (one made where there is none)."""
    out = list(bound)
    for i, d in enumerate(viscous):
        if d != 0.0:
            own = next((k for k, e in enumerate(out) if isinstance(e, fx.ViscousFriction) and e.index == i), None)
            if own is None:
                out.append(system.effect(fx.ViscousFriction(system.axis_names[i], d=float(d))))
            else:
                out[own] = dataclasses.replace(out[own], d=out[own].d + float(d))
    return out


# ---------------------------------------------------------------------------------------------
# The plant
# ---------------------------------------------------------------------------------------------


class URDFPlant(EncoderLoop):
    """Closed-loop simulator of a URDF machine with hidden effects (module docstring).

    system: a machine made by ``urdf.from_urdf`` (or a URDF path, with ``joints``). effects: hidden
    effects on its axes. parameters: the true rigid body and viscous friction in the system's
    parameter order (None: the URDF's, no friction). gains: ``FeedbackGains`` with
    ``filtered="derivative"`` (None: ``tuned_gains(system)``). fs [Hz]; substeps: RK4 steps per sample (None: from the
    effects' stiffness). u_max [N m or N]: input limit, one value or one per axis (None: none).
    encoder_resolution [rad or m per count] and noise_rms [rad or m]: one value or one per axis
    (0: exact). seed: the noise's. preroll [s]. max_error [rad or m], one value or one per axis
    (None: 30 deg on revolute, 0.1 m on prismatic axes).
    """

    def __init__(self, system: System | str, effects: Sequence[fx.Effect] = (), parameters=None,
                 gains: FeedbackGains | None = None, fs: float = 1000.0, substeps: int | None = None,
                 u_max=None, encoder_resolution=0.0, noise_rms=0.0, seed: int = 0, preroll: float = 0.5,
                 max_error=None, joints: Sequence[str] | None = None):
        if not isinstance(system, System):
            from .urdf import from_urdf

            system = from_urdf(system, joints=joints)
        self.system = system
        self.robot = urdf_robot(system)
        if not (np.isfinite(fs) and fs > 0):
            raise ValueError(f"fs must be > 0 Hz, got {fs}")
        if not (np.isfinite(preroll) and preroll >= 0):
            raise ValueError(f"preroll must be >= 0 s, got {preroll}")
        self.fs, self.preroll, self.seed = float(fs), float(preroll), seed
        self.parameters = None if parameters is None else tuple(np.asarray(parameters, dtype=float).ravel().tolist())
        self.model, viscous = self._true_model(parameters)
        self.effects = tuple(effects)
        self.bound_effects = bind_effects(self.effects, system)
        # the torques of q and qd, in records per row of pinocchio's velocity order; those that read the
        # gravity torque (a load-dependent friction) apart, for the stage's g(q)
        self._torques = with_viscous([e for e in self.bound_effects if not isinstance(e, fx.RotorInertia)], viscous, system)
        reads_load = [isinstance(e, fx.LoadFriction) for e in self._torques]
        self._E = plant_effects.pack([e for e, r in zip(self._torques, reads_load, strict=True) if not r], self.n_axes,
                                     self.robot.v_index)
        self._L = plant_effects.pack([e for e, r in zip(self._torques, reads_load, strict=True) if r], self.n_axes,
                                     self.robot.v_index)
        self._reads_load = bool(self._L[:, 0].any())
        rotor = [e for e in self.bound_effects if isinstance(e, fx.RotorInertia)]
        if rotor:  # rotor inertias: on a copy, the system's model stays the URDF's
            self.model = self.model.copy()
            armature = np.array(self.model.armature, dtype=float)
            for e in rotor:
                armature[self.robot.v_index[e.index]] += e.J
            self.model.armature = armature
        self.body = rigid_body.RigidBody.from_model(self.model)  # what the compiled loop integrates
        self.gains = (gains if gains is not None else tuned_gains(system, fs=fs)).require("derivative", "URDFPlant")
        if len(self.gains.kp) != self.n_axes:
            raise ValueError(f"gains for {len(self.gains.kp)} axes, but {system.name} has {self.n_axes}")
        self.u_max = self._per_axis("u_max", np.inf if u_max is None else u_max, positive=True)
        self.encoder_resolution = self._per_axis("encoder_resolution", encoder_resolution)
        self.noise_rms = self._per_axis("noise_rms", noise_rms)
        default = [DEFAULT_MAX_ERROR[a.kind] for a in system.axes]
        self.max_error = self._per_axis("max_error", default if max_error is None else max_error, positive=True)
        self.substeps = self._substeps(substeps)
        self._C = self._controller_rows()
        self._rng = np.random.default_rng(seed)

    @property
    def n_axes(self) -> int:
        return self.robot.n_axes

    @property
    def name(self) -> str:
        return self.system.name

    @property
    def axes(self) -> tuple[str, ...]:
        return self.system.axis_names

    def __repr__(self) -> str:
        """Everything the plant's runs depend on (a trained model's cache key includes it)."""
        arrays = {k: np.round(getattr(self, k), 12).tolist() for k in ("u_max", "encoder_resolution", "noise_rms",
                                                                        "max_error")}
        return (f"URDFPlant({self.system.name!r}, urdf={self.robot.path.name!r}, axes={list(self.axes)}, "
                f"effects={list(self.bound_effects)}, gains={self.gains}, fs={self.fs}, substeps={self.substeps}, "
                f"seed={self.seed}, preroll={self.preroll}, {arrays}, parameters={self.parameters})")

    def process_sensitivity(self, n: int, positions: np.ndarray) -> np.ndarray:
        """P S (e^{i w Ts}) (n_freq, n_axes) [rad or m per input unit] of the nominal closed loop per
        axis on the rfft grid of n samples (what plant-inversion ILC inverts, ``methods.ilc.method``):
        each axis a rigid inertia J, the diagonal of the nominal (URDF) mass matrix at the mean pose of
        ``positions`` (T, n_axes), behind a zero-order hold without computation delay
        (``physics.lti.rigid_axis``), and this plant's PID with its low-passed derivative, or its
        two-sample one (``control``; whether it differentiates e or -y, the input's way to y is the
        same)."""
        p = self.system.nominal_params().to_vector()
        q_mean = np.asarray(positions, dtype=float).mean(axis=0)
        J = np.diag(self.system.mass_matrix(p, q_mean[None, :])[0])
        ts, g = 1.0 / self.fs, self.gains
        z = np.exp(1j * 2 * math.pi * np.fft.rfftfreq(n, ts) * ts)
        out = np.empty((z.size, self.n_axes), dtype=complex)
        for a in range(self.n_axes):
            alpha = math.exp(-2 * math.pi * g.f_lp[a] / self.fs)
            pn, pd = rigid_axis(J[a], 0.0, self.fs, z)
            if g.derivative == "measurement_fir2":
                c = g.kp[a] + g.kd[a] * (1 - z**-2) / (2 * ts)
            else:
                c = g.kp[a] + g.kd[a] * (1 - alpha) * (1 - 1 / z) / ts / (1 - alpha / z)
            with np.errstate(divide="ignore", invalid="ignore"):  # the integrator's pole at z = 1 (bin 0)
                c = c + g.ki[a] * ts / (z - 1) if g.ki[a] > 0 else c
                out[:, a] = pn / (pd + pn * c)  # P / (1 + P C), finite at z = 1 without an integrator
            if g.ki[a] > 0:
                out[0, a] = 0.0  # with one it removes a constant error: P S (1) = 0
        return out

    def reference_feedback(self, positions) -> np.ndarray:
        """What this plant's feedback outputs (T, n_axes) [N m or N] when its encoders follow
        ``positions`` (T, n_axes) [rad or m] exactly: the loop's own reaction to the motion, which a
        feedforward must cancel for the loop to track exactly (``methods.loop.loop_feedforward``).
        Zero where the derivative term differentiates the tracking error; -kd times the reference's
        velocity, as the loop differentiates it, where it differentiates the measurement (a
        cascade drive's velocity loop: what its velocity feedforward supplies). The compiled
        ``control`` computes it, with the measurement set to the reference (no quantization, noise
        or input limit), from a start held at the first sample, as a run's pre-roll holds it."""
        x = np.asarray(positions, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.n_axes:
            raise ValueError(f"positions must have shape (T, {self.n_axes}), got {x.shape}")
        if self.gains.derivative == "error":
            return np.zeros_like(x)
        C = self._C.copy()
        C[:, RES], C[:, UMAX], C[:, MAXERR] = 0.0, np.inf, np.inf
        ref = np.ascontiguousarray(x[:, np.argsort(self.robot.v_index)])
        out = np.zeros((x.shape[0], 3, self.n_axes))
        exact_tracking_feedback(C, ref, np.zeros_like(ref), out, self.workspace(ref[0], np.zeros(self.n_axes)), 1.0 / self.fs)
        return out[:, OUT_U][:, self.robot.v_index]

    # ------------------------------------------------------------------ set-up
    def _true_model(self, parameters):
        """The rigid body the plant integrates and the true viscous coefficients (axis order)."""
        if parameters is None:
            return self.robot.model, np.zeros(self.n_axes)
        p = np.asarray(parameters, dtype=float).ravel()
        if p.size != self.robot.n_params or not np.all(np.isfinite(p)):
            raise ValueError(f"{self.name}: parameters must be {self.robot.n_params} finite values, got {p.size}")
        model = self.robot.model.copy()
        for k, jid in enumerate(self.robot.joint_ids):
            model.inertias[int(jid)] = pin.Inertia.FromDynamicParameters(p[10 * k : 10 * k + 10])
        return model, p[10 * self.n_axes :]

    def _per_axis(self, what: str, value, positive: bool = False) -> np.ndarray:
        v = np.full(self.n_axes, float(value)) if np.ndim(value) == 0 else np.asarray(value, dtype=float)
        if v.shape != (self.n_axes,) or np.any(np.isnan(v)) or np.any(v < 0) or (positive and np.any(v <= 0)):
            raise ValueError(f"{what} must be one value or {self.n_axes} values {'> 0' if positive else '>= 0'}, got {value!r}")
        return v

    def _substeps(self, substeps: int | None) -> int:
        if substeps is not None:
            if int(substeps) != substeps or substeps < 1:
                raise ValueError(f"substeps must be an integer >= 1, got {substeps}")
            return int(substeps)
        reads_load = any(isinstance(e, fx.LoadFriction) for e in self._torques)
        load = gravity_bound(self.robot, self.model, seed=self.seed)[self.robot.v_index] if reads_load else 0.0
        dv, dq = plant_effects.slopes(self._torques, self.n_axes, load)
        minv = 1.0 / inertia_range(self.robot, self.model, seed=self.seed)[0]
        rate = float(np.max(dv * minv + np.sqrt(dq * minv)))
        n = max(MIN_SUBSTEPS, math.ceil(rate / self.fs / STEP_RATE))
        if n > MAX_SUBSTEPS:
            raise ValueError(f"{self.name}: the hidden effects are too stiff for {self.fs:g} Hz ({n} RK4 steps per sample "
                             f"needed, fastest rate {rate:.3g} 1/s); smooth them (a larger eps) or give substeps")
        return n

    def _controller_rows(self) -> np.ndarray:
        """Controller and limits per axis, rows in pinocchio's velocity order."""
        r, g = self.robot, self.gains
        C = np.zeros((self.n_axes, N_CTRL))
        for k, row in enumerate(r.v_index):
            alpha = math.exp(-2 * math.pi * g.f_lp[k] / self.fs)
            C[row] = (g.kp[k], g.kd[k], g.ki[k], alpha, self.u_max[k], self.encoder_resolution[k], self.max_error[k],
                      {"error": D_ERROR, "measurement": D_MEASUREMENT, "measurement_fir2": D_FIR2}[g.derivative])
        return C

    # ------------------------------------------------------------------ simulation
    @property
    def deterministic(self) -> bool:
        """A run is a function of its inputs where the plant adds no measurement noise (the noise's
        stream carries on from run to run)."""
        return not np.any(np.asarray(self.noise_rms) > 0)

    @remembered  # inside the benchmark's cells: a run made before is not made again (``systems.runs``)
    def run(self, references, feedforward=None) -> Trial | list[Trial]:
        """Run the closed loop on one reference or a list of them.

        references: an array (T, n_axes) of positions [rad or m] in the machine's axis order, a
        ``references.Reference``, or a list of these. feedforward: None (zero), an array (T,
        n_axes) [N m or N], or a list matching ``references``. Returns a Trial (a list for a list)
        with the reference, encoder position ``pos``, input ``u``, feedforward ``ff`` and the true
        positions in ``extra["load_<axis>"]``; meta: the system, reference and effect names."""
        single = not isinstance(references, (list, tuple))
        refs = [references] if single else list(references)
        ffs = [feedforward] if single else (list(feedforward) if feedforward is not None else [None] * len(refs))
        if len(ffs) != len(refs):
            raise ValueError(f"{len(refs)} references but {len(ffs)} feedforward signals")
        trials = [self._run_one(*self._checked(i, r, f)) for i, (r, f) in enumerate(zip(refs, ffs, strict=True))]
        return trials[0] if single else trials

    def _checked(self, i: int, reference, feedforward) -> tuple[str, np.ndarray, np.ndarray]:
        name = reference.name if isinstance(reference, Reference) else f"reference-{i}"
        x = np.asarray(reference.positions if isinstance(reference, Reference) else reference, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.n_axes or x.shape[0] < 2:
            raise ValueError(f"{name}: reference must have shape (T >= 2, {self.n_axes}), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name}: reference contains NaN or inf at sample {int(np.argwhere(~np.isfinite(x))[0, 0])}")
        if feedforward is None:
            return name, x, np.zeros_like(x)
        f = np.asarray(feedforward, dtype=float)
        if f.shape != x.shape:
            raise ValueError(f"{name}: feedforward shape {f.shape} differs from the reference's {x.shape}")
        if not np.all(np.isfinite(f)):
            raise ValueError(f"{name}: feedforward is NaN or inf at sample {int(np.argwhere(~np.isfinite(f))[0, 0])}")
        return name, x, f

    def _run_one(self, name: str, ref: np.ndarray, ff: np.ndarray) -> Trial:
        run = ClosedLoopRun(self, name, ref, ff)
        k, status = run.advance(-run.preroll, ref.shape[0])
        if status != OK:
            run.diverged(k, status)
        return run.trial()

    def free_response(self, q0, qd0, inputs) -> tuple[np.ndarray, np.ndarray]:
        """The plant without feedback: from q0, qd0 (n_axes,) [rad or m, per s], each row of
        ``inputs`` (T, n_axes) [N m or N] held for one sample. Returns q, qd (T + 1, n_axes) at the
        sample times (the first row the initial state)."""
        u = np.atleast_2d(np.asarray(inputs, dtype=float))
        if u.ndim != 2 or u.shape[1] != self.n_axes:
            raise ValueError(f"inputs must have shape (T, {self.n_axes}), got {u.shape}")
        order, back = np.argsort(self.robot.v_index), self.robot.v_index
        S = self.workspace(np.asarray(q0, dtype=float)[order], np.asarray(qd0, dtype=float)[order])
        work = rigid_body.scratch(self.n_axes)
        q, qd = np.empty((u.shape[0] + 1, self.n_axes)), np.empty((u.shape[0] + 1, self.n_axes))
        q[0], qd[0] = S[Q][back], S[V][back]
        h = 1.0 / (self.fs * self.substeps)
        for k in range(u.shape[0]):
            S[U] = u[k, order]
            for _ in range(self.substeps):
                rk4_step(S, self._E, self._L, h, *self.body.packed(), *work)
            q[k + 1], qd[k + 1] = S[Q][back], S[V][back]
        return q, qd

    def workspace(self, q0: np.ndarray, v0: np.ndarray) -> np.ndarray:
        """Workspace rows (module constants) for a start at q0 with velocity v0 (pinocchio order)."""
        S = np.zeros((N_ROWS, self.n_axes))
        S[Q], S[V] = q0, v0
        return S

    def _diverged(self, name: str, k: int, S: np.ndarray, ref: np.ndarray, status: int):
        back, n = self.robot.v_index, self.n_axes
        q, v, r = S[Q, :n][back], S[V, :n][back], ref[back]
        when = "during the pre-roll" if k < 0 else f"at t = {k / self.fs:.3f} s (sample {k})"
        if status == NOT_FINITE:
            why = "the state is no longer finite"
        else:
            i = int(np.argmax(np.abs(r - q) / self.max_error))
            why = f"the tracking error of {self.system.axis_names[i]} is {r[i] - q[i]:.4g} (limit {self.max_error[i]:.4g})"
        raise SimulationDiverged(
            f"{self.name}: {name}: the simulation diverged {when}: {why}; q = {np.round(q, 4).tolist()}, "
            f"qd = {np.round(v, 4).tolist()}, reference {np.round(r, 4).tolist()} (axes {', '.join(self.system.axis_names)}; "
            "rad or m)")


class ClosedLoopRun:
    """One closed-loop run of a ``URDFPlant`` on one reference, sample by sample: what ``run`` loops
    over and what the Gymnasium env (``machine_env``) steps. Samples k = -preroll .. T - 1; the
    pre-roll holds the first reference and feedforward sample. ``ff`` (T, n_axes) [N m or N] may be
    filled as the run goes (``set_feedforward``) before each sample; arrays in axis order."""

    def __init__(self, plant: URDFPlant, name: str, ref: np.ndarray, ff: np.ndarray):
        self.plant, self.name = plant, name
        self.preroll, T, n = int(round(plant.preroll * plant.fs)), ref.shape[0], plant.n_axes
        P = self.preroll
        self.order = np.argsort(plant.robot.v_index)  # pinocchio velocity index -> axis
        self.ref = ref
        self.REF = np.concatenate([np.repeat(ref[:1], P, axis=0), ref])[:, self.order]
        self.FF = np.concatenate([np.repeat(ff[:1], P, axis=0), ff])[:, self.order]
        self.noise = np.zeros((P + T, n))
        if np.any(plant.noise_rms > 0):
            self.noise = plant._rng.standard_normal((P + T, n)) * plant.noise_rms[self.order]
        self.S = plant.workspace(self.REF[0], np.zeros(n))
        self.work = rigid_body.scratch(n)
        self.out = np.zeros((P + T, 3, n))
        self.ts = 1.0 / plant.fs

    def set_feedforward(self, k: int, rows: np.ndarray) -> None:
        """The feedforward of sample k (n_axes,), or of samples k, k + 1, ... (m, n_axes); axis order."""
        rows = np.atleast_2d(rows)
        self.FF[self.preroll + k : self.preroll + k + len(rows)] = rows[:, self.order]

    def sample(self, k: int) -> int:
        """Sample k: encoder, feedback and input (``control``), then the interval to the next
        sample. Returns OK, TOO_FAR or NOT_FINITE (then the state did not advance)."""
        return self.advance(k, k + 1)[1]

    def advance(self, first: int, last: int) -> tuple[int, int]:
        """Samples first .. last - 1 (``sample`` each, in one compiled loop: ``closed_loop``).
        Returns (last, OK), or (k, status) of the sample k whose control was not OK."""
        P, plant = self.preroll, self.plant
        k, status = closed_loop(P + first, P + last, self.S, plant._C, plant._E, plant._L, self.REF, self.FF, self.noise,
                                self.out, self.ts, plant.substeps, *plant.body.packed(), *self.work)
        return k - P, status

    def state(self) -> np.ndarray:
        """A copy of the loop's state (the plant's and the controller's)."""
        return self.S.copy()

    def restore(self, state: np.ndarray) -> None:
        self.S[:] = state

    def measured(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(encoder reading, input, true position) of sample k, axis order."""
        row = self.out[self.preroll + k][:, self.plant.robot.v_index]
        return row[OUT_Y], row[OUT_U], row[OUT_Q]

    def measured_readings(self, first: int, last: int) -> np.ndarray:
        """The encoder readings (last - first, n_axes) of samples first .. last - 1 (run), axis order."""
        return self.out[self.preroll + first : self.preroll + last, OUT_Y][:, self.plant.robot.v_index]

    def reading(self, k: int) -> np.ndarray:
        """The encoders' reading (n_axes,) [rad or m], axis order, of the current state as sample k
        will see it (what the loop reads next; after the last sample, without noise)."""
        n, C, row = self.plant.n_axes, self.plant._C, self.preroll + k
        noise = self.noise[row] if row < self.noise.shape[0] else np.zeros(n)
        y = np.array([encoder(self.S[Q, i], C[i, RES], noise[i]) for i in range(n)])
        return y[self.plant.robot.v_index]

    def diverged(self, k: int, status: int):
        self.plant._diverged(self.name, k, self.S, self.REF[self.preroll + k], status)

    def trial(self, n: int | None = None, **meta) -> Trial:
        """The first n samples (default all) as a Trial: reference, encoder ``pos``, input ``u``,
        feedforward ``ff``, true positions ``extra["load_<axis>"]``; ``meta`` added to its meta."""
        plant, P = self.plant, self.preroll
        n = self.ref.shape[0] if n is None else n
        back = plant.robot.v_index  # axis -> pinocchio velocity index
        rec = self.out[P : P + n]
        axes = plant.system.axis_names
        return Trial(
            t=np.arange(n) / plant.fs, ref=self.ref[:n], pos=rec[:, OUT_Y][:, back], u=rec[:, OUT_U][:, back],
            ff=self.FF[P : P + n][:, back], axes=axes,
            extra={f"load_{a}": rec[:, OUT_Q, back[i]] for i, a in enumerate(axes)},
            meta={"system": plant.name, "reference": self.name, "effects": [e.key for e in plant.bound_effects], **meta},
        )


# ---------------------------------------------------------------------------------------------
# References
# ---------------------------------------------------------------------------------------------


def reference_speeds(robot: URDFRobot, speed: float = 0.5,
                     velocity_fallback: tuple[float, float] = (1.0, 0.1)) -> np.ndarray:
    """The references' top speed per axis [rad/s or m/s]: ``speed`` x the URDF's velocity limit, or
    x ``velocity_fallback`` (revolute, prismatic) where the URDF gives none."""
    fallback = np.where(np.array(robot.kinds) == "prismatic", velocity_fallback[1], velocity_fallback[0])
    return speed * np.where(np.isfinite(robot.velocity) & (robot.velocity > 0), robot.velocity, fallback)


def random_references(system: System, n: int = 1, duration: float = 20.0, fs: float = 1000.0, seed: int = 0,
                      speed: float = 0.5, accel_time: float = 0.2, jerk_time: float = 0.05, margin: float = 0.1,
                      velocity_fallback: tuple[float, float] = (1.0, 0.1), rng: np.random.Generator | None = None,
                      prefix: str | None = None) -> list[Reference]:
    """``n`` seeded references of random point-to-point moves of every axis of a URDF machine,
    third-order setpoints (``references.random_moves``) for about ``duration`` s each.

    Targets lie within the URDF's joint limits, ``margin`` of the range inside each end (+-pi for a
    continuous joint). A move's velocity limit is a random 0.4-1 of ``speed`` times the URDF's
    velocity limit (``velocity_fallback`` [rad/s, m/s] where the URDF gives none), its
    acceleration limit reaches that velocity in ``accel_time`` s, its jerk limit that acceleration
    in ``jerk_time`` s; dwells 0.2-1 s between moves. ``rng``: the random stream (default one of
    ``seed``); the references are named ``<prefix>-<i>`` (default ``<machine>-<seed>``)."""
    robot = urdf_robot(system)
    if n < 1 or not duration > 0 or not fs > 0 or not 0 < speed or not 0 <= margin < 0.5:
        raise ValueError(f"need n >= 1, duration > 0, fs > 0, speed > 0, 0 <= margin < 0.5; got {n}, {duration}, {fs}, "
                         f"{speed}, {margin}")
    rng = np.random.default_rng(seed) if rng is None else rng
    v_max = reference_speeds(robot, speed, velocity_fallback)
    prefix = prefix or f"{system.name}-{seed}"
    return [random_moves(f"{prefix}-{i}", rng, robot.lower, robot.upper, v_max, duration, fs, system.axis_names, margin,
                         accel_time, jerk_time) for i in range(n)]


__all__ = ["ClosedLoopRun", "FeedbackGains", "URDFPlant", "bind_effects", "inertia_range", "loop_stable",
           "random_references", "reference_speeds", "tuned_gains"]
