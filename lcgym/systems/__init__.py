"""Machines: one ``System`` object per machine, and one lookup for all of them.

    from lcgym import systems
    ix = systems.get("ix")                              # a built-in benchmark machine
    emps = systems.get("emps")                          # a worked example of real data (``EXAMPLES``)
    arm = systems.get("path/to/robot.urdf", joints=("shoulder", "elbow"))   # a URDF (pinocchio)
    two = systems.get("two_link", joints=("shoulder", "elbow"))  # a URDF shipped with lcgym (``URDF_EXAMPLES``)
    mine = systems.get("my_module:MY_MACHINE")          # a System (or a function returning one)

Built-in machines (``BUILT_IN``) live in one folder each: ``systems/ix/`` (paper 000's C-arm) and
``systems/flexarm/`` (paper 002's arm); they have a plant, so the benchmark, the simulator and the
Gymnasium envs run on them. Any machine, built-in or not, has a rigid-body model, so the
diagnosis, the physical model and the PGNN run on it (``System``'s docstring).
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Sequence
from importlib import resources

from .system import Axis, ParameterVector, SimulationDiverged, System

BUILT_IN = {"ix": ("lcgym.systems.ix", "IX"), "flexarm": ("lcgym.systems.flexarm", "FLEXARM")}
"""Name -> (module, attribute) of each built-in machine."""

EXAMPLES = {"emps": ("lcgym.systems.examples.emps", "EMPS")}
"""Name -> (module, attribute) of machines shipped as worked examples of real data (no plant: the
diagnosis and the physical model run on them, the benchmark does not)."""

URDF_EXAMPLES = {"two_link": "two_link.urdf", "cobot6": "cobot6.urdf"}
"""Name -> file in ``lcgym/systems/examples/`` of the URDFs shipped with lcgym (package data): by
name, ``--system two_link`` works from an installed wheel as well as from the source tree."""

VERSIONS = {"ix": ("v0", "v1"), "flexarm": ("v0", "v1")}
"""The versions of each built-in machine's plant, oldest first. A version is frozen once released: a
plant change makes a new one (what changed: the Version History of ``systems/<machine>/env.py``).
The newest is the benchmark's default; the rigid-body model (diagnosis, physical model) is the
machine's, shared by its versions."""

_IX_ENV = {"entry_point": "lcgym.systems.ix.env:IXEnv", "vector_entry_point": "lcgym.systems.ix.env:IXVectorEnv"}
_ARM_ENV = {"entry_point": "lcgym.systems.flexarm.env:FlexArmEnv",
            "vector_entry_point": "lcgym.systems.flexarm.env:FlexArmVectorEnv"}
ENVS = {
    "lcgym/IX-v0": {**_IX_ENV, "kwargs": {"version": "v0"}},
    "lcgym/IX-v1": {**_IX_ENV, "kwargs": {"version": "v1"}},
    "lcgym/FlexArm-v0": {**_ARM_ENV, "kwargs": {"version": "v0"}},
    "lcgym/FlexArm-v1": {**_ARM_ENV, "kwargs": {"version": "v1"}},
}
"""The built-in machines' Gymnasium ids and entry points (their ``System.envs`` take them from here), so
that ``import lcgym`` registers them without importing the machines (plants, kernels, scipy)."""


def benchmark_name(spec: str) -> str:
    """The versioned name of a benchmark machine: "ix" -> the newest ("ix-v1"), "ix-v0" -> "ix-v0"."""
    family, sep, version = str(spec).rpartition("-")
    if not sep:
        family, version = spec, None
    if family not in VERSIONS or (version is not None and version not in VERSIONS[family]):
        names = ", ".join(f"{m} ({', '.join(f'{m}-{v}' for v in vs)})" for m, vs in VERSIONS.items())
        raise ValueError(f"unknown system {spec!r}; available: {names} (a name without a version is the "
                         "newest; the benchmark needs a machine with a plant)")
    return f"{family}-{version or VERSIONS[family][-1]}"


def newest_benchmarks() -> tuple[str, ...]:
    """The newest version of each built-in machine: the benchmark's default systems."""
    return tuple(benchmark_name(m) for m in VERSIONS)


def make_bench(spec: str):
    """The bench (``systems/bench.py``) of a benchmark machine, "ix", "ix-v0", "flexarm-v1", ...,
    with the plant of that version."""
    family, version = benchmark_name(spec).rsplit("-", 1)
    return get(family).bench(version)


def family_of(spec: str) -> str:
    """The machine a (versioned) benchmark name belongs to: "ix-v0" -> "ix"."""
    return benchmark_name(spec).rsplit("-", 1)[0]


def get(spec: str | System, joints: Sequence[str] | None = None, **options) -> System:
    """The machine ``spec`` names: a ``System`` (returned as is), a built-in name (``BUILT_IN``; a
    versioned one, "ix-v0", names the same machine: versions differ in their plant only), a
    ``.urdf`` file (``urdf.from_urdf(spec, joints, **options)``: ``joints`` are the axes, the
    URDF's other joints are locked) or ``module:attr`` (a ``System`` or a function returning one,
    imported from the current folder too, like ``python -m``)."""
    if isinstance(spec, System):
        return spec
    spec = str(spec)
    if spec not in BUILT_IN and spec.rpartition("-")[0] in VERSIONS:  # "ix-v0": the machine of that plant
        spec = family_of(spec)
    if spec in BUILT_IN or spec in EXAMPLES:
        module, attr = {**BUILT_IN, **EXAMPLES}[spec]
        return getattr(importlib.import_module(module), attr)
    if spec in URDF_EXAMPLES:
        spec = str(resources.files("lcgym.systems.examples").joinpath(URDF_EXAMPLES[spec]))
    if spec.lower().endswith(".urdf"):
        from .urdf import from_urdf

        return from_urdf(spec, joints=joints, **options)
    module_name, sep, attr = spec.partition(":")
    if sep and module_name and attr:
        return from_python(module_name, attr)
    known = ", ".join([*BUILT_IN, *EXAMPLES, *URDF_EXAMPLES])
    raise ValueError(f"unknown machine {spec!r}: give a built-in one ({known}), a .urdf file, "
                     "or module:attr naming a lcgym.systems.System")


def from_python(module_name: str, attr: str) -> System:
    """``module:attr``: a ``System`` instance, or a function without arguments that returns one."""
    where = f"{module_name}:{attr}"
    if os.getcwd() not in sys.path:  # like `python -m`: a module in the current folder is found
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
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


def of_trials(trials) -> System:
    """The built-in machine that recorded ``trials`` (their ``meta["system"]``; "ix" when unset)."""
    names = {t.meta.get("system", "ix") for t in trials}
    if len(names) != 1:
        raise ValueError(f"trials of several machines mixed: {sorted(names)}")
    name = names.pop()
    if name not in BUILT_IN:
        raise ValueError(f"trials of machine {name!r}: give the machine (a System) explicitly; built-in: "
                         f"{', '.join(BUILT_IN)}")
    return get(name)


def register_envs() -> None:
    """Register the built-in machines' Gymnasium ids (``ENVS``) with Gymnasium, once."""
    import gymnasium as gym

    for env_id, entry in ENVS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, **entry)


__all__ = ["Axis", "BUILT_IN", "ENVS", "EXAMPLES", "URDF_EXAMPLES", "VERSIONS", "ParameterVector", "SimulationDiverged", "System",
           "benchmark_name", "built_in", "family_of", "from_python", "get", "make_bench", "newest_benchmarks", "of_trials",
           "register_envs"]
