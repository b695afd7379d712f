"""The effect library: physical effects beyond the rigid-body model, by canonical name.

Each effect acts on one axis (``axis``, by name) of a machine and is written once:

* a *formula function* (module level, below) that computes its basis functions with numpy
  ufuncs on scalars or arrays, so that the compiled plant (numba, scalars) and the physical
  model (numpy, arrays) evaluate the same code;
* an *effect class* holding its parameters: ``coefficients`` (the parameters the torque is
  linear in, fitted by least squares) and nonlinear parameters (kept fixed during a linear fit;
  the diagnose tool searches them on a grid);
* ``columns(q, qd, qdd)``: the regressor columns of the linear coefficients (model side), so
  that ``torque = columns @ coefficients``.

An effect is bound to a machine's axes before it computes anything (``System.effect`` or
``effect.bound(axis_names)``: ``index``, the position of its axis); its formula reads the
kinematics of its own axis. Effects that need a machine's geometry (the IX's guidance friction,
the FlexArm's payload) live with that machine (``systems/<machine>/effects.py``).

Sign convention: ``torque`` is the input the axis needs to overcome the effect, i.e. it is
added to the right-hand side of tau = M qdd + H + D qd (eq. 2 of paper 000). Positions are in
rad (revolute axes) or m (prismatic), velocities per second, torques in the axis's input unit
(IX: V, 1 V = 100 N m; FlexArm: N m of the motor, for load-side angles; N on a prismatic axis).

Effects marked ``plant_only`` have internal state or change the order of the system
(stiction, drivetrain flexibility): they exist in plants but a static inverse model has no
regressor for them.

Names are canonical snake_case: the same name means the same effect in a plant, in a model, in
the diagnosis report and on the command line (``lcgym effects`` lists them per machine).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numba.extending import register_jitable

from .grids import SMOOTHING, Scaled, Search, angle_quantiles, five_angle_quantiles, position_high, position_low

DEG = math.pi / 180.0

# ---------------------------------------------------------------------------------------------
# Formula functions: numpy ufuncs only, valid on floats (numba) and arrays (numpy).
# ``register_jitable`` leaves each a plain Python function and lets compiled code call it too.
# ---------------------------------------------------------------------------------------------


@register_jitable
def smooth_sign(v, eps):
    """sign(v) smoothed over |v| < eps [rad/s]: tanh(v / eps)."""
    return np.tanh(v / eps)


@register_jitable
def stribeck_shape(v, vs):
    """exp(-(v / vs)^2): 1 at standstill, 0 well above the Stribeck velocity vs [rad/s]."""
    return np.exp(-((v / vs) ** 2))


@register_jitable
def asymmetric_friction_basis(v, eps):
    """Basis of a friction with levels of its own in each direction: (h, -(1 - h), v (2 h - 1)),
    h = (1 + tanh(v / eps)) / 2 the smoothed "moving forward" indicator [-]; v (2 h - 1) is |v|
    smoothed [rad/s or m/s]."""
    s = smooth_sign(v, eps)
    return 0.5 * (1.0 + s), -0.5 * (1.0 - s), v * s


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
def drape_basis(q):
    """(sin q, cos q): the weight of a hanging cable on a revolute axis, one harmonic of period 2 pi."""
    return np.sin(q), np.cos(q)


@register_jitable
def gear_harmonic_basis(q, qd, period, v_ref):
    """Gear-harmonic basis: (sin x, cos x, r sin x, r cos x, sin 2x, cos 2x), x = 2 pi q / period,
    r = |qd| / v_ref (amplitude growing with speed)."""
    s, c = periodic_basis(q, period)
    r = np.abs(qd) / v_ref
    return s, c, r * s, r * c, 2.0 * s * c, c * c - s * s

@register_jitable
def load_friction_basis(v, load, eps):
    """Basis of a friction whose Coulomb level grows with the load torque the joint carries:
    (s, |load| s), s = tanh(v / eps) [-, input unit]."""
    s = smooth_sign(v, eps)
    return s, np.abs(load) * s


def spline_basis(x, lo: float, hi: float, n: int) -> np.ndarray:
    """Cubic B-spline basis (..., n) of x on [lo, hi] (n - 3 equal intervals, clamped ends), x held
    at the ends beyond them; the basis functions sum to 1, and any cubic polynomial is in their span."""
    from scipy.interpolate import BSpline

    k = 3
    knots = np.concatenate([[lo] * k, np.linspace(lo, hi, n - k + 1), [hi] * k])
    x = np.clip(np.asarray(x, dtype=float), lo, hi)
    return BSpline.design_matrix(x.ravel(), knots, k).toarray().reshape(x.shape + (n,))


def hat_basis(x, knots, extend: bool = False) -> np.ndarray:
    """Piecewise-linear "hat" functions (..., K) of x on the K sorted ``knots``: column j is 1 at
    knots[j] and 0 at the others, linear in between, held constant beyond the ends; their
    combination with weights c is the curve through the points (knots[j], c[j]). ``extend``: beyond
    the last knot the curve continues on the straight line of its last segment instead (the last
    two columns extrapolated linearly)."""
    knots = np.asarray(knots, dtype=float)
    x = np.asarray(x, dtype=float)
    eye = np.eye(knots.size)
    hats = np.stack([np.interp(x, knots, eye[j]) for j in range(knots.size)], axis=-1)
    if extend:
        beyond = x > knots[-1]
        t = (x[beyond] - knots[-2]) / (knots[-1] - knots[-2])  # > 1 past the last knot
        hats[beyond, -2], hats[beyond, -1] = 1.0 - t, t
    return hats


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
class Loads:
    """The model's own torques (T, n_axes) [input unit] that some effects' formulas read (an
    effect's ``reads`` names them; None where nothing reads it): ``torque`` the rigid-body torque
    M(q) qdd + h(q, qd) + D qd of the model's parameters, ``gravity`` the same at rest, g(q)."""

    torque: np.ndarray | None = None
    gravity: np.ndarray | None = None


@dataclass(frozen=True)
class Effect:
    """Base class: an effect on one axis. Subclasses set ``name`` and the parameter lists.

    ``index``: the position of ``axis`` among the machine's axes, set by ``bound`` (keyword only;
    not part of the effect's identity)."""

    axis: str
    index: int | None = field(default=None, kw_only=True, repr=False, compare=False)
    name: ClassVar[str] = ""
    linear: ClassVar[tuple[str, ...]] = ()  # coefficient attribute names (linear parameters)
    positive: ClassVar[tuple[str, ...]] = ()  # the coefficients that are positive physically (a level, a stiffness)
    bounds: ClassVar[dict[str, str]] = {}  # what a machine can have beyond ``positive`` (``impossible``)
    nonlinear: ClassVar[tuple[str, ...]] = ()  # nonlinear parameter attribute names
    plant_only: ClassVar[bool] = False
    reads: ClassVar[tuple[str, ...]] = ()  # the model torques the formula reads (``Loads``): "torque", "gravity"
    revolute_only: ClassVar[bool] = False  # the formula is periodic in the angle (no meaning on a prismatic axis)
    search: ClassVar[Search | None] = None  # how the diagnosis searches it (physics.grids); None: it does not
    plant_kind: ClassVar[int] = 0  # its code in the plants' compiled torque (physics.plant_effects); 0: none
    no_plant_kind: ClassVar[str] = ""  # why it has no plant kind, where it has none

    def __post_init__(self):
        if not isinstance(self.axis, str) or not self.axis:
            raise ValueError(f"{self.name}: the axis must be a name, got {self.axis!r}")
        for n in self.linear + self.nonlinear:
            v = getattr(self, n)
            if not np.isfinite(v):
                raise ValueError(f"{self.key}: parameter {n} must be finite, got {v}")

    @property
    def key(self) -> str:
        """Canonical ``name@axis`` label."""
        return f"{self.name}@{self.axis}"

    def impossible(self) -> str:
        """The first of its values no machine can have, as "name = value: must be RULE" ("" if none).
        The rules: each coefficient in ``positive`` (a friction level, a stiffness, an inertia) >= 0
        (zero: the machine has none), and the class's ``bounds``: ``"> 0"`` (a smoothing speed, a
        width, a period), ``">= 0"``, ``"+1 or -1"`` (a side). A fit may pass through such values on
        its way (``physical`` judges what it ends with); a machine's hidden effects may not
        (``systems.machine``)."""
        rules = {**{n: ">= 0" for n in self.positive}, **self.bounds}
        for n, rule in rules.items():
            v = float(getattr(self, n))
            if not {">= 0": v >= 0, "> 0": v > 0, "+1 or -1": v in (-1.0, 1.0)}[rule]:
                return f"{n} = {v:g}: must be {rule}"
        return ""

    def bound(self, axis_names: Sequence[str]) -> Effect:
        """This effect with ``index`` set to its axis's position among ``axis_names``."""
        names = list(axis_names)
        if self.axis not in names:
            raise ValueError(f"{self.key}: unknown axis {self.axis!r}; choose one of {', '.join(names)}")
        return dataclasses.replace(self, index=names.index(self.axis))

    @classmethod
    def applies_to(cls, axis) -> bool:
        """Whether the formula has a meaning on ``axis`` (a ``systems.Axis``)."""
        return axis.revolute or not cls.revolute_only

    def _i(self) -> int:
        if self.index is None:
            raise ValueError(f"{self.key} is not bound to a machine's axes: build it with system.effect(...) "
                             "or effect.bound(axis_names)")
        return self.index

    def coefficients(self) -> np.ndarray:
        return np.array([getattr(self, n) for n in self.linear], dtype=float)

    def with_coefficients(self, values) -> Effect:
        values = np.asarray(values, dtype=float).ravel()
        if values.size != len(self.linear):
            raise ValueError(f"{self.key}: expected {len(self.linear)} coefficients, got {values.size}")
        return dataclasses.replace(self, **dict(zip(self.linear, map(float, values), strict=True)))

    def columns(self, q, qd, qdd, loads: Loads | None = None) -> np.ndarray:
        """Regressor columns (T, len(linear)) of this effect's torque on its own axis [input unit per unit];
        q, qd, qdd (T, n_axes) of the machine; ``loads``: the model's torques the effect ``reads``."""
        if self.plant_only:
            raise TypeError(f"{self.key} has internal dynamics and no static regressor (plant only)")
        missing = [r for r in self.reads if loads is None or getattr(loads, r) is None]
        if missing:
            raise ValueError(f"{self.key}: its regressor needs the model's {' and '.join(missing)} torque (loads=)")
        cols = self._columns(np.asarray(q, float), np.asarray(qd, float), np.asarray(qdd, float), loads)
        return np.stack(np.broadcast_arrays(*cols), axis=-1)

    def torque(self, q, qd, qdd, loads: Loads | None = None) -> np.ndarray:
        """Torque (T, n_axes) [input unit] this effect adds to the required input (zero on the other axes)."""
        out = np.zeros(np.shape(q), dtype=float)
        out[..., self._i()] = self.columns(q, qd, qdd, loads) @ self.coefficients()
        return out

    @classmethod
    def roughness(cls) -> np.ndarray | None:
        """For a curve of no set shape, a difference operator D (m, len(linear)) on its coefficients
        whose square ||D c||^2 measures how much the curve bends: the fits add it, weighted by
        ``SMOOTHING`` (a penalized spline), so that where the data barely reach, the curve goes on
        as it came instead of following a few samples. None: a parametric effect, fitted as it is."""
        return None

    @classmethod
    def physical(cls, coefficients: np.ndarray) -> bool:
        """Whether fitted ``coefficients`` (in ``linear`` order) have the signs the effect has
        physically: every one named in ``positive`` > 0 (a friction level, a stiffness, an inertia)."""
        c = np.asarray(coefficients, dtype=float)
        return bool(all(c[cls.linear.index(n)] > 0 for n in cls.positive))

    def plant_parameters(self) -> tuple[float, ...]:
        """The parameters a plant's compiled torque reads (``physics.plant_effects``): the linear
        coefficients, then the nonlinear parameters, in the class's order."""
        return tuple(float(getattr(self, n)) for n in self.linear + self.nonlinear)

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        """(largest |d torque / d qd|, largest |d torque / d q|) [input unit s/rad, input unit/rad, or
        per m] over all states: the stiffness that sets a plant's integration step (``load``: the
        largest gravity torque of the axis, for an effect that reads it)."""
        raise NotImplementedError(f"{self.name} gives no slopes: it is no torque of q and qd a plant adds")

    def _columns(self, q, qd, qdd, loads):  # pragma: no cover - abstract
        raise NotImplementedError

    def _v(self, qd):
        return qd[..., self._i()]

    def _q(self, q):
        return q[..., self._i()]


@dataclass(frozen=True)
class ViscousFriction(Effect):
    """Viscous friction d * qd. d [input unit s/rad], linear. Already part of the IX and arm models (IX: D, eq. 3)."""

    d: float = 0.0
    name: ClassVar[str] = "viscous_friction"
    plant_kind: ClassVar[int] = 1
    linear: ClassVar[tuple[str, ...]] = ("d",)
    positive: ClassVar[tuple[str, ...]] = ("d",)

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        return abs(self.d), 0.0

    def _columns(self, q, qd, qdd, loads):
        return (self._v(qd),)


@dataclass(frozen=True)
class CoulombFriction(Effect):
    """Coulomb friction Fc * tanh(qd / eps). Fc [input unit] linear; eps [rad/s or m/s] nonlinear (smoothing)."""

    Fc: float = 0.0
    eps: float = 1e-3
    name: ClassVar[str] = "coulomb_friction"
    search: ClassVar[Search] = Search("friction", {"eps": SMOOTHING})
    plant_kind: ClassVar[int] = 8
    linear: ClassVar[tuple[str, ...]] = ("Fc",)
    positive: ClassVar[tuple[str, ...]] = ("Fc",)
    nonlinear: ClassVar[tuple[str, ...]] = ("eps",)
    bounds: ClassVar[dict[str, str]] = {"eps": "> 0"}

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        return (abs(self.Fc) / self.eps if self.Fc else 0.0), 0.0

    def _columns(self, q, qd, qdd, loads):
        return (smooth_sign(self._v(qd), self.eps),)


@dataclass(frozen=True)
class StribeckFriction(Effect):
    """Stribeck increase at low speed: dF exp(-(qd/vs)^2) tanh(qd/eps).

    dF = Fs - Fc [input unit] linear (static minus Coulomb level); vs, eps [rad/s or m/s] nonlinear.
    In a plant it adds to the friction level of the same axis (with or without stiction).
    """

    dF: float = 0.0
    vs: float = 0.4 * DEG
    eps: float = 1e-3
    name: ClassVar[str] = "stribeck_friction"
    # Stribeck velocities stop at 40 % of the speed scale: a wider bump is Coulomb friction
    search: ClassVar[Search] = Search("friction", {"vs": Scaled(tuple(np.geomspace(0.005, 0.4, 20))),
                                                   "eps": Scaled((0.0025, 0.01))},
                                       extends=("coulomb_friction",), above_rest=("vs",))
    plant_kind: ClassVar[int] = 9
    linear: ClassVar[tuple[str, ...]] = ("dF",)
    positive: ClassVar[tuple[str, ...]] = ("dF",)
    nonlinear: ClassVar[tuple[str, ...]] = ("vs", "eps")
    bounds: ClassVar[dict[str, str]] = {"vs": "> 0", "eps": "> 0"}

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        """dF / eps from the sign, at most 0.86 dF / vs from the bump."""
        return (abs(self.dF) / self.eps + 0.86 * abs(self.dF) / self.vs if self.dF else 0.0), 0.0

    def _columns(self, q, qd, qdd, loads):
        v = self._v(qd)
        return (stribeck_shape(v, self.vs) * smooth_sign(v, self.eps),)


@dataclass(frozen=True)
class AsymmetricFriction(Effect):
    """Friction whose levels differ by direction of motion (a worn screw, a preloaded guide):

        Fc_pos h(qd) - Fc_neg (1 - h(qd)) + dFv qd (2 h(qd) - 1),    h(qd) = (1 + tanh(qd / eps)) / 2

    Fc_pos, Fc_neg [input unit] the Coulomb levels moving forward and backward, dFv [input unit
    s/rad or s/m] half the difference of the viscous coefficients (the model's own viscous d is
    their mean: Fv_pos = d + dFv, Fv_neg = d - dFv; qd (2h - 1) is |qd| smoothed), linear; eps
    [rad/s or m/s] nonlinear (smoothing). The form of the EMPS benchmark's asymmetric friction
    (Janot, Gautier and Brunot 2019, eq. 12), smoothed; a constant input offset lies in its span
    (Fc_pos - Fc_neg moves both levels alike).
    """

    Fc_pos: float = 0.0
    Fc_neg: float = 0.0
    dFv: float = 0.0
    eps: float = 1e-3
    name: ClassVar[str] = "asymmetric_friction"
    search: ClassVar[Search] = Search("friction", {"eps": SMOOTHING}, extends=("coulomb_friction",))
    plant_kind: ClassVar[int] = 6
    linear: ClassVar[tuple[str, ...]] = ("Fc_pos", "Fc_neg", "dFv")
    positive: ClassVar[tuple[str, ...]] = ("Fc_pos", "Fc_neg")
    nonlinear: ClassVar[tuple[str, ...]] = ("eps",)
    bounds: ClassVar[dict[str, str]] = {"eps": "> 0"}

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        """(Fc_pos + Fc_neg) / (2 eps) from the step, |dFv| from the |qd| term."""
        step = 0.5 * (abs(self.Fc_pos) + abs(self.Fc_neg))
        return (step / self.eps if step else 0.0) + abs(self.dFv), 0.0

    def _columns(self, q, qd, qdd, loads):
        return asymmetric_friction_basis(self._v(qd), self.eps)


@dataclass(frozen=True)
class LoadFriction(Effect):
    """Friction whose Coulomb level grows with the gravity load the joint holds (the tooth and
    bearing forces of a geared joint grow with the torque it transmits):

        (Fc + mu |g(q)|) tanh(qd / eps)

    with g(q) the rigid body's gravity torque on the axis [input unit] (the model's own, at its
    fitted parameters; a plant's, its true one). Fc [input unit] and mu [-] linear; eps [rad/s or
    m/s] nonlinear (smoothing). Physical: mu > 0 (a level that falls with the load is something else).
    """

    Fc: float = 0.0
    mu: float = 0.0
    eps: float = 1e-3
    name: ClassVar[str] = "load_friction"
    search: ClassVar[Search] = Search("friction", {"eps": SMOOTHING}, extends=("coulomb_friction",))
    plant_kind: ClassVar[int] = 10
    linear: ClassVar[tuple[str, ...]] = ("Fc", "mu")
    positive: ClassVar[tuple[str, ...]] = ("mu",)
    nonlinear: ClassVar[tuple[str, ...]] = ("eps",)
    bounds: ClassVar[dict[str, str]] = {"Fc": ">= 0", "eps": "> 0"}
    reads: ClassVar[tuple[str, ...]] = ("gravity",)

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        """(Fc + mu |g|) / eps, |g| at most ``load``."""
        level = abs(self.Fc) + abs(self.mu) * abs(load)
        return (level / self.eps if level else 0.0), 0.0

    def _columns(self, q, qd, qdd, loads):
        return load_friction_basis(self._v(qd), loads.gravity[..., self._i()], self.eps)


FRICTION_KNOTS = (0.0, 0.05, 0.15, 0.35, 0.65, 1.0)  # of v_top: dense near standstill, where curves bend
SMOOTHING = 1e-3  # weight of a curve's roughness penalty, relative to the mean square of its columns


def second_differences(x) -> np.ndarray:
    """The operator (n - 2, n) of second divided differences of values at the sorted points x,
    scaled by the squared mean spacing: the change of slope between neighbouring intervals."""
    x = np.asarray(x, dtype=float)
    n, h = x.size, np.diff(x)
    D = np.zeros((n - 2, n))
    for j in range(n - 2):
        D[j, j], D[j, j + 1], D[j, j + 2] = 1 / h[j], -(1 / h[j] + 1 / h[j + 1]), 1 / h[j + 1]
    return D * float(np.mean(h))


FRICTION_FORMS = ("coulomb_friction", "asymmetric_friction", "stribeck_friction")
"""The friction forms a shape-free friction curve contains (``FrictionCurve.search``)."""


@dataclass(frozen=True)
class FrictionCurve(Effect):
    """A friction curve of no set shape, per direction of motion: piecewise linear in the speed
    through its levels at the speeds ``FRICTION_KNOTS`` x v_top, continued beyond v_top on the
    straight line of its last segment (``hat_basis(extend=True)``),

        h(qd) sum_j p_j hat_j(|qd|) - (1 - h(qd)) sum_j n_j hat_j(|qd|),   h = (1 + tanh(qd / eps)) / 2

    p_j, n_j [input unit] the levels forward and backward at the knots (p0, n0: at standstill, the
    breakaway levels), linear; eps [rad/s or m/s] smoothing and v_top [rad/s or m/s] the speed of
    the last knot, nonlinear. It holds Coulomb, viscous, Stribeck-like, asymmetric and concave
    (square-root-like) friction alike; the diagnosis names it only where no curve of the
    library explains as much. Physical: p0, n0 > 0 (friction opposes the motion it starts).

    Beyond v_top (the data's 99th percentile of speed, where the diagnosis sets it) the curve
    neither holds its level nor bends: within the data a model's viscous term and the curve's slope
    trade against each other freely (together they are what the data fix), and a curve held level
    would leave the viscous term alone to carry on, at whatever slope that trade gave it. Continued
    on its last segment, the curve adds its own slope to the viscous one beyond v_top, so that the
    model's friction continues at the slope the data showed over the top 35 % of their speeds, the
    roughness penalty keeping that segment in line with the ones below it.
    """

    p0: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    p3: float = 0.0
    p4: float = 0.0
    p5: float = 0.0
    n0: float = 0.0
    n1: float = 0.0
    n2: float = 0.0
    n3: float = 0.0
    n4: float = 0.0
    n5: float = 0.0
    eps: float = 1e-3
    v_top: float = 1.0
    name: ClassVar[str] = "friction_curve"
    search: ClassVar[Search] = Search("friction", {"eps": Scaled((0.0025, 0.01, 0.05)), "v_top": Scaled((1.0,))},
                                       extends=FRICTION_FORMS, shape_free=True, fixed=("v_top",))
    no_plant_kind: ClassVar[str] = "is a curve of no set shape the diagnosis fits (a plant takes a tabulated_force)"
    linear: ClassVar[tuple[str, ...]] = ("p0", "p1", "p2", "p3", "p4", "p5", "n0", "n1", "n2", "n3", "n4", "n5")
    positive: ClassVar[tuple[str, ...]] = ("p0", "n0")
    nonlinear: ClassVar[tuple[str, ...]] = ("eps", "v_top")
    bounds: ClassVar[dict[str, str]] = {"eps": "> 0", "v_top": "> 0"}

    @classmethod
    def roughness(cls) -> np.ndarray:
        """Second differences of each direction's levels over the knots (``Effect.roughness``), and
        the levels' common slope: a trend rising alike in both directions is the viscous friction
        the model has on every axis, which takes it unpenalized. Without that row the two trade
        freely (continued on its last segment the curve reproduces b |qd| at all speeds), and the
        minimum-norm fit settled on a curve of hundreds of N m cancelled by a viscous term as large."""
        D = second_differences(FRICTION_KNOTS)
        k = np.asarray(FRICTION_KNOTS) - np.mean(FRICTION_KNOTS)
        trend = np.r_[k, k] / np.linalg.norm(np.r_[k, k])
        return np.vstack([np.block([[D, np.zeros_like(D)], [np.zeros_like(D), D]]), trend])

    def _columns(self, q, qd, qdd, loads):
        v = self._v(qd)
        hats = hat_basis(np.abs(v), np.asarray(FRICTION_KNOTS) * self.v_top, extend=True)
        s = smooth_sign(v, self.eps)[..., None]
        return (*np.moveaxis(0.5 * (1.0 + s) * hats, -1, 0), *np.moveaxis(-0.5 * (1.0 - s) * hats, -1, 0))


POSITION_KNOTS = 9


@dataclass(frozen=True)
class PositionMap(Effect):
    """A force of no set shape over the axis position: a cubic spline over [lo, hi] in
    ``POSITION_KNOTS`` B-spline coefficients (6 equal intervals), held beyond the ends,

        sum_j c_j B_j(q)

    c0 .. c8 [input unit] linear; lo, hi [rad or m] nonlinear (the range the data cover). It holds
    springs of any profile (one-sided, progressive: within an interval a cubic), a drape, an offset
    and its drift; the diagnosis names it only where no effect of the library explains as much.
    """

    c0: float = 0.0
    c1: float = 0.0
    c2: float = 0.0
    c3: float = 0.0
    c4: float = 0.0
    c5: float = 0.0
    c6: float = 0.0
    c7: float = 0.0
    c8: float = 0.0
    lo: float = -1.0
    hi: float = 1.0
    name: ClassVar[str] = "position_map"
    search: ClassVar[Search] = Search("position", {"lo": position_low, "hi": position_high},
                                       extends=("offset", "cable_spring", "cable_drape"), shape_free=True,
                                       fixed=("lo", "hi"))
    no_plant_kind: ClassVar[str] = "is a curve of no set shape the diagnosis fits (a plant takes a tabulated_force)"
    linear: ClassVar[tuple[str, ...]] = tuple(f"c{j}" for j in range(POSITION_KNOTS))
    nonlinear: ClassVar[tuple[str, ...]] = ("lo", "hi")

    def __post_init__(self):
        super().__post_init__()
        if not self.hi > self.lo:
            raise ValueError(f"{self.key}: need lo < hi, got [{self.lo}, {self.hi}]")

    @classmethod
    def roughness(cls) -> np.ndarray:
        """First differences of the B-spline coefficients (``Effect.roughness``: a P-spline): the
        curve held level where the data do not reach, and the slope a gravity term of the rigid body
        explains left to it (the two overlap over the data's range)."""
        return np.diff(np.eye(POSITION_KNOTS), axis=0)

    def _columns(self, q, qd, qdd, loads):
        return tuple(np.moveaxis(spline_basis(self._q(q), self.lo, self.hi, POSITION_KNOTS), -1, 0))


@dataclass(frozen=True)
class Offset(Effect):
    """A constant input on the axis: an amplifier's or a force sensor's bias, a constant load (an
    unbalance the rigid body lacks, a cable's pull). c [input unit], linear, of either sign."""

    c: float = 0.0
    name: ClassVar[str] = "offset"
    search: ClassVar[Search] = Search("offset")
    plant_kind: ClassVar[int] = 7
    linear: ClassVar[tuple[str, ...]] = ("c",)

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        return 0.0, 0.0

    def _columns(self, q, qd, qdd, loads):
        return (np.ones_like(self._v(qd)),)


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
    no_plant_kind: ClassVar[str] = "has internal state (LuGre bristles)"
    nonlinear: ClassVar[tuple[str, ...]] = ("sigma0", "sigma1")
    bounds: ClassVar[dict[str, str]] = {"sigma0": "> 0", "sigma1": ">= 0"}
    plant_only: ClassVar[bool] = True


@dataclass(frozen=True)
class CableSpring(Effect):
    """One-sided cable spring: k * side * width * softplus(side (q - q0) / width).

    k [input unit per rad or m] linear; q0 [rad or m] where the cable starts to tension, width smoothing,
    side (+1: tensions above q0, -1: below) nonlinear.
    """

    k: float = 0.0
    q0: float = 20 * DEG
    width: float = 3 * DEG
    side: float = 1.0
    name: ClassVar[str] = "cable_spring"
    search: ClassVar[Search] = Search("spring", {"q0": angle_quantiles, "width": Scaled((0.01, 0.05), "position"),
                                                 "side": (-1.0, 1.0)})
    plant_kind: ClassVar[int] = 2
    linear: ClassVar[tuple[str, ...]] = ("k",)
    positive: ClassVar[tuple[str, ...]] = ("k",)
    nonlinear: ClassVar[tuple[str, ...]] = ("q0", "width", "side")
    bounds: ClassVar[dict[str, str]] = {"width": "> 0", "side": "+1 or -1"}

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        return 0.0, abs(self.k)

    def _columns(self, q, qd, qdd, loads):
        return (cable_spring_basis(self._q(q), self.q0, self.width, self.side),)


@dataclass(frozen=True)
class CableInertia(Effect):
    """Configuration-dependent inertia of a cable: J(q) = dJ sigmoid((q - q0) / width).

    Adds J(q) qdd + 1/2 J'(q) qd^2 (Euler-Lagrange). dJ [input unit s^2 per rad or m] linear; q0, width [rad or m]
    nonlinear.
    """

    dJ: float = 0.0
    q0: float = 20 * DEG
    width: float = 10 * DEG
    name: ClassVar[str] = "cable_inertia"
    search: ClassVar[Search] = Search("inertia", {"q0": five_angle_quantiles,
                                                  "width": Scaled((0.05, 0.15), "position")})
    no_plant_kind: ClassVar[str] = "adds to the mass matrix (it needs qdd)"
    linear: ClassVar[tuple[str, ...]] = ("dJ",)
    positive: ClassVar[tuple[str, ...]] = ("dJ",)
    nonlinear: ClassVar[tuple[str, ...]] = ("q0", "width")
    bounds: ClassVar[dict[str, str]] = {"width": "> 0"}

    def _columns(self, q, qd, qdd, loads):
        i = self._i()
        return (cable_inertia_basis(q[..., i], qd[..., i], qdd[..., i], self.q0, self.width)[1],)


@dataclass(frozen=True)
class RotorInertia(Effect):
    """Inertia of a motor and gear on the axis that the rigid body lacks (a URDF holds the links
    only): J qdd, J [input unit s^2/rad, or per m] linear (the motor's J_m times the gear ratio
    squared, seen on the joint). Constant and on its own axis alone, unlike a link's inertia, which
    the other axes feel too (model side; a plant's rotor is part of its rigid body).
    """

    J: float = 0.0
    name: ClassVar[str] = "rotor_inertia"
    search: ClassVar[Search] = Search("inertia")
    no_plant_kind: ClassVar[str] = "adds to the mass matrix (a URDF plant's armature)"
    linear: ClassVar[tuple[str, ...]] = ("J",)
    positive: ClassVar[tuple[str, ...]] = ("J",)

    def _columns(self, q, qd, qdd, loads):
        return (qdd[..., self._i()],)


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
    search: ClassVar[Search] = Search("periodic", period="period")
    no_plant_kind: ClassVar[str] = "scales the input (it needs the drive torque)"
    linear: ClassVar[tuple[str, ...]] = ("a_sin", "a_cos")
    nonlinear: ClassVar[tuple[str, ...]] = ("period",)
    bounds: ClassVar[dict[str, str]] = {"period": "> 0"}
    reads: ClassVar[tuple[str, ...]] = ("torque",)

    @classmethod
    def from_amplitude(cls, axis: str, amplitude: float, period: float, phase: float) -> TorqueRipple:
        return cls(axis, amplitude * math.cos(phase), amplitude * math.sin(phase), period)

    def _columns(self, q, qd, qdd, loads):
        base = loads.torque[..., self._i()]
        s, c = periodic_basis(self._q(q), self.period)
        return (-base * s, -base * c)


@dataclass(frozen=True)
class GearHarmonic(Effect):
    """Position-periodic gear force, velocity-dependent amplitude, two harmonics:

        (s1 + s1v |qd| / v_ref) sin x + (c1 + c1v |qd| / v_ref) cos x + s2 sin 2x + c2 cos 2x

    with x = 2 pi q / period. s1, c1, s1v, c1v, s2, c2 [input unit] linear; period [rad or m], v_ref [per s]
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
    search: ClassVar[Search] = Search("periodic", period="period")
    plant_kind: ClassVar[int] = 3
    linear: ClassVar[tuple[str, ...]] = ("s1", "c1", "s1v", "c1v", "s2", "c2")
    nonlinear: ClassVar[tuple[str, ...]] = ("period", "v_ref")
    bounds: ClassVar[dict[str, str]] = {"period": "> 0", "v_ref": "> 0"}

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

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        """Taken at speeds up to 2 v_ref: 2 pi / period times the amplitudes, and the velocity terms / v_ref."""
        first = abs(self.s1) + abs(self.c1) + 2 * (abs(self.s1v) + abs(self.c1v))
        second = 2 * (abs(self.s2) + abs(self.c2))
        return (abs(self.s1v) + abs(self.c1v)) / self.v_ref, 2 * math.pi * (first + second) / self.period

    def _columns(self, q, qd, qdd, loads):
        return gear_harmonic_basis(self._q(q), self._v(qd), self.period, self.v_ref)


@dataclass(frozen=True)
class CableDrape(Effect):
    """Weight of a hanging cable on an axis: s sin q + c cos q [input unit] (= A sin(q + phi)). s, c linear.
    Revolute axes only.

    On the propeller it lies in the span of the rigid model's gravity terms, so a rigid-model fit
    absorbs it (with shifted mass parameters); on the roll axis it does not.
    """

    s: float = 0.0
    c: float = 0.0
    name: ClassVar[str] = "cable_drape"
    search: ClassVar[Search] = Search("gravity")
    plant_kind: ClassVar[int] = 4
    linear: ClassVar[tuple[str, ...]] = ("s", "c")
    revolute_only: ClassVar[bool] = True

    @classmethod
    def from_amplitude(cls, axis: str, amplitude: float, phase: float) -> CableDrape:
        return cls(axis, amplitude * math.cos(phase), amplitude * math.sin(phase))

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        return 0.0, math.hypot(self.s, self.c)

    def _columns(self, q, qd, qdd, loads):
        return drape_basis(self._q(q))


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
    no_plant_kind: ClassVar[str] = "adds states (a motor inertia behind a spring)"
    nonlinear: ClassVar[tuple[str, ...]] = ("k", "c", "Jm")
    bounds: ClassVar[dict[str, str]] = {"k": "> 0", "c": ">= 0", "Jm": "> 0"}
    plant_only: ClassVar[bool] = True

    def __post_init__(self):
        super().__post_init__()
        if self.k <= 0 or self.Jm <= 0 or self.c < 0:
            raise ValueError(f"{self.key}: need k > 0, Jm > 0, c >= 0 (got k={self.k}, Jm={self.Jm}, c={self.c})")


@dataclass(frozen=True)
class TabulatedForce(Effect):
    """A force curve of any shape over the axis's velocity or position (plant only).

    ``variable`` "velocity" [rad/s or m/s] or "position" [rad or m]; ``values`` [input unit] on a uniform grid of
    ``len(values)`` points (2 to 1024) over [lo, hi], linear in between and held constant outside.
    It is no model of a physical effect: it makes plants whose hidden effects
    follow none of the library's formulas (a differently shaped friction curve, a spring that
    engages smoothly), the way a real machine does, to test the diagnosis on them.
    """

    variable: str = "velocity"
    lo: float = -1.0
    hi: float = 1.0
    values: tuple[float, ...] = (0.0, 0.0)
    name: ClassVar[str] = "tabulated_force"
    plant_kind: ClassVar[int] = 5
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

    def plant_parameters(self) -> tuple[float, ...]:
        """(1 over position or 0 over velocity, lo, hi, values...) (``physics.plant_effects``)."""
        return (float(self.variable == "position"), float(self.lo), float(self.hi), *map(float, self.values))

    def slopes(self, load: float = 0.0) -> tuple[float, float]:
        """The steepest segment of the curve, on its variable."""
        values = np.asarray(self.values, dtype=float)
        slope = float(np.max(np.abs(np.diff(values)))) / ((self.hi - self.lo) / (values.size - 1))
        return (0.0, slope) if self.variable == "position" else (slope, 0.0)

    def force(self, x) -> np.ndarray:
        """The curve [input unit] at the values x of its variable (the plant's own formula)."""
        values = np.asarray(self.values, dtype=float)
        return np.array([table_lookup(float(v), self.lo, self.hi, values) for v in np.ravel(x)]).reshape(np.shape(x))


EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        ViscousFriction, CoulombFriction, StribeckFriction, AsymmetricFriction, LoadFriction, FrictionCurve, Offset,
        Stiction, CableSpring, CableInertia, RotorInertia, GearHarmonic, TorqueRipple, CableDrape, PositionMap,
        DrivetrainFlexibility, TabulatedForce,
    )
}
"""The library by name, in the order the diagnosis tries the effects that declare a ``search``."""


def parse_key(key: str) -> tuple[str, str]:
    """(name, axis) of a ``name@axis`` label."""
    name, sep, axis = str(key).partition("@")
    if not sep or not name or not axis:
        raise ValueError(f"effect {key!r}: write it as NAME@AXIS, e.g. coulomb_friction@roll")
    return name, axis


def make_effect(key: str, own: Sequence[type[Effect]] = (), **params) -> Effect:
    """An effect of the library, or of the classes ``own`` (a machine's own effects), from its
    ``name@axis`` label, unbound, e.g. ``make_effect("coulomb_friction@roll", Fc=0.05)``
    (``System.effect`` also knows the machine's own effects and binds it)."""
    name, axis = parse_key(key)
    classes = {**EFFECTS, **{cls.name: cls for cls in own}}
    if name not in classes:
        raise ValueError(f"unknown effect {name!r}; known: {', '.join(sorted(classes))}")
    return classes[name](axis=axis, **params)


def effect_record(effect: Effect) -> dict:
    """A JSON-ready description of an effect: its ``name@axis`` label and every parameter."""
    params = {f.name: getattr(effect, f.name) for f in dataclasses.fields(effect) if f.name not in ("axis", "index")}
    return {"effect": effect.key, **{k: list(v) if isinstance(v, tuple) else v for k, v in params.items()}}


def effect_from_record(record: dict, system=None, own: Sequence[type[Effect]] = ()) -> Effect:
    """Inverse of ``effect_record``; with a ``system`` (``systems.System``) bound to its axes and
    with the machine's own effects known, else unbound, knowing the classes ``own``."""
    params = {k: tuple(v) if isinstance(v, list) else v for k, v in record.items() if k != "effect"}
    if system is not None:
        return system.effect(record["effect"], **params)
    return make_effect(record["effect"], own, **params)


def check_unique(effects) -> None:
    """Refuse a list that names the same ``name@axis`` twice."""
    keys = [e.key for e in effects]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ValueError(f"effect listed twice: {dup}")
