"""Simulate feedforward controllers on the IX: collect training data, fit, run validation references.

This is what ``lcgym simulate`` does, as a library function:

1. Training experiment: the plant runs the training references with feedback only (as a
   calibration run on a real machine would), giving measured trials.
2. Each controller is fitted on those trials (feedback only: nothing to fit).
3. Each controller's feedforward is applied on the validation references; the resulting trials
   carry the reference, measured position, input and feedforward.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from .baselines import CONTROLLERS
from .data import Trial
from .envs.ix import IXPlant
from .envs.references import reference_set
from .leaderboard.metrics import input_residual_table, tracking_error_table

# fitted on the training trials alone and run on the IX; the methods that learn on the plant
# itself (ILC, the RBF expert, RL) or belong to the FlexArm run in ``lcgym bench``
SIMULATE_CONTROLLERS = {name: c for name, c in CONTROLLERS.items()
                        if "ix" in getattr(c, "systems", ("ix",)) and not getattr(c, "uses_plant", False)}


@dataclass
class SimulationResult:
    controller: str
    trials: list[Trial]
    feedforward: list[np.ndarray]


def simulate(
    controllers: Sequence[str], seed: int = 0, n_train: int = 8, n_validation: int = 4, duration: float = 40.0,
    plant: IXPlant | None = None, progress: bool = True,
) -> list[SimulationResult]:
    """Fit each named controller on seeded training references and run it on validation ones."""
    unknown = [c for c in controllers if c not in SIMULATE_CONTROLLERS]
    if unknown:
        raise ValueError(f"unknown controller(s) {unknown}; choose from {sorted(SIMULATE_CONTROLLERS)} "
                         "(the others run in lcgym bench)")
    plant = plant if plant is not None else IXPlant()
    # a context manager: a failure closes the bar before its message is printed, not after
    with tqdm(total=2 + 2 * len(controllers), desc="simulate", disable=not progress, leave=False) as steps:
        train_refs = reference_set("train", seed, n_train, duration, plant.fs)
        val_refs = reference_set("validation", seed, n_validation, duration, plant.fs)
        steps.set_postfix_str("training experiment (feedback only)")
        train_trials = plant.run(train_refs)
        steps.update(2)
        results = []
        for name in controllers:
            steps.set_postfix_str(f"fit {name}")
            ctrl = SIMULATE_CONTROLLERS[name]().fit(train_trials)
            steps.update()
            steps.set_postfix_str(f"run {name}")
            ff = [ctrl.feedforward(r) for r in val_refs]
            trials = plant.run(val_refs, ff)
            for t in trials:
                t.meta.update(controller=name, seed=seed, reference_set="validation")
            results.append(SimulationResult(name, trials, ff))
            steps.update()
    return results


def metric_table(results: Sequence[SimulationResult]) -> pd.DataFrame:
    """Tracking-error [deg] and input-residual [V] norms per controller and axis (Tables II-V)."""
    parts = []
    for r in results:
        parts.append(tracking_error_table(r.trials, r.controller))
        parts.append(input_residual_table(r.trials, r.feedforward, r.controller))
    return pd.concat(parts, ignore_index=True).rename(columns={"label": "controller"})
