"""The process's scratch memory: every cache lcgym keeps between calls, in one place.

In the spirit of pinocchio's ``Data`` beside its immutable ``Model``: machines, models and plants
hold no results of earlier calls; what is worth keeping lives in ``WORKSPACE``, one named slot
per cache, made on first use:

* ``"physics.model.reductions"``: a model's filtered designs (``physics.preprocessing.reduction_memo``);
* ``"physics.lti.foh"``: first-order-hold discretizations of linear systems (``physics.lti``);
* ``"systems.flexarm.regressors"``: the FlexArm's regressors (``System.caching``);
* ``"systems.<machine>.env_models"``: the physical model an env fitted on its plant's training
  runs, per plant and seed (``lcgym/IX-v1``, ``lcgym/FlexArm-v1``, ``lcgym/Machine-v0``);
* ``"systems.runs"``: the closed-loop runs a benchmark's cells repeat (``systems.runs``).

``WORKSPACE.clear()`` empties every slot (a test, a long-lived process between studies).

Kept elsewhere, each for a reason of its own:

* a URDF machine's regressors, with its own instance (``systems.urdf``): two URDFs differ, and the
  cache goes with the machine;
* ``functools`` caches of values that cannot go stale within a process: the package's source hash
  and git commit (``provenance``), a Butterworth filter's sections per setting
  (``physics.kinematics``), the speed-noise gain of a filter setting (``diagnose.layout``), a
  user's class wrapped as a ``Controller`` once (``methods.protocol``), and the machine a spec
  names (``systems.resolve``: a machine file once per content);
* the feedback-only training runs of a benchmark's (machine, seed), per worker process
  (``leaderboard.runner``), as a cell's worker reuses them across the methods it runs.

``clear()`` leaves those: they hold no results a study would want to drop.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


class Workspace:
    """Named caches of one process, each made by its owner on first use (``slot``)."""

    def __init__(self):
        self._slots: dict[str, object] = {}

    def slot(self, name: str, make: Callable[[], T]) -> T:
        """The cache ``name``; ``make()`` builds it the first time it is asked for."""
        if name not in self._slots:
            self._slots[name] = make()
        return self._slots[name]

    def names(self) -> list[str]:
        """The slots made so far."""
        return sorted(self._slots)

    def clear(self) -> None:
        """Empty every slot (each keeps its settings; the next use fills it again)."""
        for cache in self._slots.values():
            cache.clear()


WORKSPACE = Workspace()
"""This process's workspace."""
