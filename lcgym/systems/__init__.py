"""Machines: one ``System`` object per machine, and one lookup for all of them.

    from lcgym import systems
    ix = systems.get("ix")                              # a built-in benchmark machine
    emps = systems.get("emps")                          # a worked example of real data (``EXAMPLES``)
    arm = systems.get("path/to/robot.urdf", joints=("shoulder", "elbow"))   # a URDF (pinocchio)
    two = systems.get("two_link")                       # a built-in machine given by its machine file
    cobot = systems.get("cobot6")                       # a URDF shipped with lcgym (``URDF_EXAMPLES``)
    mine = systems.get("my_module:MY_MACHINE")          # a System (or a function returning one)
    arm = systems.resolve("my_arm.toml").bench()        # a machine file's bench: a URDF with its plant (``machine.py``)

Built-in machines (``BUILT_IN``) live in one folder each: ``systems/ix/`` (paper 000's C-arm) and
``systems/flexarm/`` (paper 002's arm); they have a plant, so the benchmark, the simulator and the
Gymnasium envs run on them. So has a machine file's or a URDF's machine (``resolve``: a
``URDFPlant`` with the hidden effects, feedback and sensors the file gives; ``lcgym/Machine-v0``).
Any machine, built-in or not, has a rigid-body model, so the
diagnosis, the physical model and the PGNN run on it (``System``'s docstring).
"""

from __future__ import annotations

import hashlib
import importlib
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from ..user_code import import_user_module
from .system import Axis, DiagnosisSettings, ParameterVector, SimulationDiverged, System

if TYPE_CHECKING:
    from .bench import Bench


@dataclass(frozen=True)
class BuiltIn:
    """Where a built-in benchmark machine lives and how Gymnasium finds it: ``module``.``attr`` is its
    ``System``; ``versions`` its plant's versions, oldest first (a version is frozen once released: a
    plant change makes a new one; the newest is the benchmark's default); ``env`` the name of its
    Gymnasium ids (``lcgym/<env>-<version>``), built by ``entry_point`` / ``vector_entry_point`` with
    ``env_kwargs`` and the version."""

    module: str
    attr: str
    versions: tuple[str, ...]
    env: str
    entry_point: str
    vector_entry_point: str
    env_kwargs: tuple[tuple[str, str], ...] = ()


_MACHINE_ENV = ("lcgym.systems.machine_env:MachineEnv", "lcgym.systems.machine_env:MachineVectorEnv")

BUILT_IN = {
    "ix": BuiltIn("lcgym.systems.ix", "IX", ("v0", "v1"), "IX", "lcgym.systems.ix.env:IXEnv",
                  "lcgym.systems.ix.env:IXVectorEnv"),
    "flexarm": BuiltIn("lcgym.systems.flexarm", "FLEXARM", ("v0", "v1"), "FlexArm", "lcgym.systems.flexarm.env:FlexArmEnv",
                       "lcgym.systems.flexarm.env:FlexArmVectorEnv"),
    "two_link": BuiltIn("lcgym.systems.two_link", "TWO_LINK", ("v0",), "TwoLink", *_MACHINE_ENV, (("machine", "two_link"),)),
    "emps_sim": BuiltIn("lcgym.systems.emps_sim", "EMPS_SIM", ("v0",), "EMPS", *_MACHINE_ENV, (("machine", "emps_sim"),)),
}
"""The built-in benchmark machines, one folder each (``systems/<name>/``): one line here registers one."""

EXAMPLES = {"emps": ("lcgym.systems.examples.emps", "EMPS")}
"""Name -> (module, attribute) of machines shipped as worked examples of real data (no plant: the
diagnosis and the physical model run on them, the benchmark does not)."""

URDF_EXAMPLES = {"cobot6": "cobot6.urdf"}
"""Name -> file in ``lcgym/systems/examples/`` of the URDFs shipped with lcgym (package data): by
name, ``--system cobot6`` works from an installed wheel as well as from the source tree. (The
two-link arm's URDF is the built-in machine ``two_link``'s, in ``systems/two_link/``.)"""

VERSIONS = {name: m.versions for name, m in BUILT_IN.items()}
"""The versions of each built-in machine's plant, oldest first (``BuiltIn.versions``). The
rigid-body model (diagnosis, physical model) is the machine's, shared by its versions."""

ENVS = {f"lcgym/{m.env}-{v}": {"entry_point": m.entry_point, "vector_entry_point": m.vector_entry_point,
                               "kwargs": {**dict(m.env_kwargs), "version": v}}
        for m in BUILT_IN.values() for v in m.versions}
ENVS["lcgym/Machine-v0"] = {"entry_point": _MACHINE_ENV[0], "vector_entry_point": _MACHINE_ENV[1], "kwargs": {}}
"""The Gymnasium ids and entry points of the built-in machines (their ``System.bench.envs`` take them
from here) and ``lcgym/Machine-v0``, any machine's (``gym.make("lcgym/Machine-v0",
machine="my_arm.toml")``), so that ``import lcgym`` registers them without importing the machines
(plants, kernels, scipy)."""


def is_file_machine(spec) -> bool:
    """A machine named by a file or by Python (``.toml``, ``.urdf``, ``module:attr``), not a built-in name."""
    text = str(spec)
    return text.lower().endswith((".toml", ".urdf")) or (":" in text and not text.startswith(":"))


@dataclass(frozen=True)
class BenchMachine:
    """A benchmark machine as ``resolve`` found it: ``name`` as the results store it ("ix-v1"; a
    machine file, URDF or ``module:attr`` as given), ``machine`` the machine it belongs to ("ix"; a
    file as given: what a method's ``systems`` names) and the plant ``version``. A built-in machine
    is imported when its ``system`` is first asked for (a benchmark's list of machines is checked
    without loading them); any other is loaded by ``resolve``."""

    name: str
    machine: str
    version: str
    loaded: System | None = None

    @property
    def system(self) -> System:
        return self.loaded if self.loaded is not None else get(self.machine)

    def bench(self) -> Bench:
        """A fresh bench of this machine and version (``System.make_bench``). Not shared: a plant
        may carry state from run to run (a URDF plant's noise stream), so each benchmark cell
        builds its own and its numbers do not depend on the cells run before it."""
        return self.system.make_bench(self.version)


def resolve(spec: str | System) -> BenchMachine:
    """The benchmark machine ``spec`` names: a built-in one ("ix" is its newest version, "ix-v0" that
    version), a machine file (its plant as the file says), a URDF (a plant with
    ``machine.MachineSettings``' defaults: no hidden effect, 10 Hz PD feedback), ``module:attr`` or a
    ``System``. A name or a file is resolved once per process (a file again when its content
    changed, not when only a file it names did), so a machine is loaded and its URDF parsed once,
    not in every cell; ``module:attr`` is looked up each time (Python keeps the module)."""
    if isinstance(spec, System):
        return _with_plant(spec, spec.name)
    spec = str(spec)
    if is_file_machine(spec) and not spec.lower().endswith((".toml", ".urdf")):
        return _resolve.__wrapped__(spec, None)
    return _resolve(spec, _file_key(spec))


@lru_cache(maxsize=64)
def _resolve(spec: str, file: tuple[str, str] | None) -> BenchMachine:
    machine, sep, version = spec.rpartition("-")
    if sep and machine in VERSIONS and version in VERSIONS[machine]:
        return BenchMachine(spec, machine, version)
    if spec in VERSIONS:
        return BenchMachine(f"{spec}-{VERSIONS[spec][-1]}", spec, VERSIONS[spec][-1])
    if is_file_machine(spec) or spec in URDF_EXAMPLES:
        return _with_plant(get(spec), spec)
    names = ", ".join(f"{m} ({', '.join(f'{m}-{v}' for v in vs)})" for m, vs in VERSIONS.items())
    raise ValueError(f"unknown system {spec!r}; available: {names}, or a machine file (.toml), a URDF or "
                     "module:attr (a name without a version is the newest; the benchmark needs a machine with a plant)")


def _file_key(spec: str) -> tuple[str, str] | None:
    """(absolute path, SHA-256 of the content) of the file ``spec`` names, if it names one."""
    path = Path(spec)
    if spec.lower().endswith((".toml", ".urdf")) and path.is_file():
        return str(path.resolve()), hashlib.sha256(path.read_bytes()).hexdigest()
    return None


def _with_plant(machine: System, name: str) -> BenchMachine:
    """``machine`` resolved as ``name``: with its own bench, or a URDF machine's default one."""
    if machine.bench is None:
        from .machine import benchmark_machine
        from .urdf import URDFRobot

        if not isinstance(getattr(machine.regressor, "__self__", None), URDFRobot):
            raise ValueError(f"machine {machine.name} has no plant, so the benchmark cannot run on it: give a machine "
                             "file (.toml), a URDF, or a System made by lcgym.systems.machine.benchmark_machine")
        machine = benchmark_machine(machine)
    return BenchMachine(name, name, machine.bench.versions[-1], machine)


def newest_benchmarks() -> tuple[str, ...]:
    """The newest version of each built-in machine: the benchmark's default systems."""
    return tuple(f"{m}-{vs[-1]}" for m, vs in VERSIONS.items())


def get(spec: str | System, joints: Sequence[str] | None = None, **options) -> System:
    """The machine ``spec`` names: a ``System`` (returned as is), a built-in name (``BUILT_IN``; a
    versioned one, "ix-v0", names the same machine: versions differ in their plant only), a
    ``.urdf`` file (``urdf.from_urdf(spec, joints, **options)``: ``joints`` are the axes, the
    URDF's other joints are locked), a machine file (``.toml``, ``machine.load_machine``: a URDF
    with the plant it should have) or ``module:attr`` (a ``System`` or a function returning one,
    imported from the current folder too, like ``python -m``)."""
    if isinstance(spec, System):
        return spec
    spec = str(spec)
    machine, _, version = spec.rpartition("-")
    if spec not in BUILT_IN and version in VERSIONS.get(machine, ()):  # "ix-v0": the machine of that plant
        spec = machine
    if spec in BUILT_IN:
        machine = getattr(importlib.import_module(BUILT_IN[spec].module), BUILT_IN[spec].attr)
        if (joints is not None and tuple(joints) != machine.axis_names) or options:
            raise ValueError(f"{spec} is a built-in machine with axes {', '.join(machine.axis_names)}: give its URDF "
                             "file to choose other joints or options")
        return machine
    if spec in EXAMPLES:
        module, attr = EXAMPLES[spec]
        return getattr(importlib.import_module(module), attr)
    if spec in URDF_EXAMPLES:
        spec = str(resources.files("lcgym.systems.examples").joinpath(URDF_EXAMPLES[spec]))
    if spec.lower().endswith(".toml"):
        from .machine import load_machine

        return load_machine(spec)
    if spec.lower().endswith(".urdf"):
        from .urdf import from_urdf

        return from_urdf(spec, joints=joints, **options)
    module_name, sep, attr = spec.partition(":")
    if sep and module_name and attr:
        return from_python(module_name, attr)
    known = ", ".join([*BUILT_IN, *EXAMPLES, *URDF_EXAMPLES])
    raise ValueError(f"unknown machine {spec!r}: give a built-in one ({known}), a .urdf file, a machine file (.toml), "
                     "or module:attr naming a lcgym.systems.System")


def from_python(module_name: str, attr: str) -> System:
    """``module:attr``: a ``System`` instance, or a function without arguments that returns one."""
    where = f"{module_name}:{attr}"
    try:
        module = import_user_module(module_name)
    except Exception as exc:  # an ImportError, or any error the user's module raises on import
        raise ValueError(f"machine {where}: cannot import module {module_name!r} ({type(exc).__name__}: {exc})") from None
    if not hasattr(module, attr):
        raise ValueError(f"machine {where}: module {module_name!r} has no {attr!r}")
    obj = getattr(module, attr)
    if isinstance(obj, System):
        return obj
    if not callable(obj):
        raise ValueError(f"machine {where} is an object of type {type(obj).__name__}, not a lcgym.systems.System "
                         "(nor a function returning one)")
    try:
        made = obj()
    except Exception as exc:
        raise ValueError(f"machine {where}: calling it raised {type(exc).__name__}: {exc}") from None
    if not isinstance(made, System):
        raise ValueError(f"machine {where} returned an object of type {type(made).__name__}, not a lcgym.systems.System")
    return made


def built_in() -> list[System]:
    """The built-in machines, in ``BUILT_IN`` order."""
    return [get(name) for name in BUILT_IN]


def register_envs() -> None:
    """Register the built-in machines' Gymnasium ids (``ENVS``) with Gymnasium, once."""
    import gymnasium as gym

    for env_id, entry in ENVS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, **entry)


__all__ = [
    "Axis", "BUILT_IN", "BuiltIn", "DiagnosisSettings", "ENVS", "EXAMPLES", "ParameterVector", "SimulationDiverged", "System",
    "URDF_EXAMPLES", "VERSIONS", "BenchMachine", "built_in", "from_python", "get", "is_file_machine",
    "newest_benchmarks", "register_envs", "resolve",
]
