"""Gymnasium tracking environment of any benchmark machine with a URDF plant: ``lcgym/Machine-v0``.

    env = gym.make("lcgym/Machine-v0", machine="my_arm.toml")          # a machine file
    venv = gym.make_vec("lcgym/Machine-v0", num_envs=4, machine="my_arm.toml",
                        vectorization_mode="vector_entry_point")

One episode tracks one reference of a reference set on the machine's closed-loop plant
(``URDFPlant``: the URDF's rigid body, the machine file's hidden effects, its feedback, encoders
and input limits; ``systems/machine.py``). The agent supplies the **feedforward**; the feedback
loop runs inside the environment. One env step is one control sample (1 / fs).

Action (float32, shape (n,), n the machine's axes): the feedforward of each axis for the current
    sample, normalized: the env applies ``action * action_scale`` [N m or N]
    (``normalize_actions=True``, the default, bounds +-1; ``info["action_scale"]``,
    ``env.action_scale``), or the action in machine units as given (``normalize_actions=False``,
    bounds +-``action_scale``; ``envs.actions``). ``base_feedforward="none"``: the action is the
    feedforward, scale u_scale (the input limit; 1 where the machine has none). ``"physical"``: the
    action is added to the rigid-model feedforward (``PhysicalModel`` fitted on feedback-only runs
    of the training references), scale: the peak of what the feedback supplies along the base's runs
    of the env's references (``base_scales``: what the base leaves the loop; a fixed 0.2 x the input
    limit drowned what there was to learn in its exploration). A fitted model (anything with
    ``predict(positions) -> (T, n)``) may be given instead: residual learning on that model. Either
    base carries what the loop needs to track exactly (minus ``URDFPlant.reference_feedback``: a
    velocity loop's velocity feedforward, ``methods.loop``). ``residual_bound`` [N m or N, one value or
    one per axis] replaces the residual's scale (a learner's own, ``methods.rl``: the same peak along
    its training references).
    Out-of-bound actions are clipped and counted (``info["clipped_actions"]``); NaN, inf, a wrong
    shape or non-numbers raise ``ValueError`` naming the step, before the plant moves.

Observation (float32, shape (3 n P + 3 n,)), all O(1); P = len(PREVIEW) preview points at 0, 10,
    25, 50 and 100 ms ahead (beyond the reference end the last sample is repeated):
    - reference position per axis at the P points, (q - centre of the joint range) / half the range
    - reference velocity, same layout / the references' speed limit of the axis
    - reference acceleration, same layout / (that speed / ``ReferenceSettings.accel_time``)
    - relay of the reference velocity, paper 000 eq. (12) (+1, -1, or 0 before motion), per axis
    - base feedforward of the current sample / u_scale, per axis
    - tracking error e = reference - encoder reading / ``ERR_SCALE`` (0.5 deg or 0.5 mm; with a base and
      no scales given, 5x the base's RMS error on the axis: Reward), clipped to +-20

Reward: -1/2 sum over axes (e_i / s_i)^2, s_i = ``REWARD_SCALE`` (0.1 deg or 0.1 mm), e the tracking
    error measured at the next sample (the error the action helped to make); the step that leaves
    the safe range gets -1/2 n ``ERR_CLIP``^2. ``axis_errors`` b [rad or m, one per axis] balances
    the axes: s_i = b_i / geomean_j(b_j / REWARD_SCALE_j), so that each axis's error counts alike
    against those, at the same overall scale (one axis: s = REWARD_SCALE). With a base and neither
    ``axis_errors`` nor ``residual_bound`` given, the machine sets the scales: s_i is the base's own
    RMS tracking error on axis i over the env's references (``base_scales``: the base scores -1/2 per
    axis and sample, as the IX's 0.1 deg is about its physical model's error), and the observed
    error's scale is 5 s_i (the IX's 0.5 deg); without a base, s = REWARD_SCALE.

Episode end: ``truncated`` after ``episode_steps`` samples (default ``EPISODE_STEPS`` = 1000;
    the next reset goes on with the same run: ``envs.episodes``) or after the last sample of the
    reference (``episode_steps=None``: one episode per reference, what the benchmark scores);
    ``terminated`` when the plant leaves its safe range (a tracking error over ``max_error`` or a
    non-finite state).

Info: per step ``pos`` (encoder [rad or m]), ``u`` (total input), ``ff`` (applied feedforward),
    ``error`` (reference - encoder), ``clipped_actions``; at the end of a reference run (single
    env) ``trial``, the run as a ``Trial``, and ``tracking_rms`` (RMS tracking error per axis).
    The vector env gives the per-step keys as (N, ...) arrays with Gymnasium's ``_key`` masks.

Reset: the reference is drawn with the env's seeded generator, or chosen with
    ``options={"reference": i}``; the plant starts settled (held at the first reference sample for
    ``plant.preroll`` s, computed once per reference); or the open run goes on
    (``envs.episodes``). Info: ``reference`` (its name), ``sample`` (where the episode starts),
    ``action_scale``, as on every lcgym env.

Render: ``render_mode="rgb_array"``: the references and tracking errors of the run so far, an RGB
    array; ``"human"``: the same in a matplotlib window (``envs.render``).

Arguments: ``machine`` (a machine file, a URDF, ``module:attr`` or a ``System``: what
    ``systems.resolve`` takes; or give ``plant``), ``references`` ("train", "validation", "test",
    or a list of ``Reference`` / (T, n) position arrays), ``reference_seed``, ``n_references`` (8)
    and ``duration`` (20 s) of a generated set, ``base_feedforward``, ``plant`` (a ``URDFPlant``),
    ``version`` ("v0", the only one), ``render_mode``, ``normalize_actions``, ``episode_steps``,
    ``residual_bound``, ``axis_errors``.

Version History:
    - v0: the first release.
    - v0, after lcgym 0.2.0: actions normalized and episodes of ``EPISODE_STEPS`` samples by default (the
      plants unchanged); ``normalize_actions=False, episode_steps=None`` gives the earlier interface.
"""

from __future__ import annotations

import copy
import math

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from ..data import Trial
from ..envs.actions import action_space_of, checked_action
from ..envs.batched import BatchedVectorEnv
from ..envs.episodes import EPISODE_STEPS, Window, checked_episode_steps
from ..envs.render import HumanWindow, checked_render_mode, human_frame_due, render_episode, rendered
from ..physics.kinematics import reference_kinematics, reference_positions, relay
from ..physics.workspace import WORKSPACE
from ..references import Reference
from .urdf_plant import OK, ClosedLoopRun, URDFPlant

DEG = math.pi / 180
PREVIEW_SECONDS = (0.0, 0.010, 0.025, 0.050, 0.100)
ERR_SCALE = {"rad": 0.5 * DEG, "m": 0.5e-3}
ERR_CLIP = 20.0
REWARD_SCALE = {"rad": 0.1 * DEG, "m": 0.1e-3}
RESIDUAL_FRACTION = 0.2  # the residual action's bound, a fraction of the input scale (no base: the whole input's)
ERR_OVER_REWARD = 5.0  # the observed error's scale over the reward's, as the IX's 0.5 deg over 0.1 deg
OBS_BOUND = 25.0
DEFAULT_REFERENCES, DEFAULT_DURATION = 8, 20.0


def base_scales(plant, references, base_ff) -> dict[str, np.ndarray]:
    """A residual's ``residual_bound`` [input unit] and the reward's ``axis_errors`` [rad or m] per
    axis from the base's runs of ``references`` (``Reference`` objects or position arrays) with the
    feedforward ``base_ff`` (the
    base's model with the loop's term): the peak of the feedback's part of the input, u - f - C r,
    and the RMS of the tracking error; each at least a small floor (1e-6 of the input limit; an
    encoder count), so that an axis with nothing left to learn keeps a finite scale. A fixed bound
    (0.2 x the input limit) was 5x the feedback's peak on the two-link arm's elbow, and its
    exploration drowned what there is to learn (docs/methods/rl.md)."""
    peak, square, samples = 0.0, 0.0, 0
    for r, f in zip(references, base_ff, strict=True):
        trial = plant.run(r, f)
        peak = np.maximum(peak, np.abs(trial.u - f - plant.reference_feedback(reference_positions(r))).max(axis=0))
        square, samples = square + np.square(trial.error).sum(axis=0), samples + trial.error.shape[0]
    limit = np.where(np.isfinite(plant.u_max), plant.u_max, 1.0)
    count = np.maximum(np.asarray(plant.encoder_resolution, dtype=float), 1e-9)
    return {"residual_bound": np.maximum(peak, 1e-6 * limit), "axis_errors": np.maximum(np.sqrt(square / samples), count)}


class MachineTask:
    """What the single and the vector env share: the plant, the references with their observation
    features and base feedforward, each reference's settled start, and the scales."""

    def __init__(self, machine, references, base_feedforward, plant: URDFPlant | None, reference_seed: int,
                 n_references: int | None, duration: float, version: str = "v0", normalize_actions: bool = True,
                 residual_bound=None, axis_errors=None):
        from . import resolve

        if plant is None and machine is None:
            raise ValueError("lcgym/Machine-v0: give machine= (a machine file, a URDF, module:attr or a System) or plant=")
        bench = resolve(plant.system if plant is not None and machine is None else machine).system.make_bench(version)
        self.plant = plant if plant is not None else bench.plant
        self.system, self.bench = self.plant.system, bench
        n, fs = self.plant.n_axes, self.plant.fs
        if isinstance(references, str):
            refs = bench.references(references, reference_seed, n_references or DEFAULT_REFERENCES, duration)
        elif isinstance(references, Reference) or (isinstance(references, np.ndarray) and references.ndim == 2):
            refs = [references]
        else:
            refs = list(references)
            if not refs:
                raise ValueError("references: empty list")
        self.names = [r.name if isinstance(r, Reference) else f"reference-{i}" for i, r in enumerate(refs)]
        self.positions = [np.asarray(reference_positions(r), dtype=float) for r in refs]
        for name, x in zip(self.names, self.positions, strict=True):
            if x.ndim != 2 or x.shape[1] != n or x.shape[0] < 3 or not np.all(np.isfinite(x)):
                raise ValueError(f"{name}: a reference must be a finite (T >= 3, {n}) array of positions, got shape {x.shape}")
        model, self.base_feedforward = self._base_model(base_feedforward, reference_seed)
        limits = self.plant.u_max
        self.u_scale = np.where(np.isfinite(limits), limits, 1.0)
        self.bound = RESIDUAL_FRACTION * self.u_scale if model is not None else self.u_scale
        if residual_bound is not None:
            if model is None:
                raise ValueError("residual_bound: a bound of the residual needs a base feedforward (base_feedforward)")
            self.bound = _per_axis("residual_bound", residual_bound, n)
        self.action_space, self.action_scale = action_space_of(self.bound, n, normalize_actions)
        robot, settings = self.plant.robot, bench.settings.references
        lo = np.where(np.isfinite(robot.lower), robot.lower, -math.pi)
        hi = np.where(np.isfinite(robot.upper), robot.upper, math.pi)
        self.centre, self.half_range = 0.5 * (lo + hi), 0.5 * (hi - lo)
        v = bench.speed_limits()
        self.v_scale, self.a_scale = v, v / settings.accel_time
        units = [a.unit for a in self.system.axes]
        self.err_scale = np.array([ERR_SCALE[u] for u in units])
        self.reward_scale = np.array([REWARD_SCALE[u] for u in units])
        self.preview = np.array([int(round(t * fs)) for t in PREVIEW_SECONDS])
        # a base's feedforward carries what the loop needs to track exactly (``methods.loop``)
        self.base_ff = [np.zeros_like(x) if model is None else np.asarray(model.predict(x), dtype=float)
                        - self.plant.reference_feedback(x) for x in self.positions]
        if model is not None and residual_bound is None and axis_errors is None:
            # the machine's own scales, as a learner takes them (``methods.rl``): what the loop with the base leaves
            defaults = base_scales(copy.deepcopy(self.plant), self.positions, self.base_ff)
            self.bound = defaults["residual_bound"]
            self.action_space, self.action_scale = action_space_of(self.bound, n, normalize_actions)
            # the reward's scale per axis: the base's own error (the base scores -1/2 per axis and sample);
            # on a rail arm's machine file the recipe's return fell with the IX's fixed 0.1 deg and rises with it
            self.reward_scale = defaults["axis_errors"]
            self.err_scale = ERR_OVER_REWARD * self.reward_scale
        elif axis_errors is not None:  # balanced: each axis's error counts alike against the given ones
            relative = _per_axis("axis_errors", axis_errors, n) / self.reward_scale
            self.reward_scale = self.reward_scale * relative / np.exp(np.mean(np.log(relative)))
        self.feats = [self._features(x, f) for x, f in zip(self.positions, self.base_ff, strict=True)]
        self.n_obs = self.feats[0].shape[1] + n
        self._settled: dict[int, np.ndarray] = {}

    def _base_model(self, base, seed: int):
        if isinstance(base, str):
            if base not in ("none", "physical"):
                raise ValueError(f"base_feedforward must be 'none', 'physical' or a fitted model, got {base!r}")
            if base == "none":
                return None, "none"
            key = (repr(self.plant), self.system.model_effects, seed)  # the plant and what its model carries
            models = WORKSPACE.slot("systems.machine_env.env_models", dict)  # (plant, seed) -> fitted model
            if key not in models:  # the first env of a process runs and fits; later ones reuse it
                train = self.bench.references("train", seed, DEFAULT_REFERENCES, DEFAULT_DURATION)
                models[key] = self.system.physical_model(fs=self.plant.fs).fit(self.plant.run(train))
            return models[key], "physical"
        if not callable(getattr(base, "predict", None)):
            raise ValueError(f"base_feedforward must be 'none', 'physical' or a fitted model with predict(positions), "
                             f"got {type(base).__name__}")
        return base, "physical (given model)"

    def _features(self, x: np.ndarray, base_ff: np.ndarray) -> np.ndarray:
        """Observation columns but the error's, for every sample of one reference, float32 (T, 3 n P + 2 n)."""
        q, qd, qdd = reference_kinematics(x, self.plant.fs)
        T = x.shape[0]
        cols = []
        for signal, offset, scale in ((q, self.centre, self.half_range), (qd, 0.0, self.v_scale), (qdd, 0.0, self.a_scale)):
            scaled = (signal - offset) / scale
            for axis in range(x.shape[1]):
                for d in self.preview:
                    cols.append(scaled[np.minimum(np.arange(T) + d, T - 1), axis])
        feats = np.column_stack([*cols, *relay(qd).T, *(base_ff / self.u_scale).T])
        return np.clip(feats, -OBS_BOUND, OBS_BOUND).astype(np.float32)

    @property
    def n_references(self) -> int:
        return len(self.names)

    def spaces(self) -> tuple[gym.spaces.Box, gym.spaces.Box]:
        return gym.spaces.Box(-OBS_BOUND, OBS_BOUND, (self.n_obs,), np.float32), self.action_space

    def start(self, r: int) -> ClosedLoopRun:
        """A run of reference r, settled: the pre-roll computed once per reference, then copied."""
        run = ClosedLoopRun(self.plant, self.names[r], self.positions[r], self.base_ff[r].copy())
        if r not in self._settled:
            for k in range(-run.preroll, 0):
                status = run.sample(k)
                if status != OK:
                    run.diverged(k, status)
            self._settled[r] = run.state()
        run.restore(self._settled[r])
        return run

    def error_columns(self, e: np.ndarray) -> np.ndarray:
        return np.clip(e / self.err_scale, -ERR_CLIP, ERR_CLIP).astype(np.float32)


def _per_axis(what: str, value, n: int) -> np.ndarray:
    """``value`` as n positive finite values (one given for every axis), or a ValueError naming it."""
    v = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 else np.asarray(value, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError(f"{what} must be one value or {n} values > 0, got {value!r}")
    return v.copy()


class Episode:
    """One sub-env's episode: its reference, its run, its step count and clipped actions."""

    def __init__(self, task: MachineTask, r: int):
        self.task, self.r, self.k, self.clipped = task, r, 0, 0
        self.run = task.start(r)
        e0 = task.positions[r][0] - self.run.reading(0)
        self.obs = np.concatenate([task.feats[r][0], task.error_columns(e0)])

    @property
    def length(self) -> int:
        return self.task.positions[self.r].shape[0]

    def step(self, action: np.ndarray) -> tuple[float, bool, bool, dict]:
        """Apply ``action`` at sample k (after the caller's checks) and advance one sample."""
        t, k, r = self.task, self.k, self.r
        clipped = np.clip(action, -t.bound, t.bound)
        self.clipped += int(np.any(clipped != action))
        self.run.set_feedforward(k, t.base_ff[r][k] + clipped)
        status = self.run.sample(k)
        pos, u, _ = self.run.measured(k)
        info = {"pos": pos, "u": u, "ff": t.base_ff[r][k] + clipped, "error": t.positions[r][k] - pos,
                "clipped_actions": self.clipped}
        self.k = k + 1
        terminated = status != OK
        nxt = min(self.k, self.length - 1)
        e_next = t.positions[r][nxt] - (self.run.reading(self.k) if not terminated else pos)
        self.obs = np.concatenate([t.feats[r][nxt], t.error_columns(e_next)])
        reward = -0.5 * float(np.sum((e_next / t.reward_scale) ** 2)) if not terminated else -0.5 * ERR_CLIP**2 * len(pos)
        truncated = self.k >= self.length and not terminated
        return reward, terminated, truncated, info

    def hold(self, action: np.ndarray, samples: int) -> tuple[float, bool, bool, dict]:
        """``samples`` calls of ``step(action)`` with the plant's samples in one compiled loop
        (``ClosedLoopRun.advance``): the same run, observations and info, and the sum of the
        rewards. It stops early where the reference ends or the plant leaves its safe range."""
        t, k, r = self.task, self.k, self.r
        clipped = np.clip(action, -t.bound, t.bound)
        ff = t.base_ff[r][k : k + min(samples, self.length - k)] + clipped
        self.run.set_feedforward(k, ff)
        end, status = self.run.advance(k, k + len(ff))
        terminated = status != OK
        last = end if terminated else end - 1  # the last sample stepped; those before `end` ran on
        self.clipped += (last - k + 1) * int(np.any(clipped != action))
        # the encoders after each sample that ran on: what the next sample's control read, then the reading now
        readings = np.vstack([self.run.measured_readings(k + 1, end), self.run.reading(end)[None, :]])[: end - k]
        e_next = t.positions[r][np.minimum(np.arange(k + 1, end + 1), self.length - 1)] - readings
        total = 0.0
        for reward in (-0.5 * np.sum((e_next / t.reward_scale) ** 2, axis=1)).tolist():  # as steps one by one add them
            total += reward
        pos, u, _ = self.run.measured(last)
        info = {"pos": pos, "u": u, "ff": ff[last - k], "error": t.positions[r][last] - pos, "clipped_actions": self.clipped}
        self.k = last + 1
        nxt = min(self.k, self.length - 1)
        if terminated:
            total += -0.5 * ERR_CLIP**2 * len(pos)
        e_last = t.positions[r][nxt] - pos if terminated else e_next[-1]
        self.obs = np.concatenate([t.feats[r][nxt], t.error_columns(e_last)])
        return total, terminated, self.k >= self.length and not terminated, info

    def trial(self) -> Trial:
        return self.run.trial(self.k, base_feedforward=self.task.base_feedforward, clipped_actions=self.clipped)


def _choose(rng: np.random.Generator, options: dict | None, n: int) -> int:
    r = (options or {}).get("reference")
    if r is None:
        return int(rng.integers(n))
    if not 0 <= int(r) < n:
        raise ValueError(f"options['reference'] must be in 0..{n - 1}, got {r}")
    return int(r)


class MachineEnv(gym.Env):
    """Tracking environment of a machine with a URDF plant, one plant; see the module docstring."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(self, machine=None, references="train", base_feedforward="none", reference_seed: int = 0,
                 n_references: int | None = None, duration: float = DEFAULT_DURATION, plant: URDFPlant | None = None,
                 render_mode: str | None = None, version: str = "v0", normalize_actions: bool = True,
                 episode_steps: int | None = EPISODE_STEPS, residual_bound=None, axis_errors=None):
        self.render_mode = checked_render_mode(render_mode)
        self._window = Window(checked_episode_steps(episode_steps))
        self.task = MachineTask(machine, references, base_feedforward, plant, reference_seed, n_references, duration,
                                version, normalize_actions, residual_bound, axis_errors)
        self.observation_space, self.action_space = self.task.spaces()
        self.action_scale = self.task.action_scale
        self._human = HumanWindow(self.metadata["render_fps"]) if render_mode == "human" else None
        self.label = f"{self.task.system.name} env"
        self._episode: Episode | None = None  # the run of the current reference
        self._running = False

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if self._window.continues(seed, options):  # the open run goes on in a new window
            self._window.start, self._window.run_open, self._running = self._episode.k, False, True
            return self._episode.obs.copy(), self._reset_info()
        r = _choose(self.np_random, options, self.task.n_references)
        self._episode = Episode(self.task, r)
        self._window.start, self._window.run_open, self._running = 0, False, True
        if human_frame_due(self.render_mode, 0, True):
            self.render()
        return self._episode.obs.copy(), self._reset_info()

    def _reset_info(self) -> dict:
        return {"reference": self.task.names[self._episode.r], "sample": self._episode.k,
                "action_scale": self.action_scale.copy()}

    def step(self, action):
        reward, terminated, run_ended, info = self._episode_now().step(self._checked(action))
        return self._finish(reward, terminated, run_ended, info)

    def step_held(self, action, samples: int):
        """``samples`` steps with one action, as ``envs.hold.HoldAction`` makes them (the summed
        reward, the last step's observation, flags and info with ``held_samples``), the plant's
        samples in one compiled loop: what ``HoldAction`` calls when it wraps this env itself. An
        episode that ends inside the hold ends it there."""
        ep = self._episode_now()
        k = ep.k
        a = self._checked(action)
        window = self._window
        limit = samples if window.steps is None else min(samples, window.start + window.steps - k)
        out = self._finish(*ep.hold(a, limit))
        out[4]["held_samples"] = ep.k - k
        return out

    def _episode_now(self) -> Episode:
        if not self._running:
            raise RuntimeError(f"{self.label}: call reset() before step()")
        return self._episode

    def _checked(self, action) -> np.ndarray:
        """The action in machine units, or the error naming the step."""
        ep, n = self._episode, self.task.plant.n_axes
        a = checked_action(action, (n,), self.label, ep.k, self._what()).astype(float)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{self.label}: action {a.tolist()} at step {ep.k} is NaN or inf")
        return a * self.action_scale

    def _finish(self, reward: float, terminated: bool, run_ended: bool, info: dict):
        """The step's return after the episode stepped: window and run ends, the trial, rendering."""
        ep = self._episode
        run_ended = run_ended or terminated
        window_ended = not run_ended and self._window.ends(ep.k)
        truncated = (run_ended or window_ended) and not terminated
        if run_ended:
            info["trial"] = ep.trial()
            info["tracking_rms"] = np.sqrt(np.mean(np.square(info["trial"].error), axis=0))
        if run_ended or window_ended:
            self._running, self._window.run_open = False, window_ended
        if human_frame_due(self.render_mode, ep.k, run_ended or window_ended):
            self.render()
        return ep.obs.copy(), reward, bool(terminated), bool(truncated), info

    def _what(self) -> str:
        return f"({', '.join(self.task.system.axis_names)}) feedforward in {self.task.system.input_unit}"

    def render(self):
        """The references and tracking errors of the run so far (module docstring, Render)."""
        return rendered(self.render_mode, self._human, self._picture)

    def close(self):
        if self._human is not None:
            self._human.close()

    def _picture(self) -> np.ndarray:
        trial = self._episode.trial() if self._episode is not None and self._episode.k > 0 else None
        system = self.task.system
        return render_episode(trial, system.name, system.axis_names, [a.display for a in system.axes])


class MachineVectorEnv(BatchedVectorEnv):
    """N plants of one machine stepped one after the other (the URDF plant runs pinocchio per
    sample, in Python: no compiled batch); Gymnasium's autoreset modes (``envs.batched``)."""

    def __init__(self, num_envs: int = 1, machine=None, references="train", base_feedforward="none",
                 reference_seed: int = 0, n_references: int | None = None, duration: float = DEFAULT_DURATION,
                 plant: URDFPlant | None = None, render_mode: str | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, version: str = "v0",
                 normalize_actions: bool = True, episode_steps: int | None = EPISODE_STEPS, residual_bound=None,
                 axis_errors=None):
        self._init_batch(num_envs, autoreset_mode, episode_steps)
        if render_mode is not None:
            raise ValueError("the machine's vector env does not render; use the single env")
        self.task = MachineTask(machine, references, base_feedforward, plant, reference_seed, n_references, duration,
                                version, normalize_actions, residual_bound, axis_errors)
        self.action_scale = self.task.action_scale
        self.label = f"{self.task.system.name} vector env"
        self.single_observation_space, self.single_action_space = self.task.spaces()
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._episodes: list[Episode | None] = [None] * num_envs
        self._obs = np.zeros((num_envs, self.task.n_obs), dtype=np.float32)
        self._k = np.zeros(num_envs, dtype=np.int64)

    def _restart(self, mask: np.ndarray) -> None:
        for i in np.flatnonzero(mask):
            self._episodes[i] = Episode(self.task, int(self.np_random.integers(self.task.n_references)))
            self._obs[i], self._k[i] = self._episodes[i].obs, 0

    def _reference_names(self) -> np.ndarray:
        return np.array([self.task.names[ep.r] for ep in self._episodes], dtype=object)

    def step(self, actions):
        if not self._started:
            raise RuntimeError(f"{self.label}: call reset() before step()")
        n = self.task.plant.n_axes
        a = checked_action(actions, (self.num_envs, n), self.label, self._steps,
                           f"({', '.join(self.task.system.axis_names)}) feedforward, one row per sub-env").astype(float)
        a = a * self.action_scale
        active = self._begin_step(a)
        N = self.num_envs
        reward = np.zeros(N)
        terminated, truncated = np.zeros(N, dtype=bool), np.zeros(N, dtype=bool)
        infos = {key: np.zeros((N, n)) for key in ("pos", "u", "ff", "error")}
        infos["clipped_actions"] = np.zeros(N, dtype=np.int64)
        for i in np.flatnonzero(active):
            ep = self._episodes[i]
            reward[i], terminated[i], truncated[i], info = ep.step(a[i])
            for key, value in info.items():
                infos[key][i] = value
            self._obs[i], self._k[i] = ep.obs, ep.k
        for key in ("pos", "u", "ff", "error", "clipped_actions"):
            infos[f"_{key}"] = active
        window = self._window_ends(active & ~terminated & ~truncated)
        truncated |= window
        self._end_step(terminated | truncated, infos, window)
        return self._obs.copy(), reward, terminated, truncated, infos
