"""Gymnasium tracking environment of the FlexArm: ``lcgym/FlexArm-v1`` (and ``-v0``; paper 002).

One episode tracks one TCP-line reference (``systems/flexarm/references.py``) on the closed-loop plant of
``systems/flexarm/plant.py`` (1 kHz, motor-side PID, flexible joints, hidden payload and drive mismatch,
quantized motor encoders). The agent supplies the **nonlinear feedforward torque update**; the
feedback loop runs inside the environment. One env step is one control sample (1 ms).

Action (float32, shape (6,)): motor torque per joint, added to the feedforward of the sample,
    normalized: the env applies ``action * action_scale`` [N m] (``normalize_actions=True``, the
    default, bounds +-1; ``info["action_scale"]``, ``env.action_scale``), or the action in N m as
    given (``normalize_actions=False``, bounds +-``action_scale``; ``envs.actions``).
    ``base_feedforward="basic"`` (default): the plant runs the nominal structure of paper 002
    Fig. 1 (motor reference with F1 and r_q,0, feedforward tau_ff,0; ``systems/flexarm/nominal.py``)
    and the action is an update of tau_nl, scale ``ACTION_BOUND`` (2 N m; the largest
    nominal feedforward on the validation lines is about 7 N m).
    ``base_feedforward="physical"``: residual learning on the machine's physical model
    (``model.ArmModel``: the motor-side rigid-joint model fitted by least squares on feedback-only
    runs of the training references of ``reference_seed`` on the env's plant, once per process, as
    ``methods.PhysicalFeedforward`` fits it on the benchmark's training trials): the plant runs
    the model's motor torque as feedforward and its joint-torsion ``reference_offset`` [rad, load
    side] as motor offset N * offset (as ``FlexArmBench.run`` applies a method's offset), and the
    action is added to that feedforward, scale ``ACTION_BOUND`` as for Basic (the fitted model
    also supplies up to about 7 N m on the validation lines). A fitted model itself may be given
    instead of "physical": anything with ``predict(reference) -> (T, 6)`` [N m] (called with the
    ``Reference``) and optionally ``reference_offset(reference) -> (T, 6)`` [rad, load side], e.g.
    a benchmark cell's ``ArmModel`` (``PhysicalFeedforward(...).fit(trials).model_``), or a fitted
    controller with ``feedforward(reference)`` (and ``reference_offset``) such as
    ``PhysicalFeedforward`` itself: residual learning on that model, ``env.base_feedforward`` (and
    the episode trial's meta) "physical (given model)".
    ``base_feedforward="none"``: feedback only plus the action, scale ``plant.u_max``.
    Any other value raises ``ValueError``.
    Out-of-bound actions are clipped and counted (``info["clipped_actions"]``); NaN, inf, a
    wrong shape or non-numbers raise ``ValueError`` naming the step, before the plant moves.
    The total torque is saturated at +-``plant.u_max``.

Observation (float32, shape (36,)), all O(1):
    - [0:6]    load-side reference angle / (pi/2 rad)
    - [6:12]   reference velocity / (1 rad/s)
    - [12:18]  reference acceleration / (5 rad/s^2)
    - [18:24]  base feedforward of the sample / (10 N m)
    - [24:30]  reference velocity 50 ms ahead / (1 rad/s) (a preview; the last sample is repeated)
    - [30:36]  joint tracking error as the motor encoders see it, e = q_lr - q_m / N, / 0.05 deg,
               clipped to +-20 (the load-side error is not measured in real time)

Reward: -1/2 sum over joints (e_i / 0.01 deg)^2 with e the encoder-side error after the sample.

Episode end: ``truncated`` after ``episode_steps`` samples (default ``EPISODE_STEPS`` = 1000,
    1 s; the next reset goes on with the same run: ``envs.episodes``) or after the reference's last
    sample (``episode_steps=None``: one episode per reference, what the benchmark scores);
    ``terminated`` when the plant leaves its safe range (a load angle 0.2 rad off its reference,
    or a non-finite state).

Info: per step ``u`` (motor torques [N m]) and ``clipped_actions``; at the end of a reference run
    ``trial``: the whole run as a ``Trial`` (motor angles, accelerometer, TCP and true load angles as
    extras, like ``FlexArmPlant.run``; its meta names the base: ``base_feedforward``) and
    ``tracking_rms``: the RMS load-side tracking error [rad] of the joints the benchmark scores
    (2, 3, 5) over the run.

Reset: the reference is drawn with the env's seeded generator from the set, or chosen with
    ``options={"reference": i}``; the plant starts in static balance, held for ``plant.preroll`` s;
    or the open run goes on (``envs.episodes``). Info: ``reference`` (its name), ``sample`` (where
    the episode starts), ``action_scale`` [N m], as on every lcgym env.

Render: ``render_mode="rgb_array"``: the references and load-side tracking errors of joints 2, 3
    and 5 in the run so far, as an RGB array; ``"human"``: the same in a matplotlib window.

Arguments: ``references`` (a set name or a list of ``Reference``), ``reference_seed``,
    ``n_references``, ``base_feedforward``, ``plant`` (a ``FlexArmPlant``; default the plant of
    ``version``), ``version`` ("v1" or "v0": ``FlexArmPlant.of_version``; the registered ids set it),
    ``render_mode``, ``normalize_actions``, ``episode_steps``.

Vector env: ``gym.make_vec("lcgym/FlexArm-v1", num_envs=n, vectorization_mode="vector_entry_point")``
is ``FlexArmVectorEnv``: n arms stepped in one compiled call (``systems/flexarm/vector.py``, the
same per-sample closed loop as the plant and this env, parallel over arms), each sub-env's numbers
bit for bit those of this env (tested); ``envs.sb3.make_sb3_vec_env`` gives it to
stable-baselines3. ``vectorization_mode="sync"`` steps n copies of this env in Python.
Speed: ``benchmarks/flexarm_vector_speed.py``.

Version History:
    - v1: a settled start (``FlexArmPlant(settled_start=True)``): the PID integrators hold only the
      gravity torque the first feedforward sample lacks, so a run whose feedforward carries gravity
      (Basic, paper 002's nominal structure) starts without a motor error (docs/machines/flexarm.md
      measures it). Hidden effects
      calibrated to paper 002's situation
      (``plant.true_arm_v1``, ``plant.true_drive_v1``): a 12 kg tool 40 cm long instead of the
      block, main-axis stiffness 3 % below nominal instead of 15 %, Coulomb friction 15 % below
      nominal instead of 30 % above. Same observation, action and reward as v0.
    - v0: the first release (``FlexArmPlant()``'s defaults): the integrators start holding the whole
      gravity torque on top of the feedforward's.
    - Both versions, after lcgym 0.2.0: actions normalized and episodes of ``EPISODE_STEPS`` samples by
      default (the plants unchanged); ``normalize_actions=False, episode_steps=None`` gives the
      earlier interface.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from ...data import Trial
from ...envs.actions import action_space_of, checked_action
from ...envs.batched import BatchedVectorEnv
from ...envs.episodes import EPISODE_STEPS, Window, checked_episode_steps
from ...envs.render import HumanWindow, checked_render_mode, human_frame_due, render_episode, rendered
from ...physics.workspace import WORKSPACE
from ...references import Reference
from . import plant as F
from . import vector as V
from .references import MOVING, arm_reference_set

ACTION_BOUND = 2.0  # N m
POS_SCALE, VEL_SCALE, ACC_SCALE, FF_SCALE = math.pi / 2, 1.0, 5.0, 10.0
ERR_SCALE, ERR_CLIP = math.radians(0.05), 20.0
REWARD_SCALE = math.radians(0.01)
PREVIEW = 50  # samples
OBS_BOUND = 25.0


BASES = ("basic", "none", "physical")  # the names base_feedforward accepts (or a fitted model)
GIVEN_MODEL = "physical (given model)"

def physical_model(plant: F.FlexArmPlant, seed: int = 0):
    """The FlexArm's physical model (``ArmModel``) fitted on feedback-only runs of the training
    references of ``seed`` on ``plant`` (kept per process, ``physics.workspace``), as ``methods.PhysicalFeedforward``
    fits it on the benchmark's training trials."""
    key = (repr(plant), seed)
    models = WORKSPACE.slot("systems.flexarm.env_models", dict)
    if key not in models:
        from . import FLEXARM

        trials = [plant.run(r) for r in arm_reference_set("train", seed, fs=plant.fs)]
        models[key] = FLEXARM.physical_model(fs=plant.fs).fit(trials)
    return models[key]


def _is_model(base) -> bool:
    return callable(getattr(base, "predict", None)) or callable(getattr(base, "feedforward", None))


def checked_base(base_feedforward) -> None:
    """``ValueError`` unless ``base_feedforward`` is one of ``BASES`` or a fitted model."""
    if isinstance(base_feedforward, str):
        if base_feedforward not in BASES:
            raise ValueError(f"base_feedforward must be 'basic', 'none', 'physical' or a fitted model, "
                             f"got {base_feedforward!r}")
    elif not _is_model(base_feedforward):
        raise ValueError("base_feedforward must be 'basic', 'none', 'physical' or a fitted model with "
                         "predict(reference) -> (T, 6) N m (and optionally reference_offset(reference) -> (T, 6) rad), "
                         f"got {type(base_feedforward).__name__}")


def base_model(base_feedforward, plant: F.FlexArmPlant, seed: int = 0) -> tuple[object, str]:
    """(what ``base_of`` evaluates: "basic", "none" or a fitted model; the base's name) of a
    ``base_feedforward`` argument ("physical": ``physical_model(plant, seed)``)."""
    checked_base(base_feedforward)
    if isinstance(base_feedforward, str):
        return (physical_model(plant, seed) if base_feedforward == "physical" else base_feedforward), base_feedforward
    return base_feedforward, GIVEN_MODEL


def base_of(reference: Reference, base_feedforward, gear=None) -> tuple[np.ndarray, np.ndarray]:
    """(feedforward [N m], motor offset [rad of the motor]) (T, 6) of a reference: the nominal
    structure (``base_feedforward="basic"``), zeros ("none"), or a fitted model's ``predict`` (or
    ``feedforward``) and ``gear`` (the gear ratios N (6,); default the nominal drive's) times its
    ``reference_offset`` (zeros where it has none), as ``FlexArmBench.run`` applies them."""
    if isinstance(base_feedforward, str) and base_feedforward == "basic":
        from .nominal import BasicFeedforward

        b = BasicFeedforward().compute(reference.positions, reference.fs)
        return b["tau_ff"], b["motor_offset"]
    T = reference.n_samples
    z = np.zeros((T, 6))
    if isinstance(base_feedforward, str):
        if base_feedforward != "none":
            raise ValueError(f"base_of: base_feedforward must be 'basic', 'none' or a fitted model (base_model gives "
                             f"the model of 'physical'), got {base_feedforward!r}")
        return z, z
    checked_base(base_feedforward)
    model = base_feedforward
    predict = model.predict if callable(getattr(model, "predict", None)) else model.feedforward
    ff = _model_signal(predict(reference), T, reference.name, "feedforward (predict)")
    offset = model.reference_offset(reference) if callable(getattr(model, "reference_offset", None)) else None
    if offset is None:
        return ff, z
    if gear is None:
        from .dynamics import DriveParameters

        gear = DriveParameters().N
    off = np.asarray(gear) * _model_signal(offset, T, reference.name, "reference_offset")
    return ff, np.ascontiguousarray(off)


def _model_signal(x, T: int, name: str, label: str) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=float)
    if a.shape != (T, 6) or not np.all(np.isfinite(a)):
        raise ValueError(f"base_feedforward: the model's {label} of {name} must be finite with shape ({T}, 6), "
                         f"got shape {a.shape}")
    return a


def observation_scales(action_bound: float) -> np.ndarray:
    """The env's constants in the order of ``vector.SCALES``."""
    return np.array([POS_SCALE, VEL_SCALE, ACC_SCALE, FF_SCALE, ERR_SCALE, ERR_CLIP, REWARD_SCALE, OBS_BOUND, PREVIEW,
                     action_bound])


def kernel_args(plant: F.FlexArmPlant) -> tuple:
    """The plant's arguments of ``plant.loop_sample`` after the per-sample ones: (DH table,
    inertial parameters, drive table, PID gains (3, 6), kernel config, accelerometer offset)."""
    return (plant.true_arm.dh.table(), plant.true_arm.vector(), plant.drive_table(),
            np.array([plant.gains.kp, plant.gains.ki, plant.gains.kd], dtype=float), plant.kernel_config(),
            np.asarray(plant.accel_offset, dtype=float))


def start_state(args: tuple, reference: Reference, ff: np.ndarray, off: np.ndarray) -> np.ndarray:
    """The closed-loop state (``plant.N_LOOP``,) at t = 0: static balance at the first sample, held
    for the plant's pre-roll (as ``FlexArmPlant.run`` starts)."""
    st = np.empty(F.N_LOOP)
    dh, pi, drive, C, cfg, accel_offset = args
    q0 = reference.positions[0]
    F.loop_start(st, q0, off[0], ff[0], dh, pi, drive, C, cfg)
    zero = np.zeros(F.N_SIG)
    for _ in range(int(cfg[6])):
        F.loop_sample(st, q0, q0, ff[0], off[0], dh, pi, drive, C, cfg, accel_offset, zero, False)
    return st


class FlexArmEnv(gym.Env):
    """``lcgym/FlexArm-v1`` (and -v0); see the module docstring."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(self, references="train", reference_seed: int = 0, n_references: int | None = None,
                 base_feedforward="basic", plant: F.FlexArmPlant | None = None, version: str = "v1",
                 render_mode: str | None = None, normalize_actions: bool = True,
                 episode_steps: int | None = EPISODE_STEPS):
        self.render_mode = checked_render_mode(render_mode)
        self._human = HumanWindow(self.metadata["render_fps"]) if render_mode == "human" else None
        self._window = Window(checked_episode_steps(episode_steps))
        checked_base(base_feedforward)  # before the plant runs the training references for "physical"
        self.plant = plant or F.FlexArmPlant.of_version(version)
        if isinstance(references, str):
            references = arm_reference_set(references, reference_seed, n_references, fs=self.plant.fs)
        self.references: list[Reference] = list(references)
        if not self.references:
            raise ValueError("FlexArmEnv: no references")
        self._model, self.base_feedforward = base_model(base_feedforward, self.plant, reference_seed)
        self.bound = self.plant.u_max if self.base_feedforward == "none" else ACTION_BOUND
        self.action_space, self.action_scale = action_space_of(self.bound, 6, normalize_actions)
        self.observation_space = gym.spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(36,), dtype=np.float32)
        self._scales = observation_scales(float(np.float32(self.bound)))
        self._base: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._idx, self._k, self._st, self._running = 0, 0, None, False

    def _base_of(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """(feedforward, motor offset) (T, 6) of reference i: the nominal structure, zeros or the model's."""
        if i not in self._base:
            self._base[i] = base_of(self.references[i], self._model, self.plant.true_drive.N)
        return self._base[i]

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if self._window.continues(seed, options):  # the open run goes on in a new window
            self._window.start, self._window.run_open, self._running = self._k, False, True
            return self._observation(), self._reset_info()
        n = len(self.references)
        i = (options or {}).get("reference")
        if i is None:
            i = int(self.np_random.integers(n))
        if not 0 <= int(i) < n:
            raise ValueError(f"options['reference'] must be in 0..{n - 1}, got {i}")
        self._idx, self._k = int(i), 0
        ref = self.references[self._idx]
        ff, off = self._base_of(self._idx)
        self._args = kernel_args(self.plant)
        self._st = start_state(self._args, ref, ff, off)
        self._sig = np.zeros((ref.n_samples, F.N_SIG))
        self._ff_applied = np.zeros((ref.n_samples, 6))
        self._clipped = 0
        self._window.start, self._window.run_open, self._running = 0, False, True
        if human_frame_due(self.render_mode, 0, True):
            self.render()
        return self._observation(), self._reset_info()

    def _reset_info(self) -> dict:
        return {"reference": self.references[self._idx].name, "sample": self._k, "action_scale": self.action_scale.copy()}

    def _observe(self) -> tuple[np.ndarray, np.ndarray]:
        """(observation at the current sample, encoder-side error e [rad] (6,))."""
        ref = self.references[self._idx]
        ff, _ = self._base_of(self._idx)
        obs = np.empty(V.N_OBS, dtype=np.float32)
        e = V.observe(self._st, ref.positions, ref.velocities, ref.accelerations, ff, ref.n_samples, self._k,
                      self._args[2][0], self._args[4][3], self._scales, obs)
        return obs, e

    def _observation(self) -> np.ndarray:
        return self._observe()[0]

    def step(self, action):
        if not self._running:
            raise RuntimeError("FlexArmEnv: call reset() before step()")
        a = checked_action(action, (6,), "FlexArmEnv", self._k, "one motor torque per joint in N m").astype(float)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"FlexArmEnv: action at step {self._k} contains NaN or inf: {a.tolist()}")
        a = a * self.action_scale
        bound = float(np.float32(self.bound))
        if np.any(np.abs(a) > bound):
            self._clipped += 1
            a = np.clip(a, -bound, bound)
        ref = self.references[self._idx]
        k, T = self._k, ref.n_samples
        ff, off = self._base_of(self._idx)
        self._ff_applied[k] = ff[k] + a
        bad = F.loop_sample(self._st, ref.positions[k], ref.positions[min(k + 1, T - 1)], self._ff_applied[k], off[k],
                            *self._args[:5], self._args[5], self._sig[k], True)
        self._k = k + 1
        obs, e = self._observe()
        reward = float(V.reward_of(e, REWARD_SCALE))
        run_ended = bool(bad) or self._k >= T
        window_ended = not run_ended and self._window.ends(self._k)
        truncated = (run_ended or window_ended) and not bad
        info = {"u": self._sig[k, F.S_U : F.S_U + 6].copy(), "clipped_actions": self._clipped}
        if run_ended:
            info["trial"] = self._trial(self._k)
            info["tracking_rms"] = np.sqrt(np.mean(np.square(F.load_error(info["trial"]))[:, list(MOVING)], axis=0))
        if run_ended or window_ended:
            self._running, self._window.run_open = False, window_ended
        if human_frame_due(self.render_mode, self._k, run_ended or window_ended):
            self.render()
        return obs, reward, bool(bad), bool(truncated), info

    def render(self):
        """The references and load-side tracking errors of the scored joints (2, 3, 5) in the run
        so far (module docstring, Render)."""
        return rendered(self.render_mode, self._human, self._picture)

    def close(self):
        if self._human is not None:
            self._human.close()

    def _picture(self) -> np.ndarray:
        trial = None
        if self._st is not None and self._k > 0:  # its own noise generator: rendering leaves the episode's draws alone
            trial = self.plant.trial_from_signals(self.references[self._idx], self._sig[: self._k], self._ff_applied,
                                                  np.random.default_rng(0))
        error = None if trial is None else F.load_error(trial)
        return render_episode(trial, self.references[self._idx].name, [self.plant.axes[i] for i in MOVING],
                              columns=list(MOVING), error=error)

    def _trial(self, n: int) -> Trial:
        trial = self.plant.trial_from_signals(self.references[self._idx], self._sig[:n], self._ff_applied, self.np_random)
        trial.meta["base_feedforward"] = self.base_feedforward
        return trial


class FlexArmVectorEnv(BatchedVectorEnv):
    """N FlexArm plants stepped at once in compiled code (``systems/flexarm/vector.py``, parallel over
    arms from ``PARALLEL_FROM`` on). Each sub-env is a ``FlexArmEnv`` with the same arguments: the
    same observation, action, reward and episode end, its numbers bit for bit those of a single env
    fed the same actions. Per step the info holds ``u`` (motor torques [N m]), ``error`` (the true
    load-side error q_lr - q_l of the sample [rad] of joints 2, 3, 5, what the benchmark scores and
    the single env's ``tracking_rms`` is taken of) and ``clipped_actions``; there is no
    whole-episode ``trial`` (use the single env for that).

    Autoreset: both of Gymnasium's modes (``envs.batched``: NEXT_STEP by default, SAME_STEP for
    stable-baselines3). Each sub-env draws its references with its own generator, seeded
    ``seed + i`` by ``reset(seed)`` (as Gymnasium's sync vector env and stable-baselines3's
    ``DummyVecEnv`` seed their copies), and
    at an episode's end draws from it the accelerometer noise a single env's episode ``trial``
    draws (though it returns no trial), so sub-env i meets the references a ``FlexArmEnv`` reset
    with ``seed + i`` meets, episode after episode.
    """

    label = "FlexArm vector env"
    PARALLEL_FROM = 8  # arms

    def __init__(self, num_envs: int = 1, references="train", reference_seed: int = 0, n_references: int | None = None,
                 base_feedforward="basic", plant: F.FlexArmPlant | None = None, version: str = "v1",
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, normalize_actions: bool = True,
                 episode_steps: int | None = EPISODE_STEPS):
        self._init_batch(num_envs, autoreset_mode, episode_steps)
        one = FlexArmEnv(references, reference_seed, n_references, base_feedforward, plant, version,
                         normalize_actions=normalize_actions)  # checks the arguments
        self.plant, self.references, self.base_feedforward = one.plant, one.references, one.base_feedforward
        self.single_observation_space, self.single_action_space = one.observation_space, one.action_space
        self.action_scale = one.action_scale
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._args = kernel_args(self.plant)
        refs = self.references
        R, T = len(refs), max(r.n_samples for r in refs)
        self._lengths = np.array([r.n_samples for r in refs], dtype=np.int64)
        stack = {name: np.zeros((R, T, 6)) for name in ("pos", "vel", "acc", "ff", "off")}
        self._start = np.empty((R, F.N_LOOP))
        self._first_obs = np.empty((R, V.N_OBS), dtype=np.float32)
        self._scales = one._scales
        for i, r in enumerate(refs):
            ff, off = one._base_of(i)
            n = r.n_samples
            for name, x in (("pos", r.positions), ("vel", r.velocities), ("acc", r.accelerations), ("ff", ff), ("off", off)):
                stack[name][i, :n] = x
            self._start[i] = start_state(self._args, r, ff, off)
            V.observe(self._start[i], stack["pos"][i], stack["vel"][i], stack["acc"][i], stack["ff"][i], n, 0,
                      self._args[2][0], self._args[4][3], self._scales, self._first_obs[i])
        self._ref = tuple(stack[name] for name in ("pos", "vel", "acc", "ff", "off"))
        N = num_envs
        self._st = np.zeros((N, F.N_LOOP))
        self._ref_idx = np.zeros(N, dtype=np.int64)
        self._k = np.zeros(N, dtype=np.int64)
        self._obs = np.zeros((N, V.N_OBS), dtype=np.float32)
        self._reward = np.zeros(N)
        self._status = np.zeros(N, dtype=np.int64)
        self._clipped = np.zeros(N, dtype=np.int64)
        self._u = np.zeros((N, 6))
        self._error = np.zeros((N, 6))
        self._rngs: list[np.random.Generator] | None = None
        self._kernel = V.step_parallel if N >= self.PARALLEL_FROM else V.step_serial

    def _restart(self, mask: np.ndarray) -> None:
        idx = np.flatnonzero(mask)
        r = np.array([self._rngs[i].integers(len(self.references)) for i in idx], dtype=np.int64)
        self._ref_idx[idx], self._k[idx], self._clipped[idx] = r, 0, 0
        self._st[idx] = self._start[r]
        self._obs[idx] = self._first_obs[r]

    def _reference_names(self) -> np.ndarray:
        return np.array([r.name for r in self.references], dtype=object)[self._ref_idx]

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None or self._rngs is None:  # sub-env i draws as a FlexArmEnv reset with seed + i
            self._rngs = [gym.utils.seeding.np_random(None if seed is None else seed + i)[0] for i in range(self.num_envs)]
        return super().reset(seed=seed, options=options)

    def step(self, actions):
        if not self._started:
            raise RuntimeError("FlexArm vector env: call reset() before step()")
        a = checked_action(actions, (self.num_envs, 6), "FlexArm vector env", self._steps,
                           "one motor torque per joint in N m, one row per sub-env").astype(np.float64) * self.action_scale
        active = self._begin_step(a)
        self._kernel(active, self._st, *self._ref, self._lengths, self._ref_idx, self._k, a, self._scales, *self._args,
                     self._obs, self._reward, self._status, self._clipped, self._u, self._error)
        terminated = active & (self._status == V.ENV_DIVERGED)
        truncated = active & ~terminated & (self._k >= self._lengths[self._ref_idx])
        window = self._window_ends(active & ~terminated & ~truncated)
        truncated |= window
        reward = np.where(active, self._reward, 0.0)
        infos = {"u": self._u.copy(), "error": self._error[:, list(MOVING)], "clipped_actions": self._clipped.copy()}
        for key in ("u", "error", "clipped_actions"):  # Gymnasium's vector-info masks: which sub-envs stepped
            infos[f"_{key}"] = active
        done = terminated | truncated
        for i in np.flatnonzero(done & ~window):  # the accelerometer noise the single env's run trial draws
            self._rngs[i].standard_normal((int(self._k[i]), 3))
        self._end_step(done, infos, window)
        return self._obs.copy(), reward, terminated, truncated, infos
