"""Which machine a log belongs to: a log of another machine than ``--system`` names is refused with
the file's axes, the machine's, and the machines whose axes the file's are (``check_log_axes``).

A log names its axes by its ``pos_<axis>`` columns. It is of another machine when it names none of
the machine's axes, nor a near-miss of one (``data.another_machine``: a typo keeps the reader's
"did you mean"). The machines suggested instead, in order: the one its sidecar names (``lcgym
simulate`` writes the ``--system`` it ran), the built-in and example machines with exactly these
axes, and the URDFs (every axis a movable joint) and machine files (exactly these joints) in the
log's folder and the current one.
"""

from __future__ import annotations

import json
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from importlib import resources
from pathlib import Path

from .. import systems
from ..data import MeasurementFileError, another_machine, file_axes

MOVABLE = ("revolute", "continuous", "prismatic")  # URDF joint types that can be axes
MAX_FILES = 50  # URDF and machine files looked at per folder, at most (sorted by name)
MAX_SHOWN = 3  # machines suggested in the message, at most (the sidecar's first)


def check_log_axes(path: str | Path, system: systems.System, spec: str | None = None, system_wins: bool = False) -> None:
    """Refuse the measurement file ``path`` when it is a log of another machine than ``system``
    (module docstring), with the machines whose axes its are; ``spec``: the machine as the user
    named it. A log whose sidecar names a machine of other axes is refused too, naming both, unless
    ``system_wins`` (the user's word that it is a log of ``system``: its other columns left out)."""
    try:
        found = file_axes(path)
    except MeasurementFileError:  # a broken header: reading the file says what is wrong with it
        return
    named = spec or system.name
    if not another_machine(found, system.axis_names):
        # the log names the machine's axes, but its sidecar may name another machine (the rail arm's
        # log read as the two-link arm's: the rail's columns would be left out without a word)
        sidecar = _sidecar_machine(path)
        theirs = None if sidecar is None or system_wins else _axes_of(sidecar)
        if theirs is not None and tuple(theirs) != tuple(system.axis_names):
            raise MeasurementFileError(
                f"{path}: its sidecar says it is a log of machine {sidecar} (axes {', '.join(theirs)}), not of {named} "
                f"(axes {', '.join(system.axis_names)}); give --system {sidecar}, or --system-wins to read it as a log "
                f"of {named}")
        return
    which = machines_with_axes(found, path)
    if not which:
        hint = "give --system the URDF or machine file (.toml) whose joints these are"
    else:
        more = len(which) - MAX_SHOWN
        hint = f"give --system {' or '.join(which[:MAX_SHOWN])}" + (f" (or one of {more} more)" if more > 0 else "")
    raise MeasurementFileError(f"{path}: the file's axes ({', '.join(found)}) are not those of machine {named} "
                               f"({', '.join(system.axis_names)}): it is a log of another machine; {hint}")


def machines_with_axes(axes: Sequence[str], log: str | Path | None = None) -> list[str]:
    """The machines (as ``--system`` takes them) whose axes are ``axes``: the one ``log``'s sidecar
    names, the built-in and example ones, and the URDFs and machine files in ``log``'s folder and the
    current one (module docstring)."""
    axes = tuple(axes)
    out = []
    named = _sidecar_machine(log) if log is not None else None
    if named is not None and _axes_of(named) == axes:
        out.append(named)
    for name in (*systems.BUILT_IN, *systems.EXAMPLES):
        if _axes_of(name) == axes:
            out.append(name)
    for name, file in systems.URDF_EXAMPLES.items():  # a URDF's axes: the joints the log names
        if _urdf_has(resources.files("lcgym.systems.examples").joinpath(file), axes):
            out.append(name)
    folders = dict.fromkeys(p.resolve() for p in ([Path(log).parent] if log is not None else []) + [Path.cwd()])
    for folder in folders:
        for file in sorted(folder.glob("*.urdf"))[:MAX_FILES]:
            if _urdf_has(file, axes):
                out.append(_shown(file))
        for file in sorted(folder.glob("*.toml"))[:MAX_FILES]:
            if _machine_file_axes(file) == axes:
                out.append(_shown(file))
    return list(dict.fromkeys(out))


def _shown(file: Path) -> str:
    """A path as the user would type it: relative to the current folder where it is inside it."""
    try:
        return str(file.relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(file)


def _sidecar_machine(log: str | Path) -> str | None:
    """The machine a log's JSON sidecar names (``"system"``: what ``lcgym simulate --system`` was
    given), if it still names one: a built-in name or a file that exists."""
    try:
        meta = json.loads(Path(f"{log}.json").read_text())
    except (OSError, ValueError):
        return None
    name = meta.get("system") if isinstance(meta, dict) else None
    if not isinstance(name, str):
        return None
    if name in systems.BUILT_IN or name in systems.EXAMPLES or name in systems.URDF_EXAMPLES:
        return name
    family = name.rpartition("-")[0]
    if family in systems.VERSIONS:  # "ix-v0"
        return name
    return name if systems.is_file_machine(name) and Path(name).is_file() else None


def _axes_of(spec: str) -> tuple[str, ...] | None:
    """The axes of a machine by its name or file (a URDF's: its movable joints), or None where it
    does not load."""
    if spec.lower().endswith(".urdf"):
        return _urdf_joints(Path(spec))
    if spec.lower().endswith(".toml"):
        return _machine_file_axes(Path(spec))
    try:
        return systems.get(spec).axis_names
    except (ValueError, ImportError, OSError):
        return None


def _urdf_has(path, axes: tuple[str, ...]) -> bool:
    """Whether every axis is a movable joint of the URDF at ``path`` (its other joints are locked)."""
    joints = _urdf_joints(Path(str(path)))
    return joints is not None and set(axes) <= set(joints)


def _urdf_joints(path: Path) -> tuple[str, ...] | None:
    """The movable joints (not mimicking another) of a URDF, from its XML; None if it does not read."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return None
    return tuple(j.get("name") for j in root.iter("joint")
                 if j.get("type") in MOVABLE and j.get("name") and j.find("mimic") is None)


def _machine_file_axes(path: Path) -> tuple[str, ...] | None:
    """The axes of a machine file: its ``joints``, else its URDF's movable joints; None if it does
    not read."""
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    joints = data.get("joints")
    if isinstance(joints, list) and all(isinstance(j, str) for j in joints):
        return tuple(joints)
    urdf = data.get("urdf")
    return _urdf_joints(path.parent / urdf) if isinstance(urdf, str) else None
