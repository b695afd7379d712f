"""A learning method's base: the feedforward it starts from and never ends worse than.

Every learning method (ILC, ILC transfer, the RBF expert, RL) adds what it learns to a base
feedforward. The base is named on the command line after the method, ``METHOD@BASE``:

* ``physical`` (the default): the machine's physical model fitted by least squares on the training
  trials (``PhysicalFeedforward``), with the effects of the machine file's ``[[model]]`` tables:
  the strongest model the machine has;
* ``basic``: the FlexArm's nominal structure of paper 002 (``BasicArmFeedforward``), what the
  paper's LCS and NN prediction start from.

A base uses the loop as it is built: where the machine's feedback reacts to the motion itself (a
cascade drive's velocity loop differentiates the measured position, the EMPS's), even a perfect
force feedforward leaves e = (kd / kp) qd_r. So every base adds what the loop needs to track
exactly, minus the loop's own output on the reference (``loop.loop_feedforward``: kd times the
reference's velocity there, a drive's velocity feedforward; zero where the loop acts on the
tracking error alone, the IX, the FlexArm and the two-link arm).

``protocol.split_spec("ilc@basic")`` is ("ilc", "basic"); the results name a method on its default base by
its id alone (``ilc``) and on another base by ``id@base`` (``ilc@basic``), and the ``base`` column
says which base every learning row has.
"""

from __future__ import annotations

import numpy as np

from .. import systems
from .protocol import BASES


def runs_on(method_systems: tuple[str, ...] | None, base: str | None) -> tuple[str, ...] | None:
    """The machines ("flexarm") a method that runs on ``method_systems`` (None: all) runs on when
    built on ``base``: "basic" exists on the FlexArm only."""
    if base != "basic":
        return method_systems
    from .basic import BasicArmFeedforward

    where = BasicArmFeedforward.systems
    return where if method_systems is None else tuple(s for s in method_systems if s in where)


def base_controller(system: systems.System, base: str):
    """An unfitted controller of ``base`` on ``system`` (``fit(trials)`` it): ``PhysicalFeedforward``
    or ``BasicArmFeedforward``; a ValueError where the machine has no such base."""
    from .basic import BasicArmFeedforward
    from .physical import PhysicalFeedforward

    if base == "physical":
        return PhysicalFeedforward(system=system)
    if base == "basic":
        if system.nominal is None:
            raise ValueError(f"base 'basic' is paper 002's nominal structure, which {system.name} does not have; "
                             f"use base 'physical'")
        return BasicArmFeedforward(system=system)
    raise ValueError(f"unknown base {base!r}; bases: {', '.join(BASES)}")


def closed_loop(plant, reference, feedforward: np.ndarray, offset: np.ndarray | None):
    """One closed-loop trial of ``reference`` with ``feedforward`` and a load-side reference offset
    [rad] (None: none; a plant whose loads lag their motors, the FlexArm's, takes it with
    ``run_with_offset``)."""
    if offset is None:
        return plant.run(reference, feedforward)
    return plant.run_with_offset(reference, feedforward, offset)


class ReferenceMemo:
    """A method's signals computed once per reference object: the benchmark asks for a reference's
    feedforward and its offset one after the other, and a safeguard for the base's on each training
    reference several times; each is a model evaluation (a network, a regressor) that may cost more
    than the plant run it feeds. The values are shared, never written to. Keep one per fitted state
    (a new one at ``fit``; ``forget`` where what a key computes changes)."""

    def __init__(self):
        self._store: dict = {}

    def get(self, key: str, reference, compute):
        """``compute()`` for ``reference``, or its value already computed under ``key``."""
        hit = self._store.get((key, id(reference)))
        if hit is not None and hit[0] is reference:
            return hit[1]
        value = compute()
        self._store[(key, id(reference))] = (reference, value)
        return value

    def forget(self, key: str) -> None:
        self._store = {k: v for k, v in self._store.items() if k[0] != key}

