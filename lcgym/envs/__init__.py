"""Gymnasium glue shared by the machines' environments: action checks (``actions.py``), the
stable-baselines3 adapters (``sb3.py``) and ``make_env``. The environments themselves live with
their machines (``systems/ix/env.py``, ``systems/flexarm/env.py``) and are registered on import of
lcgym (``systems.register_envs``): ``gym.make("lcgym/IX-v1")``.
"""

from __future__ import annotations

import gymnasium as gym


def make_env(env_id: str, **kwargs) -> gym.Env:
    """The registered env ``env_id`` built from its entry point with ``kwargs``, without the wrappers
    ``gym.make`` adds (the env checker, order enforcing): what the methods that train on an env use."""
    spec = gym.spec(env_id)
    entry = spec.entry_point
    if isinstance(entry, str):
        from gymnasium.envs.registration import load_env_creator

        entry = load_env_creator(entry)
    return entry(**{**spec.kwargs, **kwargs})


def env_takes(env_id: str, keyword: str) -> bool:
    """Whether the registered env ``env_id``'s entry point names the keyword ``keyword`` (a setting
    one machine's env has and another's has not: ``residual_bound`` on ``lcgym/Machine-v0``)."""
    import inspect

    entry = gym.spec(env_id).entry_point
    if isinstance(entry, str):
        from gymnasium.envs.registration import load_env_creator

        entry = load_env_creator(entry)
    try:
        return keyword in inspect.signature(entry).parameters
    except (TypeError, ValueError):
        return False
