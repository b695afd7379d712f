"""Episodes an agent learns from: windows of ``episode_steps`` samples of a reference run.

A reference is 20-40 s of motion, 10,000-40,000 control samples: as one episode, an agent's first
episodes end after hundreds of thousands of steps, and stable-baselines3 logs nothing until then.
Every lcgym env therefore cuts its reference runs into **windows** of ``episode_steps`` samples
(``EPISODE_STEPS`` by default; ``episode_steps=None``: the whole reference, what the benchmark
scores). A window's end is a time limit (``truncated``, never ``terminated``): the plant is still
on its reference. The next ``reset()`` without a seed and without options goes on with the same
run, from the same plant state, in a new window; after the reference's last sample (or a plant
that left its safe range), ``reset()`` draws a new reference and starts it settled. ``reset(seed=...)``
or ``reset(options={"reference": i})`` always starts afresh. The reset info says which:
``"sample"`` is the reference sample the episode starts at (0 for a fresh start).

So an agent meets every part of every reference (not only their first seconds), in the plant
state its own actions led to, and the whole-reference run stays available: ``info["trial"]`` at
the end of a reference covers the run from its first sample.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np

EPISODE_STEPS = 1000
"""Samples per episode by default: 2 s on the IX (500 Hz), 1 s on the FlexArm and a machine file's
arm at 1 kHz. With stable-baselines3's PPO defaults (2048 steps per env and rollout) every env
ends at least two episodes in each rollout."""


def checked_episode_steps(value) -> int | None:
    """``value`` as a positive int, or None (whole references); ValueError otherwise."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"episode_steps must be a positive integer or None (whole references), got {value!r}")
    return int(value)


@dataclass
class Window:
    """A single env's window: ``steps`` per episode (None: whole references), the reference sample
    the episode started at, and whether the run can go on at the next reset (the last episode ended
    at a window's end, not at the reference's end or by leaving the safe range)."""

    steps: int | None
    start: int = 0
    run_open: bool = False

    def ends(self, k: int) -> bool:
        """Whether the episode ends by its window after the step that reached reference sample k."""
        return self.steps is not None and k - self.start >= self.steps

    def continues(self, seed, options) -> bool:
        """Whether ``reset(seed, options)`` goes on with the open run (module docstring)."""
        return self.run_open and seed is None and not options


def window_ends(steps: int | None, k: np.ndarray, k0: np.ndarray, running: np.ndarray) -> np.ndarray:
    """Vector envs: which of the ``running`` sub-envs (not at their reference's end, not diverged)
    end their episode by the window, at reference sample ``k`` of an episode begun at ``k0``."""
    if steps is None:
        return np.zeros_like(running)
    return running & (k - k0 >= steps)
