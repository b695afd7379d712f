"""Trials (one measured run) and the measurement-file format of lcgym.

A ``Trial`` holds uniformly sampled signals of one run, per axis: reference ``ref`` [rad or m;
None when the log has none], measured position ``pos`` [rad or m], total input ``u`` (IX: V;
arm: N m; a prismatic axis: N), and where known the feedforward part ``ff`` and the feedback part
``fb = u - ff``. Extra sensors (accelerometer, motor angles, true load angle of a simulation) live
in ``extra``; free metadata in ``meta``.

Files: one row per sample, CSV or Parquet, columns ``t`` [s], optional ``trial``, and per axis
``pos_<axis>``, ``u_<axis>``, optional ``ref_<axis>`` (all axes or none) and ``ff_<axis>``;
other columns are kept as extras. Axes are named as the machine's joints. An optional JSON
sidecar ``<file>.json`` carries metadata. Reading is strict: a missing required column, a
non-numeric, NaN or inf value, a non-increasing or non-uniform time column, or too few samples
raises ``MeasurementFileError`` naming the file, the column and the first offending data row (1 =
first row after the header). A log with jitter and dropouts can instead be put on uniform grids
(``read_trials(..., resample=HZ or "auto")``, ``regularize``: every column interpolated linearly,
short gaps bridged, the trial split at long ones). Files are read in chunks, so a large
file needs memory for its numbers, not for a table of the file. Writing goes to a temporary file
that is renamed into place, so an existing file is never left half-written.
"""

from __future__ import annotations

import difflib
import json
import os
import re
import tempfile
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

UNIFORM_TOLERANCE = 1e-3  # relative deviation of a time step from the file's step
MAX_GAP_STEPS = 5.0  # resampling: the longest gap, in nominal steps, that interpolation bridges (or max_gap, if longer)
GAP_STEPS = 2.0  # a step longer than this many median steps lost samples (shorter ones are jitter)
CHUNK_ROWS = 50_000  # rows read at a time: memory holds the trials and one chunk, not the file


class MeasurementFileError(ValueError):
    """A measurement file broke a reading rule; the message names file, column and row."""


@dataclass
class Trial:
    """One uniformly sampled run. Arrays are (T,) for ``t`` and (T, n_axes) per signal."""

    t: np.ndarray
    ref: np.ndarray | None
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
        """Tracking error e = ref - pos [rad or m]."""
        if self.ref is None:
            raise ValueError("this trial has no reference: its tracking error is unknown")
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


UNITS = {"rad": ("revolute", 1.0), "deg": ("revolute", np.pi / 180.0), "m": ("prismatic", 1.0),
         "mm": ("prismatic", 1e-3)}
"""The position units a log may be written in (``read_trials(units=...)``, ``--units``, a sidecar's
"units"): the axes they apply to and their factor to SI."""
LOOKS_WRONG = {"revolute": (2 * np.pi, "angles", "degrees", "deg", "rad"),
               "prismatic": (10.0, "lengths", "millimetres", "mm", "m")}
"""Per axis kind: the position [rad, m] beyond which a log's positions look like another unit, the
words for the message, the unit they look like and the SI unit a user can confirm instead."""


def parse_units(units: str | None) -> dict[str, float]:
    """``"deg"``, ``"mm"``, ``"deg,mm"``, ``"rad"``... as {axis kind: factor to SI}; a kind named is a
    kind settled (its look-alike check is off: a continuous joint's many turns in rad)."""
    if units is None:
        return {}
    out = {}
    for name in str(units).replace(" ", "").split(","):
        if name not in UNITS:
            raise ValueError(f"units: {name!r} is none of {', '.join(UNITS)} (a list like 'deg,mm' for both kinds)")
        kind, factor = UNITS[name]
        if kind in out:
            raise ValueError(f"units: {units!r} names the {kind} axes' unit twice")
        out[kind] = factor
    return out


def read_trials(path: str | Path, axes=None, min_samples: int = 3, resample: float | str | None = None,
                max_gap: float = 0.0, units: str | None = None) -> list[Trial]:
    """Read a measurement file (CSV or Parquet) into trials, enforcing the reading rules.

    ``axes``: the expected axis names (a sequence, or a machine: anything with ``axis_names``);
    without them the axes are taken from the ``pos_<axis>`` columns present. ``units``: the unit of
    the positions (``pos_``, ``ref_``) in the file, ``parse_units`` (else the sidecar's "units",
    else rad and m), converted to rad and m on reading. Given a machine (its axes' kinds known), a
    file whose angles go beyond 2 pi (they look like degrees) or whose lengths go beyond 10 m (mm)
    in a unit not settled is refused, with the fix; without one, it is warned of. ``resample``: [Hz] or
    "auto" (the log's own rate): put a trial whose time column is not uniform on a uniform grid
    instead of refusing it (``regularize``: gaps up to ``max_gap`` [s] or ``MAX_GAP_STEPS`` steps
    bridged, longer ones split the trial, segments shorter than ``min_samples`` left out; each
    new trial's ``meta["resampled"]`` says what was done). The file
    is streamed in chunks of ``CHUNK_ROWS`` rows into arrays sized once from a count of the file's
    lines: memory holds the trials' arrays and one chunk, never the whole file as a table, and a
    bad value stops the reading at its chunk.
    """
    path = Path(path)
    where = str(path)
    if not path.exists():
        raise MeasurementFileError(f"{where}: file not found")
    kinds = {a.name: a.kind for a in getattr(axes, "axes", ()) if hasattr(a, "kind")}  # a machine's axes
    axes = tuple(getattr(axes, "axis_names", axes) or ())
    if resample is not None and resample != "auto" and not (np.isfinite(resample) and resample > 0):
        raise ValueError(f"resample must be a sample rate > 0 Hz or 'auto', got {resample}")

    table: _Table | None = None
    for chunk in _chunks(path, where):
        if table is None:  # the first chunk: check the header, size the arrays
            table = _Table(list(chunk.columns), axes, _row_bound(path), where)
        table.append(chunk)
    if table is None or table.n == 0:
        raise MeasurementFileError(f"{where}: file has a header but no data rows")

    sidecar = Path(f"{path}.json")
    try:
        meta = json.loads(sidecar.read_text()) if sidecar.exists() else {}
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise MeasurementFileError(f"{sidecar}: the JSON sidecar cannot be parsed: {exc}") from None
    trial_meta = meta.pop("trials", []) if isinstance(meta, dict) else []
    given = units if units is not None else (meta.get("units") if isinstance(meta, dict) else None)
    try:
        settled = parse_units(given)
    except ValueError as exc:
        raise MeasurementFileError(f"{where if units is not None else sidecar}: {exc}") from None

    trials = []
    extras = table.extras()
    data_rows = np.arange(table.n)  # 0-based data rows of the file
    for gi, (label, rows) in enumerate(table.trial_rows()):
        trial_where = where if label is None else f"{where} (trial {label:g})"
        file_rows = data_rows[rows]
        need = max(min_samples, 2)
        if len(file_rows) < need:
            raise MeasurementFileError(
                f"{trial_where}: column 't', row {int(file_rows[0]) + 1}: only {len(file_rows)} samples, "
                f"need at least {need}"
            )
        t = table.t[rows]
        _check_time(t, file_rows, trial_where, resample)
        sig = {p: table.signals[p][rows] if p in table.signals else None for p in ("ref", "pos", "u")}
        for p in ("ref", "pos"):
            for i, ax in enumerate(table.axes if sig[p] is not None else ()):
                kind = kinds.get(ax)  # None: no machine given (its axes read as angles, as before)
                if (kind or "revolute") in settled:
                    sig[p][:, i] *= settled[kind or "revolute"]
                    continue
                _check_unit(sig[p][:, i], f"{p}_{ax}", kind, trial_where)
        ff = table.signals["ff"][rows] if "ff" in table.signals else None
        tm = dict(meta) if isinstance(meta, dict) else {}
        if gi < len(trial_meta) and isinstance(trial_meta[gi], dict):
            tm.update(trial_meta[gi])
        tm["source"] = where
        extra = {c: v[rows] for c, v in extras.items()}
        trials.append((Trial(t=t, axes=table.axes, ff=ff, extra=extra, meta=tm, **sig), trial_where, file_rows))
    if resample is None:
        return [tr for tr, _, _ in trials]
    rate = log_rate([tr for tr, _, _ in trials]) if resample == "auto" else float(resample)
    out = []
    for trial, trial_where, file_rows in trials:
        parts = regularize(trial, rate, max_gap, trial_where, file_rows)
        kept = [p for p in parts if p.n_samples >= need]
        if not kept:
            raise MeasurementFileError(f"{trial_where}: column 't': no part between the log's gaps holds {need} samples")
        for p in kept:
            if len(kept) < len(parts):
                p.meta["resampled"]["short_segments_left_out"] = len(parts) - len(kept)
        out.extend(kept)
    return out


def _check_unit(x: np.ndarray, column: str, kind: str | None, where: str) -> None:
    """Refuse a position column whose values look like another unit than rad or m (``LOOKS_WRONG``;
    a known axis kind), with the fix; warn of one whose kind is not known (angles beyond 2 pi)."""
    peak = float(np.max(np.abs(x))) if len(x) else 0.0
    limit, words, looks, short, si = LOOKS_WRONG[kind or "revolute"]
    if peak <= limit:
        return
    if kind is None:
        warnings.warn(f"{where}: column '{column}' reaches {peak:.3g}, beyond 2 pi: the file's angles look like "
                      "degrees; lcgym reads them as rad (give the machine, and --units deg where they are)", stacklevel=3)
        return
    raise MeasurementFileError(
        f"{where}: column '{column}' reaches {peak:.3g}, beyond {'2 pi rad' if kind == 'revolute' else '10 m'}: the "
        f"file's {words} look like {looks}; give --units {short} (or \"units\": \"{short}\" in the log's JSON "
        f"sidecar) to convert them on reading, or --units {si} where they are in {si}")


def log_step(dt: np.ndarray) -> float:
    """A log's step [s] from its time steps ``dt``: the mean of the steps that lost no samples (at
    most ``GAP_STEPS`` median steps). Not the median itself: stamps jittered off their grid by a few
    milliseconds make the median of 1,000 steps wander by 1 %, while their mean only by the
    jitter over the span."""
    dt = np.asarray(dt, dtype=float)
    return float(np.mean(dt[dt <= GAP_STEPS * np.median(dt)]))


def log_rate(trials: Sequence[Trial]) -> float:
    """A log's own rate [Hz]: one over its step (``log_step`` of all its trials' time steps), rounded
    to 3 significant digits (the controller's nominal rate)."""
    return float(f"{1.0 / log_step(np.concatenate([np.diff(tr.t) for tr in trials])):.3g}")


def regularize(trial: Trial, fs: float | None = None, max_gap: float = 0.0, where: str = "trial",
               rows: np.ndarray | None = None) -> list[Trial]:
    """``trial`` on uniform time grids, as real controllers' logs need (jittered stamps, dropouts).

    The rate is ``fs`` [Hz], or the log's own (``log_rate``). A step of more than
    ``GAP_STEPS`` median steps is a gap (samples lost): up to ``max(MAX_GAP_STEPS steps, max_gap
    [s])`` it is bridged by the interpolation, longer ones split the trial into segments there, each
    put on its own grid (every signal and extra column interpolated linearly in time). A uniform
    trial at the rate asked is returned as it is. Each new trial's ``meta["resampled"]`` records what
    was done: the rate, the log's step (``log_step``), the gaps bridged (count, largest [s]), the splits
    (count, largest gap [s]) and, for a segment, which of the trial's segments it is. ``rows``: the
    trial's 0-based data rows of its file, and ``where`` its name, for errors.
    """
    t = trial.t
    if t.size < 3:
        raise MeasurementFileError(f"{where}: column 't': only {t.size} samples")
    dt = np.diff(t)
    step = float(np.median(dt))  # gaps are told from it; the rate from the mean of the rest
    rate = log_rate([trial]) if fs is None else float(fs)
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"{where}: the resampling rate must be > 0 Hz, got {rate}")
    uniform = bool(np.all(np.abs(dt - 1.0 / rate) <= UNIFORM_TOLERANCE / rate))
    if uniform:
        return [trial]
    bridge = max(MAX_GAP_STEPS * step, float(max_gap))
    gap = dt > GAP_STEPS * step
    split = np.flatnonzero(dt > bridge)
    bridged = gap & (dt <= bridge)
    note = {"fs": rate, "log_step": log_step(dt), "largest_gap": float(dt.max()),
            "gaps_bridged": int(bridged.sum()), "largest_bridged": float(dt[bridged].max()) if bridged.any() else 0.0,
            "splits": int(split.size), "largest_split": float(dt[split].max()) if split.size else 0.0}
    edges = np.concatenate([[0], split + 1, [t.size]])
    out = []
    for k in range(edges.size - 1):
        part = np.arange(edges[k], edges[k + 1])
        grid = t[part[0]] + np.arange(int(np.floor((t[part[-1]] - t[part[0]]) * rate + 1e-9)) + 1) / rate
        if grid.size < 3:
            continue  # a sliver between two gaps: nothing to interpolate
        meta = {**trial.meta, "resampled": {**note, **({"segment": k, "segments": edges.size - 1} if split.size else {})}}
        out.append(_interpolated(trial, part, grid, meta))
    if not out:
        row = (int(rows[split[0] + 1]) + 1) if rows is not None and split.size else 1
        raise MeasurementFileError(f"{where}: column 't', row {row}: no part between the log's gaps (longer than "
                                   f"{bridge:.6g} s) holds 3 samples at {rate:g} Hz")
    return out


def _interpolated(trial: Trial, part: np.ndarray, grid: np.ndarray, meta: dict) -> Trial:
    """The samples ``part`` of ``trial`` interpolated linearly in time onto ``grid``."""
    t = trial.t[part]

    def interp(a):
        a = np.asarray(a, dtype=float)[part]
        if a.ndim == 1:
            return np.interp(grid, t, a)
        return np.column_stack([np.interp(grid, t, a[:, i]) for i in range(a.shape[1])])

    extra = {}
    for name, values in trial.extra.items():
        v = np.asarray(values)
        extra[name] = interp(v) if v.dtype.kind in "fiu" and v.shape[:1] == trial.t.shape else v
    return Trial(t=grid, ref=None if trial.ref is None else interp(trial.ref), pos=interp(trial.pos), u=interp(trial.u),
                 axes=trial.axes, ff=None if trial.ff is None else interp(trial.ff), extra=extra, meta=meta)


def file_axes(path: str | Path) -> tuple[str, ...]:
    """The axes a measurement file names (its ``pos_<axis>`` columns, in order), from its header only."""
    path = Path(path)
    where = str(path)
    if not path.exists():
        raise MeasurementFileError(f"{where}: file not found")
    for chunk in _chunks(path, where):
        return _check_header(list(chunk.columns), (), where)
    raise MeasurementFileError(f"{where}: file is empty (no header row)")


class _Table:
    """The file's checked numbers, filled chunk by chunk into preallocated arrays.

    ``t`` (N,), ``signals[p]`` (N, n_axes) for p in pos, u and (when every axis has one) ref and ff,
    ``labels`` (N,) of the ``trial`` column or None; the other columns are extras, kept as read.
    """

    def __init__(self, names: list[str], axes: tuple[str, ...], capacity: int, where: str):
        self.where = where
        self.axes = _check_header(names, axes, where)
        prefixes = ["pos", "u"] + [p for p in ("ref", "ff") if all(f"{p}_{ax}" in names for ax in self.axes)]
        self.t = np.empty(capacity)
        self.signals = {p: np.empty((capacity, len(self.axes))) for p in prefixes}
        self.labels = np.empty(capacity) if "trial" in names else None
        self.n = 0
        self._signal_of = {f"{p}_{ax}": (p, j) for p in prefixes for j, ax in enumerate(self.axes)}
        stored = {"t", "trial", *self._signal_of}
        # an ff column of only some axes is checked like the others and kept as an extra
        self._checked = {c for c in names if c in stored or c.startswith("ff_") and c[3:] in self.axes}
        partial = [f"ref_{ax}" for ax in self.axes if f"ref_{ax}" not in names]
        if "ref" not in prefixes and len(partial) < len(self.axes):
            raise MeasurementFileError(f"{where}: reference column {partial[0]!r} missing (give a ref_<axis> column "
                                       "for every axis, or none)")
        self._extras: dict[str, list[np.ndarray]] = {c: [] for c in names if c not in stored}

    def append(self, chunk: pd.DataFrame) -> None:
        stop = self.n + len(chunk)
        if stop > len(self.t):
            self._grow(max(stop, 2 * len(self.t)))
        rows = slice(self.n, stop)
        for col in chunk.columns:
            values = chunk[col]
            if col in self._checked:
                values = _numeric_column(values, self.where, col)
            if col == "t":
                self.t[rows] = values.to_numpy()
            elif col == "trial":
                self.labels[rows] = values.to_numpy()
            elif col in self._signal_of:
                p, j = self._signal_of[col]
                self.signals[p][rows, j] = values.to_numpy()
            else:
                self._extras[col].append(values.to_numpy(copy=True))
        self.n = stop

    def _grow(self, capacity: int) -> None:
        """More rows than the line count promised (a line ending it did not count): enlarge."""

        def bigger(a: np.ndarray) -> np.ndarray:
            b = np.empty((capacity, *a.shape[1:]))
            b[: self.n] = a[: self.n]
            return b

        self.t = bigger(self.t)
        self.signals = {p: bigger(a) for p, a in self.signals.items()}
        self.labels = None if self.labels is None else bigger(self.labels)

    def extras(self) -> dict[str, np.ndarray]:
        """The extra columns, each joined into one array (they are not checked)."""
        return {c: parts[0] if len(parts) == 1 else np.concatenate(parts) for c, parts in self._extras.items()}

    def trial_rows(self) -> list[tuple[float | None, slice | np.ndarray]]:
        """(label, rows) per trial in order of first appearance; rows is a slice when they are
        adjacent, so that the trial's arrays are views of the table, not copies."""
        if self.labels is None:
            return [(None, slice(0, self.n))]
        values, first, inverse = np.unique(self.labels[: self.n], return_index=True, return_inverse=True)
        by_label = np.split(np.argsort(inverse, kind="stable"), np.cumsum(np.bincount(inverse))[:-1])
        out = []
        for i in np.argsort(first):
            rows = by_label[i]  # in file order
            adjacent = rows[-1] - rows[0] + 1 == len(rows)
            out.append((float(values[i]), slice(int(rows[0]), int(rows[-1]) + 1) if adjacent else rows))
        return out


def _row_bound(path: Path) -> int:
    """An upper bound of the data rows: the file's line count (Parquet: its row count)."""
    if path.suffix.lower() != ".csv":
        return max(pq.ParquetFile(path).metadata.num_rows, 1)
    lines, last = 0, b"\n"
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            lines += max(block.count(b"\n"), block.count(b"\r"))
            last = block[-1:]
    return max(lines + (last not in b"\r\n"), 1)


def _chunks(path: Path, where: str) -> Iterator[pd.DataFrame]:
    """The file's rows, ``CHUNK_ROWS`` at a time, indexed by 0-based data row of the file."""
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise MeasurementFileError(f"{where}: unknown file type {path.suffix!r} (use .csv or .parquet)")
    try:
        if suffix == ".csv":
            with pd.read_csv(path, chunksize=CHUNK_ROWS) as reader:  # the chunks' index runs on over the file
                yield from reader
        else:
            parquet = pq.ParquetFile(path)
            start = 0
            for batch in parquet.iter_batches(batch_size=CHUNK_ROWS):
                chunk = batch.to_pandas()
                chunk.index = pd.RangeIndex(start, start + len(chunk))
                start += len(chunk)
                yield chunk
            if start == 0:  # no row group: one empty chunk carries the header
                yield parquet.schema_arrow.empty_table().to_pandas()
    except pd.errors.EmptyDataError:
        raise MeasurementFileError(f"{where}: file is empty (no header row)") from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError, pa.ArrowException) as exc:
        raise MeasurementFileError(f"{where}: cannot parse file: {exc}") from None


def another_machine(found: Sequence[str], expected: Sequence[str]) -> bool:
    """Whether a log whose ``pos_`` columns name the axes ``found`` is one of another machine than
    the one of the axes ``expected``: it names none of them, nor one that looks like a misspelling
    of one (the same letters but for case, or a close name: difflib ratio of 0.75 at least)."""
    if not found or any(ax in found for ax in expected):
        return False
    lower = [f.lower() for f in found]
    return not any(difflib.get_close_matches(ax.lower(), lower, n=1, cutoff=0.75) for ax in expected)


ROLES = {"t": ("t", "time", "timestamp", "times", "sec", "seconds", "s"),
         "pos": ("pos", "position", "q", "angle", "theta", "enc", "encoder", "x", "meas", "measured", "actual", "act"),
         "u": ("u", "input", "tau", "torque", "force", "effort", "cmd", "command", "current", "voltage", "trq")}
"""The column prefixes that hold each required column's quantity (a log's own names for them):
a missing column is suggested among the columns of its role, never another role's (``ref_``, ``ff_``)."""


def _same_role(col: str, names: list[str]) -> list[str]:
    """The file's columns that may hold ``col``'s quantity under another name (at most three): those
    of the same axis whose prefix names the same role (``tau_elbow`` for ``u_elbow``), or that read
    as a misspelling of ``col`` itself (``pos_elbw``, ``U_elbow``); another axis's column is not one
    (it says the log is of another machine)."""
    role, _, axis = col.partition("_")
    aliases = ROLES[role]

    def prefix(name: str) -> str:
        return re.split(r"[_\s\[(.]", name.strip().lower(), maxsplit=1)[0]

    same = [n for n in names if prefix(n) in aliases and prefix(n) != role
            and (not axis or n.lower().endswith(axis.lower()))]
    misspelled = difflib.get_close_matches(col, [n for n in names if prefix(n) == role or prefix(n) not in
                                                 ("ref", "ff", *ROLES["pos"], *ROLES["u"])], n=3, cutoff=0.8)
    return list(dict.fromkeys(same + misspelled))[:3]


def _check_header(names: list[str], axes: tuple[str, ...], where: str) -> tuple[str, ...]:
    """The axes of a file with these column names, after checking that every required column is
    there. A missing column is named, with the file's nearest column names when one looks like a
    renamed or misspelled version of it.
    """
    if len(names) == 1 and any(sep in names[0] for sep in ";\t|"):
        raise MeasurementFileError(f"{where}: the header is one column {names[0][:60]!r}: lcgym reads "
                                   "comma-separated files; convert the file (e.g. pandas.read_csv(path, sep=';'))")
    if {"run_id", "system", "method", "signal"} <= set(names):
        raise MeasurementFileError(f"{where}: an lcgym bench results file (lcgym leaderboard reads it), not a "
                                   "measurement log: a log has t, pos_<axis> and u_<axis> columns "
                                   "(docs/measurement-format.md)")
    if not axes:
        axes = tuple(c[4:] for c in names if c.startswith("pos_"))
        if not axes:
            raise MeasurementFileError(f"{where}: column 'pos_<axis>' missing (no position column found)")
    found = [c[4:] for c in names if c.startswith("pos_")]
    if another_machine(found, axes):
        raise MeasurementFileError(f"{where}: the file's axes ({', '.join(found)}) are not the axes expected "
                                   f"({', '.join(axes)}): is it a log of another machine?")
    required = ["t"] + [f"{p}_{ax}" for p in ("pos", "u") for ax in axes]
    for col in required:
        if col not in names:
            near = _same_role(col, [n for n in names if n not in required])
            hint = f"; did you mean {' or '.join(map(repr, near))}?" if near else ""
            others = [n[4:] for n in names if n.startswith("pos_") and n[4:] not in axes]
            if others and not near:
                hint = f"; the file's axes are {', '.join(others)}: is it a file of another machine?"
            raise MeasurementFileError(f"{where}: required column {col!r} missing{hint}")
    return axes


def _numeric_column(col: pd.Series, where: str, name: str) -> pd.Series:
    """``col`` as floats; its index is the 0-based data row of the file, named 1-based in errors."""
    values = pd.to_numeric(col, errors="coerce")
    bad_text = values.isna() & col.notna()
    if bad_text.any():
        i = int(np.flatnonzero(bad_text.to_numpy())[0])
        raise MeasurementFileError(
            f"{where}: column {name!r}, row {int(col.index[i]) + 1}: non-numeric value {col.iloc[i]!r}"
        )
    arr = values.to_numpy(dtype=float)
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise MeasurementFileError(
            f"{where}: column {name!r}, row {int(col.index[i]) + 1}: {arr[i]} (NaN or inf, or an empty cell)"
        )
    return values.astype(float)


def _check_time(t: np.ndarray, rows: np.ndarray, where: str, resample: float | None = None) -> None:
    """Strictly increasing, and (unless it is to be resampled) uniform up to ``UNIFORM_TOLERANCE``."""
    dt = np.diff(t)
    nonpos = np.flatnonzero(dt <= 0)
    if nonpos.size:
        r = int(rows[nonpos[0] + 1]) + 1
        a, b = t[nonpos[0]], t[nonpos[0] + 1]
        hint = " (several runs in one file? give each run its own number in a 'trial' column)" if b < a else ""
        raise MeasurementFileError(f"{where}: column 't', row {r}: time not strictly increasing ({a} -> {b}){hint}")
    if resample is not None:
        return
    step = float(np.median(dt))
    off = np.flatnonzero(np.abs(dt - step) > UNIFORM_TOLERANCE * step)
    if off.size:
        r = int(rows[off[0] + 1]) + 1
        gaps = np.flatnonzero(dt > MAX_GAP_STEPS * step)
        if gaps.size:  # no resampling bridges it: say so first
            g = int(gaps[0])
            raise MeasurementFileError(
                f"{where}: column 't', row {int(rows[g + 1]) + 1}: a gap of {dt[g]:.6g} s ({dt[g] / step:.1f} of the "
                f"log's {step:.6g} s steps): split the log into trials there (a 'trial' column), or read it with "
                "resample='auto' (lcgym diagnose does)")
        raise MeasurementFileError(
            f"{where}: column 't', row {r}: non-uniform sampling (step {dt[off[0]]:.6g} s, file step {step:.6g} s); "
            "read it with resample='auto' to put it on a uniform grid at its own rate (lcgym diagnose does)"
        )
