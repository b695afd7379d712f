"""Method ``rl``: a stable-baselines3 agent that learns the feedforward on the plant.

The agent acts in the system's Gymnasium env (``lcgym/IX-v0``, ``lcgym/FlexArm-v0``, the feedback
loop inside it) over the cell's training references, on every control sample or holding each action
for several (``RLConfig.agent_rate``, else the machine's ``RLMachineSettings.agent_rate``: 50 Hz on the
IX, the two-link arm and the EMPS, ``envs.hold``; every sample on the FlexArm, whose residual shapes
10-15 Hz resonances).

* **Residual** (default, ``RLConfig.residual``): the action, bounded, is added to the method's base
  feedforward (``bases``): the cell's fitted physical model (``base="physical"``, the default; IX
  +-1 V; FlexArm +-2 N m, with the model's joint-torsion reference offset) or the FlexArm's Basic
  (``base="basic"``, paper 002: tau_nl update +-2 N m, with Basic's motor reference offset).
  ``residual=False``: the action is the whole feedforward (IX +-5 V; arm +-u_max, no offset).
* **Budget**: ``passes`` x the training samples, in env steps (``RLConfig.passes``, else the
  machine's ``RLMachineSettings.passes``: IX 3, FlexArm 1; else ``PASSES``); ``total_steps`` overrides.
* **Observation**: the env's, with the tracking error the encoders measure (``observe_error``): the
  policy closes an extra loop, so its feedforward for a reference is what it applies in one
  deterministic rollout on the plant (``learn``; one plant trial), which the benchmark replays (the
  plants are deterministic). ``observe_error=False`` zeroes the error in every observation: a pure
  feedforward of the reference, whose rollout needs no plant run and counts none.
* **Hyperparameters**: ``HYPERPARAMETERS`` per algorithm (PPO default; SAC, TD3), overridden by
  ``RLConfig.hyperparameters``. Torch trains on the CPU with one thread (small networks; more
  threads stall on a busy machine) in float32 (``torch_settings``), the caller's settings restored.
* **Cache**: ``<cache_dir>/<key>.zip`` in stable-baselines3's format (key: hash of the
  configuration, system, training references, base model, plant and lcgym's source), with the
  training curve (``.csv``, ``.png``) and a JSON record (env steps, episodes, wall time, the zip's
  SHA-256); ``learn`` loads only that file, under its key, when the record's hash matches. A zip
  unpickles Python objects: ``RLFeedforward.load_model(path)`` loads another file only when asked;
  give it files from trusted sources only.
* **Scales from the base** (``RLConfig.scaled``, on by default; where the env takes them, a machine
  file's ``lcgym/Machine-v0``): the residual's bound per axis is the peak of what the feedback
  supplied along the base's runs of the training references (what the base leaves the loop), and
  the axes' rewards are balanced by the base's RMS tracking errors there, so that the axis with the
  smaller error is learned too (``env_scales``; the base's runs are counted as plant trials). The
  fixed bound, 0.2 x the input limit, was 5x the feedback's peak on the two-link arm's elbow, and its
  exploration drowned what there is to learn; with one 0.1 deg for both axes the elbow's error,
  three times the shoulder's, took the reward (docs/methods/rl.md).
* **Safeguard** (``RLConfig.safeguard``, on by default): a residual policy is kept only where it
  lowers the tracking error on each of its training references (RMS per scored axis and reference,
  its deterministic rollouts against the base alone). An axis where it is worse on any reference
  loses its action; the masked policy is rolled out again, and if still worse anywhere, the base
  acts alone on every axis. ``kept_``: axes the residual acts on; ``safeguard_``: RMS figures;
  ``note_`` (the row's ``note``): what was dropped. It costs 2-3 rollouts per reference, counted.

Cost (``cost_``): env steps of training (also when loaded from the cache) plus those of the rollouts
that ran the plant; plant trials: training episodes begun plus those rollouts; ``cached_seconds``:
the training wall time of a cached model. Measurements: docs/methods/rl.md.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from .. import systems
from ..fitted import check_fitted, is_fitted
from ..provenance import source_hash
from ..systems import SimulationDiverged
from .bases import base_controller
from .loop import loop_feedforward, machine_loop
from .protocol import DEFAULT_BASE, Controller, Cost, given_system, machine_settings
from .safeguard import dropped_note, keep_axes, scored_axes

ALGORITHMS = ("ppo", "sac", "td3")
PASSES = 1.0  # env steps per training sample on a machine that sets none (System.settings["rl"])
NUM_ENVS = 4  # parallel envs on a machine that sets none


@dataclass(frozen=True)
class RLMachineSettings:
    """The method's settings on one machine, from its ``[benchmark.rl]`` table
    (``System.settings["rl"]``): ``passes``, env steps per training sample; ``num_envs``,
    parallel envs; ``agent_rate`` [Hz], the agent's action rate (0: every control sample).
    ``RLConfig`` overrides each."""

    passes: float = PASSES
    num_envs: int = NUM_ENVS
    agent_rate: float = 0.0

    @classmethod
    def of(cls, system: systems.System) -> RLMachineSettings:
        """The machine's settings; a key this method does not take is an error that names it."""
        return machine_settings(cls, system, "rl")


# One documented place for the hyperparameters (stable-baselines3 keyword arguments).
# PPO: SB3's defaults, written out (2048 agent steps per env and update, minibatches of 64, 10
# epochs, learning rate 3e-4, initial exploration std 1 of the action's unit). Acting on every
# sample, tuned settings (learning rate 1e-3, std e^-2) did better; with the agent at 50 Hz
# (``agent_rate``) the defaults do better still (the measurements: docs/methods/rl.md). SAC and TD3: SB3's defaults with the same
# network size and a buffer of about a full pass over the IX's training data; not tuned.
HYPERPARAMETERS: dict[str, dict] = {
    "ppo": dict(n_steps=2048, batch_size=64, n_epochs=10, learning_rate=3e-4, gamma=0.99, gae_lambda=0.95,
                policy_kwargs=dict(net_arch=[64, 64], log_std_init=0.0)),
    "sac": dict(learning_rate=3e-4, buffer_size=300_000, batch_size=256, learning_starts=5_000, gamma=0.99,
                train_freq=1, gradient_steps=1, policy_kwargs=dict(net_arch=[64, 64])),
    "td3": dict(learning_rate=1e-3, buffer_size=300_000, batch_size=256, learning_starts=5_000, gamma=0.99,
                train_freq=1, gradient_steps=1, policy_kwargs=dict(net_arch=[64, 64])),
}


def default_cache_dir() -> Path:
    """``$LCGYM_CACHE/rl``, else ``~/.cache/lcgym/rl``."""
    return Path(os.environ.get("LCGYM_CACHE", Path.home() / ".cache" / "lcgym")) / "rl"


@dataclass(frozen=True)
class RLConfig:
    """What the ``rl`` method trains (see the module docstring).

    algorithm: "ppo", "sac" or "td3"; residual: act on top of the physical model (else from
    scratch); observe_error: the policy sees the tracking error; passes: env steps per training
    sample (None: the machine's, ``setting``); total_steps: a fixed budget instead; num_envs:
    parallel envs (None: the machine's; one compiled batch where the env has a vector entry
    point, both built-in machines'; else ``DummyVecEnv`` copies); hyperparameters: overrides of
    ``HYPERPARAMETERS[algorithm]``; seed: of the agent and its envs; cache: save trained models
    and reuse them (``cache_dir``, default ``default_cache_dir()``); progress: a progress bar of
    the training (env steps, last episode's RMS tracking error); safeguard: keep a residual only
    where it lowers the training references' tracking error (module docstring); agent_rate [Hz]:
    how often the agent acts, each action held for the samples between (``envs.hold``; None: the
    machine's, else every sample; 0: every sample); scaled: the residual's bound and the reward's
    per-axis scale from the base's runs, where the env takes them (module docstring). Budgets count
    control samples either way.
    """

    algorithm: str = "ppo"
    residual: bool = True
    observe_error: bool = True
    passes: float | None = None
    total_steps: int | None = None
    num_envs: int | None = None
    hyperparameters: dict = field(default_factory=dict)
    seed: int = 0
    cache: bool = True
    cache_dir: str | None = None
    progress: bool = False
    safeguard: bool = True
    agent_rate: float | None = None
    scaled: bool = True

    def __post_init__(self):
        if self.algorithm not in ALGORITHMS:
            raise ValueError(f"RLConfig.algorithm must be one of {', '.join(ALGORITHMS)}, got {self.algorithm!r}")
        if self.total_steps is not None and self.total_steps < 1:
            raise ValueError(f"RLConfig.total_steps must be >= 1, got {self.total_steps}")
        if self.passes is not None and not self.passes > 0:
            raise ValueError(f"RLConfig.passes must be > 0, got {self.passes}")
        if self.num_envs is not None and self.num_envs < 1:
            raise ValueError(f"RLConfig.num_envs must be >= 1, got {self.num_envs}")
        if self.agent_rate is not None and not (np.isfinite(self.agent_rate) and self.agent_rate >= 0):
            raise ValueError(f"RLConfig.agent_rate must be a rate >= 0 in Hz (0: every sample), got {self.agent_rate}")

    def on(self, system: systems.System) -> RLMachineSettings:
        """``passes``, ``num_envs`` and ``agent_rate`` on ``system``: this configuration's where it
        sets them, else the machine's (``RLMachineSettings.of``)."""
        own = {f.name: getattr(self, f.name) for f in fields(RLMachineSettings) if getattr(self, f.name) is not None}
        return replace(RLMachineSettings.of(system), **own)

    def agent_kwargs(self, agent_steps: int | None = None, num_envs: int = 1) -> dict:
        """The algorithm's keyword arguments: the defaults updated by ``hyperparameters``. PPO's
        rollout (``n_steps`` per env) where ``hyperparameters`` does not set it: no longer than a
        budget of ``agent_steps`` over ``num_envs`` envs needs (``ppo_rollout``)."""
        kwargs = {**HYPERPARAMETERS[self.algorithm], **self.hyperparameters}
        if self.algorithm == "ppo" and agent_steps is not None and "n_steps" not in self.hyperparameters:
            kwargs["n_steps"] = ppo_rollout(kwargs["n_steps"], kwargs["batch_size"], agent_steps, num_envs)
        return kwargs


def ppo_rollout(n_steps: int, batch_size: int, agent_steps: int, num_envs: int) -> int:
    """PPO's agent steps per env and update: ``n_steps``, or fewer where one rollout of all
    ``num_envs`` envs covers the whole budget of ``agent_steps`` (PPO trains in whole rollouts: a
    budget of 2,000 agent steps would otherwise run 2,048 per env and 10 epochs over all of them),
    rounded up so that the rollout is a whole number of minibatches of ``batch_size``. The
    benchmark's full budgets all exceed one rollout of 2,048; ``lcgym bench --quick``'s do not."""
    step = batch_size // math.gcd(batch_size, num_envs)
    needed = -(-agent_steps // num_envs)
    return min(n_steps, -(-needed // step) * step)


def env_scales(plant, references, base, loop) -> dict[str, np.ndarray]:
    """The env's ``residual_bound`` [input unit] and ``axis_errors`` [rad or m] per axis from the
    base's runs of ``references`` (its model ``base``, with ``loop``'s term): the machine env's own
    defaults (``systems.machine_env.base_scales``), on the learner's training references."""
    from ..systems.machine_env import base_scales

    feedforward = [np.asarray(base.predict(r.positions), dtype=float) + loop_feedforward(loop, r) for r in references]
    return base_scales(plant, references, feedforward)


def _vec_env(system: systems.System, references, plant, base, config: RLConfig, hold: int, scales: dict):
    """The stable-baselines3 vector env of the training references: the env's own compiled batch
    where it has a vector entry point, else copies of the env in SB3's ``DummyVecEnv``; each action
    held for ``hold`` samples."""
    import gymnasium as gym
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    from ..envs import make_env
    from ..envs.hold import VecHoldAction
    from ..envs.sb3 import HideError, make_sb3_vec_env

    env_id, n = system.env_id, config.on(system).num_envs
    kwargs = dict(references=references, base_feedforward=base, plant=plant, episode_steps=None, **scales)
    if gym.spec(env_id).vector_entry_point is not None:
        venv = make_sb3_vec_env(env_id, num_envs=n, **kwargs)
    else:
        venv = DummyVecEnv([lambda: Monitor(make_env(env_id, **kwargs))] * n)
    if hold > 1:
        venv = VecHoldAction(venv, hold)
    return venv if config.observe_error else HideError(venv, system.bench.observation_error)


class RLFeedforward(Controller):
    """``fit(trials)`` keeps the training references (and fits the physical model on the base
    "physical"; ``base``: the feedforward the residual adds to, ``bases``);
    ``learn(plant, reference)`` trains (or loads from the cache) on the first call, then rolls the
    policy out deterministically on ``reference``; ``feedforward(reference)`` returns that
    rollout's feedforward. Learned: ``model_`` (the SB3 agent), ``curve_`` (training curve),
    ``record_`` (steps, episodes, seconds, cache key), ``kept_`` (per action axis, whether the
    residual acts there: the safeguard), ``safeguard_`` (its training RMS figures), ``note_``,
    ``rollouts_`` (reference name -> the rollout's ``Trial``), ``cost_``. ``system``: the machine (a ``System`` or a spec for
    ``systems.get``, such as "ix")."""

    name = "rl"
    relative_cost = 17.0  # seconds of a quick cell (protocol.Controller)
    uses_plant = True

    def __init__(self, config: RLConfig | None = None, system: systems.System | str | None = None,
                 base: str = DEFAULT_BASE):
        self.config = config
        self.system = system
        self.base = base

    # --- fit: what the training data gives -------------------------------------------------
    def fit(self, trials) -> RLFeedforward:
        from ..references import references_of

        self.system_ = given_system(self)
        cfg = self._config()
        self.base_ = None
        if cfg.residual and self.base == "physical":
            self.base_ = base_controller(self.system_, "physical").fit(trials).model_
        elif cfg.residual:
            base_controller(self.system_, self.base)  # a clear error where the machine lacks it
        self.training_ = references_of(trials)
        self.cost_ = Cost()
        self.rollouts_: dict = {}
        return self

    def _config(self) -> RLConfig:
        return self.config or RLConfig()

    def _base(self):
        """The env's ``base_feedforward`` argument."""
        if not self._config().residual:
            return "none"
        return self.base_ if self.base == "physical" else self.system_.nominal.name

    def hold(self) -> int:
        """Control samples per agent action (``RLConfig.agent_rate`` on the machine's rate)."""
        from ..envs.hold import samples_per_action

        rate = self._config().on(self.system_).agent_rate
        return samples_per_action(self.system_.fs, rate) if rate and self.system_.fs else 1

    def budget(self) -> int:
        """Env steps (control samples) of training: ``total_steps`` or passes x training samples."""
        cfg = self._config()
        if cfg.total_steps is not None:
            return int(cfg.total_steps)
        return int(round(cfg.on(self.system_).passes * sum(r.n_samples for r in self.training_)))

    # --- learn: train once, then one rollout per reference ----------------------------------
    def learn(self, plant, reference) -> RLFeedforward:
        check_fitted(self, "training_", hint="call fit(trials) before learn()")
        if not is_fitted(self, "scales_"):
            self.scales_ = self._scales(plant)
        if not is_fitted(self, "model_"):
            self._train_or_load(plant)
        if not is_fitted(self, "kept_"):  # also for a model of the user's (``load_model``)
            self._safeguard(plant)
        self.rollouts_[reference.name] = self._rollout(plant, reference, self.kept_)
        return self

    def _scales(self, plant) -> dict[str, np.ndarray]:
        """The env's scales from the base's runs (``env_scales``), where the config asks for them, the
        residual acts on the fitted physical model and the env takes them; else none."""
        from ..envs import env_takes

        cfg = self._config()
        if not (cfg.scaled and cfg.residual and self.base == "physical" and env_takes(self.system_.env_id, "residual_bound")):
            return {}
        self.cost_.plant_trials += len(self.training_)
        return env_scales(plant, self.training_, self.base_, machine_loop(self.system_))

    def cache_key(self, plant) -> str:
        """Hash of everything the trained model depends on."""
        import stable_baselines3
        import torch

        config = {k: v for k, v in asdict(self._config()).items()
                  if k not in ("cache", "cache_dir", "progress", "safeguard")}
        h = hashlib.sha256()
        h.update(json.dumps({"config": config, "system": self.system_.name, "budget": self.budget(), "hold": self.hold(),
                             "plant": repr(plant),
                             "lcgym": source_hash(), "sb3": stable_baselines3.__version__,
                             "torch": torch.__version__}, sort_keys=True, default=str).encode())
        for r in self.training_:  # the references, and the base feedforward the residual adds to
            h.update(np.ascontiguousarray(r.positions, dtype=np.float64).tobytes())
            if self.base_ is not None:
                h.update(np.ascontiguousarray(self.base_.predict(r.positions), dtype=np.float64).tobytes())
        return h.hexdigest()[:16]

    def _train_or_load(self, plant) -> None:
        cfg = self._config()
        key = self.cache_key(plant)
        folder = Path(cfg.cache_dir) if cfg.cache_dir else default_cache_dir()
        record = None
        if cfg.cache:
            record = _read_cached(folder, key)
        if record is not None:
            self.model_ = self.load_model(folder / f"{key}.zip", _verified=record["sha256"])
            self.curve_ = pd.read_csv(folder / f"{key}.csv")
            self.cost_.cached_seconds += record["seconds"]
        else:
            record = self._train(plant)
            record["key"] = key
            if cfg.cache:
                _write_cached(folder, key, self.model_, self.curve_, record, self.system_.name)
        self.record_ = record
        self.cost_.env_steps += record["env_steps"]
        self.cost_.plant_trials += record["episodes"]

    def _train(self, plant) -> dict:
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.logger import Logger

        cfg = self._config()
        algorithm = _algorithm_class(cfg.algorithm)
        hold = self.hold()
        venv = _vec_env(self.system_, self.training_, plant, self._base(), cfg, hold, self.scales_)
        rows: list[dict] = []
        shown = [(f"rms_{self.training_[0].axes[i]}_{unit}", factor)
                 for i, (factor, unit) in zip(self._scored(), self._display(), strict=True)]

        bar = tqdm(total=self.budget(), desc=f"rl {cfg.algorithm} on {self.system_.name}", unit="step",
                   disable=not cfg.progress, leave=False)

        class TrainingCurve(BaseCallback):
            """One row per finished episode: env steps so far (agent steps x hold: control samples,
            counting an episode's last, shorter hold as whole), return, RMS tracking error per scored
            axis [deg or mm]."""

            def _on_step(self) -> bool:
                bar.update(self.training_env.num_envs * hold)
                for info in self.locals["infos"]:
                    if "tracking_rms" in info:
                        rows.append({"env_steps": self.num_timesteps * hold, "return": info["episode"]["r"],
                                     **{name: float(factor * v)
                                        for (name, factor), v in zip(shown, info["tracking_rms"], strict=True)}})
                        last = list(rows[-1].values())[2:]
                        bar.set_postfix_str("episode RMS " + " / ".join(
                            f"{v:.4f} {name.rsplit('_', 1)[1]}" for v, (name, _) in zip(last, shown, strict=True)))
                return True

        try:
            with torch_settings():
                agent_steps = -(-self.budget() // hold)
                model = algorithm("MlpPolicy", venv, seed=cfg.seed, device="cpu", verbose=0,
                                  **cfg.agent_kwargs(agent_steps, venv.num_envs))
                # SB3's default logger makes an empty folder in the temp dir on every learn()
                model.set_logger(Logger(folder=None, output_formats=[]))
                t0 = time.perf_counter()
                model.learn(agent_steps, callback=TrainingCurve(), progress_bar=False)
                seconds = time.perf_counter() - t0
        finally:
            bar.close()
        venv.close()
        self.model_ = model
        self.curve_ = pd.DataFrame(rows, columns=["env_steps", "return", *[name for name, _ in shown]])
        samples = int(model.num_timesteps) if hold == 1 else int(venv.samples_run)
        return {"env_steps": samples, "episodes": len(rows) + venv.num_envs, "hold": hold,
                "seconds": round(seconds, 3), "algorithm": cfg.algorithm}

    def _safeguard(self, plant) -> None:
        """Keep the residual only on the axes where it lowers the training references' RMS tracking
        error against the base alone (module docstring); sets ``kept_``, ``safeguard_``, ``note_``."""
        n = self.model_.action_space.shape[0]
        self.kept_ = np.ones(n, dtype=bool)
        self.note_ = ""
        if not (self._config().safeguard and self._config().residual):
            return
        scored = self._scored()
        self.diverged_ = 0
        base = self._training_rms(plant, np.zeros(n, dtype=bool))
        full = self._training_rms(plant, self.kept_)
        self.kept_, figures = keep_axes(base, full, lambda kept: self._training_rms(plant, kept), scored, n,
                                        learned_key="policy")
        samples = [r.n_samples for r in self.training_]
        factor = np.array([f for f, _ in self._display()])  # to deg or mm
        self.safeguard_ = {k: (factor * np.sqrt(np.average(np.square(v), axis=0, weights=samples))).round(6).tolist()
                           for k, v in figures.items()}  # RMS over all training samples [deg or mm]
        self.safeguard_["references_worse"] = int((full > base).any(axis=1).sum())
        self.note_ = dropped_note("rl", self.kept_, list(self.training_[0].axes), self.safeguard_["references_worse"],
                                  len(self.training_), what="residual", diverged=self.diverged_)

    def _scored(self) -> list[int]:
        """The axes (indices) the machine's benchmark scores: the safeguard compares those."""
        return scored_axes(self.system_, len(self.training_[0].axes))

    def _display(self) -> list[tuple[float, str]]:
        """Per scored axis, (factor from rad or m, unit) of the figures it reports: deg or mm."""
        return [self.system_.axes[i].display for i in self._scored()]

    def _training_rms(self, plant, kept: np.ndarray) -> np.ndarray:
        """RMS tracking error [rad or m] (references, scored axes) of the rollouts on the training
        references with the residual acting on the axes ``kept`` (none: the base alone)."""
        rms = []
        for reference in self.training_:
            try:
                trial = self._rollout(plant, reference, kept)
            except SimulationDiverged:  # the residual's failed rollout counts as infinitely worse; the base's fails the cell
                if not np.any(kept):
                    raise
                self.diverged_ += 1
                rms.append(np.full(len(self._scored()), np.inf))
                continue
            error = self.system_.bench.tracking_error(trial)
            rms.append(np.sqrt(np.mean(np.square(error[:, self._scored()]), axis=0)))
        return np.array(rms)

    def _rollout(self, plant, reference, kept: np.ndarray):
        """Deterministic rollout on ``reference`` with the residual acting on the axes ``kept``: its
        ``Trial`` (``ff``: the applied feedforward).

        The residual of the first action (its held samples) is zero: the env settles the plant at the start with the
        base feedforward, a replay (``plant.run``) with the feedforward's first sample; equal
        first samples make the replay equal to the rollout (tested)."""
        from ..envs import make_env
        from ..envs.hold import HoldAction

        cfg = self._config()
        env = HoldAction(make_env(self.system_.env_id, references=[reference], base_feedforward=self._base(),
                                  plant=plant, episode_steps=None, **self.scales_), self.hold())
        hide = self.system_.bench.observation_error
        act = deterministic_actor(self.model_)
        obs, _ = env.reset(seed=cfg.seed, options={"reference": 0})
        action = np.zeros(env.action_space.shape)  # at the first sample: the base alone, see below
        done = False
        mask = np.asarray(kept, dtype=float)
        while not done:
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            if not cfg.observe_error:
                obs[hide] = 0.0
            action = act(obs) * mask
        if terminated:
            raise SimulationDiverged(f"rl: the plant left its safe range in the rollout on {reference.name}")
        if cfg.observe_error:
            self.cost_.plant_trials += 1
            self.cost_.env_steps += reference.n_samples
        return info["trial"]

    # --- operation --------------------------------------------------------------------------
    def feedforward(self, reference) -> np.ndarray:
        if reference.name not in getattr(self, "rollouts_", {}):
            raise RuntimeError(f"rl: call learn(plant, reference) for {reference.name} first (it rolls the policy out)")
        return np.asarray(self.rollouts_[reference.name].ff, dtype=float)

    def reference_offset(self, reference) -> np.ndarray | None:
        if not self._config().residual:
            return None
        if self.base == "physical":
            return self.base_.reference_offset(reference) if hasattr(self.base_, "reference_offset") else None
        return self.system_.nominal.reference_offset(reference)

    def load_model(self, path: str | Path, _verified: str | None = None):
        """Load a stable-baselines3 zip of this configuration's algorithm. It unpickles Python
        objects: give only files from trusted sources. (``learn`` calls it for its own cache only,
        after checking the file's SHA-256 against the record it wrote.) To use a model of your
        own: ``rl.fit(trials); rl.model_ = rl.load_model(path)``; ``learn`` then only rolls it
        out (its training cost is unknown to lcgym and not counted)."""
        data = Path(path).read_bytes()
        if _verified is not None and hashlib.sha256(data).hexdigest() != _verified:
            raise ValueError(f"rl: cached model {path} does not match its record; delete it to retrain")
        with torch_settings():
            return _algorithm_class(self._config().algorithm).load(io.BytesIO(data), device="cpu")

    def plot_curve(self, path: str | Path) -> Path:
        """Save the training curve (episode RMS tracking error per axis vs env steps) as a PNG."""
        return plot_training_curve(self.curve_, path, title=f"{self._config().algorithm} on {self.system_.name}")


@contextmanager
def torch_settings():
    """One torch thread (the networks are small: one is fastest, and several stall on a busy
    machine) and float32 tensors (SB3's observations are float32), whatever the caller had set;
    restored on exit."""
    import torch

    threads, dtype = torch.get_num_threads(), torch.get_default_dtype()
    torch.set_num_threads(1)
    torch.set_default_dtype(torch.float32)
    try:
        yield
    finally:
        torch.set_num_threads(threads)
        torch.set_default_dtype(dtype)


def deterministic_actor(model):
    """The agent's deterministic action (what ``model.predict(obs, deterministic=True)`` returns)
    as a numpy function of one observation: the actor's layers copied out of torch, 24-26x
    faster per call than SB3's ``predict`` (``benchmarks/rl_actor.py``). PPO: the mean, clipped to the bounds;
    SAC: tanh of the mean, scaled to the bounds; TD3: the actor's tanh output, scaled."""
    import torch
    from stable_baselines3 import PPO, SAC, TD3

    policy = model.policy
    if isinstance(model, PPO):
        modules, squash = [*policy.mlp_extractor.policy_net, policy.action_net], None
    elif isinstance(model, SAC):
        modules, squash = [*policy.actor.latent_pi, policy.actor.mu], np.tanh
    elif isinstance(model, TD3):
        modules, squash = list(policy.actor.mu), None  # mu ends with its own Tanh
    else:
        raise TypeError(f"deterministic_actor: no numpy actor for {type(model).__name__}")
    layers = []
    for m in modules:
        if isinstance(m, torch.nn.Linear):
            layers.append((m.weight.detach().numpy().T.astype(np.float64), m.bias.detach().numpy().astype(np.float64)))
        elif isinstance(m, (torch.nn.Tanh, torch.nn.ReLU)):
            layers.append(np.tanh if isinstance(m, torch.nn.Tanh) else (lambda x: np.maximum(x, 0.0)))
        else:
            raise TypeError(f"deterministic_actor: unexpected layer {m}")
    low, high = model.action_space.low.astype(np.float64), model.action_space.high.astype(np.float64)

    def act(obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float64)
        for layer in layers:
            x = x @ layer[0] + layer[1] if isinstance(layer, tuple) else layer(x)
        if isinstance(model, PPO):
            return np.clip(x, low, high)
        x = squash(x) if squash is not None else x
        return low + 0.5 * (x + 1.0) * (high - low)

    return act


def _algorithm_class(name: str):
    from stable_baselines3 import PPO, SAC, TD3

    return {"ppo": PPO, "sac": SAC, "td3": TD3}[name]


def plot_training_curve(curve: pd.DataFrame, path: str | Path, title: str = "") -> Path:
    """Episode RMS tracking error [deg or mm] per axis against env steps (points: training episodes,
    run with the exploring policy; line: the mean of the last 16), written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..data import atomic_write

    cols = [c for c in curve.columns if c.startswith("rms_")]
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, c in enumerate(cols):
        ax.plot(curve["env_steps"], curve[c], ".", ms=3, color=f"C{i}", alpha=0.4)
        ax.plot(curve["env_steps"], curve[c].rolling(16, min_periods=1).mean(), color=f"C{i}",
                label=c.removeprefix("rms_").rsplit("_", 1)[0])
    ax.set_xlabel("env steps")
    ax.set_ylabel(f"episode RMS tracking error [{', '.join(sorted({c.rsplit('_', 1)[1] for c in cols}))}]")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    path = Path(path)
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png", dpi=100))
    plt.close(fig)
    return path


def _read_cached(folder: Path, key: str) -> dict | None:
    """The record of a cached model, or None when there is none (or it is incomplete)."""
    record_path = folder / f"{key}.json"
    if not record_path.is_file() or not (folder / f"{key}.zip").is_file() or not (folder / f"{key}.csv").is_file():
        return None
    try:
        record = json.loads(record_path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    needed = ("env_steps", "episodes", "seconds", "sha256")
    return record if isinstance(record, dict) and all(k in record for k in needed) else None


def _write_cached(folder: Path, key: str, model, curve: pd.DataFrame, record: dict, system: str) -> None:
    """Model zip, curve CSV and PNG, then the record (last: a record means a complete entry)."""
    from ..data import atomic_write

    folder.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    model.save(buffer)
    data = buffer.getvalue()
    atomic_write(folder / f"{key}.zip", lambda tmp: Path(tmp).write_bytes(data))
    atomic_write(folder / f"{key}.csv", lambda tmp: curve.to_csv(tmp, index=False))
    if len(curve):
        plot_training_curve(curve, folder / f"{key}.png", title=f"{record['algorithm']} on {system}")
    record["sha256"] = hashlib.sha256(data).hexdigest()
    atomic_write(folder / f"{key}.json", lambda tmp: Path(tmp).write_text(json.dumps(record, indent=1)))
