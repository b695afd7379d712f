"""A machine of your own in the benchmark: a URDF plus what its simulated plant should carry.

The rigid body comes from the URDF (``urdf.from_urdf``, pinocchio); the plant (``URDFPlant``) adds
the hidden effects you declare (what the nominal model lacks: your machine's friction, a cable, a
gear), a feedback loop, encoders and input limits. They are written in a machine file (TOML; every
key but ``urdf`` is optional; each key, with its unit and default: docs/own-machine-bench.md,
"Every key of a machine file"), read by ``load_machine``. Its ``[[model]]`` tables name the
effects the physical model carries beyond its rigid body and viscous friction, with no values: the
model's fit finds them, and every method that starts from the physical model has them.

In Python, ``benchmark_machine(system_or_urdf, hidden=[...], ...)`` takes the same settings as
arguments (the model's effects are the machine's: ``dataclasses.replace(system, model_effects=(...))``).
Either gives a ``System`` with a bench (``URDFBench``: references, plant runs, the scored tables) and
a Gymnasium env (``lcgym/Machine-v0``, ``systems.machine_env``): ``lcgym bench --systems my_arm.toml``
and ``gym.make("lcgym/Machine-v0", machine="my_arm.toml")``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .bench import BenchFactory
from .feedback import FeedbackGains
from .system import System
from .urdf_bench import URDFBench

MACHINE_ENV = "lcgym/Machine-v0"
"""The Gymnasium id of every machine given by a machine file or by ``benchmark_machine``."""



@dataclass(frozen=True)
class ReferenceSettings:
    """Random point-to-point moves of every axis (``references.point_to_point``): a move's top speed
    is a random 0.4-1 of ``speed`` x the URDF velocity limit (``velocity_fallback`` [rad/s, m/s]
    where it gives none), reached in ``accel_time`` s with its acceleration reached in ``jerk_time``
    s; targets ``margin`` (a fraction of the range) clear of each joint limit."""

    speed: float = 0.5
    accel_time: float = 0.2
    jerk_time: float = 0.05
    margin: float = 0.1
    velocity_fallback: tuple[float, float] = (1.0, 0.1)

    def __post_init__(self):
        if not (self.speed > 0 and self.accel_time > 0 and self.jerk_time > 0 and 0 <= self.margin < 0.5):
            raise ValueError(f"references: need speed, accel_time, jerk_time > 0 and 0 <= margin < 0.5, got {self}")
        fallback = np.asarray(self.velocity_fallback, dtype=float)
        if fallback.shape != (2,) or not np.all(fallback > 0):
            raise ValueError(f"references.velocity_fallback = {self.velocity_fallback}: must be two speeds > 0 "
                             "(revolute [rad/s], prismatic [m/s])")


@dataclass(frozen=True)
class FeedbackSettings:
    """The plant's feedback: gains derived from ``bandwidth`` [Hz], ``damping`` and ``integral_time``
    [s] (``urdf_plant.tuned_gains``), or given per axis (``kp``, ``kd``, ``ki``; ``f_lp`` [Hz]);
    ``derivative``: what the derivative term differentiates (``FeedbackGains.derivative``: "error",
    "measurement", "measurement_fir2")."""

    bandwidth: float = 10.0
    damping: float = 0.7
    integral_time: float | None = None
    kp: tuple[float, ...] | None = None
    kd: tuple[float, ...] | None = None
    ki: tuple[float, ...] | None = None
    f_lp: float | None = None
    derivative: str = "error"

    def __post_init__(self):
        """Values no loop has are refused, naming the key: a gain of the wrong sign makes an unstable
        loop or one that pushes the error on, a zero corner frequency no filter."""
        rules = {"bandwidth": (self.bandwidth, "> 0"), "damping": (self.damping, "> 0"),
                 "integral_time": (self.integral_time, "> 0"), "kp": (self.kp, "> 0"), "kd": (self.kd, ">= 0"),
                 "ki": (self.ki, ">= 0"), "f_lp": (self.f_lp, "> 0")}
        for key, (value, rule) in rules.items():
            values = np.atleast_1d(np.asarray(value if value is not None else 1.0, dtype=float))
            if not (np.all(np.isfinite(values)) and np.all(values > 0 if rule == "> 0" else values >= 0)):
                raise ValueError(f"feedback.{key} = {value}: must be {rule}{' on every axis' if values.size > 1 else ''}")

    def gains(self, system: System, fs: float) -> FeedbackGains:
        if self.kp is None:
            if self.kd is not None or self.ki is not None:
                raise ValueError("feedback: give kp with kd (and ki), or a bandwidth")
            from .urdf_plant import tuned_gains

            tuned = tuned_gains(system, self.bandwidth, self.damping, self.integral_time, fs=fs)
            return tuned if self.derivative == "error" else dataclasses.replace(tuned, derivative=self.derivative)
        return FeedbackGains(self.kp, self.kd if self.kd is not None else (0.0,) * len(self.kp), self.ki,
                             f_lp=self.f_lp or 10 * self.bandwidth, filtered="derivative", derivative=self.derivative)


@dataclass(frozen=True)
class MachineSettings:
    """What the simulated plant of a URDF machine carries beyond the URDF (module docstring). fs
    [Hz]; encoder_resolution, noise_rms [rad or m], u_max [N m or N; None: the URDF's effort
    limits], max_error [rad or m; None: the plant's default]: one value or one per axis; hidden: the
    hidden effects (``physics.effects`` objects); methods: each method's settings on the machine,
    keyed by method id (``System.settings``, the machine file's ``[benchmark.<method>]`` tables: e.g.
    ``{"rl": {"passes": 1.0}}``); source: the machine file, if any."""

    fs: float = 1000.0
    feedback: FeedbackSettings = field(default_factory=FeedbackSettings)
    encoder_resolution: float | tuple[float, ...] = 0.0
    noise_rms: float | tuple[float, ...] = 0.0
    u_max: float | tuple[float, ...] | None = None
    max_error: float | tuple[float, ...] | None = None
    hidden: tuple = ()
    references: ReferenceSettings = field(default_factory=ReferenceSettings)
    methods: Mapping = field(default_factory=dict)
    source: str | None = None

    def __post_init__(self):
        if not (np.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f"fs must be > 0 Hz, got {self.fs}")
        for effect in self.hidden:
            if why := effect.impossible():
                raise ValueError(f"hidden effect {effect.key}: {why}: no machine has that")

    def plant(self, system: System, seed: int = 0):
        """The simulated plant of ``system`` with these settings (``URDFPlant``)."""
        from .urdf import urdf_robot
        from .urdf_plant import URDFPlant

        u_max = self.u_max
        if u_max is None:
            effort = urdf_robot(system).effort
            u_max = np.where(np.isfinite(effort) & (effort > 0), effort, np.inf)
        return URDFPlant(system, effects=self.hidden, gains=self.feedback.gains(system, self.fs), fs=self.fs,
                         u_max=u_max, encoder_resolution=self.encoder_resolution, noise_rms=self.noise_rms,
                         seed=seed, max_error=self.max_error)


def benchmark_machine(machine: System | str | Path, settings: MachineSettings | None = None,
                      joints: Sequence[str] | None = None, name: str | None = None, envs: Mapping | None = None,
                      **kwargs) -> System:
    """A benchmark machine: ``machine`` (a URDF machine, ``urdf.from_urdf``, or a URDF path with
    ``joints`` and ``name``) with a simulated plant of ``settings`` (or ``MachineSettings(**kwargs)``):
    its bench (``MachineBench``, ``System.make_bench``), its Gymnasium ids (``envs``; default ``MACHINE_ENV``) and
    the methods' settings of ``settings``."""
    from .urdf import from_urdf

    settings = settings or MachineSettings(**kwargs)
    system = machine if isinstance(machine, System) else from_urdf(machine, joints=joints, name=name)
    methods = {**system.settings, **{k: dict(v) for k, v in settings.methods.items()}}
    # the id's entry points are registered once, in ``systems.ENVS``; the env's error columns come last
    bench = BenchFactory(MachineBench, settings,
                         envs=envs or {MACHINE_ENV: {"kwargs": {"machine": settings.source or system.name}}},
                         observation_error=slice(-system.n_axes, None))
    return dataclasses.replace(system, fs=settings.fs, bench=bench, settings=methods)


class MachineBench(URDFBench):
    """The bench of a machine of ``benchmark_machine`` (a machine file): a URDF bench whose runs
    record their plant (``plant_record``, in each trial's ``meta["plant"]``, so in a measurement
    file's sidecar), from which ``plant_from_record`` rebuilds it: ``lcgym diagnose --replay``
    re-runs a simulated log of the machine."""

    def run(self, references, feedforward=None, offsets=None):
        trials = super().run(references, feedforward, offsets)
        record = plant_record(self.plant, self.settings)
        for trial in trials:
            trial.meta["plant"] = record
        return trials

    def plant_from_record(self, record: Mapping):
        """The plant of the machine's settings, after checking that it is the one ``record``
        describes (else a ValueError says what differs: the log was simulated on another machine,
        or the machine file changed since)."""
        return plant_from_record(self.system, self.settings, record)


def plant_record(plant, settings: MachineSettings) -> dict:
    """A JSON-ready description of a machine's plant (``URDFPlant``): the machine, its machine file,
    the plant's seed and everything its runs depend on (``repr(plant)``: effects, gains, fs,
    sensors, limits) with a SHA-256 of the URDF (the rigid body). ``plant_from_record`` checks a
    rebuilt plant against it."""
    return {"system": plant.name, "machine_file": settings.source, "seed": plant.seed, "description": repr(plant),
            "urdf_sha256": hashlib.sha256(plant.robot.path.read_bytes()).hexdigest()}


def plant_from_record(system: System, settings: MachineSettings, record: Mapping):
    """``settings.plant(system)`` with the seed of ``record`` (``plant_record``), refused with the
    difference named when it is not the plant that ``record`` describes."""
    what = settings.source or system.name
    if not isinstance(record, Mapping) or not {"system", "description", "urdf_sha256"} <= set(record):
        raise ValueError(f"the log's plant record is not one of a machine file's plant (no system, description and "
                         f"urdf_sha256); it cannot be re-run on {what}")
    if record["system"] != system.name:
        raise ValueError(f"the log was simulated on machine {record['system']!r}, not on {system.name} ({what})")
    plant = settings.plant(system, seed=int(record.get("seed", 0)))
    now = plant_record(plant, settings)
    changed = [part for part, key in (("its URDF", "urdf_sha256"),
                                      ("its hidden effects, feedback, sensors or limits", "description"))
               if now[key] != record[key]]
    if changed:
        was = record.get("machine_file") or record["system"]
        raise ValueError(f"the log was simulated on the plant of {was}; {what} describes another ({' and '.join(changed)} "
                         f"differ): replay on the machine file the log was simulated on, or simulate it again "
                         f"(lcgym simulate --system {what} --out FILE)")
    return plant


def hidden_effects(system: System) -> dict[str, type]:
    """The effects a machine file's ``[[hidden]]`` accepts on ``system``, by name: those its plant
    simulates (``urdf_plant.bind_effects``: a torque of q and qd, ``Effect.plant_kind``,
    and the rotor inertia, an armature) whose formula applies to one of its axes at least."""
    from ..physics import effects as fx
    from ..physics import plant_effects

    return {name: cls for name, cls in sorted(system.effect_classes().items())
            if (plant_effects.has_plant_kind(cls) or issubclass(cls, fx.RotorInertia))
            and any(cls.applies_to(a) for a in system.axes)}


# ---------------------------------------------------------------------------------------------
# The machine file
# ---------------------------------------------------------------------------------------------

TOP_KEYS = ("urdf", "joints", "name", "fs", "gravity", "description", "feedback", "sensors", "limits", "references",
            "hidden", "model", "benchmark")
SECTION_KEYS = {
    "feedback": tuple(f.name for f in dataclasses.fields(FeedbackSettings)),
    "sensors": ("encoder_resolution", "noise_rms"),
    "limits": ("u_max", "max_error"),
    "references": tuple(f.name for f in dataclasses.fields(ReferenceSettings)),
}


class MachineFileError(ValueError):
    """A machine file broke its format; the message names the file and the key."""


def load_machine(path: str | Path, envs: Mapping | None = None) -> System:
    """The benchmark machine a machine file describes (module docstring); ``envs``: its Gymnasium ids
    (a built-in machine's own; default ``MACHINE_ENV``)."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:  # TOML: data only (tables, strings, numbers), nothing is executed
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise MachineFileError(f"machine file {path} not found") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise MachineFileError(f"{path}: not a readable TOML file ({exc})") from None
    where = str(path)

    def fail(key: str, why: str):
        raise MachineFileError(f"{where}: {key}: {why}")

    unknown = [k for k in data if k not in TOP_KEYS]
    if unknown:
        fail(unknown[0], f"unknown key; a machine file has {', '.join(TOP_KEYS)}")
    if "urdf" not in data or not isinstance(data["urdf"], str):
        fail("urdf", "give the URDF file, a path relative to the machine file")
    sections = {}
    for section, keys in SECTION_KEYS.items():
        table = data.get(section, {})
        if not isinstance(table, dict):
            fail(section, "must be a table, [section]")
        bad = [k for k in table if k not in keys]
        if bad:
            fail(f"{section}.{bad[0]}", f"unknown key; [{section}] has {', '.join(keys)}")
        sections[section] = {k: tuple(v) if isinstance(v, list) else v for k, v in table.items()}
    try:
        urdf = (path.parent / data["urdf"]).resolve()
        from .urdf import from_urdf

        system = from_urdf(urdf, joints=data.get("joints"), gravity=data.get("gravity"), name=data.get("name"))
        if "description" in data:  # the file's words first, then what the URDF gives (its base parameters)
            system = dataclasses.replace(system, description=f"{data['description']} ({system.description})")
        hidden = tuple(_hidden_effect(system, i, entry) for i, entry in enumerate(_list(data.get("hidden", []), "hidden")))
        system = dataclasses.replace(system, model_effects=model_effects(system, _list(data.get("model", []), "model")))
        settings = MachineSettings(
            fs=float(data.get("fs", 1000.0)), feedback=FeedbackSettings(**sections["feedback"]),
            hidden=hidden, references=ReferenceSettings(**sections["references"]), methods=_methods(data.get("benchmark", {})),
            source=str(path), **sections["sensors"], **sections["limits"])
        made = benchmark_machine(system, settings, envs=envs)
        settings.plant(made)  # the plant builds: gains, limits and effects fit the machine
        return made
    except MachineFileError:
        raise
    except (ValueError, TypeError) as exc:
        raise MachineFileError(f"{where}: {' '.join(str(exc).split())}") from None


def _list(value, key: str) -> list:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise ValueError(f"{key}: must be a list of tables, [[{key}]]")
    return value


def _hidden_effect(system: System, i: int, entry: Mapping):
    """The i-th [[hidden]] table as an effect bound to ``system``."""
    entry = dict(entry)
    name, axis = entry.pop("effect", None), entry.pop("axis", None)
    if not isinstance(name, str) or not isinstance(axis, str):
        raise ValueError(f"hidden[{i}]: give effect = \"<name>\" and axis = \"<axis>\" (e.g. coulomb_friction, "
                         f"{system.axis_names[0]})")
    classes = system.effect_classes()
    if name not in classes:  # a library effect the plant cannot simulate is refused by the plant, with why
        raise ValueError(f"hidden[{i}]: unknown effect {name!r}; a machine file's plant simulates "
                         f"{', '.join(hidden_effects(system))} (lcgym effects)")
    fields = {f.name for f in dataclasses.fields(classes[name]) if f.init and f.name not in ("axis", "index")}
    bad = [k for k in entry if k not in fields]
    if bad:
        raise ValueError(f"hidden[{i}] ({name}): unknown parameter {bad[0]!r}; it has {', '.join(sorted(fields))}")
    params = {k: tuple(v) if isinstance(v, list) else v for k, v in entry.items()}
    effect = system.effect(f"{name}@{axis}", **params)
    if why := effect.impossible():
        raise ValueError(f"hidden[{i}] ({effect.key}): {why}: no machine has that")
    return effect


def model_effects(system: System, tables: Sequence[Mapping]) -> tuple[str, ...]:
    """The ``name@axis`` keys of a machine file's ``[[model]]`` tables (``System.model_effects``),
    each checked: an effect and an axis, no parameter value, one the model can fit
    (``physics.shapes.model_candidate``), none twice; a ValueError names the table, model[i]."""
    from ..physics.model import PhysicalModel
    from ..physics.shapes import model_candidate

    keys: list[str] = []
    for i, entry in enumerate(tables):
        entry = dict(entry)
        name, axis = entry.pop("effect", None), entry.pop("axis", None)
        if not isinstance(name, str) or not isinstance(axis, str):
            raise ValueError(f"model[{i}]: give effect = \"<name>\" and axis = \"<axis>\" (e.g. coulomb_friction, "
                             f"{system.axis_names[0]})")
        if entry:
            raise ValueError(f"model[{i}] ({name}@{axis}): {next(iter(entry))} = ...: a [[model]] table takes no "
                             "parameter values (effect and axis only): the model's fit finds them")
        key = f"{name}@{axis}"
        try:
            model_candidate(system, key, (system.model or PhysicalModel).built_in)
        except ValueError as exc:
            raise ValueError(f"model[{i}]: {exc}") from None
        if key in keys:
            raise ValueError(f"model[{i}]: {key} is listed twice (model[{keys.index(key)}] and model[{i}])")
        keys.append(key)
    return tuple(keys)


def _methods(table) -> dict:
    """[benchmark.<method>] tables -> ``System.settings``."""
    if not isinstance(table, dict) or not all(isinstance(v, dict) for v in table.values()):
        raise ValueError("benchmark: must hold one table per method, [benchmark.<method>]")
    return table


__all__ = ["MACHINE_ENV", "FeedbackSettings", "MachineBench", "MachineFileError", "MachineSettings", "ReferenceSettings",
           "benchmark_machine", "hidden_effects", "load_machine", "model_effects", "plant_from_record", "plant_record"]
