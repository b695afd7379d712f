"""Gymnasium tracking environments of the IX C-arm: ``lcgym/IX-v1`` (and ``-v0``) and its batched vector env.

One episode tracks one reference of a reference set on the closed-loop IX plant of
``systems/ix/plant.py`` (500 Hz, fixed PD + low-pass feedback, hidden effects, quantized encoders). The
agent supplies the **feedforward**; the feedback loop runs inside the environment. One env step
is one control sample (2 ms).

Action (float32, shape (2,)): feedforward input of (propeller, roll) for the current sample,
    normalized: the env applies ``action * action_scale`` [V] (``normalize_actions=True``, the
    default, with bounds +-1; ``info["action_scale"]``, ``env.action_scale``), or the action in V
    as given (``normalize_actions=False``, bounds +-``action_scale``; ``envs.actions``).
    ``base_feedforward="none"``: the action is the feedforward, scale 5 V (the amplifier
    limit). ``base_feedforward="physical"``: the action is added to the rigid-model feedforward
    (``PhysicalModel`` fitted on feedback-only runs of the training references; residual
    learning), scale 1 V (``RESIDUAL_BOUND``; the fitted model already supplies up to about
    3 V). A fitted model itself (anything with ``predict(positions) -> (T, 2)`` [V], e.g. a
    benchmark cell's ``PhysicalModel``) may be given instead of "physical": residual learning on
    that model. Out-of-bound actions are clipped and counted (``info["clipped_actions"]``, per episode);
    NaN, inf, a wrong shape or non-numbers (strings, bool, complex) raise ``ValueError`` naming
    the step, before the plant moves. The total input is saturated at +-5 V by the plant.

Observation (float32, shape (36,)), all O(1); P = len(PREVIEW) = 5 preview points at 0, 10, 25,
    50 and 100 samples ahead (0-200 ms; beyond the reference end the last sample is repeated):
    - [0:10]   reference position, propeller then roll, at the P preview points / (pi/2 rad)
    - [10:20]  reference velocity, same layout / (20 deg/s)
    - [20:30]  reference acceleration, same layout / (40 deg/s^2)
    - [30:32]  relay of the reference velocity, paper 000 eq. (12) (+1, -1, or 0 before motion)
    - [32:34]  base feedforward of the current sample / 5 V (zero with base_feedforward="none")
    - [34:36]  tracking error e = reference - encoder reading / 0.5 deg, clipped to +-20

Reward: -1/2 sum over axes (e_i / 0.1 deg)^2 with e the tracking error measured at the next
    sample, i.e. the error the action helped to make (about -0.25 per step at 0.05 deg on both
    axes, -25 at 0.5 deg).

Episode end: ``truncated`` after ``episode_steps`` samples (default ``EPISODE_STEPS`` = 1000,
    2 s; the next reset goes on with the same run: ``envs.episodes``) or after the last sample of
    the reference (``episode_steps=None``: one episode per reference, what the benchmark
    scores); ``terminated`` only when the plant leaves its safe range (tracking error over 30 deg,
    speed over 1 rad/s, or a non-finite state; ``IXPlant.max_error`` / ``max_velocity``).

Info: per step the measured signals of the sample: ``pos`` (encoder reading [rad]), ``u``
    (total input [V]), ``ff`` (applied feedforward [V]), ``error`` (reference - encoder [rad]),
    ``clipped_actions`` (in the reference run so far); at the end of a reference run (single env)
    ``trial``: the whole run as a ``Trial``. The vector env gives the same per-step keys as
    (N, ...) arrays with Gymnasium's ``_key`` masks.

Reset: the reference is drawn with the env's seeded generator from the set, or chosen with
    ``options={"reference": i}``; the plant starts settled (held at the first reference sample
    for ``plant.preroll`` s, computed once per reference); or the open run goes on
    (``envs.episodes``). Info: ``reference`` (its name), ``sample`` (where the episode starts),
    ``action_scale`` [V], as on every lcgym env.

Render: ``render_mode="rgb_array"``: the references and tracking errors of the run so far, an RGB
    array; ``"human"``: the same in a matplotlib window (``envs.render``).

Arguments: ``references`` ("train", "validation", "test", "calibration" or a list of
    ``Reference`` / (T, 2) position arrays [rad]), ``reference_seed`` and ``n_references`` /
    ``duration`` of the generated set, ``base_feedforward``, ``plant`` (an ``IXPlant``; default
    the plant of ``version``), ``version`` ("v1" or "v0": ``IXPlant.of_version``; the registered
    ids set it), ``render_mode="rgb_array"``.

The vector env (``gym.make_vec("lcgym/IX-v1", num_envs=N, vectorization_mode="vector_entry_point")``)
steps N plants in one compiled call (parallel over plants), with Gymnasium's next-step autoreset.

Version History:
    - v1: the hidden effects and the feedback recalibrated so that the benchmark's machine-describing
      rows (feedback-only and physical-model tracking error, physical-model input residual) match
      paper 000's Tables II-V within 25 % (``studies/calibrate_ix.py``; ``plant.V1_SIZES``,
      ``plant.V1_GAINS``). Same effects, observation, action and reward as v0.
    - v0: the first release (``IXPlant()``'s defaults).
    - Both versions, after lcgym 0.2.0: actions normalized and episodes of ``EPISODE_STEPS`` samples by
      default (the plants unchanged); ``normalize_actions=False, episode_steps=None`` gives the
      earlier interface.
"""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from ...data import Trial
from ...envs.actions import action_space_of, checked_action
from ...envs.batched import BatchedVectorEnv
from ...envs.episodes import EPISODE_STEPS, Window, checked_episode_steps
from ...envs.render import HumanWindow, checked_render_mode, human_frame_due, render_episode, rendered
from ...physics.kinematics import reference_kinematics, reference_positions, relay
from ...physics.model import PhysicalModel
from ...physics.workspace import WORKSPACE
from ...references import Reference
from . import kernel as K
from .plant import IXPlant
from .references import reference_set

DEG = math.pi / 180
PREVIEW = (0, 10, 25, 50, 100)  # samples ahead
POS_SCALE, VEL_SCALE, ACC_SCALE = math.pi / 2, 20 * DEG, 40 * DEG
FF_SCALE = 5.0  # V
ERR_SCALE, ERR_CLIP = 0.5 * DEG, 20.0
REWARD_SCALE = 0.1 * DEG
RESIDUAL_BOUND = 1.0  # V, action bound with base_feedforward="physical"
OBS_BOUND = 25.0
N_OBS = 6 * len(PREVIEW) + 6  # 3 signals x 2 axes x P preview points, relay, base ff, error
IX_ACTION = "(propeller, roll) feedforward in V"

def physical_model(plant: IXPlant, seed: int = 0) -> PhysicalModel:
    """Rigid model fitted on feedback-only runs of the training references (kept per process,
    ``physics.workspace``)."""
    from . import IX

    key = (repr(plant), seed)
    models = WORKSPACE.slot("systems.ix.env_models", dict)
    if key not in models:
        models[key] = IX.physical_model(fs=plant.fs).fit(plant.run(reference_set("train", seed, fs=plant.fs)))
    return models[key]


def reference_features(positions: np.ndarray, fs: float, base_ff: np.ndarray) -> np.ndarray:
    """Observation columns [0:34] for every sample of one reference, float32 (T, 34)."""
    q, qd, qdd = reference_kinematics(positions, fs)
    T = q.shape[0]
    cols = []
    for signal, scale in ((q, POS_SCALE), (qd, VEL_SCALE), (qdd, ACC_SCALE)):
        for axis in range(2):
            for d in PREVIEW:
                idx = np.minimum(np.arange(T) + d, T - 1)
                cols.append(signal[idx, axis] / scale)
    feats = np.column_stack(cols + [relay(qd)[:, 0], relay(qd)[:, 1], base_ff[:, 0] / FF_SCALE, base_ff[:, 1] / FF_SCALE])
    return np.clip(feats, -OBS_BOUND, OBS_BOUND).astype(np.float32)  # stays in the space for any input


class IXTask:
    """What the single and the vector env share: the plant, the references (padded to one length)
    with their observation features and base feedforward, and each reference's settled start."""

    def __init__(self, references, base_feedforward, plant: IXPlant | None, reference_seed: int,
                 n_references: int | None, duration: float, version: str = "v1", normalize_actions: bool = True):
        if isinstance(base_feedforward, str) and base_feedforward not in ("none", "physical"):
            raise ValueError(f"base_feedforward must be 'none', 'physical' or a fitted model, got {base_feedforward!r}")
        if not isinstance(base_feedforward, str) and not callable(getattr(base_feedforward, "predict", None)):
            raise ValueError(f"base_feedforward must be 'none', 'physical' or a fitted model with predict(positions), "
                             f"got {type(base_feedforward).__name__}")
        self.plant = plant if plant is not None else IXPlant.of_version(version)
        fs = self.plant.fs
        if isinstance(references, str):
            refs = reference_set(references, reference_seed, n_references, duration, fs)
        elif isinstance(references, Reference) or (isinstance(references, np.ndarray) and references.ndim == 2):
            refs = [references]  # one reference given on its own
        else:
            refs = list(references)
            if not refs:
                raise ValueError("references: empty list")
        self.names = [r.name if isinstance(r, Reference) else f"reference-{i}" for i, r in enumerate(refs)]
        positions = [reference_positions(r) for r in refs]
        for name, x in zip(self.names, positions, strict=True):
            if x.ndim != 2 or x.shape[1] != 2 or x.shape[0] < 3 or not np.all(np.isfinite(x)):
                raise ValueError(f"{name}: a reference must be a finite (T >= 3, 2) array of positions [rad], "
                                 f"got shape {x.shape}")
            if np.max(np.abs(x)) > 2 * np.pi:
                warnings.warn(f"{name}: reference reaches {np.max(np.abs(x)):.3g}, beyond 2 pi: it looks like degrees; "
                              "lcgym reads rad", stacklevel=3)
        if isinstance(base_feedforward, str):
            model = physical_model(self.plant, reference_seed) if base_feedforward == "physical" else None
            self.base_feedforward = base_feedforward
        else:
            model, self.base_feedforward = base_feedforward, "physical (given model)"
        self.bound = RESIDUAL_BOUND if model is not None else self.plant.gains.u_max
        self.action_space, self.action_scale = action_space_of(self.bound, 2, normalize_actions)
        R, T = len(positions), max(x.shape[0] for x in positions)
        self.lengths = np.array([x.shape[0] for x in positions], dtype=np.int64)
        self.ref_pos = np.zeros((R, T, 2))
        self.base_ff = np.zeros((R, T, 2))
        self.feats = np.zeros((R, T, N_OBS - 2), dtype=np.float32)
        for r, x in enumerate(positions):
            n = x.shape[0]
            self.ref_pos[r, :n], self.ref_pos[r, n:] = x, x[-1]
            if model is not None:
                self.base_ff[r, :n] = model.predict(x)
            self.feats[r, :n] = reference_features(x, fs, self.base_ff[r, :n])
        p = self.plant
        self.kernel_args = (p._p, p._E, p._C, p._cfg)
        self.scales = np.array([ERR_SCALE, ERR_CLIP, REWARD_SCALE, self.bound])
        # settled start of every reference, and the first observation's error columns
        self.start = np.zeros((R, K.N_LOOP))
        self.start_error = np.zeros((R, 2), dtype=np.float32)
        work, y = np.empty((K.N_WORK, K.N_STATE)), np.empty(2)
        for r in range(R):
            K.settle(self.start[r], self.ref_pos[r, 0], self.base_ff[r, 0], p.preroll_samples, *self.kernel_args, work)
            K.sensor(self.start[r], p._E, p._cfg, y)
            e = self.ref_pos[r, 0] - y
            self.start_error[r] = np.clip(e / ERR_SCALE, -ERR_CLIP, ERR_CLIP)

    @property
    def n_references(self) -> int:
        return len(self.names)

    def spaces(self) -> tuple[gym.spaces.Box, gym.spaces.Box]:
        return gym.spaces.Box(-OBS_BOUND, OBS_BOUND, (N_OBS,), np.float32), self.action_space

    def first_observation(self, r: int) -> np.ndarray:
        return np.concatenate([self.feats[r, 0], self.start_error[r]])


class IXEnv(gym.Env):
    """IX tracking environment, one plant; see the module docstring for spaces, reward and ends."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(self, references="train", base_feedforward="none", reference_seed: int = 0,
                 n_references: int | None = None, duration: float = 40.0, plant: IXPlant | None = None,
                 render_mode: str | None = None, version: str = "v1", normalize_actions: bool = True,
                 episode_steps: int | None = EPISODE_STEPS):
        self.render_mode = checked_render_mode(render_mode)
        self._window = Window(checked_episode_steps(episode_steps))
        self.task = IXTask(references, base_feedforward, plant, reference_seed, n_references, duration, version,
                           normalize_actions)
        self.observation_space, self.action_space = self.task.spaces()
        self.action_scale = self.task.action_scale
        self._human = HumanWindow(self.metadata["render_fps"]) if render_mode == "human" else None
        T = self.task.ref_pos.shape[1]
        self._st = np.zeros((1, K.N_LOOP))
        self._work = np.zeros((1, K.N_WORK, K.N_STATE))
        self._ref_idx = np.zeros(1, dtype=np.int64)
        self._k = np.zeros(1, dtype=np.int64)
        self._obs = np.zeros((1, N_OBS), dtype=np.float32)
        self._reward = np.zeros(1)
        self._status = np.zeros(1, dtype=np.int64)
        self._clipped = np.zeros(1, dtype=np.int64)
        self._sig = np.zeros((1, K.N_ENV_SIG))
        self._active = np.ones(1, dtype=np.bool_)
        self._record = np.zeros((T, K.N_ENV_SIG))
        self._action = np.zeros((1, 2))
        self._started = False

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if self._window.continues(seed, options):  # the open run goes on in a new window
            self._window.start, self._window.run_open, self._started = int(self._k[0]), False, True
            return self._obs[0].copy(), self._reset_info()
        r = (options or {}).get("reference")
        if r is None:
            r = int(self.np_random.integers(self.task.n_references))
        elif not 0 <= int(r) < self.task.n_references:
            raise ValueError(f"options['reference'] must be in 0..{self.task.n_references - 1}, got {r}")
        r = int(r)
        self._ref_idx[0], self._k[0], self._clipped[0] = r, 0, 0
        self._st[0] = self.task.start[r]
        self._obs[0] = self.task.first_observation(r)
        self._window.start, self._window.run_open, self._started = 0, False, True
        if human_frame_due(self.render_mode, 0, True):
            self.render()
        return self._obs[0].copy(), self._reset_info()

    def _reset_info(self) -> dict:
        return {"reference": self.task.names[int(self._ref_idx[0])], "sample": int(self._k[0]),
                "action_scale": self.action_scale.copy()}

    def step(self, action):
        if not self._started:
            raise RuntimeError("IX env: call reset() before step()")
        t = self.task
        k = int(self._k[0])
        self._action[0] = checked_action(action, (2,), "IX env", k, IX_ACTION) * t.action_scale
        K.env_step_serial(self._active, self._st, self._work, t.ref_pos, t.feats, t.base_ff, t.lengths, self._ref_idx,
                          self._k, self._action, t.scales, *t.kernel_args, self._obs, self._reward, self._status,
                          self._clipped, self._sig)
        status = self._status[0]
        if status == K.ENV_BAD_ACTION:
            raise ValueError(f"IX env: action {self._action[0].tolist()} at step {k} is NaN or inf")
        sig = self._sig[0].copy()  # the info's arrays are views of this fresh copy
        self._record[k] = sig
        terminated = status == K.ENV_DIVERGED
        run_ended = terminated or k + 1 >= t.lengths[self._ref_idx[0]]
        window_ended = not run_ended and self._window.ends(k + 1)
        truncated = (run_ended or window_ended) and not terminated
        info = {
            "pos": sig[K.SIG_Y : K.SIG_Y + 2],
            "u": sig[K.SIG_U : K.SIG_U + 2],
            "ff": sig[K.SIG_FF : K.SIG_FF + 2],
            "error": sig[K.SIG_ERR : K.SIG_ERR + 2],
            "clipped_actions": int(self._clipped[0]),
        }
        if run_ended:
            info["trial"] = self.episode_trial()
        if run_ended or window_ended:
            self._started, self._window.run_open = False, window_ended
        if human_frame_due(self.render_mode, k + 1, run_ended or window_ended):
            self.render()
        return self._obs[0].copy(), float(self._reward[0]), bool(terminated), bool(truncated), info

    def episode_trial(self) -> Trial:
        """The episode so far as a Trial (reference, encoder, input, feedforward, true load angle)."""
        t, r, n = self.task, int(self._ref_idx[0]), int(self._k[0])
        rec = self._record[:n]
        return Trial(
            t=np.arange(n) / t.plant.fs, ref=t.ref_pos[r, :n], pos=rec[:, K.SIG_Y : K.SIG_Y + 2],
            u=rec[:, K.SIG_U : K.SIG_U + 2], ff=rec[:, K.SIG_FF : K.SIG_FF + 2], axes=t.plant.axes,
            extra={f"load_{ax}": rec[:, K.SIG_LOAD + i].copy() for i, ax in enumerate(t.plant.axes)},
            meta={"system": "ix", "reference": t.names[r], "base_feedforward": t.base_feedforward,
                  "clipped_actions": int(self._clipped[0])},
        )

    def render(self):
        """The references and tracking errors of the run so far (module docstring, Render)."""
        return rendered(self.render_mode, self._human, lambda: render_episode(
            self.episode_trial() if self._k[0] > 0 else None, self.task.names[int(self._ref_idx[0])], self.task.plant.axes))

    def close(self):
        if self._human is not None:
            self._human.close()


class IXVectorEnv(BatchedVectorEnv):
    """N IX plants stepped at once in compiled code (parallel over plants). Autoreset: both of
    Gymnasium's modes (``envs.batched``: NEXT_STEP by default, SAME_STEP for stable-baselines3)."""

    label = "IX vector env"

    def __init__(self, num_envs: int = 1, references="train", base_feedforward="none",
                 reference_seed: int = 0, n_references: int | None = None, duration: float = 40.0,
                 plant: IXPlant | None = None, render_mode: str | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, version: str = "v1",
                 normalize_actions: bool = True, episode_steps: int | None = EPISODE_STEPS):
        self._init_batch(num_envs, autoreset_mode, episode_steps)
        if render_mode is not None:
            raise ValueError("the IX vector env does not render; use the single env")
        self.task = IXTask(references, base_feedforward, plant, reference_seed, n_references, duration, version,
                           normalize_actions)
        self.single_observation_space, self.single_action_space = self.task.spaces()
        self.action_scale = self.task.action_scale
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        N = num_envs
        self._st = np.zeros((N, K.N_LOOP))
        self._work = np.zeros((N, K.N_WORK, K.N_STATE))
        self._ref_idx = np.zeros(N, dtype=np.int64)
        self._k = np.zeros(N, dtype=np.int64)
        self._obs = np.zeros((N, N_OBS), dtype=np.float32)
        self._reward = np.zeros(N)
        self._status = np.zeros(N, dtype=np.int64)
        self._clipped = np.zeros(N, dtype=np.int64)
        self._sig = np.zeros((N, K.N_ENV_SIG))
        self._kernel = K.env_step_parallel if N >= 16 else K.env_step_serial

    def _restart(self, mask: np.ndarray) -> None:
        idx = np.flatnonzero(mask)
        r = self.np_random.integers(self.task.n_references, size=idx.size)
        self._ref_idx[idx], self._k[idx], self._clipped[idx] = r, 0, 0
        self._st[idx] = self.task.start[r]
        self._obs[idx, :-2] = self.task.feats[r, 0]
        self._obs[idx, -2:] = self.task.start_error[r]

    def _reference_names(self) -> np.ndarray:
        return np.array(self.task.names, dtype=object)[self._ref_idx]

    def step(self, actions):
        if not self._started:
            raise RuntimeError("IX vector env: call reset() before step()")
        a = checked_action(actions, (self.num_envs, 2), "IX vector env", self._steps,
                           f"{IX_ACTION}, one row per sub-env")
        a = a.astype(np.float64, copy=False) * self.task.action_scale
        active = self._begin_step(a)
        t = self.task
        self._kernel(active, self._st, self._work, t.ref_pos, t.feats, t.base_ff, t.lengths, self._ref_idx, self._k,
                     a, t.scales, *t.kernel_args, self._obs, self._reward, self._status, self._clipped, self._sig)
        terminated = active & (self._status == K.ENV_DIVERGED)
        truncated = active & ~terminated & (self._k >= t.lengths[self._ref_idx])
        window = self._window_ends(active & ~terminated & ~truncated)
        truncated |= window
        reward = np.where(active, self._reward, 0.0)
        infos = {
            "pos": self._sig[:, K.SIG_Y : K.SIG_Y + 2].copy(),
            "u": self._sig[:, K.SIG_U : K.SIG_U + 2].copy(),
            "ff": self._sig[:, K.SIG_FF : K.SIG_FF + 2].copy(),
            "error": self._sig[:, K.SIG_ERR : K.SIG_ERR + 2].copy(),
            "clipped_actions": self._clipped.copy(),
        }
        for key in ("pos", "u", "ff", "error", "clipped_actions"):  # Gymnasium's vector-info masks: which sub-envs stepped
            infos[f"_{key}"] = active
        self._end_step(terminated | truncated, infos, window)
        return self._obs.copy(), reward, terminated, truncated, infos
