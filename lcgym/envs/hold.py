"""An agent slower than the plant: each action held for several control samples (frame skip).

Every lcgym env steps one control sample per action (2 ms on the IX, 1 ms on the arms and the
EMPS). An agent that acts that often must assign credit through the closed loop over hundreds of
steps: PPO's discount 0.99 weighs about 100 samples, 0.2 s on the IX, and one sample's action
barely moves the next error. Measured with stable-baselines3's PPO, all defaults, on the IX-v1
residual (``studies/rl_recipe.py``, docs/environments.md): acting on every sample, the
deterministic policy's validation return wanders between 0.84 and 1.39 times the base
feedforward's; holding each action for 10 samples (the agent at 50 Hz), it rises to 0.27 times the
base's within 65,536 agent steps. The feedforward a machine needs is smooth (the references are),
so 50 Hz loses little; the tracking error is still scored on every sample. Not on a flexible arm,
whose residual shapes resonances near the hold's rate (the FlexArm: every sample).

``HoldAction`` wraps a single env, ``VecHoldAction`` a stable-baselines3 vector env: one agent step
applies the action on ``samples`` consecutive samples and returns the last observation and the
sum of the samples' rewards (the usual frame-skip convention). An episode that ends inside a hold
ends the agent step there. ``hold_samples(env)``: the samples per action for ``AGENT_RATE``. An env
that holds an action itself, in one call (``step_held(action, samples)``, the same steps: a URDF
machine's env runs them in compiled code), is asked to when ``HoldAction`` wraps it directly.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper

AGENT_RATE = 50.0
"""Hz: the rate at which the recipe's and the benchmark's agents act (``hold_samples``)."""


def sample_rate(env) -> float:
    """The control sample rate [Hz] of an lcgym env, single or vector (its plant's ``fs``)."""
    inner = getattr(env, "unwrapped", env)
    plant = getattr(inner, "plant", None) or getattr(getattr(inner, "task", None), "plant", None)
    if plant is None or not getattr(plant, "fs", None):
        raise ValueError(f"{type(inner).__name__} has no plant with a sample rate fs: give the hold in samples")
    return float(plant.fs)


def samples_per_action(fs: float, agent_rate: float | None = AGENT_RATE) -> int:
    """Samples per agent action so that an agent acts at about ``agent_rate`` [Hz] on a plant
    sampled at ``fs`` [Hz] (at least 1; ``None``: 1, an action every sample)."""
    if agent_rate is None:
        return 1
    if not (np.isfinite(agent_rate) and agent_rate > 0):
        raise ValueError(f"agent_rate must be a rate > 0 in Hz or None, got {agent_rate!r}")
    return max(1, round(fs / agent_rate))


def hold_samples(env, agent_rate: float | None = AGENT_RATE) -> int:
    """``samples_per_action`` on an lcgym env, single or vector (its plant's rate)."""
    return 1 if agent_rate is None else samples_per_action(sample_rate(env), agent_rate)


def _checked_samples(samples) -> int:
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ValueError(f"samples: an integer >= 1 (control samples per action), got {samples!r}")
    return int(samples)


class HoldAction(gym.Wrapper):
    """A single env whose every action is applied on ``samples`` consecutive control samples.

    ``step`` returns the last sample's observation, ``terminated``, ``truncated`` and info (with
    ``held_samples``: how many samples this action was applied), and the sum of the samples'
    rewards. It stops early where the episode ends inside the hold."""

    def __init__(self, env: gym.Env, samples: int):
        super().__init__(env)
        self.samples = _checked_samples(samples)

    def step(self, action):
        if hasattr(type(self.env), "step_held"):  # the env holds the action itself (a URDF machine's: compiled)
            return self.env.step_held(action, self.samples)
        total, held = 0.0, 0
        while held < self.samples:
            obs, reward, terminated, truncated, info = self.env.step(action)
            total, held = total + float(reward), held + 1
            if terminated or truncated:
                break
        info = dict(info, held_samples=held)
        return obs, total, terminated, truncated, info


class VecHoldAction(VecEnvWrapper):
    """A stable-baselines3 vector env whose every action is applied on ``samples`` consecutive
    control samples: the last observations and the summed rewards. A vector env steps all its
    envs together, so where any env's episode ends inside the hold, the agent step ends there for
    all (the others' next action then starts early; with ``make_sb3_vec_env``'s episodes of 1000
    samples, a multiple of the hold, they end together)."""

    def __init__(self, venv, samples: int):
        super().__init__(venv)
        self.samples = _checked_samples(samples)
        self.samples_run = 0  # control samples stepped, over all envs
        self._actions = None

    def reset(self):
        return self.venv.reset()

    def step_async(self, actions):
        self._actions = actions

    def step_wait(self):
        total = np.zeros(self.num_envs, dtype=np.float32)
        for _ in range(self.samples):
            self.venv.step_async(self._actions)
            obs, reward, done, infos = self.venv.step_wait()
            total += reward
            self.samples_run += self.num_envs
            if np.any(done):
                break
        return obs, total, done, infos
