"""The results store: one tidy CSV, one row per (run, system, method, seed, reference set, axis, signal).

Columns (``COLUMNS``): identification (``run_id``, ``system``: the machine and its version,
``ix-v1``, or a user's machine as it was named, ``method``, ``base``: the feedforward a learning
method builds on, ``physical`` or ``basic`` (``methods.bases``; empty for a method with none),
``seed``, ``reference_set``, ``axis``, ``signal`` and ``signal_label``: what the machine's bench
scores, by name and as the leaderboard shows it (``metrics.Signal``), ``period``: the samples the
norms are taken over, ``all``, ``dynamic`` while the reference moves or ``static``), the norms
``metrics.METRICS`` (paper 000 eqs. (34)-(36): ``MA``, ``RMS``, ``Inf``) with their ``unit`` (per
row, as the bench gives it: the tracking error in deg on a revolute axis and mm on a prismatic one,
the input residual in the axis's input unit), the method's cost (``plant_trials``: closed-loop runs
it learned from, the shared training runs included; ``env_steps``; ``fit_seconds``: wall time of fit
and learn, plus that of learning reused from a cache, ``Cost.cached_seconds``), ``nn_rms`` (RMS of a
neural network's feedforward contribution, where the method has one), ``status`` (``ok`` or
``failed``) and ``error``, provenance (``lcgym_version``, ``git_commit``, ``timestamp`` in UTC,
``config_hash`` of the benchmark's configuration), ``note``: what the method says of its cell,
``share``: a learner's share of the learnable on that seed (``leaderboard.shares``: (base - method)
/ (base - ILC on its base) in RMS; empty where it has no base, ILC is no better than the base or a
row it needs is missing; the runner fills it as the rows it needs arrive), and ``schema``: the
version of these columns (``SCHEMA``).

The store knows no machine: a row's machine, signal and unit are what its bench wrote. It checks
that every ok row has finite norms >= 0, a signal and a unit, and that one configuration gives each
(system, signal, axis) one unit.

A failed cell is one row with ``status = failed``, its error message and empty metrics.

Appends are atomic: under an exclusive lock on the CSV itself (``locked``: for concurrent writers;
no lock file is left beside it), the existing rows are read, the new ones added, and the whole
table written to a temporary file that is renamed over the CSV. An interrupted writer leaves the
previous complete file.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from pathlib import Path

import pandas as pd

from ..data import atomic_write
from ..metrics import METRICS, PERIODS

SCHEMA = 3
"""The version of ``COLUMNS``. 1: files written before the column existed (``_from_schema_1``); 2
added ``signal_label`` and ``schema``; 3 added ``share`` (a file of 1 or 2 reads with it empty)."""
COLUMNS = (
    "run_id", "system", "method", "base", "seed", "reference_set", "axis", "signal", "signal_label", "period",
    *METRICS, "unit", "plant_trials", "env_steps", "fit_seconds", "nn_rms", "share", "status", "error",
    "lcgym_version", "git_commit", "timestamp", "config_hash", "note", "schema",
)
REFERENCE_SETS = ("train", "validation", "test")
IDENTITY = ("run_id", "system", "method", "signal")
"""Columns a file must have to be taken for a results CSV at all (``validate``)."""
STATUS = ("ok", "failed")


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


def append_rows(path: str | Path, rows: Sequence[dict],
                derive: Callable[[pd.DataFrame], pd.DataFrame] | None = None) -> None:
    """Append rows (dicts keyed by COLUMNS, ``schema`` left out) to the results CSV atomically and
    under the lock. ``derive``: a function of the whole table that returns it with the columns
    derived from other rows filled in (the runner's ``share``), applied before it is written."""
    path = Path(path)
    if not rows:
        return
    new = pd.DataFrame(list(rows))
    unknown = set(new.columns) - set(COLUMNS)
    if unknown:
        raise ValueError(f"unknown result columns {sorted(unknown)}")
    new = new.reindex(columns=COLUMNS).assign(schema=SCHEMA)
    with locked(path):
        old = read_results(path) if path.exists() and path.stat().st_size > 0 else None
        table = new if old is None else pd.concat([old, new], ignore_index=True)
        if derive is not None:
            table = derive(table).reindex(columns=COLUMNS)
        atomic_write(path, lambda tmp: table.to_csv(tmp, index=False, float_format="%.9g"))


def read_results(path: str | Path) -> pd.DataFrame:
    """Read and validate a results CSV (schema, allowed values, metrics of ok rows finite); a file of
    an older schema is read in today's columns, each row keeping the ``schema`` it was written in."""
    path = Path(path)
    try:
        df = pd.read_csv(path, keep_default_na=True, dtype={"error": str, "git_commit": str, "run_id": str,
                                                           "config_hash": str, "note": str, "base": str,
                                                           "signal_label": str})
    except pd.errors.EmptyDataError:
        raise ResultsFileError(f"{path}: empty results file") from None
    _results_file(df, str(path))  # before any column is added, so that a stranger's own columns are named
    if "schema" not in df.columns:
        df = _from_schema_1(df)
    if "share" not in df.columns:  # schema 1 or 2: the views compute it from the means
        df = df.assign(share=float("nan")).reindex(columns=COLUMNS)
    df[["base", "note"]] = df[["base", "note"]].fillna("")
    validate(df, str(path))
    return df


def _from_schema_1(df: pd.DataFrame) -> pd.DataFrame:
    """Rows written before the ``schema`` column, in today's columns: a file older still may lack
    ``period`` (its rows: all samples), ``note`` (nothing said) and ``base`` (none recorded); the
    signal's label is its name in words (the bench that declared it is not asked)."""
    defaults = {"period": "all", "note": "", "base": ""}
    df = df.assign(**{c: v for c, v in defaults.items() if c not in df.columns})
    df["signal_label"] = df["signal"].astype(str).str.replace("_", " ")
    return df.reindex(columns=COLUMNS).assign(schema=1)


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

    def named(column: str) -> pd.Series:
        return df[column].notna() & (df[column].astype(str).str.strip().str.len() > 0)

    bad("system", ~named("system"))
    bad("schema", ~pd.to_numeric(df["schema"], errors="coerce").isin(range(1, SCHEMA + 1)))
    bad("status", ~df["status"].isin(STATUS))
    ok = df["status"] == "ok"
    bad("reference_set", ok & ~df["reference_set"].isin(REFERENCE_SETS))
    bad("signal", ok & ~named("signal"))
    bad("signal_label", ok & ~named("signal_label"))
    bad("period", ok & ~df["period"].isin(PERIODS))
    for col in METRICS:
        values = pd.to_numeric(df[col], errors="coerce")
        bad(col, ok & ~(values.notna() & (values >= 0) & values.abs().lt(float("inf"))))
    share = pd.to_numeric(df["share"], errors="coerce")
    bad("share", (df["share"].notna() & share.isna()) | share.abs().eq(float("inf")))  # a number or empty
    bad("seed", ~pd.to_numeric(df["seed"], errors="coerce").ge(0))
    bad("unit", ok & ~named("unit"))
    units = df[ok].groupby(["config_hash", "system", "signal", "axis"], dropna=False)["unit"].transform("nunique")
    bad("unit", ok & units.reindex(df.index, fill_value=1).gt(1))  # one axis's signal in two units


def _results_file(df: pd.DataFrame, where: str) -> None:
    """Raise ResultsFileError where ``df`` lacks a column of ``IDENTITY``: a file of something else (a
    measurement), not a results file short of a column."""
    absent = [c for c in IDENTITY if c not in df.columns]
    if absent:
        has = ", ".join(map(str, df.columns[:6])) + (", ..." if len(df.columns) > 6 else "")
        raise ResultsFileError(f"{where}: not an lcgym results file (no column {', '.join(map(repr, absent))}; "
                               f"its columns: {has or 'none'}); lcgym bench writes one")


def completed_cells(path: str | Path, config_hash: str) -> set[tuple[str, str, int]]:
    """(system, method, seed) cells stored with status ok under this configuration hash."""
    path = Path(path)
    if not path.exists() or path.stat().st_size == 0:
        return set()
    df = read_results(path)
    done = df[(df["status"] == "ok") & (df["config_hash"] == config_hash)]
    return {(s, m, int(k)) for s, m, k in zip(done["system"], done["method"], done["seed"], strict=True)}
