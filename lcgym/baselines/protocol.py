"""The controller protocol: what every method in the leaderboard (and a user's own) provides.

A feedforward controller has

* ``name``: a short display name (the results name a method by the id or ``module:Class`` it was
  run with, so that ``--resume`` finds it again);
* ``fit(trials)``: learn offline from measured training trials (may do nothing);
* ``learn(plant, reference)``: learn by running the plant on this reference (ILC, RL); the runner
  calls it before ``feedforward`` on every evaluation reference when ``uses_plant`` is true;
* ``feedforward(reference) -> (T, n_axes)``: the signal to apply [V for the IX];
* ``cost_``: a ``Cost`` with the plant trials and env steps it used beyond the shared training
  data (the runner adds wall time);
* optionally ``reference_offset(reference) -> (T, n_axes)`` [rad] or None: added to the reference
  the feedback tracks, on systems with that channel (the FlexArm's motor reference);
  ``systems``: the systems it runs on (default all); and ``relative_cost``: about how many
  seconds a quick cell of it takes (default 1), which only orders the parallel workers' cells;
* optionally a constructor keyword ``budget`` (default 1): the fraction of its full learning budget
  a method spends (the PGNN's iterations, ILC's trials), which ``lcgym bench --quick`` lowers
  (``BenchConfig.budget``) for a smoke run of every cell;
* optionally a constructor keyword ``base`` (the learning methods: default "physical"): the
  feedforward it builds on (``bases``), which ``METHOD@BASE`` on the command line sets.

Subclassing ``Controller`` gives the no-op defaults; duck typing works too. A user's class is
named on the command line as ``module:Class`` (see ``load_method``).

Each method is handed its machine, scikit-learn style: the constructor takes ``system`` (a
``System``, or what ``systems.get`` resolves: a name such as "ix", a .urdf file, ``module:attr``),
stores it as given, and ``fit`` resolves it (``given_system``). Whoever builds a method hands it
the machine: the benchmark's cell and ``simulate`` through ``build_method``, which builds a user's
class whose constructor takes no ``system`` without it. ``apply`` then runs the protocol on a list
of references, the same way for both.
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from .. import systems
from ..envs.actions import short_repr

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


class Controller:
    """Base class with the protocol's defaults: nothing to fit, nothing to learn online."""

    name = "controller"
    uses_plant = False
    learns_on_scored_references = False
    """True for a method whose ``learn`` runs the plant on each evaluation reference itself before it
    is scored (ILC): the leaderboard marks its rows as learned on the references they score."""
    relative_cost = 1.0
    """About how long a cell of this method takes, in seconds of ``lcgym bench --quick``'s cells on the
    built-in machines (the median of their cells' times; pgnn, pgnn-ls, rl and ilc from a serial run,
    ``--jobs 1``, of 2026-12-05, the others 2026-12-04): the runner starts the
    costlier cells first, so that its parallel workers end together. It orders, nothing else."""

    def fit(self, trials: Sequence) -> Controller:
        self.cost_ = getattr(self, "cost_", Cost())
        return self

    def learn(self, plant, reference) -> Controller:
        self.cost_ = getattr(self, "cost_", Cost())
        return self

    def feedforward(self, reference) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


def load_method(spec: str, registry: dict[str, type]) -> type:
    """A controller class from a method id of ``registry`` or from ``module:Class``, either with an
    optional ``@BASE`` (``bases.split_spec``; a class that takes no ``base`` is refused one)."""
    spec, base = split_spec(spec)
    cls = _load_class(spec, registry)
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
    if os.getcwd() not in sys.path:  # like `python -m`: a module in the current folder is found
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"method {spec!r}: cannot import module {module_name!r} ({exc})") from None
    cls = getattr(module, class_name, None)
    if cls is None:
        raise ValueError(f"method {spec!r}: module {module_name!r} has no {class_name!r}")
    missing = [m for m in ("fit", "feedforward") if not callable(getattr(cls, m, None))]
    if missing:
        raise ValueError(f"method {spec!r}: {class_name} lacks {', '.join(missing)} (see lcgym.baselines.protocol)")
    return cls


def given_system(method, alternative: str = "") -> systems.System:
    """The machine ``method`` was handed (its ``system``: a ``System`` or a spec for ``systems.get``),
    or a ValueError that says how to give it (``alternative``: another way the method accepts)."""
    if getattr(method, "system", None) is None:
        example = next(iter(getattr(method, "systems", None) or ()), "ix")  # a machine it runs on
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
        fixed = getattr(cls, "base", "")
        return fixed if isinstance(fixed, str) else ""
    return base or inspect.signature(cls).parameters["base"].default


def build_method(spec: str, system: systems.System, registry: dict[str, type], budget: float = 1.0):
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


def apply(controller, plant, references: Sequence, axes: Sequence[str], learn: Literal["each", "first"] = "each",
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
        if getattr(controller, "uses_plant", False) and (learn == "each" or i == 0):
            stage[0] = f"learn on {r.name}"
            t0 = time.perf_counter()
            controller.learn(plant, r)
            out.learn_seconds += time.perf_counter() - t0
        stage[0] = f"feedforward of {r.name}"
        out.feedforwards.append(checked(controller.feedforward(r), r, "feedforward", axes))
        offset = getattr(controller, "reference_offset", lambda _: None)(r)
        out.offsets.append(None if offset is None else checked(offset, r, "reference_offset", axes))
        if hasattr(controller, "nn_contribution"):
            out.nn_contributions.append(controller.nn_contribution(r))
    return out


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
