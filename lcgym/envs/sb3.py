"""stable-baselines3 view of the IX vector env: one compiled batch instead of N Python envs.

stable-baselines3's ``VecEnv`` resets a finished sub-env within the same step and hands the
last observation over as ``info["terminal_observation"]``; ``IXVectorEnv`` does the same with
``autoreset_mode=SAME_STEP``, so this adapter only renames. Build it with ``make_sb3_vec_env``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv


class SB3VecAdapter(VecEnv):
    """Wraps an ``IXVectorEnv`` built with ``autoreset_mode=AutoresetMode.SAME_STEP``."""

    def __init__(self, venv):
        if venv.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError("SB3VecAdapter needs a vector env with autoreset_mode=AutoresetMode.SAME_STEP")
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions = None

    def reset(self):
        seed = self._seeds[0] if self._seeds and self._seeds[0] is not None else None
        obs, _ = self.venv.reset(seed=seed)
        self._reset_seeds()
        return obs

    def step_async(self, actions):
        self._actions = np.asarray(actions)

    def step_wait(self):
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        done = terminated | truncated
        infos = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(done):
            infos[i]["terminal_observation"] = info["final_obs"][i]
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
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


def make_sb3_vec_env(env_id: str = "lcgym/IX-v0", num_envs: int = 8, **kwargs) -> SB3VecAdapter:
    """``gym.make_vec(env_id, num_envs, vector_entry_point, same-step autoreset)`` for stable-baselines3."""
    venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
    return SB3VecAdapter(venv)
