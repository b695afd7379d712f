"""The method contract: ``Controller``, the abstract base class every method in the leaderboard
implements, and the driver that builds and runs one.

``Controller`` declares the whole contract with its defaults: ``feedforward(reference)`` (abstract),
``fit(trials)``, ``learn(plant, reference)``, ``reference_offset`` and ``nn_contribution``, the
class attributes the runner reads before it builds one (``systems``, ``base``, ``uses_plant``,
``learns_once``, ``learns_on_scored_references``, ``relative_cost``) and what it reads after
(``system``, ``cost_``, ``note_``). A constructor may take the keywords ``system`` (the machine,
scikit-learn style: stored as given and resolved in ``fit``, ``given_system``), ``budget`` (the
fraction of its full learning budget, lowered by ``lcgym bench --quick``) and ``base`` (the
feedforward a learner builds on, ``METHOD@BASE``, ``bases``).

A user's class is named on the command line as ``module:Class`` (``load_method``); one that does
not subclass ``Controller`` but has ``fit`` and ``feedforward`` is wrapped once, where it is
loaded (``UserMethod``). ``build_method`` builds a method for a machine, and ``apply`` runs the
contract on a list of references; ``evaluate`` fits a method and scores it on a bench's reference
sets (fit, apply, run, tables), the same way for the benchmark and ``simulate``.
"""

from __future__ import annotations

import dataclasses
import inspect
import time
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import ClassVar, Literal

import numpy as np
import pandas as pd

from .. import systems
from ..envs.actions import short_repr
from ..systems.bench import Bench
from ..user_code import import_user_module

DEFAULT_BASE = "physical"
BASES = ("physical", "basic")


def split_spec(spec: str) -> tuple[str, str | None]:
    """("ilc", "basic") of "ilc@basic"; (spec, None) without "@"; a ValueError for an empty part or an
    unknown base."""
    method, sep, base = spec.rpartition("@")
    if not sep:
        return spec, None
    if not method or not base:
        raise ValueError(f"method {spec!r}: write METHOD@BASE, e.g. ilc@basic (bases: {', '.join(BASES)})")
    if base not in BASES:
        raise ValueError(f"method {spec!r}: unknown base {base!r}; bases: {', '.join(BASES)}")
    return method, base


def display_name(method: str, base: str | None) -> str:
    """The results' name of ``method`` on ``base``: the id alone on the default base."""
    return method if base in (None, DEFAULT_BASE) else f"{method}@{base}"


@dataclass
class Cost:
    """What a method used to learn: closed-loop plant trials and env steps of its own, and the
    wall time [s] of learning done earlier and reused from a cache (the results add it to the
    time they measure)."""

    plant_trials: int = 0
    env_steps: int = 0
    cached_seconds: float = 0.0


class Controller(ABC):
    """The contract every method implements, in the style of stable-baselines3's ``BaseAlgorithm``:
    ``feedforward`` is abstract; everything else has its default here, so that the runner and
    ``simulate`` read it without asking whether it exists.

    What the runner reads from the class, before it builds one: ``name``, ``systems``, ``base``,
    ``uses_plant``, ``learns_once``, ``learns_on_scored_references`` and ``relative_cost``. What it
    reads from a built one: ``system`` (the machine it was handed), and after ``fit`` and ``learn``
    the learned ``cost_`` and ``note_``.
    """

    name: ClassVar[str] = "controller"
    """The method's id in ``CONTROLLERS`` (a user's class: its ``module:Class`` names it in the results)."""
    systems: ClassVar[tuple[str, ...] | None] = None
    """The machines ("flexarm", not a version) it runs on; None: every machine."""
    base: ClassVar[str] = ""
    """A fixed base it builds on (``bases``; "" none) for a class without a ``base`` keyword."""
    uses_plant: ClassVar[bool] = False
    """Whether it learns on the plant: the runner calls ``learn(plant, reference)`` before the
    ``feedforward`` of every evaluation reference."""
    learns_once: ClassVar[bool] = False
    """Whether its ``learn`` runs the plant on its first call only (the PGNN records its training
    data): ``simulate``, which learns once, runs it too."""
    learns_on_scored_references: ClassVar[bool] = False
    """Whether its ``learn`` runs the plant on each evaluation reference itself before it is scored
    (ILC): the leaderboard marks its rows as learned on the references they score."""
    relative_cost: ClassVar[float] = 1.0
    """About how long a quick cell of it takes [s] (``docs/speed.md``): the runner starts the
    costlier cells first, so that its parallel workers end together. It orders, nothing else."""
    system = None
    """The machine it was handed (a ``System`` or a spec for ``systems.get``; ``given_system``)."""
    note_: str = ""
    """What it says of its cell after learning (the results' ``note``)."""

    @property
    def cost_(self) -> Cost:
        """What it used to learn beyond the shared training data (``Cost``; nothing until it says)."""
        return self.__dict__.setdefault("_cost", Cost())

    @cost_.setter
    def cost_(self, value: Cost) -> None:
        self.__dict__["_cost"] = value

    def fit(self, trials: Sequence) -> Controller:
        """Learn offline from measured training trials (by default: nothing to learn)."""
        return self

    def learn(self, plant, reference) -> Controller:
        """Learn by running ``plant`` on ``reference`` (a method with ``uses_plant``)."""
        return self

    @abstractmethod
    def feedforward(self, reference) -> np.ndarray:
        """The feedforward (T, n_axes) for ``reference``, in the machine's input units [V, N m, N]."""

    def reference_offset(self, reference) -> np.ndarray | None:
        """An offset (T, n_axes) [rad, load side] added to the reference the feedback tracks, on a
        machine with that channel (the FlexArm's motor reference); None: none."""
        return None

    def nn_contribution(self, reference) -> np.ndarray | None:
        """A neural network's part (T, n_axes) of the feedforward (the results' ``nn_rms``); None:
        the method has no network."""
        return None


class UserMethod(Controller):
    """A user's class that does not subclass ``Controller``, wrapped once where it is loaded
    (``load_method``): the wrapper class carries the user's class attributes (or the defaults),
    builds the user's object with the constructor's own arguments, and forwards the protocol to it.
    The one place that asks a user's object what it has."""

    wrapped: ClassVar[type]

    def __init__(self, **kwargs):
        self.inner = self.wrapped(**kwargs)

    @property
    def system(self):
        return getattr(self.inner, "system", None)

    @property
    def cost_(self) -> Cost:
        return getattr(self.inner, "cost_", None) or Cost()

    @property
    def note_(self) -> str:
        return getattr(self.inner, "note_", "")

    def fit(self, trials: Sequence) -> UserMethod:
        self.inner.fit(trials)
        return self

    def learn(self, plant, reference) -> UserMethod:
        if callable(getattr(self.inner, "learn", None)):
            self.inner.learn(plant, reference)
        return self

    def feedforward(self, reference) -> np.ndarray:
        return self.inner.feedforward(reference)

    def reference_offset(self, reference) -> np.ndarray | None:
        offset = getattr(self.inner, "reference_offset", None)
        return offset(reference) if callable(offset) else None

    def nn_contribution(self, reference) -> np.ndarray | None:
        part = getattr(self.inner, "nn_contribution", None)
        return part(reference) if callable(part) else None


@cache
def _wrapped(cls: type) -> type[Controller]:
    """``cls`` as a ``Controller``: itself where it is one, else a ``UserMethod`` class of its name,
    class attributes and constructor signature."""
    if issubclass(cls, Controller):
        return cls
    declared = ("name", "systems", "base", "uses_plant", "learns_once", "learns_on_scored_references", "relative_cost")
    attributes = {k: getattr(cls, k) for k in declared if hasattr(cls, k)}
    try:
        signature = inspect.signature(cls)
    except (TypeError, ValueError):  # a signature Python cannot read: built without arguments
        signature = inspect.Signature()
    return type(cls.__name__, (UserMethod,), {**attributes, "wrapped": cls, "__signature__": signature,
                                              "__module__": cls.__module__, "__qualname__": cls.__qualname__})


def load_method(spec: str, registry: dict[str, type]) -> type[Controller]:
    """A controller class from a method id of ``registry`` or from ``module:Class``, either with an
    optional ``@BASE`` (``bases.split_spec``; a class that takes no ``base`` is refused one). A
    user's class that is no ``Controller`` comes wrapped (``UserMethod``)."""
    spec, base = split_spec(spec)
    cls = _wrapped(_load_class(spec, registry))
    if base is not None and not takes_keyword(cls, "base"):
        raise ValueError(f"method {spec!r} builds on no base: write it without @{base} (the learning methods take "
                         f"one: {', '.join(sorted(n for n, c in registry.items() if takes_keyword(c, 'base')))})")
    return cls


def _load_class(spec: str, registry: dict[str, type]) -> type:
    if spec in registry:
        return registry[spec]
    module_name, sep, class_name = spec.partition(":")
    if not sep or not module_name or not class_name:
        raise ValueError(f"unknown method {spec!r}: use one of {', '.join(sorted(registry))} or module:Class")
    try:
        module = import_user_module(module_name)
    except ImportError as exc:
        raise ValueError(f"method {spec!r}: cannot import module {module_name!r} ({exc})") from None
    cls = getattr(module, class_name, None)
    if cls is None:
        raise ValueError(f"method {spec!r}: module {module_name!r} has no {class_name!r}")
    missing = [m for m in ("fit", "feedforward") if not callable(getattr(cls, m, None))]
    if missing:
        raise ValueError(f"method {spec!r}: {class_name} lacks {', '.join(missing)} (see lcgym.methods.protocol)")
    return cls


def given_system(method: Controller, alternative: str = "") -> systems.System:
    """The machine ``method`` was handed (its ``system``: a ``System`` or a spec for ``systems.get``),
    or a ValueError that says how to give it (``alternative``: another way the method accepts)."""
    if method.system is None:
        example = next(iter(method.systems or ()), "ix")  # a machine it runs on
        raise ValueError(f"{method.name}: give the machine, {type(method).__name__}(system={example!r}) (a name, a "
                         f".urdf file, module:attr or a System){alternative}")
    return systems.get(method.system)


def takes_system(cls: type) -> bool:
    """Whether ``cls``'s constructor takes a ``system`` keyword (by name, or through ``**kwargs``)."""
    try:
        parameters = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):  # a signature Python cannot read: built without arguments
        return False
    keyword = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return any((p.name == "system" and p.kind in keyword) or p.kind is inspect.Parameter.VAR_KEYWORD
               for p in parameters)


def takes_keyword(cls: type, name: str) -> bool:
    """Whether ``cls``'s constructor names the keyword ``name`` (``budget``, ``base``; ``**kwargs``
    alone does not count: a class that does not know the word is not handed it)."""
    try:
        parameters = inspect.signature(cls).parameters
    except (TypeError, ValueError):
        return False
    return name in parameters and parameters[name].kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                            inspect.Parameter.KEYWORD_ONLY)


def method_base(spec: str, registry: dict[str, type]) -> str:
    """The base a method of ``spec`` builds on: the one after "@", else its class's default (the
    constructor's ``base`` default, ``bases.DEFAULT_BASE`` for the learners), or the fixed one a class
    without that keyword declares as its ``base`` attribute; "" for a method with none (feedback,
    physical, basic, a user's class without ``base``)."""
    base = split_spec(spec)[1]
    cls = load_method(spec, registry)
    if not takes_keyword(cls, "base"):  # a fixed base, declared as a class attribute (the paper variants, the PGNN)
        return cls.base if isinstance(cls.base, str) else ""
    return base or inspect.signature(cls).parameters["base"].default


def machine_settings(cls: type, system: systems.System, method: str):
    """A method's settings on ``system``: its table (``System.settings[method]``, a machine file's
    ``[benchmark.<method>]``) read into the method's dataclass ``cls``; a key ``cls`` does not take
    is an error that names it."""
    table = dict(system.settings.get(method, {}))
    known = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ValueError(f"machine {system.name}: [benchmark.{method}] has no setting {', '.join(unknown)} "
                         f"(it takes {', '.join(known)})")
    return cls(**table)


def build_method(spec: str, system: systems.System, registry: dict[str, type], budget: float = 1.0) -> Controller:
    """The controller of method ``spec`` (an id of ``registry`` or ``module:Class``, with an
    optional ``@BASE``, ``load_method``) for ``system``: ``cls(system=system)`` (and
    ``base=BASE``); a user's class whose constructor takes no ``system`` is built without arguments.
    ``budget``: the fraction of its full learning budget, handed to a class
    whose constructor names ``budget`` (``Controller``) where it is not 1."""
    cls = load_method(spec, registry)
    kwargs = {"system": system} if takes_system(cls) else {}
    if budget != 1.0 and takes_keyword(cls, "budget"):
        kwargs["budget"] = budget
    base = split_spec(spec)[1]
    if base is not None:
        kwargs["base"] = base
    return cls(**kwargs)


@dataclass
class Signals:
    """What a controller gives on a list of references (``apply``), one entry per reference:
    feedforwards (T, n_axes), reference offsets (T, n_axes) [rad] or None, the network's
    contributions (only for a method with ``nn_contribution``, else empty), and the wall time [s]
    its ``learn`` calls took."""

    feedforwards: list[np.ndarray] = field(default_factory=list)
    offsets: list[np.ndarray | None] = field(default_factory=list)
    nn_contributions: list[np.ndarray] = field(default_factory=list)
    learn_seconds: float = 0.0


def apply(controller: Controller, plant, references: Sequence, axes: Sequence[str], learn: Literal["each", "first"] = "each",
          stage: list[str] | None = None) -> Signals:
    """Run a fitted controller's protocol on ``references``, one reference after the other: a method
    that learns on the plant (``uses_plant``) gets ``learn(plant, reference)`` first, before every
    reference (``learn="each"``, the benchmark) or before the first only ("first", ``simulate``,
    whose methods learn once); then its ``feedforward`` and ``reference_offset``, checked
    (``checked``), and its ``nn_contribution`` where it has one. ``stage[0]`` names the step it is
    in (the benchmark's time limit reports it)."""
    if learn not in ("each", "first"):
        raise ValueError(f"learn must be 'each' or 'first', got {learn!r}")
    stage = [""] if stage is None else stage
    out = Signals()
    for i, r in enumerate(references):
        if controller.uses_plant and (learn == "each" or i == 0):
            stage[0] = f"learn on {r.name}"
            t0 = time.perf_counter()
            controller.learn(plant, r)
            out.learn_seconds += time.perf_counter() - t0
        stage[0] = f"feedforward of {r.name}"
        out.feedforwards.append(checked(controller.feedforward(r), r, "feedforward", axes))
        offset = controller.reference_offset(r)
        out.offsets.append(None if offset is None else checked(offset, r, "reference_offset", axes))
        part = controller.nn_contribution(r)
        if part is not None:
            out.nn_contributions.append(part)
    return out


@dataclass
class Evaluation:
    """A fitted controller on one reference set of a bench (``evaluate``): the closed-loop
    ``trials``, what the controller gave (``signals``) and the bench's norm ``tables``."""

    references: list
    trials: list
    signals: Signals
    tables: list[pd.DataFrame]


def evaluate(controller: Controller, bench: Bench, train_trials: list, reference_sets: Mapping[str, Sequence],
             learn: Literal["each", "first"] = "each", stage: list[str] | None = None) -> tuple[float, dict[str, Evaluation]]:
    """Fit ``controller`` on the training trials, then on each named reference set ``apply`` it,
    run the bench's plant with what it gave and score the trials (``bench.tables``): the one
    driver of the benchmark's cells and of ``lcgym simulate``. Returns the seconds the method
    spent learning (its ``fit`` and ``learn`` calls) and each set's ``Evaluation``. ``stage[0]``
    names the step it is in (the benchmark's time limit reports it)."""
    stage = [""] if stage is None else stage
    stage[0] = "fit"
    t0 = time.perf_counter()
    controller.fit(train_trials)
    seconds = time.perf_counter() - t0
    out = {}
    for set_name, references in reference_sets.items():
        references = list(references)
        signals = apply(controller, bench.plant, references, bench.axes, learn=learn, stage=stage)
        seconds += signals.learn_seconds
        stage[0] = f"the plant runs of the {set_name} references"
        trials = bench.run(references, signals.feedforwards, signals.offsets)
        out[set_name] = Evaluation(references, trials, signals, bench.tables(trials, signals.feedforwards, references))
    return seconds, out


def checked(values, reference, what: str, axes: Sequence[str]) -> np.ndarray:
    """A method's signal for ``reference`` as a float array, or a clear error: real numbers, the
    reference's shape, finite (the error names the first bad sample and axis)."""
    f = np.asarray(values)
    if f.dtype.kind not in "fiu":
        raise ValueError(f"{what} for {reference.name} must be real numbers, got dtype {f.dtype}: {short_repr(values)}")
    if f.shape != reference.positions.shape:
        raise ValueError(f"{what} for {reference.name} has shape {f.shape}, expected {reference.positions.shape}")
    f = f.astype(float, copy=False)
    bad = np.argwhere(~np.isfinite(f))
    if len(bad):
        sample, axis = bad[0]
        raise ValueError(f"{what} for {reference.name} contains NaN or inf, first at sample {sample}, axis "
                         f"{axes[axis]}: {f[sample, axis]}")
    return f
