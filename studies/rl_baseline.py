"""The ``rl`` method per env-step budget, on the benchmark's references of one seed.

Trains ``RLFeedforward`` (``lcgym.methods.rl``) on the bench's 8 training references (IX: 40 s
of moves each; FlexArm: TCP lines) for each budget, rolls it out on the 4 validation references
and prints their RMS tracking error per axis [deg] beside the starting feedforward alone
(IX: the fitted physical model; FlexArm: Basic), with the env steps, plant trials and training
time. Saves each training curve as ``<out>/rl_<system>_<tag>.csv`` and ``.png``.

Run:  .venv/bin/python studies/rl_baseline.py [--system ix] [--seed 0] [--passes 6,60]
      [--no-error] [--algorithm ppo] [--set learning_rate=3e-4 ...] [--no-cache] [--out results]
"""

from __future__ import annotations

import argparse
import ast
import time
from pathlib import Path

import numpy as np
import torch

from lcgym import systems
from lcgym.leaderboard.runner import BenchConfig
from lcgym.methods import BasicArmFeedforward, PhysicalFeedforward
from lcgym.methods.rl import RLConfig, RLFeedforward


def validation_rms(bench, references, controller, plant) -> np.ndarray:
    """RMS of the scored tracking error per axis [deg] with the controller's feedforward."""
    ffs, offsets = [], []
    for r in references:
        if getattr(controller, "uses_plant", False):
            controller.learn(plant, r)
        ffs.append(controller.feedforward(r))
        offsets.append(controller.reference_offset(r))
    table = bench.tables(bench.run(references, ffs, offsets), ffs)[0]
    return table["RMS"].to_numpy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--system", default="ix", help="a benchmark machine: ix, flexarm (the newest version) or ix-v0, ...")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--passes", default=None, help="comma-separated passes over the training samples "
                                                         "(default: RLConfig's for the system)")
    parser.add_argument("--no-error", action="store_true", help="hide the tracking error from the policy")
    parser.add_argument("--algorithm", default="ppo", choices=("ppo", "sac", "td3"))
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="hyperparameter override (a Python literal), repeatable")
    parser.add_argument("--no-cache", action="store_true")
    parser.add_argument("--out", default="results")
    args = parser.parse_args()
    torch.set_num_threads(1)
    overrides = {k: ast.literal_eval(v) for k, v in (s.split("=", 1) for s in args.set)}
    bench = systems.resolve(args.system).bench()
    family = bench.family
    machine = systems.get(family)
    passes = [float(p) for p in args.passes.split(",")] if args.passes else [RLConfig().on(machine).passes]
    cfg = BenchConfig()
    train = bench.references("train", args.seed, cfg.n_train, cfg.duration)
    val = bench.references("validation", args.seed, cfg.n_validation, cfg.duration)
    trials = bench.run(train)
    start = (PhysicalFeedforward if family == "ix" else BasicArmFeedforward)(system=machine).fit(trials)
    axes = ", ".join(bench.tables(trials, [t.ff for t in trials])[0]["axis"])
    print(f"{bench.name}, seed {args.seed}: validation RMS tracking error [deg] ({axes})")
    print(f"  {start.name} alone: {np.round(validation_rms(bench, val, start, bench.plant), 4)}")
    for p in passes:
        config = RLConfig(algorithm=args.algorithm, observe_error=not args.no_error,
                          passes=p, hyperparameters=overrides, seed=args.seed,
                          cache=not args.no_cache, progress=True)
        rl = RLFeedforward(config, system=machine).fit(trials)
        t0 = time.perf_counter()
        rms = validation_rms(bench, val, rl, bench.plant)
        seconds = rl.record_["seconds"]
        settings = "".join(f"_{k}{v}" for k, v in sorted(overrides.items()))  # --set KEY=VALUE: a file of its own
        tag = f"{args.algorithm}_{p:g}passes{'_noerror' if args.no_error else ''}{settings}_seed{args.seed}"
        out = Path(args.out)
        out.mkdir(exist_ok=True)
        rl.curve_.to_csv(out / f"rl_{bench.name}_{tag}.csv", index=False)
        rl.plot_curve(out / f"rl_{bench.name}_{tag}.png")
        cached = " (loaded from the cache)" if rl.cost_.cached_seconds else ""
        print(f"  rl {tag}: {np.round(rms, 4)}; {rl.record_['env_steps']} training env steps in {seconds:.0f} s "
              f"({rl.record_['env_steps'] / seconds:.0f} steps/s){cached}; cell total: {rl.cost_.env_steps} env steps, "
              f"{rl.cost_.plant_trials} plant trials; {time.perf_counter() - t0:.0f} s here")


if __name__ == "__main__":
    main()
