"""Training time of paper 002's NN predictor: all networks of the three moving FlexArm joints
(issue budget: least squares in at most 5 s on the project's 2-core machine).

Data: the model-following error e_pl of Basic runs of ``--lines`` training lines (seed 0), as the
``rbf-expert`` method and ``studies/rbf_expert_arm.py`` train on. Timed, from the references and
errors to trained networks (motion influence, preprocessing, expert logic and the 12 networks):

* least squares (the default) with the default 2D networks and with the paper's 3D 20 x 10 x 11;
* the momentum gradient method of eqs. (36)-(38) with Table 4's gains on the default networks: its
  time, iterations per network, and its cost against least squares' (the same problem).

The reference measured in the same run: one Basic simulation of one training line (the plant run
that yields a line's training data). Printed: times, the ratio to the budget and to the reference.

Run:  .venv/bin/python benchmarks/rbf_training.py [--lines 24]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lcgym.methods.rbf_expert.influence import task_influence
from lcgym.methods.rbf_expert.predictor import RBFExpertConfig, RBFExpertPredictor
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import MOVING, arm_reference_set

BUDGET_S = 5.0


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=24)
    args = parser.parse_args()
    plant = FlexArmPlant()
    train = arm_reference_set("train", 0, args.lines)
    BasicFeedforward().run(plant, train[0])  # compile
    runs, _ = timed(lambda: [BasicFeedforward().run(plant, r) for r in train])
    _, reference_s = timed(lambda: BasicFeedforward().run(plant, train[0]))
    errors = [np.column_stack([tr.extra[f"e_pl_{a}"] for a in tr.axes]) for tr in runs]
    phi = task_influence(train, FLEXARM.joint_axes())
    samples = sum(r.n_samples for r in train)
    print(f"{args.lines} training lines, {samples} samples; reference (one Basic run of a line): {reference_s:.2f} s")
    results = {}
    for label, cfg in (("least squares, 2D 10 x 11 (default)", RBFExpertConfig()),
                       ("least squares, 3D 20 x 10 x 11 (paper)", RBFExpertConfig(dims=3)),
                       ("momentum (eqs. 36-38, Table 4), 2D", RBFExpertConfig(method="momentum"))):
        pred, seconds = timed(lambda cfg=cfg: RBFExpertPredictor(phi, MOVING, cfg).fit(train, errors))
        results[label] = pred
        nets = [n for j in MOVING for n in pred.networks_[j].values()]
        extra = ""
        if cfg.method == "momentum":
            its = [len(n.history_) - 1 for n in nets]
            direct = results["least squares, 2D 10 x 11 (default)"]
            ratio = [n.cost_ / d.cost_ for n, d in zip(nets, [d for j in MOVING for d in direct.networks_[j].values()],
                                                        strict=True)]
            extra = (f"; iterations per network {min(its)}-{max(its)} (total {sum(its)}); cost / least squares' "
                     f"{min(ratio):.6f}-{max(ratio):.6f}")
        print(f"{label:40s} {len(nets)} networks in {seconds:6.2f} s = {seconds / BUDGET_S:.2f} x the budget, "
              f"{seconds / reference_s:.1f} x the reference{extra}")


if __name__ == "__main__":
    main()
