"""The one check of an agent's action, shared by the IX and FlexArm environments.

An action must be real numbers (a float or integer array) of the env's action shape. Strings,
booleans, complex numbers or Python objects are refused before numpy would convert them
silently (a complex action would lose its imaginary part, ``True`` would become 1 V) or fail
with a message that names neither the env nor the step. NaN and inf are checked by each env
next to the physics (the IX kernel refuses them in its loop).

Normalized actions (``action_space_of``): by default every lcgym env's action space is [-1, 1] per
axis, the convention of stable-baselines3 (its ``check_env`` warns otherwise, and its Gaussian
policies start with a unit standard deviation) and of most agents; the env multiplies the action
by its ``action_scale`` (the bound in machine units: V, N m or N) before anything else.
``normalize_actions=False`` gives the action in machine units, bounded by the same scale.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

NUMERIC_KINDS = "fiu"  # float, signed and unsigned integer


def checked_action(action, shape: tuple[int, ...], env: str, step: int, what: str) -> np.ndarray:
    """``action`` as an array of ``shape``; ValueError naming ``env``, ``step`` and the fault if not.

    ``what`` describes one action in words and units, e.g. "(propeller, roll) feedforward in V".
    """
    a = np.asarray(action)
    if a.dtype.kind not in NUMERIC_KINDS:
        raise ValueError(
            f"{env}: action at step {step} must be real numbers, {what}; got dtype {a.dtype}: {short_repr(action)}"
        )
    if a.shape != shape:
        raise ValueError(f"{env}: action at step {step} must have shape {shape}, {what}; got shape {a.shape}")
    return a


def short_repr(value, width: int = 80) -> str:
    """``repr(value)`` on one line (numpy's line breaks folded) and at most ``width`` characters."""
    text = " ".join(repr(value).split())
    return text if len(text) <= width else text[: width - 3] + "..."


def action_space_of(bound, n: int, normalize: bool) -> tuple[gym.spaces.Box, np.ndarray]:
    """(action space, scale (n,)): [-1, 1]^n and the bound [machine units] per axis with
    ``normalize``; else the bound itself as the space and a scale of ones (the action is applied
    as given: ``action * scale`` is then the action, bit for bit)."""
    bound = np.broadcast_to(np.asarray(bound, dtype=float), (n,)).copy()
    if normalize:
        return gym.spaces.Box(-1.0, 1.0, (n,), np.float32), bound
    return gym.spaces.Box(-bound.astype(np.float32), bound.astype(np.float32), dtype=np.float32), np.ones(n)
