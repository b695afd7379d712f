"""Which samples the diagnosis fits and scores, and how it splits them for held-out scoring.

Not every sample of a real log says something about the model:

- **Standstill.** Where an axis rests, the friction holds anything between its static levels (the
  drives holding an arm, a brake): u there follows no static model. An axis's samples whose speed
  is below its rest speed are left out of that axis's fit and score (the other axes keep them):
  set to zero in its u and its regressor columns before the low-pass, so that nothing of them
  spreads into the samples around (``PhysicalModel.masked_reduce``), their rows dropped after. The rest speed
  comes from the data: ``REST_NOISE`` times the speed noise the position's noise makes through the
  kinematics' low-pass and differentiation (the noise estimated from the log, at least the
  encoder step's quantization), and at least ``REST_SHARE`` of the axis's top speed (99th
  percentile): an axis crawling that slowly shows its friction no better than one at rest.
- **Trial edges.** The kinematics' zero-phase filters are padded beyond a trial's ends: the first
  and last ``settle`` s of each trial are left out on every axis. A trial whose loop has not settled when
  the log starts, or that stops mid-move, leaves more than that at its ends; the workflow finds
  such edges in the residual (``edge_outliers``) and trims them too.

``settle`` is one period of the fit's low-pass corner (0.2 s at 5 Hz): the zero-phase
Butterworth's step response is within 1 % of its end value 0.17 s from the step.

Held-out scoring splits the trials into blocks that alternate between two folds
(``diagnose.search``). Their length follows the data: about an eighth of the data
(``TARGET_BLOCKS``), at most ``MAX_BLOCK`` s and at least ``MIN_BLOCK_SETTLES`` x settle (1 s
at 5 Hz), each trial cut into equal blocks; rows within ``settle`` of a boundary between blocks
are left out of the training folds, so that no held-out row is scored on a fit that saw it
through the filter. Scoring needs ``MIN_BLOCKS_PER_FOLD`` blocks in each fold: 6 s of data at
the least; below that ``DataTooShort`` says what is there and what is needed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..physics.kinematics import lowpass_zero_phase

REST_NOISE = 3.0  # rest speed: this many times the speed noise ...
REST_SHARE = 0.01  # ... and at least this share of the axis's top speed
TARGET_BLOCKS = 8
MAX_BLOCK = 4.0  # s
MIN_BLOCK_SETTLES = 5
MIN_BLOCKS_PER_FOLD = 3
EDGE_SIGMAS = 6.0  # an edge outlier: this many robust standard deviations of its axis's residual ...
EDGE_WINDOW = 2.0  # s ... within this long of a trial's end ...
EDGE_ENERGY = 0.2  # ... and trimmed where the edges hold this share of an axis's residual energy


class DataTooShort(ValueError):
    """Too little data for held-out scoring."""


@dataclass(frozen=True)
class Layout:
    """What the diagnosis counts (module docstring). ``used`` (N, A): per sample of all trials
    (concatenated) and axis, whether it is fitted and scored; ``blocks``: per trial, its held-out
    blocks' length [s]; ``settle`` [s]; ``rest_speed`` (A,) [rad/s or m/s]; ``counts``: what was
    left out, for the report ({"standstill": (A,) samples, "edges": samples per axis, "edge_trimmed":
    samples beyond the fixed margin})."""

    used: np.ndarray
    blocks: tuple[float, ...]
    settle: float
    rest_speed: np.ndarray
    counts: dict


def settle_time(filter_hz: float) -> float:
    """The filters' reach [s]: one period of the fit's low-pass corner."""
    return 1.0 / float(filter_hz)


def block_lengths(durations: Sequence[float], settle: float, block_seconds: float | None = None) -> tuple[float, ...]:
    """Per trial, the length [s] of its equal held-out blocks (module docstring); ``block_seconds``
    fixes the target length instead. Raises ``DataTooShort`` when a fold would get fewer than
    ``MIN_BLOCKS_PER_FOLD`` blocks."""
    shortest = MIN_BLOCK_SETTLES * settle
    total = float(sum(durations))
    if block_seconds is None:
        target = min(MAX_BLOCK, max(shortest, total / TARGET_BLOCKS))
    else:
        if not block_seconds > 0:
            raise ValueError(f"block_seconds must be > 0, got {block_seconds}")
        target = float(block_seconds)
    blocks, per_fold = [], [0, 0]
    for k, d in enumerate(durations):
        n = max(1, int(math.floor(d / target + 1e-9)))
        blocks.append(d / n)
        for b in range(n):
            per_fold[(b + k) % 2] += 1
    if min(per_fold) < MIN_BLOCKS_PER_FOLD:
        need = 2 * MIN_BLOCKS_PER_FOLD * max(target if block_seconds else shortest, shortest)
        raise DataTooShort(
            f"{total:.1f} s of data in {len(durations)} trial(s): held-out scoring needs {MIN_BLOCKS_PER_FOLD} blocks of "
            f"at least {max(target if block_seconds else shortest, shortest):.3g} s in each of its two folds, {need:.3g} s "
            f"of data at the least (blocks alternate between the folds within each trial; got {per_fold[0]} and "
            f"{per_fold[1]})")
    return tuple(blocks)


def rest_speeds(positions: Sequence[np.ndarray], speed: np.ndarray, fs: float, filter_hz: float) -> np.ndarray:
    """Per axis, the speed [rad/s or m/s] below which it counts as resting (module docstring):
    ``positions`` the measured positions of each trial (T, A), ``speed`` |qd| of the fit's
    kinematics over all trials (N, A), ``filter_hz`` the corner of the low-pass the velocity went
    through."""
    noise = position_noise(positions)
    floor = REST_SHARE * np.quantile(np.abs(speed), 0.99, axis=0)
    return np.maximum(REST_NOISE * noise * speed_noise_gain(fs, filter_hz), floor)


def position_noise(positions: Sequence[np.ndarray]) -> np.ndarray:
    """Per axis, the RMS [rad or m] of the measured position's noise: from its second differences
    (1.4826 x their median absolute value / sqrt(6), white noise on a smooth motion), and at least
    an encoder step's quantization (the smallest step between readings / sqrt(12))."""
    d2 = np.concatenate([np.diff(p, 2, axis=0) for p in positions if len(p) > 2])
    d1 = np.abs(np.concatenate([np.diff(p, axis=0) for p in positions if len(p) > 1]))
    out = []
    for i in range(d2.shape[1]):
        nonzero = np.abs(d2[:, i])[np.abs(d2[:, i]) > 0]
        white = 1.4826 * float(np.median(nonzero)) / math.sqrt(6.0) if nonzero.size else 0.0
        steps = d1[:, i][d1[:, i] > 0]
        quant = float(steps.min()) / math.sqrt(12.0) if steps.size else 0.0
        out.append(max(white if nonzero.size > 0.1 * d2.shape[0] else 0.0, quant))
    return np.asarray(out)


@lru_cache(maxsize=32)
def speed_noise_gain(fs: float, filter_hz: float, n: int = 20_000) -> float:
    """RMS speed [per s] that white position noise of RMS 1 gives after the zero-phase low-pass at
    ``filter_hz`` and central differences at ``fs`` (measured on seeded noise)."""
    x = np.random.default_rng(0).standard_normal(n)
    v = np.gradient(lowpass_zero_phase(x, fs, filter_hz), 1.0 / fs)
    return float(np.std(v[n // 10 : -n // 10]))


def used_samples(trials: Sequence, kin: tuple[np.ndarray, np.ndarray, np.ndarray], lengths: Sequence[int], fs: float,
                 filter_hz: float, velocity_filter_hz: float, trim: Sequence[tuple[int, int]] | None = None
                 ) -> tuple[np.ndarray, np.ndarray, dict]:
    """(used (N, A), rest speed (A,), counts) of ``trials`` whose fit kinematics are ``kin`` (each
    (N, A)): standstill and trial edges left out (module docstring). ``filter_hz``: the fit's
    low-pass corner, ``velocity_filter_hz``: the one the velocity went through; ``trim``: per
    trial, samples to leave out at its start and at its end beyond the fixed margin (``edge_outliers``)."""
    settle = settle_time(filter_hz)
    margin = int(math.ceil(settle * fs))
    speed = np.abs(kin[1])
    rest = rest_speeds([tr.pos for tr in trials], speed, fs, velocity_filter_hz)
    resting = speed < rest
    edges = np.zeros(speed.shape[0], dtype=bool)
    start, extra = 0, 0
    for k, n in enumerate(lengths):
        head, tail = (0, 0) if trim is None else trim[k]
        extra += head + tail
        edges[start : start + min(n, margin + head)] = True
        edges[start + max(0, n - margin - tail) : start + n] = True
        start += n
    counts = {"standstill": (resting & ~edges[:, None]).sum(axis=0), "edges": int(edges.sum()), "edge_trimmed": extra,
              "samples": int(speed.shape[0])}
    return ~resting & ~edges[:, None], rest, counts


def layout(trials: Sequence, kin: tuple[np.ndarray, np.ndarray, np.ndarray], lengths: Sequence[int], fs: float,
           filter_hz: float, velocity_filter_hz: float, block_seconds: float | None = None,
           trim: Sequence[tuple[int, int]] | None = None) -> Layout:
    """The ``Layout`` of ``trials`` (``used_samples``, and the held-out blocks: ``block_lengths``)."""
    used, rest, counts = used_samples(trials, kin, lengths, fs, filter_hz, velocity_filter_hz, trim)
    settle = settle_time(filter_hz)
    return Layout(used, block_lengths([n / fs for n in lengths], settle, block_seconds), settle, rest, counts)


def edge_outliers(residual: np.ndarray, used: np.ndarray, trial: np.ndarray, time: np.ndarray,
                  durations: Sequence[float], fs: float, settle: float) -> list[tuple[int, int]] | None:
    """Trial edges that the residual is dominated by (an unsettled start, a reference that stops
    mid-move): per trial, (samples at its start, samples at its end) to leave out beyond the fixed
    margin, or None when no edge stands out. ``residual`` (R, A) at the reduced rows, ``used`` (R,
    A), ``trial`` (R,) each row's trial and ``time`` (R,) [s] since that trial's start;
    ``durations`` [s] of the trials.

    A row is an outlier where an axis's residual exceeds ``EDGE_SIGMAS`` robust standard deviations
    of that axis (1.4826 x the median absolute deviation over the used rows); an edge's part runs
    from the trial's end to its last outlier within ``EDGE_WINDOW`` s of it, plus ``settle``. The
    edges are trimmed only where those parts together hold at least ``EDGE_ENERGY`` of some axis's
    residual energy."""
    r = np.where(used, residual, np.nan)
    center = np.nanmedian(r, axis=0)
    scale = 1.4826 * np.nanmedian(np.abs(r - center), axis=0)
    out = np.nan_to_num(np.abs(r - center) > EDGE_SIGMAS * np.where(scale > 0, scale, np.inf), nan=0.0).any(axis=1)
    margin = int(math.ceil(settle * fs))
    trims, part = [], np.zeros(r.shape[0], dtype=bool)
    for k, duration in enumerate(durations):
        rows = np.flatnonzero((trial == k) & used.any(axis=1))
        head = rows[time[rows] <= time[rows].min() + EDGE_WINDOW] if rows.size else rows
        tail = rows[time[rows] >= time[rows].max() - EDGE_WINDOW] if rows.size else rows
        start = end = 0
        if head.size and out[head].any():
            last = head[np.flatnonzero(out[head]).max()]
            part[head[head <= last]] = True
            start = max(0, int(math.ceil((time[last] + settle) * fs)) - margin)
        if tail.size and out[tail].any():
            first = tail[np.flatnonzero(out[tail]).min()]
            part[tail[tail >= first]] = True
            end = max(0, int(math.ceil((duration - time[first] + settle) * fs)) - margin)
        trims.append((start, end))
    energy = np.nansum(np.where(part[:, None], r, 0.0) ** 2, axis=0) / np.maximum(np.nansum(r**2, axis=0), 1e-300)
    return trims if np.any(energy >= EDGE_ENERGY) else None
