"""Gymnasium's vector-env bookkeeping shared by the machines' batched vector envs (``IXVectorEnv``,
``FlexArmVectorEnv``, ``MachineVectorEnv``): the autoreset modes, the episode windows
(``envs.episodes``), refusing a non-finite action before the kernel runs, and the end of a step. A
machine's class sets up its arrays (``_k``: each sub-env's reference sample) and spaces, calls
``_init_batch(num_envs, autoreset_mode, episode_steps)``, and provides ``_restart(mask)`` (start
the masked sub-envs on a drawn reference, their first observation into ``self._obs``) and
``_reference_names()``.

Windows: a sub-env whose episode ends at its window's end (``_window_ends``) goes on with its run
in the next episode, from the same plant state and observation, instead of restarting; the
vector env's ``reset()`` restarts every sub-env.

Autoreset (Gymnasium 1.x): ``AutoresetMode.NEXT_STEP`` (default): the step after an episode ends
resets that sub-env, ignores its action and returns its first observation with reward 0.
``AutoresetMode.SAME_STEP``: the sub-env resets within the step that ends it; the returned
observation is the new episode's first, the last one is in ``info["final_obs"]`` (mask
``info["_final_obs"]``). stable-baselines3 expects the latter (``envs.sb3.SB3VecAdapter``).
"""

from __future__ import annotations

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from .episodes import checked_episode_steps, window_ends


class BatchedVectorEnv(VectorEnv):
    """Base of the compiled vector envs; see the module docstring."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}
    label = "vector env"  # names the env in errors

    def _init_batch(self, num_envs: int, autoreset_mode: AutoresetMode | str, episode_steps: int | None = None) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        mode = AutoresetMode(autoreset_mode)
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode must be NEXT_STEP or SAME_STEP, got {mode}")
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.num_envs = num_envs
        self._autoreset = np.zeros(num_envs, dtype=np.bool_)
        self._continue = np.zeros(num_envs, dtype=np.bool_)  # of those, the ones whose run goes on
        self.episode_steps = checked_episode_steps(episode_steps)
        self._k0 = np.zeros(num_envs, dtype=np.int64)  # the reference sample each sub-env's episode began at
        self._started = False
        self._steps = 0  # vector steps since reset, named in errors

    def _restart(self, mask: np.ndarray) -> None:
        raise NotImplementedError

    def _reference_names(self) -> np.ndarray:
        """The name of each sub-env's reference, (N,) object array."""
        raise NotImplementedError

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Every sub-env starts afresh on a drawn reference. Info: ``reference`` (their names) and
        ``action_scale`` (N, n), with Gymnasium's ``_key`` masks."""
        super().reset(seed=seed)
        every = np.ones(self.num_envs, dtype=np.bool_)
        self._restart(every)
        self._k0[:] = self._k
        self._autoreset[:] = False
        self._continue[:] = False
        self._started = True
        self._steps = 0
        info = {"reference": self._reference_names(), "_reference": every,
                "action_scale": np.tile(self.action_scale, (self.num_envs, 1)), "_action_scale": every}
        return self._obs.copy(), info

    def _window_ends(self, running: np.ndarray) -> np.ndarray:
        """Of the ``running`` sub-envs (stepped, not at their reference's end, not diverged), those
        whose episode ends now by its window."""
        return window_ends(self.episode_steps, self._k, self._k0, running)

    def _begin_step(self, a: np.ndarray) -> np.ndarray:
        """Checks before the kernel, which would step the sub-envs before a bad one: refuses a NaN or
        inf action of a sub-env that steps (the action of one that autoresets now is ignored).
        Returns the mask of the sub-envs that step. (The subclass's ``step`` checks first that reset
        was called, then the action's shape.)"""
        bad = np.flatnonzero(~np.isfinite(a).all(axis=1) & ~self._autoreset)
        if bad.size:
            i = int(bad[0])
            raise ValueError(f"{self.label}: action at step {self._steps} contains NaN or inf for sub-env {i} "
                             f"(its sample {self._k[i]}): {a[i].tolist()}")
        self._steps += 1
        return ~self._autoreset

    def _end_step(self, done: np.ndarray, infos: dict, window: np.ndarray | None = None) -> None:
        """Autoreset after the kernel: ``done`` (N,) the sub-envs whose episode ended in this step,
        ``window`` those of them that ended by the window (their run goes on)."""
        window = np.zeros_like(done) if window is None else window
        if self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP:
            if done.any():
                infos["final_obs"], infos["_final_obs"] = self._obs.copy(), done
                self._next_episode(done, window)
        else:
            if self._autoreset.any():
                self._next_episode(self._autoreset, self._continue)
            self._autoreset, self._continue = done, window

    def _next_episode(self, mask: np.ndarray, goes_on: np.ndarray) -> None:
        """The masked sub-envs begin their next episode: on the same run (``goes_on``) or afresh."""
        fresh = mask & ~goes_on
        if fresh.any():
            self._restart(fresh)
        self._k0[mask] = self._k[mask]
