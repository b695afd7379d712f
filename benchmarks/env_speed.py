"""Step rates of the IX environments, measured in one run against Gymnasium's Pendulum-v1.

Prints:
* single-env steps/s of ``gym.make("lcgym/IX-v0")`` and of ``gym.make("Pendulum-v1")`` (both with
  the wrappers gym.make adds), and their ratio;
* vector-env env-steps/s of ``gym.make_vec("lcgym/IX-v0", num_envs=N,
  vectorization_mode="vector_entry_point")`` at N = 1, 64, 1024, and the ratio to Pendulum.

Actions are random within the action space, drawn before timing. The machine is shared and its
speed drifts, so Pendulum and IX single-env timings are interleaved over five rounds and each
rate is the best round (the least disturbed); vector rates are the best of five, after a warm-up.

Run:  .venv/bin/python benchmarks/env_speed.py
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import lcgym  # noqa: F401  (registers lcgym/IX-v0)


class SingleEnvTimer:
    """Times env.step on pre-drawn random actions, resetting at episode ends."""

    def __init__(self, env_id: str, steps: int, **kwargs):
        self.env = gym.make(env_id, **kwargs)
        self.env.reset(seed=0)
        shape = self.env.action_space.shape
        self.actions = np.random.default_rng(0).uniform(-1, 1, (steps, *shape)).astype(np.float32)
        self.best = 0.0
        for a in self.actions[:200]:  # warm-up: compilation, the checker's first-step tests
            self.env.step(a)

    def run_once(self) -> None:
        env = self.env
        env.reset(seed=0)
        t0 = time.perf_counter()
        for a in self.actions:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()
        self.best = max(self.best, len(self.actions) / (time.perf_counter() - t0))


def vector_rate(num_envs: int, env_steps: int) -> float:
    venv = gym.make_vec("lcgym/IX-v0", num_envs=num_envs, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    n = max(50, env_steps // num_envs)
    actions = np.random.default_rng(0).uniform(-1, 1, (n, num_envs, 2))
    for a in actions[: max(10, n // 3)]:  # warm-up: thread pool, first touches of the state arrays
        venv.step(a)
    best = 0.0
    for _ in range(5):
        t0 = time.perf_counter()
        for a in actions:
            venv.step(a)
        best = max(best, n * num_envs / (time.perf_counter() - t0))
    return best


def main() -> None:
    timers = [SingleEnvTimer("Pendulum-v1", 20_000), SingleEnvTimer("lcgym/IX-v0", 20_000)]
    for _ in range(5):
        for timer in timers:
            timer.run_once()
    pendulum, ix = (t.best for t in timers)
    print(f"single env   Pendulum-v1 : {pendulum:12,.0f} steps/s")
    print(f"single env   lcgym/IX-v0 : {ix:12,.0f} steps/s   ratio to Pendulum-v1: {ix / pendulum:.2f}")
    for n in (1, 64, 1024):
        rate = vector_rate(n, 1_000_000 if n > 1 else 20_000)
        print(f"vector env   N = {n:5d}    : {rate:12,.0f} env-steps/s   ratio to Pendulum-v1: {rate / pendulum:.1f}")


if __name__ == "__main__":
    main()
