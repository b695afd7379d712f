"""Speed of the batched FlexArm vector env (issue 23, item 1), as ratios to references measured in
the same run:

* env steps/s of ``gym.make_vec("lcgym/FlexArm-v1", N, vectorization_mode="vector_entry_point")``
  at N = 1, 16, 256, against the single ``FlexArmEnv`` (random actions in both);
* PPO (stable-baselines3, default settings) learning on the vector env through
  ``envs.sb3.make_sb3_vec_env`` against the same PPO on ``DummyVecEnv`` copies of the single env
  (each wrapped in ``Monitor``, what ``methods/rl.py`` does for an env without a vector entry
  point): env steps per second of ``learn`` (collection and updates together), same N; and the same
  PPO on a batched env with the FlexArm's spaces and no physics (``free_vec_env``: a step costs
  nothing), PPO's own ceiling on this machine whatever the env does.

Run:  .venv/bin/python benchmarks/flexarm_vector_speed.py [--ppo-envs 8] [--ppo-rollouts 2] [--rounds 5] [--no-ppo]
The first vector env compiles the kernel (cached on disk); its time is printed separately.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np
import torch

import lcgym  # noqa: F401  (registers the ids)
from lcgym.systems.flexarm.env import FlexArmEnv

ENV_ID = "lcgym/FlexArm-v1"


def single_rate(steps: int) -> float:
    env = FlexArmEnv(references="train")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (steps, 6)).astype(np.float32)
    t0 = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t0)


def vector_rate(num_envs: int, vector_steps: int) -> float:
    venv = gym.make_vec(ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (vector_steps, num_envs, 6)).astype(np.float32)
    venv.step(actions[0])  # threads start
    t0 = time.perf_counter()
    for a in actions:
        venv.step(a)
    return num_envs * vector_steps / (time.perf_counter() - t0)


def free_vec_env(num_envs: int):
    """A stable-baselines3 VecEnv with the FlexArm env's spaces and no physics: zero observations
    and rewards in one batch, episodes of 5,000 steps, no per-env Python. What PPO costs by itself."""
    from stable_baselines3.common.vec_env import VecEnv

    like = FlexArmEnv(references="train")

    class FreeVecEnv(VecEnv):
        def __init__(self):
            super().__init__(num_envs, like.observation_space, like.action_space)
            self._obs = np.zeros((num_envs, *like.observation_space.shape), dtype=like.observation_space.dtype)
            self._t = 0

        def reset(self):
            self._t = 0
            return self._obs.copy()

        def step_async(self, actions):
            pass

        def step_wait(self):
            self._t += 1
            done = self._t % 5000 == 0
            infos = [{"terminal_observation": self._obs[0].copy(), "TimeLimit.truncated": True} if done else {}
                     for _ in range(num_envs)]
            return self._obs.copy(), np.zeros(num_envs, dtype=np.float32), np.full(num_envs, done), infos

        def close(self):
            pass

        def get_attr(self, attr_name, indices=None):
            return [getattr(self, attr_name, None)] * num_envs

        def set_attr(self, attr_name, value, indices=None):
            pass

        def env_method(self, method_name, *args, indices=None, **kwargs):
            return [None] * num_envs

        def env_is_wrapped(self, wrapper_class, indices=None):
            return [False] * num_envs

    return FreeVecEnv()


def ppo_rate(vec_env, rollouts: int) -> float:
    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", vec_env, seed=0, device="cpu")
    steps = model.n_steps * vec_env.num_envs * rollouts
    t0 = time.perf_counter()
    model.learn(total_timesteps=steps)
    return steps / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ppo-envs", type=int, default=8)
    parser.add_argument("--ppo-rollouts", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=5, help="alternating rounds of the env-step measurements")
    parser.add_argument("--no-ppo", action="store_true", help="the env-step figures only")
    args = parser.parse_args()
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    gym.make_vec(ENV_ID, num_envs=1, vectorization_mode="vector_entry_point").reset(seed=0)
    print(f"first vector env (compiles or loads the kernel, computes the start states): {time.perf_counter() - t0:.1f} s")
    # the single env and each N in alternation, several rounds: the ratio of each round's pair, then
    # the median over rounds (a busy moment of the machine slows one pair, not the figure)
    sizes = ((1, 3000), (16, 1000), (256, 200))
    ratios: dict[int, list[float]] = {n: [] for n, _ in sizes}
    rates: dict[int, list[float]] = {n: [] for n, _ in sizes}
    singles = []
    for _ in range(args.rounds):
        singles.append(single_rate(5000))
        for n, steps in sizes:
            rates[n].append(vector_rate(n, steps))
            ratios[n].append(rates[n][-1] / singles[-1])
    print(f"single FlexArmEnv: {np.median(singles):,.0f} env steps/s (median of {args.rounds} rounds)")
    for n, _ in sizes:
        print(f"vector env N = {n:4d}: {np.median(rates[n]):,.0f} env steps/s = {np.median(ratios[n]):.2f}x the single "
              f"env (median; rounds {min(ratios[n]):.2f}-{max(ratios[n]):.2f}x)")

    if args.no_ppo:
        return
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    from lcgym.envs.sb3 import make_sb3_vec_env

    n = args.ppo_envs
    dummy = ppo_rate(make_vec_env(lambda: FlexArmEnv(references="train"), n_envs=n, vec_env_cls=DummyVecEnv),
                     args.ppo_rollouts)
    batched = ppo_rate(make_sb3_vec_env(ENV_ID, num_envs=n), args.ppo_rollouts)
    free = ppo_rate(free_vec_env(n), args.ppo_rollouts)
    print(f"PPO (default settings, {n} envs, {args.ppo_rollouts} rollouts of {2048 * n} steps): DummyVecEnv "
          f"{dummy:,.0f} env steps/s, vector env {batched:,.0f} env steps/s = {batched / dummy:.2f}x; "
          f"on an env without physics {free:,.0f} env steps/s = {free / dummy:.2f}x (PPO's own ceiling)")


if __name__ == "__main__":
    main()
