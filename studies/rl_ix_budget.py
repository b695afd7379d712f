"""Residual PPO on ``lcgym/IX-v0``: how far a stable-baselines3 agent gets per env-step budget,
against the physical-model feedforward it adds to (a sizing study for the RL baseline's issue; the
leaderboard method does not exist yet).

Trained on the benchmark's 8 training references of seed 0 (40 s of moves each) with
``base_feedforward="physical"`` on the compiled vector env (8 envs, ``envs.sb3``), evaluated
deterministically on seed 0's 4 validation references; prints the validation RMS tracking error
per axis [deg] beside the physical model alone (zero action). ``--no-error``: the tracking error is
zeroed in the observation (the policy sees the reference preview and the base feedforward only,
a pure feedforward; with the error it can act as an added feedback loop). ``--arm``: the FlexArm
env's PPO throughput instead.

Run:  .venv/bin/python studies/rl_ix_budget.py [--budgets 50000,500000,2000000] [--no-error] [--arm]
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnvWrapper

import lcgym  # noqa: F401  (registers the environments)
from lcgym.envs.references import reference_set
from lcgym.envs.sb3 import make_sb3_vec_env

ERROR = slice(34, 36)  # the tracking error's place in the IX observation (envs/ix_env.py)


class HideError(VecEnvWrapper):
    """Zeroes the tracking error in the observations of an SB3 vector env."""

    def reset(self):
        obs = self.venv.reset()
        obs[:, ERROR] = 0.0
        return obs

    def step_wait(self):
        obs, reward, done, infos = self.venv.step_wait()
        obs[:, ERROR] = 0.0
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"][ERROR] = 0.0
        return obs, reward, done, infos


def validation_rms(refs, policy=None, hide_error: bool = False) -> np.ndarray:
    """RMS tracking error per axis [deg] over the references; zero action without a policy."""
    env = gym.make("lcgym/IX-v0", references=refs, base_feedforward="physical")
    errors = []
    for i in range(len(refs)):
        obs, _ = env.reset(seed=0, options={"reference": i})
        done = False
        while not done:
            if hide_error:
                obs = obs.copy()
                obs[ERROR] = 0.0
            action = policy.predict(obs, deterministic=True)[0] if policy else np.zeros(2, dtype=np.float32)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            errors.append(info["error"])
    return np.degrees(np.sqrt(np.mean(np.square(errors), axis=0)))


def arm_throughput(steps: int = 50_000) -> None:
    from lcgym.envs.arm_references import arm_reference_set

    train = arm_reference_set("train", 0, 8)
    venv = DummyVecEnv([lambda: gym.make("lcgym/FlexArm-v0", references=train) for _ in range(4)])
    model = PPO("MlpPolicy", venv, n_steps=1024, batch_size=1024, verbose=0, seed=0,
                policy_kwargs=dict(log_std_init=-2.0))
    t0 = time.perf_counter()
    model.learn(steps)
    seconds = time.perf_counter() - t0
    print(f"FlexArm-v0, 4 DummyVecEnv copies: {steps} PPO steps in {seconds:.0f} s ({steps / seconds:.0f} steps/s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", default="50000,500000,2000000")
    parser.add_argument("--no-error", action="store_true")
    parser.add_argument("--arm", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(1)
    if args.arm:
        arm_throughput()
        return
    train = reference_set("train", 0, 8, 40.0, 500.0)
    val = reference_set("validation", 0, 4, 40.0, 500.0)
    print(f"physical model alone: validation RMS {np.round(validation_rms(val), 4)} deg (propeller, roll)")
    for budget in map(int, args.budgets.split(",")):
        venv = make_sb3_vec_env("lcgym/IX-v0", num_envs=8, references=train, base_feedforward="physical")
        if args.no_error:
            venv = HideError(venv)
        model = PPO("MlpPolicy", venv, n_steps=1024, batch_size=1024, learning_rate=3e-4, gamma=0.99, verbose=0,
                    seed=0, policy_kwargs=dict(net_arch=[64, 64], log_std_init=-2.0))
        t0 = time.perf_counter()
        model.learn(budget)
        seconds = time.perf_counter() - t0
        rms = validation_rms(val, model, args.no_error)
        print(f"residual PPO{' (no error observed)' if args.no_error else ''}, {budget} env steps in {seconds:.0f} s "
              f"({budget / seconds:.0f} steps/s): validation RMS {np.round(rms, 4)} deg")


if __name__ == "__main__":
    main()
