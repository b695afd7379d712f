"""Speed of the ``rl`` method's rollout actor against stable-baselines3's ``predict``, in one run.

``lcgym.methods.rl.deterministic_actor`` copies a policy's layers to numpy for the rollouts on
the plant. Prints the time per call of the numpy actor and of ``model.predict(obs,
deterministic=True)`` for an untrained PPO MlpPolicy (64 x 64) on 2,000 observations of the IX
env, the ratio, and the largest difference between their actions. Best of five rounds each.

Run:  .venv/bin/python benchmarks/rl_actor.py
"""

from __future__ import annotations

import time

import numpy as np
import torch
from stable_baselines3 import PPO

from lcgym.methods.rl import deterministic_actor
from lcgym.systems.ix.env import IXEnv


def best_per_call(fn, observations, rounds: int = 5) -> float:
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        for obs in observations:
            fn(obs)
        best = min(best, (time.perf_counter() - t0) / len(observations))
    return best


def main() -> None:
    torch.set_num_threads(1)
    env = IXEnv(references="validation", base_feedforward="physical", n_references=1, duration=4.0)
    model = PPO("MlpPolicy", env, seed=0, device="cpu", policy_kwargs=dict(net_arch=[64, 64]))
    observations = np.random.default_rng(0).normal(size=(2000, env.observation_space.shape[0])).astype(np.float32)
    act = deterministic_actor(model)
    numpy_s = best_per_call(act, observations)
    sb3_s = best_per_call(lambda o: model.predict(o, deterministic=True), observations)
    diff = max(np.abs(act(o) - model.predict(o, deterministic=True)[0]).max() for o in observations[:200])
    print(f"numpy actor {numpy_s * 1e6:.1f} us per call, SB3 predict {sb3_s * 1e6:.1f} us per call: "
          f"ratio {sb3_s / numpy_s:.1f}; largest action difference {diff:.1e}")


if __name__ == "__main__":
    main()
