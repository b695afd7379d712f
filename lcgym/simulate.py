"""Simulate feedforward controllers on a built-in machine: collect training data, fit, run validation
references.

This is what ``lcgym simulate`` does, as a library function:

1. Training experiment: the machine's plant runs the training references with feedback only (as a
   calibration run on a real machine would), giving measured trials.
2. Each controller is built for the machine (``protocol.build_method``: handed its ``System``) and
   fitted on those trials (feedback only: nothing to fit).
3. Each controller's feedforward (and, on the FlexArm, its reference offset) is applied on the
   validation references (``protocol.evaluate``, the benchmark's driver; a method that learns on the
   plant learns once, before the first); the resulting trials carry the reference, measured
   position, input and feedforward; ``metric_table`` gives the norms the benchmark scores
   (``System.bench``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from . import systems
from .data import Trial
from .methods import CONTROLLERS
from .methods.protocol import build_method, evaluate
from .systems.bench import Bench

# fitted on the training trials (the PGNN also records its training data once on the plant:
# ``learns_once``); the methods that learn on the plant per reference (ILC, the RBF expert, RL) run
# in ``lcgym bench``
SIMULATE_CONTROLLERS = {name: c for name, c in CONTROLLERS.items() if not c.uses_plant or c.learns_once}


def controllers_for(system: str) -> list[str]:
    """The controllers ``simulate`` runs on a built-in machine (a method's ``systems`` limits it)."""
    return [n for n, c in SIMULATE_CONTROLLERS.items() if system in (c.systems or (system,))]


@dataclass
class SimulationResult:
    controller: str
    trials: list[Trial]
    feedforward: list[np.ndarray]
    bench: Bench  # the machine's bench (what it scores, ``tables`` and ``trace``)
    references: list  # the validation references the trials ran
    tables: list[pd.DataFrame]  # the bench's norm tables of the trials


def simulate(
    controllers: Sequence[str], system: str = "ix", seed: int = 0, n_train: int = 8, n_validation: int = 4,
    duration: float = 40.0, progress: bool = True,
) -> list[SimulationResult]:
    """Fit each named controller on seeded training references of a benchmark machine and run it on
    validation ones. ``duration`` [s]: moving time of a reference (a FlexArm reference is one TCP
    line out and back); ``system``: "ix", "flexarm", "two_link" (their newest versions), a
    versioned name, "ix-v0", or a machine file, URDF or ``module:attr`` (``systems.resolve``), with
    the plant of that version."""
    machine = systems.resolve(system)  # a clear error for a machine without a plant
    available = controllers_for(machine.system.name)
    unknown = [c for c in controllers if c not in available]
    if unknown:
        raise ValueError(f"unknown controller {', '.join(unknown)} on {machine.system.name}; choose from "
                         f"{', '.join(available)} (the others run in lcgym bench)")
    bench = machine.bench()
    # a context manager: a failure closes the bar before its message is printed, not after
    with tqdm(total=2 + len(controllers), desc="simulate", disable=not progress, leave=False) as steps:
        train_refs = bench.references("train", seed, n_train, duration)
        val_refs = bench.references("validation", seed, n_validation, duration)
        steps.set_postfix_str("training experiment (feedback only)")
        train_trials = bench.run(train_refs)
        steps.update(2)
        results = []
        for name in controllers:
            steps.set_postfix_str(f"fit and run {name}")
            ctrl = build_method(name, machine.system, SIMULATE_CONTROLLERS)
            _, evaluated = evaluate(ctrl, bench, train_trials, {"validation": val_refs}, learn="first")
            run = evaluated["validation"]
            for t in run.trials:
                t.meta.update(controller=name, seed=seed, reference_set="validation")
            results.append(SimulationResult(name, run.trials, run.signals.feedforwards, bench, run.references,
                                            run.tables))
            steps.update()
    return results


def metric_table(results: Sequence[SimulationResult]) -> pd.DataFrame:
    """The norms the machine's benchmark scores per controller and axis (IX: tracking error [deg] and
    input residual [V], Tables II-V; arm: also the TCP error [mm] and paper 002's errors per period)."""
    parts = [table.assign(label=r.controller) for r in results for table in r.tables]
    return pd.concat(parts, ignore_index=True).rename(columns={"label": "controller"})
