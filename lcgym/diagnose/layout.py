"""Which samples the diagnosis fits and scores, and how it splits them for held-out scoring.

Not every sample of a real log says something about the model:

- **Standstill.** Where an axis rests, the friction holds anything between its static levels (the
  drives holding an arm, a brake): u there follows no static model. Where an axis's speed stays
  below its rest speed for at least ``settle`` s (shorter: the axis reverses, and the friction's
  switch is what identifies it), those samples are left out of that axis's fit and score (the
  other axes keep them): set to zero in its u and its regressor columns before the low-pass, so
  that nothing of them spreads into the samples around (``Preprocessing.masked_reduce``), their
  rows dropped after. A log without a reference has u low-passed with its position before the fit
  (``Preprocessing.inputs``): there a rest is widened by that low-pass's reach. The rest speed
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

Held-out scoring has two folds (``diagnose.search``). Where the data hold runs of different motions,
the folds are whole runs (``run_folds``): a candidate is fitted on some motions and judged on
others, as the next run will judge it (a curve fitted up to one speed is scored where another run
goes faster). Runs that repeat one trajectory (``repeated_runs``) go in one fold. Whole runs are
used where the smaller fold holds at least ``RUN_SHARE`` of the data and of the samples in which
each moving axis moves (both folds can fit every axis), and at least ``RUN_SECONDS`` (16 s: in three
runs of 5-6 s, one run as a fold let a cable drape take a joint's Coulomb friction); else, and for
one run or one trajectory, the trials are cut into blocks that alternate between the folds. The
blocks' length follows the data: about an eighth of the data (``TARGET_BLOCKS``), at most
``MAX_BLOCK`` s and at least ``MIN_BLOCK_SETTLES`` x settle (1 s at 5 Hz), each trial cut into equal
blocks, the repeats of one trajectory in step (a stretch of it is held out in every repeat at once);
rows within ``settle`` of a boundary between blocks are left out of the training folds, so that no
held-out row is scored on a fit that saw it through the filter. Scoring needs
``MIN_BLOCKS_PER_FOLD`` blocks in each fold: 6 s of data at the least; below that ``DataTooShort``
says what is there and what is needed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..physics.kinematics import lowpass_zero_phase

REST_NOISE = 3.0  # rest speed: this many times the speed noise ...
REST_SHARE = 0.01  # ... and at least this share of the axis's top speed
REST_SETTLES = 1.0  # a rest lasts at least this many settle times (shorter: a reversal)
TARGET_BLOCKS = 8
COVERAGE_FACTORS = (0.7, 0.8, 0.9, 1.12, 1.25, 1.4)  # block lengths tried beside the target (``block_lengths``)
MAX_BLOCK = 4.0  # s
MIN_BLOCK_SETTLES = 5
MIN_BLOCKS_PER_FOLD = 3
EDGE_SIGMAS = 6.0  # an edge outlier: this many robust standard deviations of its axis's residual ...
EDGE_WINDOW = 2.0  # s ... within this long of a trial's end ...
EDGE_ENERGY = 0.2  # ... and trimmed where the edges hold this share of an axis's residual energy
RUN_SHARE = 0.25  # whole runs as folds where the smaller fold holds this share of the data and of each moving axis's
RUN_SECONDS = 4 * MAX_BLOCK  # ... motion, and at least this long (s): a short run shows too few moves to fit on


REPEAT_DIFFERENCE = 0.05  # runs repeat one trajectory where their positions differ by less than this share of the motion


def repeated_runs(trials: Sequence, moving: Sequence[int]) -> list[list[int]]:
    """Groups of trials (indices) that repeat one trajectory: the same number of samples (within 2 %)
    and positions (the reference, else the measured ones) of the ``moving`` axes that differ by less
    than ``REPEAT_DIFFERENCE`` of the motion's RMS about its mean. Held-out blocks of one trajectory
    share its quirks (the same moves at the same places, the same transients): they cannot tell a
    missing effect from those (``diagnose`` then selects more strictly)."""
    paths = [np.asarray(tr.ref if tr.ref is not None else tr.pos, dtype=float)[:, list(moving)] for tr in trials]
    group = list(range(len(trials)))
    for i in range(len(trials)):
        for j in range(i + 1, len(trials)):
            a, b = paths[i], paths[j]
            if group[j] != j or abs(len(a) - len(b)) > 0.02 * max(len(a), len(b)):
                continue
            n = min(len(a), len(b))
            motion = np.sqrt(np.mean((a[:n] - a[:n].mean(axis=0)) ** 2))
            if motion > 0 and np.sqrt(np.mean((a[:n] - b[:n]) ** 2)) < REPEAT_DIFFERENCE * motion:
                group[j] = group[i]
    out: dict[int, list[int]] = {}
    for k, g in enumerate(group):
        out.setdefault(g, []).append(k)
    return [g for g in out.values() if len(g) > 1]


class DataTooShort(ValueError):
    """Too little data for held-out scoring."""


@dataclass(frozen=True)
class Layout:
    """What the diagnosis counts (module docstring). ``used`` (N, A): per sample of all trials
    (concatenated) and axis, whether it is fitted and scored; ``blocks``: per trial, its held-out
    blocks' length [s] (its duration where whole runs are the folds); ``first``: per trial, the fold
    (0 or 1) of its first block; ``whole_runs``: whether the folds are whole runs, and ``why_not``
    the reason they are not where there are several runs; ``settle`` [s]; ``rest_speed`` (A,)
    [rad/s or m/s]; ``counts``: what was left out, for the report ({"standstill": (A,) samples,
    "edges": samples per axis, "edge_trimmed": samples beyond the fixed margin})."""

    used: np.ndarray
    blocks: tuple[float, ...]
    settle: float
    rest_speed: np.ndarray
    counts: dict
    first: tuple[int, ...] = ()
    whole_runs: bool = False
    why_not: str = ""


def settle_time(filter_hz: float) -> float:
    """The filters' reach [s]: one period of the fit's low-pass corner."""
    return 1.0 / float(filter_hz)


def run_folds(durations: Sequence[float], repeats: Sequence[Sequence[int]] = ()) -> tuple[int, ...] | None:
    """Per trial, its fold where whole runs are the folds: the runs of each trajectory together
    (``repeats``: groups of trials that repeat one, ``repeated_runs``), the trajectories dealt the
    longest first to the fold with less data. None where there is one trajectory, or where the
    smaller fold would hold less than ``RUN_SHARE`` of the data or less than ``RUN_SECONDS``."""
    group = list(range(len(durations)))
    for g in repeats:
        for k in g:
            group[k] = g[0]
    trajectories = sorted(set(group), key=lambda g: -sum(d for k, d in enumerate(durations) if group[k] == g))
    if len(trajectories) < 2:
        return None
    fold_of, held = {}, [0.0, 0.0]
    for g in trajectories:
        f = int(held[1] < held[0])
        fold_of[g] = f
        held[f] += sum(d for k, d in enumerate(durations) if group[k] == g)
    if min(held) < max(RUN_SHARE * sum(held), RUN_SECONDS):
        return None
    return tuple(fold_of[g] for g in group)


def block_lengths(durations: Sequence[float], settle: float, block_seconds: float | None = None,
                  coverage: Callable[[tuple[float, ...]], float] | None = None,
                  first: Sequence[int] | None = None) -> tuple[float, ...]:
    """Per trial, the length [s] of its equal held-out blocks (module docstring); ``block_seconds``
    fixes the target length instead. ``coverage``: a score of a choice of lengths (``fold_coverage``):
    of the lengths within 0.7-1.4 times the target, the one that scores best is taken (a motion that
    repeats with about two blocks' period would otherwise put all of one direction in one fold).
    ``first``: per trial, the fold of its first block (default trial k's in fold k mod 2).
    Raises ``DataTooShort`` when a fold would get fewer than ``MIN_BLOCKS_PER_FOLD`` blocks."""
    shortest = MIN_BLOCK_SETTLES * settle
    total = float(sum(durations))
    if block_seconds is None:
        target = min(MAX_BLOCK, max(shortest, total / TARGET_BLOCKS))
    else:
        if not block_seconds > 0:
            raise ValueError(f"block_seconds must be > 0, got {block_seconds}")
        target = float(block_seconds)
    first = [k % 2 for k in range(len(durations))] if first is None else list(first)
    target_blocks = _blocks(durations, target, shortest, block_seconds, first)
    if coverage is None or block_seconds is not None:
        return target_blocks
    options = [target_blocks]
    for factor in COVERAGE_FACTORS:
        length = min(MAX_BLOCK, max(shortest, factor * target))
        try:
            options.append(_blocks(durations, length, shortest, block_seconds, first))
        except DataTooShort:
            continue
    scores = [coverage(b) for b in options]
    return options[int(np.argmax(scores))]  # the first best: the target's own where it is as good


def _blocks(durations: Sequence[float], target: float, shortest: float, block_seconds: float | None,
            first: Sequence[int]) -> tuple[float, ...]:
    """``block_lengths`` at one target length [s]."""
    total = float(sum(durations))
    blocks, per_fold = [], [0, 0]
    for k, d in enumerate(durations):
        n = max(1, int(math.floor(d / target + 1e-9)))
        blocks.append(d / n)
        for b in range(n):
            per_fold[(b + first[k]) % 2] += 1
    if min(per_fold) < MIN_BLOCKS_PER_FOLD:
        need = 2 * MIN_BLOCKS_PER_FOLD * max(target if block_seconds else shortest, shortest)
        raise DataTooShort(
            f"{total:.1f} s of data in {len(durations)} trial(s): held-out scoring needs {MIN_BLOCKS_PER_FOLD} blocks of "
            f"at least {max(target if block_seconds else shortest, shortest):.3g} s in each of its two folds, {need:.3g} s "
            f"of data at the least (blocks alternate between the folds within each trial; got {per_fold[0]} and "
            f"{per_fold[1]})")
    return tuple(blocks)


def fold_assignment(lengths: Sequence[int], fs: float, blocks: Sequence[float],
                    first: Sequence[int] | None = None) -> np.ndarray:
    """The fold (0 or 1) of every sample (N,) for the blocks of ``block_lengths``: blocks alternate
    within each trial, the first block of trial k in fold ``first[k]`` (default k mod 2)."""
    out = []
    for k, n in enumerate(lengths):
        t = np.arange(n) / fs
        n_blocks = max(1, int(round(n / fs / blocks[k])))
        start = k % 2 if first is None else first[k]
        out.append((np.minimum(np.floor(t / blocks[k] + 1e-9).astype(int), n_blocks - 1) + start) % 2)
    return np.concatenate(out)


def fold_coverage(q: np.ndarray, qd: np.ndarray, used: np.ndarray, lengths: Sequence[int], fs: float,
                  moving: np.ndarray, first: Sequence[int] | None = None) -> Callable[[tuple[float, ...]], float]:
    """A score of a choice of block lengths: how evenly the two folds share each way each moving
    axis turns in each quarter of its range (the used samples of bins holding at least 1 % of
    them): the smallest fold's share over those bins, 0 (a fold never sees one) to 0.5 (``first``:
    as ``fold_assignment`` takes it)."""
    bins = []
    for i in np.flatnonzero(moving):
        m = used[:, i]
        if not m.any():
            continue
        quarter = np.digitize(q[:, i], np.quantile(q[m, i], [0.25, 0.5, 0.75]))
        bins.append(np.where(m, quarter * 2 + (qd[:, i] > 0), -1))

    def score(blocks: tuple[float, ...]) -> float:
        fold = fold_assignment(lengths, fs, blocks, first)
        worst = 0.5
        for b in bins:
            keep = b >= 0
            counts = np.bincount(b[keep] * 2 + fold[keep], minlength=16).reshape(8, 2)
            total = counts.sum(axis=1)
            big = total >= 0.01 * keep.sum()
            if big.any():
                worst = min(worst, float((counts[big].min(axis=1) / total[big]).min()))
        return worst

    return score


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


def rests(slow: np.ndarray, lengths: Sequence[int], shortest: int) -> np.ndarray:
    """The runs of ``slow`` (N, A) samples, within each trial and axis, of at least ``shortest``
    samples: an axis at rest, not one passing through zero speed as it reverses."""
    out = np.zeros_like(slow)
    start = 0
    for n in lengths:
        for i in range(slow.shape[1]):
            s = slow[start : start + n, i].astype(np.int8)
            edges = np.flatnonzero(np.diff(np.concatenate([[0], s, [0]])))
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                if b - a >= shortest:
                    out[start + a : start + b, i] = True
        start += n
    return out


def dilate(mask: np.ndarray, lengths: Sequence[int], width: int) -> np.ndarray:
    """``mask`` (N, A) grown by ``width`` samples on each side of every True run, within each trial."""
    if width <= 0:
        return mask
    out = np.empty_like(mask)
    start = 0
    kernel = np.ones(2 * width + 1)
    for n in lengths:
        for i in range(mask.shape[1]):
            out[start : start + n, i] = np.convolve(mask[start : start + n, i].astype(float), kernel, mode="same") > 0
        start += n
    return out


def used_samples(trials: Sequence, kin: tuple[np.ndarray, np.ndarray, np.ndarray], lengths: Sequence[int], fs: float,
                 filter_hz: float, velocity_filter_hz: float, trim: Sequence[tuple[int, int]] | None = None,
                 spread: float = 0.0) -> tuple[np.ndarray, np.ndarray, dict]:
    """(used (N, A), rest speed (A,), counts) of ``trials`` whose fit kinematics are ``kin`` (each
    (N, A)): standstill and trial edges left out (module docstring). ``filter_hz``: the fit's
    low-pass corner, ``velocity_filter_hz``: the one the velocity went through; ``trim``: per
    trial, samples to leave out at its start and at its end beyond the fixed margin
    (``edge_outliers``); ``spread`` [s]: how far a low-pass that u went through before the fit
    (the measured position's, ``Preprocessing.inputs``) spreads a rest into the motion around it:
    that much more is left out on either side of each rest."""
    settle = settle_time(filter_hz)
    margin = int(math.ceil(settle * fs))
    speed = np.abs(kin[1])
    rest = rest_speeds([tr.pos for tr in trials], speed, fs, velocity_filter_hz)
    resting = dilate(rests(speed < rest, lengths, int(math.ceil(REST_SETTLES * settle * fs))), lengths,
                     int(math.ceil(spread * fs)))
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
           trim: Sequence[tuple[int, int]] | None = None, spread: float = 0.0,
           moving: Sequence[int] | None = None, repeats: Sequence[Sequence[int]] = ()) -> Layout:
    """The ``Layout`` of ``trials`` (``used_samples``, and the held-out folds: whole runs, ``run_folds``,
    or blocks, ``block_lengths``, chosen for the folds' coverage of the ``moving`` axes, indices;
    default all). ``repeats``: groups of trials that repeat one trajectory (``repeated_runs``);
    ``block_seconds`` given: blocks of that length, never whole runs."""
    used, rest, counts = used_samples(trials, kin, lengths, fs, filter_hz, velocity_filter_hz, trim, spread)
    settle = settle_time(filter_hz)
    moving = np.isin(np.arange(used.shape[1]), np.arange(used.shape[1]) if moving is None else list(moving))
    durations = [n / fs for n in lengths]
    first = [k % 2 for k in range(len(lengths))]
    for g in repeats:  # the repeats of one trajectory in step: a stretch of it is held out in all at once
        for k in g:
            first[k] = first[g[0]]
    blocks = block_lengths(durations, settle, block_seconds, fold_coverage(kin[0], kin[1], used, lengths, fs, moving,
                                                                           first), first)
    trajectories = len(lengths) - sum(len(g) - 1 for g in repeats)
    if block_seconds is not None or trajectories < 2:
        return Layout(used, blocks, settle, rest, counts, tuple(first))
    runs = run_folds(durations, repeats)
    if runs is None:
        why_not = (f"whole runs as folds would leave one fold less than {100 * RUN_SHARE:.0f}% of the data or less than "
                   f"{RUN_SECONDS:g} s")
    else:
        fold = fold_assignment(lengths, fs, durations, runs)
        per_fold = np.stack([(used & (fold == f)[:, None]).sum(axis=0) for f in (0, 1)])[:, moving]
        least = per_fold.min(axis=0) / np.maximum(per_fold.sum(axis=0), 1)
        if least.min() >= RUN_SHARE:
            return Layout(used, tuple(durations), settle, rest, counts, runs, True)
        why_not = (f"whole runs as folds would leave one fold {100 * least.min():.0f}% of an axis's samples in motion "
                   f"(at least {100 * RUN_SHARE:.0f}% needed)")
    return Layout(used, blocks, settle, rest, counts, tuple(first), False, why_not)


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
