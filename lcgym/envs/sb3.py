"""stable-baselines3 view of a machine's batched vector env (the IX's, the FlexArm's): one compiled
batch instead of N Python envs.

stable-baselines3's ``VecEnv`` resets a finished sub-env within the same step and hands the
last observation over as ``info["terminal_observation"]``; ``IXVectorEnv`` does the same with
``autoreset_mode=SAME_STEP`` (and ``FlexArmVectorEnv``), so this adapter mostly renames. It also keeps per-episode sums and
reports, in the info of the step that ends an episode, ``episode`` (return ``r``, length ``l``,
wall time ``t`` [s]: what stable-baselines3's ``Monitor`` reports, so its logger shows
``ep_rew_mean``) and ``tracking_rms``: the episode's RMS tracking error per axis [rad]. Build it
with ``make_sb3_vec_env``.

An env without a vector entry point goes into SB3's ``DummyVecEnv`` inside SB3's ``Monitor``,
which reports ``episode``; the env then reports ``tracking_rms`` itself at the episode's end.
``HideError``: zeroes the tracking error in the observations (a policy that sees only the
reference: a pure feedforward).
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from .hold import VecHoldAction, hold_samples


class SB3VecAdapter(VecEnv):
    """Wraps a vector env (``IXVectorEnv``, ``FlexArmVectorEnv``) built with
    ``autoreset_mode=AutoresetMode.SAME_STEP`` whose step info carries the tracking ``error`` (N, the
    scored axes)."""

    def __init__(self, venv):
        if venv.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError("SB3VecAdapter needs a vector env with autoreset_mode=AutoresetMode.SAME_STEP")
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions = None
        self._return, self._length = np.zeros(self.num_envs), np.zeros(self.num_envs, dtype=np.int64)
        self._sq_error = None  # sums over the open episodes, (N, scored axes) from the first step's info
        self._t0 = time.perf_counter()

    def _clear(self, mask: np.ndarray) -> None:
        self._return[mask], self._length[mask] = 0.0, 0
        if self._sq_error is not None:
            self._sq_error[mask] = 0.0

    def reset(self):
        seed = self._seeds[0] if self._seeds and self._seeds[0] is not None else None
        obs, _ = self.venv.reset(seed=seed)
        self._reset_seeds()
        self._clear(np.ones(self.num_envs, dtype=bool))
        return obs

    def step_async(self, actions):
        self._actions = np.asarray(actions)

    def step_wait(self):
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        done = terminated | truncated
        self._return += reward
        self._length += 1
        if self._sq_error is None:
            self._sq_error = np.zeros_like(info["error"], dtype=float)
        self._sq_error += np.square(info["error"])
        infos = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(done):
            infos[i]["terminal_observation"] = info["final_obs"][i]
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            infos[i]["episode"] = {"r": float(self._return[i]), "l": int(self._length[i]),
                                   "t": round(time.perf_counter() - self._t0, 6)}
            infos[i]["tracking_rms"] = np.sqrt(self._sq_error[i] / self._length[i])
        self._clear(done)
        return obs, reward.astype(np.float32), done, infos

    def close(self):
        self.venv.close()

    def get_attr(self, attr_name, indices=None):
        return [getattr(self.venv, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name, value, indices=None):
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result] * len(self._get_indices(indices))

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False] * len(self._get_indices(indices))


def make_sb3_vec_env(env_id: str = "lcgym/IX-v1", num_envs: int = 4, agent_rate: float | None = None,
                     **kwargs) -> SB3VecAdapter | VecHoldAction:
    """``gym.make_vec(env_id, num_envs, vector_entry_point, same-step autoreset)`` for stable-baselines3
    (default: the IX's newest version; 4 envs). ``agent_rate`` [Hz]: each action held so that the
    agent acts at that rate (``envs.hold``; ``AGENT_RATE``, 50 Hz, holds 10 samples on the IX and
    20 on the 1 kHz machines: what the recipe of docs/environments.md uses); ``None``, the
    default: an action every sample. With episodes of the default 1000 samples, PPO's first
    rollout (2048 agent steps per env) already ends episodes and logs them. ``kwargs`` go to the env."""
    venv = SB3VecAdapter(gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                                      autoreset_mode=AutoresetMode.SAME_STEP, **kwargs))
    samples = hold_samples(venv.venv, agent_rate)
    return venv if samples == 1 else VecHoldAction(venv, samples)


class HideError(VecEnvWrapper):
    """Zeroes the observation's tracking-error ``columns`` (``System.bench.observation_error``) in every
    observation of an SB3 vector env, terminal ones included."""

    def __init__(self, venv: VecEnv, columns: slice):
        super().__init__(venv)
        self.columns = columns

    def reset(self):
        obs = self.venv.reset()
        obs[:, self.columns] = 0.0
        return obs

    def step_wait(self):
        obs, reward, done, infos = self.venv.step_wait()
        obs[:, self.columns] = 0.0
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"][self.columns] = 0.0
        return obs, reward, done, infos
