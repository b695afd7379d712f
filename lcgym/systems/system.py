"""``System``: everything lcgym knows about one machine, in one object.

A machine is its axes (name, revolute or prismatic, the unit of its actuator), its rigid-body
model and, for the built-in benchmark machines, its plant. The rigid-body model is written in
the parameters p = [zeta_l, zeta_n]: the model is linear in zeta_l (``n_linear`` of them: masses,
inertias, friction coefficients; Lemma 1 of paper 000) and may be nonlinear in the rest
(the IX's centres of mass). What the learners and the diagnosis use of it:

* ``regressor(zeta_n, q, qd, qdd) -> (T, n_axes, n_linear)``, numpy: u = regressor @ zeta_l;
* ``inverse_dynamics(p, q, qd, qdd) -> (T, n_axes)``, numpy or torch (autograd in p, the PGNN);
* ``mass_matrix(p, q) -> (T, n_axes, n_axes)``, numpy or torch;
* ``positive``: the parameters that are positive physically (masses, inertias, damping);
* ``parameters``: what makes the parameter objects (with ``to_vector()``): called without arguments
  it gives the nominal ones; a class with ``from_vector(p)`` (the IX's ``IXParameters``) or a
  function of the vector p (machines given by their regressor: ``ParameterVector``; see
  ``params_from_vector``).

Machines given only by their regressor (a URDF, a user's Python class; ``System.from_regressor``,
whose user-side regressor is the simpler ``regressor(q, qd, qdd)``) are linear in all their
parameters: inverse dynamics and mass matrix then follow from the
regressor (M e_j = X(q, 0, e_j) p - X(q, 0, 0) p), with one implementation for all.

Units: SI on every axis (rad or m, rad/s or m/s, rad/s^2 or m/s^2); the actuator input in the
axis's ``input_unit`` (N m or N; the IX's amplifier input in V).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from .bench import Bench, BenchFactory

DEG = math.pi / 180.0
KINDS = ("revolute", "prismatic")


class SimulationDiverged(RuntimeError):
    """A simulated plant left its safe range (unstable gains, huge feedforward, ...)."""


REGRESSOR_MIN_ROWS = 1000
"""Kinematics of fewer samples (a training batch) are not kept by a machine's regressor memo
(``physics.memo.ArrayMemo``): hashing them costs about as much as the regressor."""


@dataclass(frozen=True)
class Axis:
    """One axis (joint) of a machine.

    kind: "revolute" (rad) or "prismatic" (m); input_unit: its actuator's unit (default N m for
    a revolute joint, N for a prismatic one). speed_scale [rad/s or m/s] and position_scale [rad
    or m]: the scales of the diagnosis's search grids on this axis (friction smoothing, spring
    widths, the shortest period searched); None: taken from the data (the 99th percentile of
    |velocity|, the range of the position).
    """

    name: str
    kind: str = "revolute"
    input_unit: str | None = None
    speed_scale: float | None = None
    position_scale: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or any(c in self.name for c in "@, \t\n"):
            raise ValueError(f"axis name must be a non-empty string without '@', ',' or spaces, got {self.name!r}")
        if self.kind not in KINDS:
            raise ValueError(f"axis {self.name}: kind must be 'revolute' or 'prismatic', got {self.kind!r}")
        if self.input_unit is None:
            object.__setattr__(self, "input_unit", "N m" if self.kind == "revolute" else "N")
        for what in ("speed_scale", "position_scale"):
            v = getattr(self, what)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise ValueError(f"axis {self.name}: {what} must be > 0, got {v}")

    @property
    def revolute(self) -> bool:
        return self.kind == "revolute"

    @property
    def unit(self) -> str:
        """SI unit of the position: rad or m."""
        return "rad" if self.revolute else "m"

    @property
    def display(self) -> tuple[float, str]:
        """(factor, unit) that turn an SI position into the unit reports print: deg or mm."""
        return (180.0 / math.pi, "deg") if self.revolute else (1000.0, "mm")

    @property
    def min_travel(self) -> float:
        """An axis whose reference spans less stands still for the diagnosis: 1 deg, or 1 mm."""
        return DEG if self.revolute else 1e-3


@dataclass(frozen=True)
class ParameterVector:
    """Named parameters of a machine given by its regressor: ``names`` and ``values`` (same order)."""

    names: tuple[str, ...]
    values: tuple[float, ...]

    def to_vector(self) -> np.ndarray:
        return np.asarray(self.values, dtype=float)

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.names, self.values, strict=True))


def _as_axes(axes) -> tuple[Axis, ...]:
    out = tuple(a if isinstance(a, Axis) else Axis(str(a)) for a in axes)
    names = [a.name for a in out]
    if not out:
        raise ValueError("a machine needs at least one axis")
    if len(set(names)) < len(names):
        raise ValueError(f"axis names must be unique, got {names}")
    return out


@dataclass(frozen=True)
class DiagnosisSettings:
    """What the diagnosis needs of a machine beyond its model (``System.diagnosis``).

    noise_rms [input unit]: the RMS below which the diagnosis does not count an improvement as
    real (None: 1 % of each axis's low-passed input RMS). candidates: its candidate effects beyond
    the library's (``physics.candidates.Candidate``: the IX's guidance friction, the FlexArm's
    payload, a user's, ``diagnose.register_effect``). candidate_names: the effect names the
    diagnosis tries (None: every one that applies).
    """

    noise_rms: float | None = None
    candidates: tuple = ()
    candidate_names: tuple[str, ...] | None = None

    def __post_init__(self):
        object.__setattr__(self, "candidates", tuple(self.candidates))
        if self.candidate_names is not None:
            object.__setattr__(self, "candidate_names", tuple(self.candidate_names))
        if self.noise_rms is not None and not (np.isfinite(self.noise_rms) and self.noise_rms >= 0):
            raise ValueError(f"DiagnosisSettings: noise_rms must be >= 0, got {self.noise_rms}")


@dataclass(frozen=True)
class NonlinearStructure:
    """How a machine's regressor depends on zeta_n, where it says more than "some function of it"
    (``System.nonlinear``; the variable projection then evaluates less): ``quadratic``, its entries
    are polynomials of degree <= 2 in zeta_n (the IX's centres of mass: an exact quadratic
    expansion); ``columns``, the linear parameters whose regressor columns depend on zeta_n at all
    (the IX: the two masses, which multiply the centres of mass in eqs. 4-7), evaluated through
    ``regressor(zeta_n, q, qd, qdd, columns=...)``; None: all."""

    quadratic: bool = False
    columns: tuple[int, ...] | None = None

    def __post_init__(self):
        if self.columns is not None:
            object.__setattr__(self, "columns", tuple(int(i) for i in self.columns))
            if not self.quadratic:
                raise ValueError(f"nonlinear columns {self.columns} are for a regressor quadratic in zeta_n")


class NominalStructure(Protocol):
    """A nominal feedforward structure learning methods may start from (``System.nominal``; paper
    002's Basic on the FlexArm, ``systems/flexarm/nominal.py``)."""

    def compute(self, q_lr: np.ndarray, fs: float) -> dict:
        """Its parts along a reference (T, n_axes) [rad]: ``tau_ff`` (the feedforward) and
        ``reference_offset`` among them."""


class Caching(Protocol):
    """``caching(size=None)``: a context manager inside which the machine keeps its last ``size``
    regressors (``System.caching``)."""

    def __call__(self, size: int | None = None) -> AbstractContextManager: ...


@dataclass(frozen=True, eq=False)
class RigidBodyModel:
    """A machine's rigid-body model (module docstring), the core of its ``System``.

    name; axes; param_names and ``parameters`` (what makes the parameter objects); ``regressor``;
    ``n_linear``, the parameters the model is linear in (None: all); ``inverse_dynamics`` and
    ``mass_matrix`` (None: from the regressor, for a machine linear in all its parameters);
    ``positive``, the indices of the parameters that are positive physically; ``fs`` [Hz], the
    machine's sample rate (None: the data's); ``advance`` [samples], how far ahead of a sample the
    feedforward's kinematics are evaluated (computation delay plus half the hold interval of the
    machine's controller); ``joint_axes``, ``() -> (n_axes, 3)``, the unit axis of each joint in
    the base frame at the machine's reference pose (the RBF expert's motion influence; None: all
    mutually perpendicular).
    """

    name: str
    axes: tuple[Axis, ...]
    param_names: tuple[str, ...]
    regressor: Callable
    parameters: type | Callable
    n_linear: int | None = None
    inverse_dynamics: Callable | None = None
    mass_matrix: Callable | None = None
    positive: tuple[int, ...] = ()
    fs: float | None = None
    advance: float = 0.5
    joint_axes: Callable | None = None

    def __post_init__(self):
        object.__setattr__(self, "axes", _as_axes(self.axes))
        object.__setattr__(self, "param_names", tuple(self.param_names))
        if self.n_linear is None:
            object.__setattr__(self, "n_linear", len(self.param_names))
        if not 0 < self.n_linear <= len(self.param_names):
            raise ValueError(f"{self.name}: n_linear must be in 1..{len(self.param_names)}, got {self.n_linear}")
        if self.inverse_dynamics is None:
            if not self.fully_linear:
                raise ValueError(f"{self.name}: a machine with nonlinear parameters must give its inverse_dynamics")
            object.__setattr__(self, "inverse_dynamics", self._linear_inverse_dynamics)
        if self.mass_matrix is None:
            if not self.fully_linear:
                raise ValueError(f"{self.name}: a machine with nonlinear parameters must give its mass_matrix")
            object.__setattr__(self, "mass_matrix", self._linear_mass_matrix)
        bad = [i for i in self.positive if not 0 <= i < len(self.param_names)]
        if bad:
            raise ValueError(f"{self.name}: positive parameter indices {bad} out of range")
        if self.fs is not None and not (np.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f"{self.name}: fs must be > 0, got {self.fs}")

    # ------------------------------------------------------------------ axes and units
    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @property
    def n_axes(self) -> int:
        return len(self.axes)

    @property
    def input_units(self) -> tuple[str, ...]:
        return tuple(a.input_unit for a in self.axes)

    @property
    def input_unit(self) -> str:
        """The actuator unit, or the axes' units joined by '/' when they differ (N m / N)."""
        units = list(dict.fromkeys(self.input_units))
        return units[0] if len(units) == 1 else " / ".join(units)

    def axis(self, name: str) -> Axis:
        for a in self.axes:
            if a.name == name:
                return a
        raise ValueError(f"{self.name} has no axis {name!r}; its axes are {', '.join(self.axis_names)}")

    # ------------------------------------------------------------------ parameters
    @property
    def fully_linear(self) -> bool:
        """True when every parameter is linear (no zeta_n): then u = regressor @ p exactly."""
        return self.n_linear == len(self.param_names)

    def nominal_params(self):
        """The nominal parameters (the machine's description: CAD, URDF, Table I)."""
        return self.parameters()

    def params_from_vector(self, p):
        return self.parameters.from_vector(p) if hasattr(self.parameters, "from_vector") else self.parameters(p)

    # ------------------------------------------------------------------ linear machines
    def _linear_inverse_dynamics(self, p, q, qd, qdd):
        """u = X(q, qd, qdd) p, numpy or torch (differentiable in p)."""
        X = self.regressor(np.zeros(0), *(_numpy(x) for x in (q, qd, qdd)))
        return _contract(X, p)

    def _linear_mass_matrix(self, p, q):
        """M(q) from the regressor: column j = X(q, 0, e_j) p - X(q, 0, 0) p, (T, A, A)."""
        q = np.atleast_2d(_numpy(q))
        T, A = q.shape
        zero = np.zeros_like(q)
        base = self.regressor(np.zeros(0), q, zero, zero)
        basis = np.empty((T, A, A, base.shape[-1]))
        for j in range(A):
            e = zero.copy()
            e[:, j] = 1.0
            basis[:, :, j, :] = self.regressor(np.zeros(0), q, zero, e) - base
        return _contract(basis, p)

    @classmethod
    def from_regressor(cls, name: str, axes: Sequence, parameters: Mapping[str, float], regressor: Callable,
                       positive: Sequence[str] = (), **kwargs) -> System:
        """A machine linear in its parameters, given by ``regressor(q, qd, qdd) -> (T, n_axes,
        n_params)`` (numpy; u = regressor @ p) and its nominal ``parameters`` {name: value}, in the
        regressor's column order. ``positive``: names of the parameters that stay positive.
        Other keyword arguments are ``System`` fields (fs, advance, noise_rms, description, ...)."""
        names = tuple(parameters)
        values = tuple(float(parameters[n]) for n in names)
        axes_names = [getattr(a, "name", a) for a in axes]
        unknown = [n for n in positive if n not in names]
        if unknown:
            raise ValueError(f"{name}: positive names {unknown} are not parameters ({', '.join(names)})")

        def vector(p=None) -> ParameterVector:
            v = values if p is None else tuple(float(x) for x in np.asarray(p, dtype=float).ravel())
            if len(v) != len(names):
                raise ValueError(f"{name}: parameter vector must have {len(names)} values, got {len(v)}")
            return ParameterVector(names, v)

        def full(zeta_n, q, qd, qdd):
            try:
                X = np.asarray(regressor(q, qd, qdd), dtype=float)
            except Exception as exc:  # a user's function: say whose it is, in one line
                raise ValueError(f"{name}: the regressor raised {type(exc).__name__}: {exc}") from exc
            T, A = np.shape(q)[0], len(axes)
            if X.shape != (T, A, len(names)):
                raise ValueError(f"{name}: the regressor returned shape {X.shape}, expected ({T}, {A}, {len(names)})")
            bad = np.argwhere(~np.isfinite(X))
            if len(bad):
                k, a, j = bad[0]
                raise ValueError(f"{name}: the regressor returned {X[k, a, j]} at sample {k}, axis {axes_names[a]}, "
                                 f"parameter {names[j]} (q={np.asarray(q)[k].tolist()})")
            return X

        return cls(name=name, axes=tuple(axes), param_names=names, regressor=full, parameters=vector,
                   positive=tuple(names.index(n) for n in positive), **kwargs)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, axes={list(self.axis_names)}, {len(self.param_names)} parameters)"


@dataclass(frozen=True, eq=False, repr=False)
class System(RigidBodyModel):
    """One machine: its rigid-body model (``RigidBodyModel``) with typed attachments.

    description: one line for listings. model: the physical-model class (``physics.model.
    PhysicalModel`` or a subclass), built with ``physical_model`` / ``diagnosis_model``. effects:
    effect classes of this machine beyond ``physics.effects`` (their formulas use its geometry).
    model_effects: effects its physical model knows beyond its rigid body (``name@axis`` keys; a
    machine file's ``[[model]]`` tables), declared without values: ``physical_model`` and
    ``diagnosis_model`` carry them, and a fit finds their parameters, the coefficients by least
    squares with the rigid body, the shapes on the diagnosis's grids (``physics.shapes``). Every
    method that starts from the physical model sees them. nonlinear: how the regressor depends on
    zeta_n (``NonlinearStructure``). diagnosis: what the diagnosis needs beyond the model
    (``DiagnosisSettings``: its noise floor and candidate effects). settings: each method's table of
    settings on this machine, keyed by method id (a machine file's ``[benchmark.<method>]``); a
    method reads its table into a dataclass it declares, which checks the keys
    (``methods.protocol.machine_settings``: ``methods.rl.RLMachineSettings``,
    ``methods.pgnn.method.PGNNProtocol``). caching: ``Caching``, inside which the machine keeps its
    last regressors (a diagnosis evaluates the model, its effects and its refits on the same
    kinematics many times; a benchmark cell its bases on each reference); None: nothing is kept.
    bench: the benchmark machine's ``bench.BenchFactory`` (``make_bench`` makes a bench, which holds
    the plant, the reference sets and what the benchmark scores, ``systems/bench.py``; and the
    machine's Gymnasium envs); None: a machine without a plant. nominal: a nominal feedforward
    structure learning methods may start from (``NominalStructure``: paper 002's Basic on the
    FlexArm; None: they start from the fitted physical model). What a learning method may ask of the
    machine's loop, its plant offers (``systems.plant.Plant.learning_law``).
    """

    description: str = ""
    model: type | None = None
    effects: tuple[type, ...] = ()
    model_effects: tuple[str, ...] = ()
    nonlinear: NonlinearStructure = field(default_factory=NonlinearStructure)
    diagnosis: DiagnosisSettings = field(default_factory=DiagnosisSettings)
    settings: Mapping[str, Mapping] = field(default_factory=dict)
    caching: Caching | None = None
    bench: BenchFactory | None = None
    nominal: NominalStructure | None = None

    def __post_init__(self):
        super().__post_init__()
        columns = self.nonlinear.columns
        if columns is not None and any(not 0 <= i < self.n_linear for i in columns):
            raise ValueError(f"{self.name}: nonlinear columns must be indices of linear parameters (0..{self.n_linear - 1}), "
                             f"got {columns}")
        object.__setattr__(self, "settings", {k: dict(v) for k, v in self.settings.items()})
        object.__setattr__(self, "model_effects", tuple(self.model_effects))
        twice = sorted({k for k in self.model_effects if self.model_effects.count(k) > 1})
        if twice:
            raise ValueError(f"{self.name}: model effect {twice[0]} listed twice")
        if self.model_effects:
            from ..physics.model import PhysicalModel
            from ..physics.shapes import model_candidate

            for key in self.model_effects:  # a ValueError says why its model cannot carry it
                model_candidate(self, key, (self.model or PhysicalModel).built_in)

    @property
    def env_id(self) -> str | None:
        """The machine's Gymnasium id (its newest version's, the last), or None (a machine without a plant)."""
        return None if self.bench is None else next(reversed(self.bench.envs), None)

    def make_bench(self, version: str | None = None) -> Bench:
        """A fresh bench of this machine with the plant of ``version`` (None: the newest); a
        machine without a plant cannot be benchmarked (``systems.resolve`` gives a URDF one)."""
        if self.bench is None:
            raise ValueError(f"machine {self.name} has no plant, so the benchmark cannot run on it")
        return self.bench(self, version)

    # ------------------------------------------------------------------ effects
    def effect_classes(self) -> dict[str, type]:
        """Every effect that can act on this machine by name: the library's and its own."""
        from ..physics.effects import EFFECTS

        return {**EFFECTS, **{e.name: e for e in self.effects}}

    def effect(self, key, **params):
        """An effect on this machine, bound to its axis: a ``name@axis`` label (with its parameters)
        or an Effect object (checked and bound)."""
        from ..physics.effects import Effect, parse_key

        if isinstance(key, Effect):
            effect = key
        else:
            name, axis = parse_key(key)
            classes = self.effect_classes()
            if name not in classes:
                raise ValueError(f"unknown effect {name!r} on {self.name}; known: {', '.join(sorted(classes))}")
            effect = classes[name](axis=axis, **params)
        if effect.axis not in self.axis_names:
            raise ValueError(f"{effect.key}: {self.name} has no axis {effect.axis!r}; choose one of "
                             f"{', '.join(self.axis_names)}")
        own = self.effect_classes().get(effect.name)
        if own is not None and not isinstance(effect, own):
            raise ValueError(f"{effect.key}: {type(effect).__name__} is not {self.name}'s {effect.name}")
        if not effect.applies_to(self.axis(effect.axis)):
            raise ValueError(f"{effect.key}: {effect.name} does not apply to a {self.axis(effect.axis).kind} axis")
        return effect.bound(self.axis_names)

    # ------------------------------------------------------------------ models
    def physical_model(self, **kwargs):
        """The machine's physical model (unfitted), ``self.model(system=self, **kwargs)``, with its
        ``model_effects`` (their parameters found by its fit), fitted on the kinematics its class
        names (``PhysicalModel.fitted_on``, unless ``kwargs`` give ``positions``): the motion the
        machine made, as the diagnosis fits its model, so that an effect the diagnosis names and a
        machine file's ``[[model]]`` table then declares is found by one estimator
        (``physics.shapes``) from the same kinematics."""
        model = self._model_class()
        return self._with_model_effects(model(system=self, **{"positions": model.fitted_on, **kwargs}))

    def diagnosis_model(self, fs: float):
        """The model ``lcgym diagnose`` starts from (``PhysicalModel.for_diagnosis``), with the
        machine's ``model_effects``."""
        return self._with_model_effects(self._model_class().for_diagnosis(self, fs))

    def _with_model_effects(self, model):
        """``model`` with the machine's ``model_effects`` added, their shapes to be found by its fit
        (``PhysicalModel.search_shapes``)."""
        if not self.model_effects:
            return model
        have = {e.key for e in model.effects}
        again = [k for k in self.model_effects if k in have]
        if again:
            raise ValueError(f"{again[0]}: the model given has it already, and it is one of {self.name}'s model effects")
        return dataclasses.replace(model, effects=(*model.effects, *(self.effect(k) for k in self.model_effects)),
                                   search_shapes=(*model.search_shapes, *self.model_effects))

    def _model_class(self) -> type:
        if self.model is not None:
            return self.model
        from ..physics.model import PhysicalModel

        return PhysicalModel

def _numpy(x) -> np.ndarray:
    return x.detach().double().numpy() if hasattr(x, "detach") else np.asarray(x, dtype=float)


def _contract(X, p):
    """X (..., k) @ p (k,) in p's array type (a torch p gives a torch result, differentiable in p)."""
    if hasattr(p, "detach"):
        import torch

        X = np.ascontiguousarray(X)
        # a cached regressor is read-only: torch gets a copy of it, never a view it could write to
        return (torch.as_tensor(X, dtype=p.dtype) if X.flags.writeable else torch.tensor(X, dtype=p.dtype)) @ p
    return np.asarray(X) @ np.asarray(p, dtype=float)
