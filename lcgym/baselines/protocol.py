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
  the feedback tracks, on systems with that channel (the FlexArm's motor reference); and
  ``systems``: the systems it runs on (default all).

Subclassing ``Controller`` gives the no-op defaults; duck typing works too. A user's class is
named on the command line as ``module:Class`` (see ``load_method``).
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


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

    def fit(self, trials: Sequence) -> Controller:
        self.cost_ = getattr(self, "cost_", Cost())
        return self

    def learn(self, plant, reference) -> Controller:
        self.cost_ = getattr(self, "cost_", Cost())
        return self

    def feedforward(self, reference) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


def load_method(spec: str, registry: dict[str, type]) -> type:
    """A controller class from a method id of ``registry`` or from ``module:Class``."""
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
