"""Gymnasium's vector-env bookkeeping shared by the machines' batched vector envs (``IXVectorEnv``,
``FlexArmVectorEnv``): the autoreset modes, refusing a non-finite action before the kernel runs,
and the end of a step. A machine's class sets up its arrays and spaces, calls
``_init_batch(num_envs, autoreset_mode)``, and provides ``_restart(mask)`` (start the masked
sub-envs on a drawn reference, their first observation into ``self._obs``).

Autoreset (Gymnasium 1.x): ``AutoresetMode.NEXT_STEP`` (default): the step after an episode ends
resets that sub-env, ignores its action and returns its first observation with reward 0.
``AutoresetMode.SAME_STEP``: the sub-env resets within the step that ends it; the returned
observation is the new episode's first, the last one is in ``info["final_obs"]`` (mask
``info["_final_obs"]``). stable-baselines3 expects the latter (``envs.sb3.SB3VecAdapter``).
"""

from __future__ import annotations

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv


class BatchedVectorEnv(VectorEnv):
    """Base of the compiled vector envs; see the module docstring."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}
    label = "vector env"  # names the env in errors

    def _init_batch(self, num_envs: int, autoreset_mode: AutoresetMode | str) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        mode = AutoresetMode(autoreset_mode)
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode must be NEXT_STEP or SAME_STEP, got {mode}")
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.num_envs = num_envs
        self._autoreset = np.zeros(num_envs, dtype=np.bool_)
        self._started = False
        self._steps = 0  # vector steps since reset, named in errors

    def _restart(self, mask: np.ndarray) -> None:
        raise NotImplementedError

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._restart(np.ones(self.num_envs, dtype=np.bool_))
        self._autoreset[:] = False
        self._started = True
        self._steps = 0
        return self._obs.copy(), {}

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

    def _end_step(self, done: np.ndarray, infos: dict) -> None:
        """Autoreset after the kernel: ``done`` (N,) the sub-envs whose episode ended in this step."""
        if self.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP:
            if done.any():
                infos["final_obs"], infos["_final_obs"] = self._obs.copy(), done
                self._restart(done)
        else:
            if self._autoreset.any():
                self._restart(self._autoreset)
            self._autoreset = done
