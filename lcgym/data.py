"""Trials (one measured run) and the measurement-file format of lcgym.

A ``Trial`` holds uniformly sampled signals of one run, per axis: reference ``ref`` [rad],
measured position ``pos`` [rad], total input ``u`` (IX: V; arm: N m), and where known the
feedforward part ``ff`` and the feedback part ``fb = u - ff``. Extra sensors (accelerometer,
motor angles, true load angle of a simulation) live in ``extra``; free metadata in ``meta``.

Files: one row per sample, CSV or Parquet, columns ``t``, optional ``trial``, and per axis
``ref_<axis>``, ``pos_<axis>``, ``u_<axis>``, optional ``ff_<axis>``; other columns are kept
as extras. An optional JSON sidecar ``<file>.json`` carries metadata. Reading is strict: a
missing required column, a non-numeric, NaN or inf value, a non-increasing or non-uniform time
column, or too few samples raises ``MeasurementFileError`` naming the file, the column and the
first offending data row (1 = first row after the header). Writing goes to a temporary file
that is renamed into place, so an existing file is never left half-written.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

SYSTEM_AXES = {
    "ix": ("propeller", "roll"),
    "flexarm": ("j1", "j2", "j3", "j4", "j5", "j6"),
}
UNIFORM_TOLERANCE = 1e-3  # relative deviation of a time step from the file's step


class MeasurementFileError(ValueError):
    """A measurement file broke a reading rule; the message names file, column and row."""


@dataclass
class Trial:
    """One uniformly sampled run. Arrays are (T,) for ``t`` and (T, n_axes) per signal."""

    t: np.ndarray
    ref: np.ndarray
    pos: np.ndarray
    u: np.ndarray
    axes: tuple[str, ...]
    ff: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        n, k = self.t.shape[0], len(self.axes)
        for name in ("ref", "pos", "u", "ff"):
            a = getattr(self, name)
            if a is None:
                continue
            a = np.asarray(a, dtype=float)
            if a.shape != (n, k):
                raise ValueError(f"Trial.{name} must have shape ({n}, {k}), got {a.shape}")
            setattr(self, name, a)

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        return 1.0 / float(self.t[1] - self.t[0])

    @property
    def n_samples(self) -> int:
        return self.t.shape[0]

    @property
    def error(self) -> np.ndarray:
        """Tracking error e = ref - pos [rad]."""
        return self.ref - self.pos

    @property
    def fb(self) -> np.ndarray | None:
        """Feedback part of the input, u - ff (None if ff is unknown)."""
        return None if self.ff is None else self.u - self.ff

    def to_frame(self) -> pd.DataFrame:
        cols: dict[str, np.ndarray] = {"t": self.t}
        for prefix in ("ref", "pos", "u", "ff"):
            a = getattr(self, prefix)
            if a is not None:
                for i, ax in enumerate(self.axes):
                    cols[f"{prefix}_{ax}"] = a[:, i]
        cols.update({k: np.asarray(v) for k, v in self.extra.items()})
        return pd.DataFrame(cols)


def atomic_write(path: Path, write) -> None:
    """Call write(tmp_path), then rename tmp into ``path`` (same folder, so the rename is atomic)."""
    path = Path(path)
    if not path.parent.exists():
        raise FileNotFoundError(f"cannot write {path}: folder {path.parent} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_trials(path: str | Path, trials: Sequence[Trial], meta: dict | None = None) -> Path:
    """Write trials to one CSV or Parquet file (by extension) plus a JSON sidecar with metadata."""
    path = Path(path)
    if not trials:
        raise ValueError("write_trials: no trials to write")
    frames = []
    for i, tr in enumerate(trials):
        f = tr.to_frame()
        if len(trials) > 1:
            f.insert(1, "trial", i)
        frames.append(f)
    frame = pd.concat(frames, ignore_index=True)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.10g"))
    elif suffix in (".parquet", ".pq"):
        atomic_write(path, lambda tmp: frame.to_parquet(tmp, index=False))
    else:
        raise ValueError(f"cannot write {path}: use a .csv or .parquet file name")
    sidecar = {**(meta or {}), "fs": trials[0].fs, "trials": [_jsonable(tr.meta) for tr in trials]}
    atomic_write(Path(f"{path}.json"), lambda tmp: Path(tmp).write_text(json.dumps(sidecar, indent=1)))
    return path


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return obj


def read_trials(path: str | Path, system: str | None = None, min_samples: int = 3) -> list[Trial]:
    """Read a measurement file (CSV or Parquet) into trials, enforcing the reading rules.

    ``system`` ("ix" or "flexarm") fixes the expected axes; without it the axes are taken from
    the ``ref_<axis>`` columns present.
    """
    path = Path(path)
    where = str(path)
    if not path.exists():
        raise MeasurementFileError(f"{where}: file not found")
    try:
        if path.suffix.lower() == ".csv":
            frame = pd.read_csv(path, low_memory=False)
        elif path.suffix.lower() in (".parquet", ".pq"):
            frame = pd.read_parquet(path)
        else:
            raise MeasurementFileError(f"{where}: unknown file type {path.suffix!r} (use .csv or .parquet)")
    except pd.errors.EmptyDataError:
        raise MeasurementFileError(f"{where}: file is empty (no header row)") from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError) as exc:
        if isinstance(exc, MeasurementFileError):
            raise
        raise MeasurementFileError(f"{where}: cannot parse file: {exc}") from None

    if system is not None:
        if system not in SYSTEM_AXES:
            raise ValueError(f"unknown system {system!r}; choose one of {sorted(SYSTEM_AXES)}")
        axes = SYSTEM_AXES[system]
    else:
        axes = tuple(c[4:] for c in frame.columns if c.startswith("ref_"))
        if not axes:
            raise MeasurementFileError(f"{where}: column 'ref_<axis>' missing (no reference column found)")
    required = ["t"] + [f"{p}_{ax}" for p in ("ref", "pos", "u") for ax in axes]
    optional = [f"ff_{ax}" for ax in axes]
    for col in required:
        if col not in frame.columns:
            raise MeasurementFileError(f"{where}: required column {col!r} missing")
    if len(frame) == 0:
        raise MeasurementFileError(f"{where}: file has a header but no data rows")

    for col in required + [c for c in optional if c in frame.columns] + (["trial"] if "trial" in frame else []):
        frame[col] = _numeric_column(frame[col], where, col)

    sidecar = Path(f"{path}.json")
    try:
        meta = json.loads(sidecar.read_text()) if sidecar.exists() else {}
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise MeasurementFileError(f"{sidecar}: the JSON sidecar cannot be parsed: {exc}") from None
    trial_meta = meta.pop("trials", []) if isinstance(meta, dict) else []

    groups = [frame] if "trial" not in frame else [g for _, g in frame.groupby("trial", sort=False)]
    trials = []
    for gi, g in enumerate(groups):
        label = "" if "trial" not in frame else f" (trial {int(g['trial'].iloc[0])})"
        if len(g) < max(min_samples, 2):
            need = max(min_samples, 2)
            raise MeasurementFileError(
                f"{where}{label}: column 't', row {int(g.index[0]) + 1}: only {len(g)} samples, need at least {need}"
            )
        t = g["t"].to_numpy(dtype=float)
        _check_time(t, g.index.to_numpy(), where + label)
        for ax in axes:
            p = g[f"pos_{ax}"].to_numpy(dtype=float)
            if np.max(np.abs(p)) > 2 * np.pi:
                warnings.warn(
                    f"{where}{label}: column 'pos_{ax}' reaches {np.max(np.abs(p)):.3g}, beyond 2 pi: "
                    "the file's positions look like degrees; lcgym reads them as rad",
                    stacklevel=2,
                )
        sig = {p: np.column_stack([g[f"{p}_{ax}"].to_numpy(dtype=float) for ax in axes]) for p in ("ref", "pos", "u")}
        ff = (
            np.column_stack([g[f"ff_{ax}"].to_numpy(dtype=float) for ax in axes])
            if all(f"ff_{ax}" in g for ax in axes)
            else None
        )
        known = set(required) | set(optional) | {"trial"}
        extra = {c: g[c].to_numpy() for c in g.columns if c not in known}
        tm = dict(meta) if isinstance(meta, dict) else {}
        if gi < len(trial_meta) and isinstance(trial_meta[gi], dict):
            tm.update(trial_meta[gi])
        tm["source"] = where
        trials.append(Trial(t=t, axes=axes, ff=ff, extra=extra, meta=tm, **sig))
    return trials


def _numeric_column(col: pd.Series, where: str, name: str) -> pd.Series:
    values = pd.to_numeric(col, errors="coerce")
    bad_text = values.isna() & col.notna()
    if bad_text.any():
        row = int(np.flatnonzero(bad_text.to_numpy())[0])
        raise MeasurementFileError(f"{where}: column {name!r}, row {row + 1}: non-numeric value {col.iloc[row]!r}")
    arr = values.to_numpy(dtype=float)
    bad = ~np.isfinite(arr)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise MeasurementFileError(f"{where}: column {name!r}, row {row + 1}: {arr[row]} (NaN or inf, or an empty cell)")
    return values.astype(float)


def _check_time(t: np.ndarray, rows: np.ndarray, where: str) -> None:
    dt = np.diff(t)
    nonpos = np.flatnonzero(dt <= 0)
    if nonpos.size:
        r = int(rows[nonpos[0] + 1]) + 1
        a, b = t[nonpos[0]], t[nonpos[0] + 1]
        raise MeasurementFileError(f"{where}: column 't', row {r}: time not strictly increasing ({a} -> {b})")
    step = float(np.median(dt))
    off = np.flatnonzero(np.abs(dt - step) > UNIFORM_TOLERANCE * step)
    if off.size:
        r = int(rows[off[0] + 1]) + 1
        raise MeasurementFileError(
            f"{where}: column 't', row {r}: non-uniform sampling (step {dt[off[0]]:.6g} s, file step {step:.6g} s)"
        )
