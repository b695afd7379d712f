"""The docs' PPO recipe (docs/environments.md) on a machine file: the return of every episode over
20,000 agent steps, per seed (issue 61, item 7).

PPO with SB3's defaults, a residual on the physical model acting at 50 Hz, 4 references of 20 s,
the env's scales (``lcgym.systems.machine_env``: from the machine unless given); this prints each
seed's mean return over the first and the last fifth of its episodes and their ratio (below 1: the
return rose; it is negative). ``--machine``: a machine file; ``rail`` (the default) is the user's
machine of ``studies/user_loop.py`` (a rail with a 20 N Coulomb friction carrying a two-link arm
with a cable spring on the elbow), ``rail_arm`` the one of ``tests/data/rail_arm``.

Run:  .venv/bin/python studies/rl_machine_recipe.py [--seeds 0,1,2] [--steps 20000] [--machine rail|rail_arm|FILE]
(about 1 min per seed on a 2-core machine, 2026-12-07.)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback

from lcgym.envs.hold import AGENT_RATE
from lcgym.envs.sb3 import make_sb3_vec_env

RAIL_ARM = Path(__file__).resolve().parents[1] / "tests" / "data" / "rail_arm" / "rail_arm.toml"


class Returns(BaseCallback):
    """Every finished episode's return, in order."""

    def __init__(self):
        super().__init__()
        self.returns: list[float] = []

    def _on_step(self) -> bool:
        self.returns += [info["episode"]["r"] for info in self.locals["infos"] if "episode" in info]
        return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--machine", default="rail")
    args = parser.parse_args()
    torch.set_num_threads(1)
    if args.machine == "rail":  # the user's machine of studies/user_loop.py, written to a temporary folder
        sys.path.insert(0, str(Path(__file__).parent))
        import user_loop

        folder = Path(tempfile.mkdtemp(prefix="lcgym-rl-rail-"))
        (folder / "rail.urdf").write_text(user_loop.URDF)
        (folder / "rail.toml").write_text(user_loop.MACHINE)
        args.machine = str(folder / "rail.toml")
    elif args.machine == "rail_arm":
        args.machine = str(RAIL_ARM)
    for seed in map(int, args.seeds.split(",")):
        start = time.perf_counter()
        venv = make_sb3_vec_env("lcgym/Machine-v0", machine=args.machine, agent_rate=AGENT_RATE,
                                base_feedforward="physical", n_references=4, duration=20.0)
        model = PPO("MlpPolicy", venv, seed=seed, device="cpu")
        returns = Returns()
        model.learn(args.steps, callback=returns)
        r = np.array(returns.returns)
        k = max(1, len(r) // 5)
        print(f"seed {seed}: {len(r)} episodes, first fifth {r[:k].mean():.4g}, last fifth {r[-k:].mean():.4g}, "
              f"ratio {r[-k:].mean() / r[:k].mean():.3f} ({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
