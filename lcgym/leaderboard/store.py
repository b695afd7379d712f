"""The results store: one tidy CSV, one row per (run, system, method, seed, reference set, axis, signal).

Columns (``COLUMNS``): identification (``run_id``, ``system``: the machine and its version,
``ix-v1``, ``method``, ``base``: the feedforward a learning method builds on, ``physical`` or
``basic`` (``baselines.bases``; empty for a method with none; older files: empty), ``seed``,
``reference_set``, ``axis``, ``signal``, ``period``: the samples the norms are taken over, ``all``,
``dynamic`` while the reference moves or ``static``; older files without the column read as
``all``), the norms of paper 000 eqs. (34)-(36) (``MA``, ``RMS``,
``Inf``) with their ``unit`` (per row: the tracking error in deg on a revolute axis and mm on a
prismatic one, the input residual in the axis's input unit: V on the IX, N m on a revolute joint,
N on a prismatic one), the method's cost (``plant_trials``: closed-loop runs it learned
from, the shared training runs included; ``env_steps``; ``fit_seconds``: wall time of fit and
learn, plus that of learning reused from a cache, ``Cost.cached_seconds``), ``nn_rms`` (RMS of
a neural network's feedforward contribution, where the method has one), ``status`` (``ok`` or
``failed``) and ``error``, and provenance (``lcgym_version``, ``git_commit``, ``timestamp`` in
UTC, ``config_hash`` of the benchmark's configuration), and ``note``: what the method says of its
cell (a method's ``note_``; the ``rl`` safeguard's dropped residual; older files read as empty).

A failed cell is one row with ``status = failed``, its error message and empty metrics.

Appends are atomic: under an exclusive lock on the CSV itself (``locked``: for concurrent writers;
no lock file is left beside it), the existing rows are read, the new ones added, and the whole
table written to a temporary file that is renamed over the CSV. An interrupted writer leaves the
previous complete file.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path

import pandas as pd

from .. import systems
from ..data import atomic_write
from ..metrics import PERIODS

COLUMNS = (
    "run_id", "system", "method", "base", "seed", "reference_set", "axis", "signal", "period", "MA", "RMS", "Inf", "unit",
    "plant_trials", "env_steps", "fit_seconds", "nn_rms", "status", "error",
    "lcgym_version", "git_commit", "timestamp", "config_hash", "note",
)
SYSTEMS = (*(f"{m}-{v}" for m, versions in systems.VERSIONS.items() for v in versions), *systems.BUILT_IN)
"""Versioned built-in machines ("ix-v1"), and the bare names of files written before versions (their v0).
Any other non-empty name is a user's machine (a machine file, a URDF, ``module:attr``), whose input
units are its own: each input-residual row carries its axis's (N m, N, ...; files written before
the units were per axis carry the machine's joined "N m / N", which still reads)."""
REFERENCE_SETS = ("train", "validation", "test")
SIGNALS = {
    "tracking_error": "deg",
    "input_residual": {name: systems.get(name).input_unit for name in SYSTEMS},
    "model_following_error": "rad/s^2",
    "ee_acceleration_error": "m/s^2",
    "tcp_position_error": "mm",
}
IDENTITY = ("run_id", "system", "method", "signal")
"""Columns a file must have to be taken for a results CSV at all (``validate``)."""
STATUS = ("ok", "failed")
TRACKING_UNITS = {name: {axis.display[1] for axis in systems.get(name).axes} for name in SYSTEMS}
"""The units a built-in machine's tracking-error rows may carry: its axes' display units (deg on a
revolute axis, mm on a prismatic one: the EMPS)."""


class ResultsFileError(ValueError):
    """A results CSV broke the schema; the message names the file, column and row."""


@contextmanager
def locked(path: str | Path):
    """Exclusive advisory lock (``flock``) on the file at ``path`` itself, held by one writer process
    at a time; the file is created empty where missing, and nothing else is left beside it.

    Writers replace the file (``atomic_write`` renames a new one over it), so a lock won on a file
    that is no longer the one at ``path`` excludes nobody: it is let go and taken again on the file
    there now, until the file locked is the file at ``path``. A lock file removed after use would
    break the exclusion in the same way, hence no lock file."""
    path = Path(path)
    while True:
        fh = open(path, "a")  # kept open (not a with block) while the lock is held
        try:
            fcntl.flock(fh, fcntl.LOCK_EX)
            if _same_file(fh, path):
                break
        except BaseException:
            fh.close()
            raise
        fh.close()  # closing lets go of the lock on the replaced file
    try:
        yield
    finally:
        fcntl.flock(fh, fcntl.LOCK_UN)
        fh.close()


def _same_file(fh, path: Path) -> bool:
    """Whether the open file ``fh`` is still the file at ``path`` (not replaced nor removed since)."""
    try:
        here = os.stat(path)
    except FileNotFoundError:
        return False
    mine = os.fstat(fh.fileno())
    return (mine.st_dev, mine.st_ino) == (here.st_dev, here.st_ino)


def append_rows(path: str | Path, rows: Sequence[dict]) -> None:
    """Append rows (dicts keyed by COLUMNS) to the results CSV atomically and under the lock."""
    path = Path(path)
    if not rows:
        return
    new = pd.DataFrame(list(rows))
    unknown = set(new.columns) - set(COLUMNS)
    if unknown:
        raise ValueError(f"unknown result columns {sorted(unknown)}")
    new = new.reindex(columns=COLUMNS)
    with locked(path):
        old = read_results(path) if path.exists() and path.stat().st_size > 0 else None
        table = new if old is None else pd.concat([old, new], ignore_index=True)
        atomic_write(path, lambda tmp: table.to_csv(tmp, index=False, float_format="%.9g"))


def read_results(path: str | Path) -> pd.DataFrame:
    """Read and validate a results CSV (schema, allowed values, metrics of ok rows finite)."""
    path = Path(path)
    try:
        df = pd.read_csv(path, keep_default_na=True, dtype={"error": str, "git_commit": str, "run_id": str,
                                                           "config_hash": str, "note": str, "base": str})
    except pd.errors.EmptyDataError:
        raise ResultsFileError(f"{path}: empty results file") from None
    _results_file(df, str(path))  # before the columns added below, so that a stranger's own columns are named
    if "period" not in df.columns and "signal" in df.columns:  # written before the column existed: all samples
        df.insert(int(df.columns.get_loc("signal")) + 1, "period", "all")
    if "note" not in df.columns:  # written before the column existed: no method said anything
        df["note"] = ""
    if "base" not in df.columns:  # written before the column existed: no base recorded
        df.insert(int(df.columns.get_loc("method")) + 1, "base", "")
    df["base"] = df["base"].fillna("")
    validate(df, str(path))
    return df


def validate(df: pd.DataFrame, where: str = "results") -> None:
    """Raise ResultsFileError at the first violation of the schema."""
    _results_file(df, where)
    missing = [c for c in COLUMNS if c not in df.columns]
    if missing:
        raise ResultsFileError(f"{where}: column {missing[0]!r} missing")

    def bad(column: str, mask) -> None:
        rows = mask.to_numpy().nonzero()[0]
        if rows.size:
            r = int(rows[0])
            raise ResultsFileError(f"{where}: column {column!r}, row {r + 1}: invalid value {df[column].iloc[r]!r}")

    bad("system", ~(df["system"].isin(SYSTEMS) | (df["system"].astype(str).str.strip().str.len() > 0)))
    bad("status", ~df["status"].isin(STATUS))
    ok = df["status"] == "ok"
    bad("reference_set", ok & ~df["reference_set"].isin(REFERENCE_SETS))
    bad("signal", ok & ~df["signal"].isin(list(SIGNALS)))
    bad("period", ok & ~df["period"].isin(PERIODS))
    for col in ("MA", "RMS", "Inf"):
        values = pd.to_numeric(df[col], errors="coerce")
        bad(col, ok & ~(values.notna() & (values >= 0) & values.abs().lt(float("inf"))))
    bad("seed", ~pd.to_numeric(df["seed"], errors="coerce").ge(0))
    expected_unit = [_unit(s, sys, unit) for s, sys, unit in zip(df["signal"], df["system"], df["unit"], strict=True)]
    bad("unit", ok & (df["unit"] != pd.Series(expected_unit, index=df.index)))


def _results_file(df: pd.DataFrame, where: str) -> None:
    """Raise ResultsFileError where ``df`` lacks a column of ``IDENTITY``: a file of something else (a
    measurement), not a results file short of a column."""
    absent = [c for c in IDENTITY if c not in df.columns]
    if absent:
        has = ", ".join(map(str, df.columns[:6])) + (", ..." if len(df.columns) > 6 else "")
        raise ResultsFileError(f"{where}: not an lcgym results file (no column {', '.join(map(repr, absent))}; "
                               f"its columns: {has or 'none'}); lcgym bench writes one")


def _unit(signal: str, system: str, unit: str):
    """The unit a row of ``signal`` on ``system`` must carry (``unit``, the row's, where it may be its own:
    a user machine's input residual, its axis's; a prismatic axis's tracking error in mm)."""
    expected = SIGNALS.get(signal)
    if signal == "tracking_error" and system in SYSTEMS:  # its axes' display units (the EMPS's: mm only)
        return unit if unit in TRACKING_UNITS[system] else sorted(TRACKING_UNITS[system])[0]
    if system not in SYSTEMS:
        if signal == "input_residual" and isinstance(unit, str) and unit.strip():
            return unit
        if signal == "tracking_error" and unit in ("deg", "mm"):
            return unit
    return expected.get(system) if isinstance(expected, dict) else expected


def completed_cells(path: str | Path, config_hash: str) -> set[tuple[str, str, int]]:
    """(system, method, seed) cells stored with status ok under this configuration hash."""
    path = Path(path)
    if not path.exists() or path.stat().st_size == 0:
        return set()
    df = read_results(path)
    done = df[(df["status"] == "ok") & (df["config_hash"] == config_hash)]
    return {(s, m, int(k)) for s, m, k in zip(done["system"], done["method"], done["seed"], strict=True)}
