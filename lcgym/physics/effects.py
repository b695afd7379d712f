"""The effect library: physical effects beyond the rigid-body model, by canonical name.

Each effect acts on one axis (``axis``) of the systems it names (``systems``: the IX's propeller
and roll, the FlexArm's joints j1-j6) and is written once:

* a *formula function* (module level, below) that computes its basis functions with numpy
  ufuncs on scalars or arrays, so that the compiled plant (numba, scalars) and the physical
  model (numpy, arrays) evaluate the same code;
* an *effect class* holding its parameters: ``coefficients`` (the parameters the torque is
  linear in, fitted by least squares) and nonlinear parameters (kept fixed during a linear fit;
  the diagnose tool searches them on a grid);
* ``columns(q, qd, qdd)``: the regressor columns of the linear coefficients (model side), so
  that ``torque = columns @ coefficients``.

Sign convention: ``torque`` is the input [V] the axis needs to overcome the effect, i.e. it is
added to the right-hand side of tau = M qdd + H + D qd (eq. 2 of paper 000). All angles are in
rad, velocities in rad/s, torques in the system's input unit (IX: V, 1 V = 100 N m; FlexArm: N m
of the motor, for load-side angles).

Effects marked ``plant_only`` have internal state or change the order of the system
(stiction, drivetrain flexibility): they exist in plants but a static inverse model has no
regressor for them.

Names follow `spec/effects.md`; ``cable_drape`` (the weight of a hanging cable, a sinusoid in
the axis angle) and ``payload`` (an unknown rigid body at the FlexArm's flange) are additions of
lcgym to that vocabulary.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba.extending import register_jitable

from ..data import SYSTEM_AXES

DEG = math.pi / 180.0


def axis_index(axis: str) -> int:
    """Position of an axis among its system's axes (axis names are unique across systems)."""
    for axes in SYSTEM_AXES.values():
        if axis in axes:
            return axes.index(axis)
    raise ValueError(f"unknown axis {axis!r}")

# ---------------------------------------------------------------------------------------------
# Formula functions: numpy ufuncs only, valid on floats (numba) and arrays (numpy).
# ``register_jitable`` leaves each a plain Python function and lets compiled code call it too.
# ---------------------------------------------------------------------------------------------


@register_jitable
def smooth_sign(v, eps):
    """sign(v) smoothed over |v| < eps [rad/s]: tanh(v / eps)."""
    return np.tanh(v / eps)


@register_jitable
def normal_force_basis(s2, c2, c3):
    """Configuration dependence of a guidance's normal force: (|cos q2|, |cos q2| cos q3, |sin q2|).

    Takes s2 = sin q2, c2 = cos q2, c3 = cos q3 (propeller and roll angles). The gravity load on
    rollers scales with the magnitude of the gravity components through the guidance; the roll
    body's offset CoM modulates it with the roll angle.
    """
    a2 = np.abs(c2)
    return a2, a2 * c3, np.abs(s2)


@register_jitable
def stribeck_shape(v, vs):
    """exp(-(v / vs)^2): 1 at standstill, 0 well above the Stribeck velocity vs [rad/s]."""
    return np.exp(-((v / vs) ** 2))


@register_jitable
def softplus(x):
    """log(1 + exp(x)), overflow-free."""
    return 0.5 * (x + np.abs(x)) + np.log1p(np.exp(-np.abs(x)))


@register_jitable
def sigmoid(x):
    """1 / (1 + exp(-x))."""
    return 0.5 * (1.0 + np.tanh(0.5 * x))


@register_jitable
def cable_spring_basis(q, q0, width, side):
    """One-sided spring deflection [rad]: side * width * softplus(side (q - q0) / width).

    Zero on one side of q0, slope 1 (times side) beyond it; smooth over +-width.
    """
    return side * width * softplus(side * (q - q0) / width)


@register_jitable
def cable_inertia_basis(q, qd, qdd, q0, width):
    """Torque per unit of added inertia dJ for J(q) = dJ sigmoid((q - q0) / width).

    Euler-Lagrange of T = 1/2 J(q) qd^2 gives J(q) qdd + 1/2 J'(q) qd^2; returns
    (shape(q), torque basis) so that the plant can add dJ shape to its mass matrix.
    """
    s = sigmoid((q - q0) / width)
    ds = s * (1.0 - s) / width
    return s, s * qdd + 0.5 * ds * qd * qd


@register_jitable
def periodic_basis(q, period):
    """(sin, cos) of 2 pi q / period: one harmonic of a position-periodic force."""
    x = 2.0 * math.pi * q / period
    return np.sin(x), np.cos(x)


@register_jitable
def gear_harmonic_basis(q, qd, period, v_ref):
    """Gear-harmonic basis: (sin x, cos x, r sin x, r cos x, sin 2x, cos 2x), x = 2 pi q / period,
    r = |qd| / v_ref (amplitude growing with speed)."""
    s, c = periodic_basis(q, period)
    r = np.abs(qd) / v_ref
    return s, c, r * s, r * c, 2.0 * s * c, c * c - s * s

@register_jitable
def table_lookup(x, lo, hi, values):
    """Piecewise-linear curve through ``values`` on a uniform grid over [lo, hi], held constant
    outside it; x a float. Used by plants to carry force curves of any shape."""
    n = values.shape[0]
    if x <= lo:
        return values[0]
    if x >= hi:
        return values[n - 1]
    f = (x - lo) / (hi - lo) * (n - 1)
    k = min(int(f), n - 2)
    w = f - k
    return values[k] * (1.0 - w) + values[k + 1] * w

# ---------------------------------------------------------------------------------------------
# Effect classes
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Effect:
    """Base class: an effect on one axis. Subclasses set ``name`` and the parameter lists."""

    axis: str
    name: ClassVar[str] = ""
    linear: ClassVar[tuple[str, ...]] = ()  # coefficient attribute names (linear parameters)
    nonlinear: ClassVar[tuple[str, ...]] = ()  # nonlinear parameter attribute names
    plant_only: ClassVar[bool] = False
    needs_base_torque: ClassVar[bool] = False
    systems: ClassVar[tuple[str, ...]] = ("ix",)  # where the effect's formula applies

    def __post_init__(self):
        allowed = [a for s in self.systems for a in SYSTEM_AXES[s]]
        if self.axis not in allowed:
            raise ValueError(f"{self.name}: unknown axis {self.axis!r} (the effect applies to {', '.join(self.systems)}); "
                             f"choose one of {allowed}")
        for n in self.linear + self.nonlinear:
            v = getattr(self, n)
            if not np.isfinite(v):
                raise ValueError(f"{self.key}: parameter {n} must be finite, got {v}")

    @property
    def key(self) -> str:
        """Canonical ``name@axis`` label."""
        return f"{self.name}@{self.axis}"

    @property
    def index(self) -> int:
        return axis_index(self.axis)

    def coefficients(self) -> np.ndarray:
        return np.array([getattr(self, n) for n in self.linear], dtype=float)

    def with_coefficients(self, values) -> Effect:
        values = np.asarray(values, dtype=float).ravel()
        if values.size != len(self.linear):
            raise ValueError(f"{self.key}: expected {len(self.linear)} coefficients, got {values.size}")
        return dataclasses.replace(self, **dict(zip(self.linear, map(float, values), strict=True)))

    def columns(self, q, qd, qdd, base=None) -> np.ndarray:
        """Regressor columns (T, len(linear)) of this effect's torque on its own axis [input unit per unit]."""
        if self.plant_only:
            raise TypeError(f"{self.key} has internal dynamics and no static regressor (plant only)")
        cols = self._columns(np.asarray(q, float), np.asarray(qd, float), np.asarray(qdd, float), base)
        return np.stack(np.broadcast_arrays(*cols), axis=-1)

    def torque(self, q, qd, qdd, base=None) -> np.ndarray:
        """Torque (T, n_axes) [input unit] this effect adds to the required input (zero on the other axes)."""
        out = np.zeros(np.shape(q), dtype=float)
        out[..., self.index] = self.columns(q, qd, qdd, base) @ self.coefficients()
        return out

    def _columns(self, q, qd, qdd, base):  # pragma: no cover - abstract
        raise NotImplementedError

    def _v(self, qd):
        return qd[..., self.index]

    def _q(self, q):
        return q[..., self.index]


@dataclass(frozen=True)
class ViscousFriction(Effect):
    """Viscous friction d * qd. d [input unit s/rad], linear. Already part of the IX and arm models (IX: D, eq. 3)."""

    d: float = 0.0
    name: ClassVar[str] = "viscous_friction"
    linear: ClassVar[tuple[str, ...]] = ("d",)
    systems: ClassVar[tuple[str, ...]] = ("ix", "flexarm")

    def _columns(self, q, qd, qdd, base):
        return (self._v(qd),)


@dataclass(frozen=True)
class CoulombFriction(Effect):
    """Coulomb friction Fc * tanh(qd / eps). Fc [V or N m] linear; eps [rad/s] nonlinear (smoothing)."""

    Fc: float = 0.0
    eps: float = 1e-3
    name: ClassVar[str] = "coulomb_friction"
    linear: ClassVar[tuple[str, ...]] = ("Fc",)
    nonlinear: ClassVar[tuple[str, ...]] = ("eps",)
    systems: ClassVar[tuple[str, ...]] = ("ix", "flexarm")

    def _columns(self, q, qd, qdd, base):
        return (smooth_sign(self._v(qd), self.eps),)


@dataclass(frozen=True)
class StribeckFriction(Effect):
    """Stribeck increase at low speed: dF exp(-(qd/vs)^2) tanh(qd/eps).

    dF = Fs - Fc [V or N m] linear (static minus Coulomb level); vs [rad/s], eps [rad/s] nonlinear.
    In a plant it adds to the friction level of the same axis (with or without stiction).
    """

    dF: float = 0.0
    vs: float = 0.4 * DEG
    eps: float = 1e-3
    name: ClassVar[str] = "stribeck_friction"
    linear: ClassVar[tuple[str, ...]] = ("dF",)
    nonlinear: ClassVar[tuple[str, ...]] = ("vs", "eps")
    systems: ClassVar[tuple[str, ...]] = ("ix", "flexarm")

    def _columns(self, q, qd, qdd, base):
        v = self._v(qd)
        return (stribeck_shape(v, self.vs) * smooth_sign(v, self.eps),)


@dataclass(frozen=True)
class PositionDependentFriction(Effect):
    """Friction whose level follows the guidance's normal force:

        (c_cos |cos q2| + c_cos_roll |cos q2| cos q3 + c_sin |sin q2|) tanh(qd / eps)

    c_* [V] linear, eps [rad/s] nonlinear; q2, q3 are the propeller and roll angles.
    """

    c_cos: float = 0.0
    c_cos_roll: float = 0.0
    c_sin: float = 0.0
    eps: float = 1e-3
    name: ClassVar[str] = "position_dependent_friction"
    linear: ClassVar[tuple[str, ...]] = ("c_cos", "c_cos_roll", "c_sin")
    nonlinear: ClassVar[tuple[str, ...]] = ("eps",)

    def _columns(self, q, qd, qdd, base):
        sgn = smooth_sign(self._v(qd), self.eps)
        basis = normal_force_basis(np.sin(q[..., 0]), np.cos(q[..., 0]), np.cos(q[..., 1]))
        return tuple(b * sgn for b in basis)


@dataclass(frozen=True)
class Stiction(Effect):
    """Sticking at standstill: LuGre bristle dynamics on the axis's friction (plant only).

        zdot = v - sigma0 |v| z / mu,   tau = L(q) (sigma0 z + sigma1 zdot)

    with L(q) the Coulomb + position-dependent level [V] and mu = (L + dF exp(-(v/vs)^2)) / L
    from the Stribeck effect. sigma0 [1/rad] bristle stiffness, sigma1 [s/rad] bristle damping.
    Without this effect a plant's friction is the static tanh-smoothed curve.
    """

    sigma0: float = 1e4
    sigma1: float = 60.0
    name: ClassVar[str] = "stiction"
    nonlinear: ClassVar[tuple[str, ...]] = ("sigma0", "sigma1")
    plant_only: ClassVar[bool] = True


@dataclass(frozen=True)
class CableSpring(Effect):
    """One-sided cable spring: k * side * width * softplus(side (q - q0) / width).

    k [V/rad] linear; q0 [rad] where the cable starts to tension, width [rad] smoothing,
    side (+1: tensions above q0, -1: below) nonlinear.
    """

    k: float = 0.0
    q0: float = 20 * DEG
    width: float = 3 * DEG
    side: float = 1.0
    name: ClassVar[str] = "cable_spring"
    linear: ClassVar[tuple[str, ...]] = ("k",)
    nonlinear: ClassVar[tuple[str, ...]] = ("q0", "width", "side")

    def _columns(self, q, qd, qdd, base):
        return (cable_spring_basis(self._q(q), self.q0, self.width, self.side),)


@dataclass(frozen=True)
class CableInertia(Effect):
    """Configuration-dependent inertia of a cable: J(q) = dJ sigmoid((q - q0) / width).

    Adds J(q) qdd + 1/2 J'(q) qd^2 (Euler-Lagrange). dJ [V s^2/rad] linear; q0, width [rad]
    nonlinear.
    """

    dJ: float = 0.0
    q0: float = 20 * DEG
    width: float = 10 * DEG
    name: ClassVar[str] = "cable_inertia"
    linear: ClassVar[tuple[str, ...]] = ("dJ",)
    nonlinear: ClassVar[tuple[str, ...]] = ("q0", "width")

    def _columns(self, q, qd, qdd, base):
        i = self.index
        return (cable_inertia_basis(q[..., i], qd[..., i], qdd[..., i], self.q0, self.width)[1],)


@dataclass(frozen=True)
class TorqueRipple(Effect):
    """Motor torque ripple: the delivered torque is u (1 + a_sin sin(x) + a_cos cos(x)), x = 2 pi q_m / period.

    a_sin, a_cos [-] linear (amplitude a and phase phi: a_sin = a cos phi, a_cos = a sin phi);
    period [rad of the axis angle] nonlinear. q_m is the motor angle in axis units.
    Model side, to first order in a: required input = tau (1 - a_sin sin x - a_cos cos x), so
    the columns are -tau_base [sin x, cos x] with tau_base the model's torque without ripple.
    """

    a_sin: float = 0.0
    a_cos: float = 0.0
    period: float = 3 * DEG
    name: ClassVar[str] = "torque_ripple"
    linear: ClassVar[tuple[str, ...]] = ("a_sin", "a_cos")
    nonlinear: ClassVar[tuple[str, ...]] = ("period",)
    needs_base_torque: ClassVar[bool] = True

    @classmethod
    def from_amplitude(cls, axis: str, amplitude: float, period: float, phase: float) -> TorqueRipple:
        return cls(axis, amplitude * math.cos(phase), amplitude * math.sin(phase), period)

    def _columns(self, q, qd, qdd, base):
        if base is None:
            raise ValueError(f"{self.key}: the ripple regressor needs the base torque of the model")
        s, c = periodic_basis(self._q(q), self.period)
        return (-base * s, -base * c)


@dataclass(frozen=True)
class GearHarmonic(Effect):
    """Position-periodic gear force, velocity-dependent amplitude, two harmonics:

        (s1 + s1v |qd| / v_ref) sin x + (c1 + c1v |qd| / v_ref) cos x + s2 sin 2x + c2 cos 2x

    with x = 2 pi q / period. s1, c1, s1v, c1v, s2, c2 [V] linear; period [rad], v_ref [rad/s]
    nonlinear. It shows up at |qd| / period Hz in the input.
    """

    s1: float = 0.0
    c1: float = 0.0
    s1v: float = 0.0
    c1v: float = 0.0
    s2: float = 0.0
    c2: float = 0.0
    period: float = 5 * DEG
    v_ref: float = 15 * DEG
    name: ClassVar[str] = "gear_harmonic"
    linear: ClassVar[tuple[str, ...]] = ("s1", "c1", "s1v", "c1v", "s2", "c2")
    nonlinear: ClassVar[tuple[str, ...]] = ("period", "v_ref")

    @classmethod
    def from_amplitudes(
        cls, axis, a1, phase1, a2, phase2, velocity_gain=0.0, period=5 * DEG, v_ref=15 * DEG
    ) -> GearHarmonic:
        """a1 (1 + velocity_gain |qd| / v_ref) sin(x + phase1) + a2 sin(2x + phase2)."""
        s1, c1 = a1 * math.cos(phase1), a1 * math.sin(phase1)
        return cls(
            axis, s1, c1, velocity_gain * s1, velocity_gain * c1,
            a2 * math.cos(phase2), a2 * math.sin(phase2), period, v_ref,
        )

    def _columns(self, q, qd, qdd, base):
        return gear_harmonic_basis(self._q(q), self._v(qd), self.period, self.v_ref)


@dataclass(frozen=True)
class CableDrape(Effect):
    """Weight of a hanging cable on an axis: s sin q + c cos q [V] (= A sin(q + phi)). s, c linear.

    On the propeller it lies in the span of the rigid model's gravity terms, so a rigid-model fit
    absorbs it (with shifted mass parameters); on the roll axis it does not.
    """

    s: float = 0.0
    c: float = 0.0
    name: ClassVar[str] = "cable_drape"
    linear: ClassVar[tuple[str, ...]] = ("s", "c")

    @classmethod
    def from_amplitude(cls, axis: str, amplitude: float, phase: float) -> CableDrape:
        return cls(axis, amplitude * math.cos(phase), amplitude * math.sin(phase))

    def _columns(self, q, qd, qdd, base):
        return periodic_basis(self._q(q), 2 * math.pi)


@dataclass(frozen=True)
class DrivetrainFlexibility(Effect):
    """Two-mass drive: motor inertia Jm [V s^2/rad] coupled to the load by stiffness k [V/rad] and
    damping c [V s/rad] (plant only; the motor-side encoder then measures the motor angle).

    Jm is split off the rigid model's axis inertia (J2yy or J3xx), so the total stays the same.
    """

    k: float = 7500.0
    c: float = 7.0
    Jm: float = 0.20
    name: ClassVar[str] = "drivetrain_flexibility"
    nonlinear: ClassVar[tuple[str, ...]] = ("k", "c", "Jm")
    plant_only: ClassVar[bool] = True

    def __post_init__(self):
        super().__post_init__()
        if self.k <= 0 or self.Jm <= 0 or self.c < 0:
            raise ValueError(f"{self.key}: need k > 0, Jm > 0, c >= 0 (got k={self.k}, Jm={self.Jm}, c={self.c})")


@dataclass(frozen=True)
class TabulatedForce(Effect):
    """A force curve of any shape over the axis's velocity or position (plant only).

    ``variable`` "velocity" [rad/s] or "position" [rad]; ``values`` [V] on a uniform grid of
    ``len(values)`` points (2 to 1024) over [lo, hi], linear in between and held constant outside.
    It is not part of the vocabulary of `spec/effects.md`: it makes plants whose hidden effects
    follow none of the library's formulas (a differently shaped friction curve, a spring that
    engages smoothly), the way a real machine does, to test the diagnosis on them.
    """

    variable: str = "velocity"
    lo: float = -1.0
    hi: float = 1.0
    values: tuple[float, ...] = (0.0, 0.0)
    name: ClassVar[str] = "tabulated_force"
    plant_only: ClassVar[bool] = True
    max_points: ClassVar[int] = 1024

    def __post_init__(self):
        super().__post_init__()
        if self.variable not in ("velocity", "position"):
            raise ValueError(f"{self.key}: variable must be 'velocity' or 'position', got {self.variable!r}")
        values = np.asarray(self.values, dtype=float)
        if not 2 <= values.size <= self.max_points or not np.all(np.isfinite(values)):
            raise ValueError(f"{self.key}: need 2 to {self.max_points} finite values, got {values.size}")
        if not (np.isfinite(self.lo) and np.isfinite(self.hi) and self.hi > self.lo):
            raise ValueError(f"{self.key}: need finite lo < hi, got [{self.lo}, {self.hi}]")

    @classmethod
    def from_function(cls, axis: str, variable: str, function, lo: float, hi: float, points: int = 64) -> TabulatedForce:
        """Tabulate ``function`` (a numpy function of the variable, returning V) on [lo, hi]."""
        grid = np.linspace(lo, hi, points)
        return cls(axis, variable, lo, hi, tuple(float(v) for v in function(grid)))

    def force(self, x) -> np.ndarray:
        """The curve [V] at the values x of its variable (the plant's own formula)."""
        values = np.asarray(self.values, dtype=float)
        return np.array([table_lookup(float(v), self.lo, self.hi, values) for v in np.ravel(x)]).reshape(np.shape(x))


@dataclass(frozen=True)
class Payload(Effect):
    """FlexArm: an unknown rigid body fixed to the flange, seen in one joint's motor torque.

    Its 10 standard inertial parameters in frame 6 (``physics.arm``: m [kg], m c [kg m], inertia
    about the frame's origin [kg m^2]) add to link 6's; the torque is linear in them: the joint's
    row of link 6's regressor columns (``physics.arm_motor.link_columns``, motor side).
    Fitted per joint, each joint sees the payload through its own row (the shared 10 parameters
    are what the benchmark's physical model identifies with all inertial parameters free).
    """

    m: float = 0.0
    mx: float = 0.0
    my: float = 0.0
    mz: float = 0.0
    Ixx: float = 0.0
    Ixy: float = 0.0
    Ixz: float = 0.0
    Iyy: float = 0.0
    Iyz: float = 0.0
    Izz: float = 0.0
    name: ClassVar[str] = "payload"
    linear: ClassVar[tuple[str, ...]] = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")
    systems: ClassVar[tuple[str, ...]] = ("flexarm",)

    def _columns(self, q, qd, qdd, base):
        from .arm_motor import link_columns

        return tuple(link_columns(5, q, qd, qdd)[:, self.index, :].T)


EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        ViscousFriction, CoulombFriction, StribeckFriction, PositionDependentFriction, Stiction,
        CableSpring, CableInertia, TorqueRipple, GearHarmonic, CableDrape, DrivetrainFlexibility,
        TabulatedForce, Payload,
    )
}


def make_effect(key: str, **params) -> Effect:
    """Build an effect from its ``name@axis`` label, e.g. ``make_effect("coulomb_friction@roll", Fc=0.05)``."""
    name, sep, axis = key.partition("@")
    if not sep:
        raise ValueError(f"effect {key!r}: write it as NAME@AXIS, e.g. coulomb_friction@roll")
    if name not in EFFECTS:
        raise ValueError(f"unknown effect {name!r}; known: {', '.join(sorted(EFFECTS))}")
    return EFFECTS[name](axis=axis, **params)


def effect_record(effect: Effect) -> dict:
    """A JSON-ready description of an effect: its ``name@axis`` label and every parameter."""
    params = {f.name: getattr(effect, f.name) for f in dataclasses.fields(effect) if f.name != "axis"}
    return {"effect": effect.key, **{k: list(v) if isinstance(v, tuple) else v for k, v in params.items()}}


def effect_from_record(record: dict) -> Effect:
    """Inverse of ``effect_record``."""
    params = {k: tuple(v) if isinstance(v, list) else v for k, v in record.items() if k != "effect"}
    return make_effect(record["effect"], **params)


def check_unique(effects) -> None:
    """Refuse a list that names the same ``name@axis`` twice."""
    keys = [e.key for e in effects]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ValueError(f"effect listed twice: {dup}")
