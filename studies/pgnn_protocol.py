"""The PGNN's benchmark protocol, step by step: what each choice of ``methods/pgnn/method.py`` buys on
the leaderboard's data (8 training references of 40 s, seed 0), against the plant's own static
feedforward (``IXPlant.static_model``: the best a static function of the PGNN's inputs can do).

Rows (each trained with J and with J_LS; printed: RMS and Inf tracking error [deg] on the 4
validation references, the ratio physical / PGNN, RMS of f^C [V], iterations and wall time):

A. the previous protocol: the feedback-only runs, u at 1 Hz, one-epoch iterations, zeta relative;
B. runs recorded with the physical model's feedforward on (the axes follow theta_d);
C. B with 80-step iterations and zeta absolute (``PGNNConfig`` defaults);
D. C with u at 5 Hz: the leaderboard's protocol.

Run:  .venv/bin/python studies/pgnn_protocol.py [--version v1] [--seed 0] [--rows ABCD]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from lcgym.methods import PhysicalFeedforward
from lcgym.methods.pgnn import PGNN, PGNNConfig
from lcgym.systems.ix import IX
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set

PREVIOUS = dict(filter_hz=1.0, steps_per_iteration=None, zeta_steps="relative")
ROWS = {
    "A": ("feedback-only runs, 1 Hz, one-epoch iterations, zeta relative", "feedback", PREVIOUS),
    "B": ("runs with the physical feedforward on", "physical", PREVIOUS),
    "C": ("B + 80-step iterations, zeta absolute", "physical", {**PREVIOUS, "steps_per_iteration": 80,
                                                                "zeta_steps": "absolute"}),
    "D": ("C + u at 5 Hz (the leaderboard's)", "physical", {"filter_hz": 5.0, "steps_per_iteration": 80,
                                                           "zeta_steps": "absolute"}),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--version", default="v1")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rows", default="ABCD")
    args = parser.parse_args()
    torch.set_num_threads(1)
    plant = IXPlant.of_version(args.version)
    train_refs = reference_set("train", args.seed)
    val_refs = reference_set("validation", args.seed)
    feedback_runs = plant.run(train_refs)
    physical = PhysicalFeedforward(system="ix").fit(feedback_runs)
    data = {"feedback": feedback_runs, "physical": plant.run(train_refs, [physical.feedforward(r) for r in train_refs])}

    def tracking(model):
        runs = plant.run(val_refs, [model(r) for r in val_refs])
        e = np.degrees(np.concatenate([t.error for t in runs]))
        return np.sqrt(np.mean(e * e, axis=0)), np.abs(e).max(axis=0)

    base, _ = tracking(physical.feedforward)
    oracle, _ = tracking(plant.static_model(IX).predict)
    print(f"IX-{args.version}, seed {args.seed}: physical model RMS {base.round(4)} deg; the plant's static feedforward "
          f"RMS {oracle.round(4)} deg, physical / static {(base / oracle).round(2)}")
    for key in args.rows:
        label, collected, options = ROWS[key]
        for regularize in (True, False):
            t0 = time.perf_counter()
            m = PGNN(PGNNConfig(threads=1, regularize=regularize, **options), system="ix").fit(data[collected])
            rms, inf = tracking(m.predict)
            fc = np.sqrt(np.mean(np.concatenate([m.nn_contribution(r) for r in val_refs]) ** 2, axis=0))
            print(f"{key} {label} [{'J' if regularize else 'J_LS'}]: RMS {rms.round(4)} Inf {inf.round(3)} "
                  f"physical / this {(base / rms).round(2)}, RMS f^C {fc.round(3)} V, {m.info_['epochs']} iterations, "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
