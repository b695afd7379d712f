"""Make a simulated run look like what a real controller logs: to test the diagnosis (and anything
else that reads measurement files) on data with the flaws of real logs, with a known truth.

Every function takes a ``data.Trial`` of a plant run (uniformly sampled, usually at 1 kHz) and
returns a new one; the simulated signals themselves are not changed except where a function says so.

- ``drop`` removes samples: logging dropouts (the time column then jumps over them);
- ``jittered`` reads the run at a logger's own rate, each instant off its grid by up to a jitter,
  reading the latest simulated sample (a logger polls the controller's values);
- ``without_reference`` removes the reference (a log of positions and inputs only);
- ``held_at_rest`` adds standstill before and after the motion, the axes held by their drives
  while friction carries an unknown share of the load: the input differs from the holding torque
  the run ends with by a constant within +-``levels`` per axis and window (static friction can hold
  anything up to its breakaway level);
- ``cut`` keeps a window of a run, which then starts and ends wherever it was cut (mid-move);
- ``lowpassed`` filters the input and the positions as a logger's own causal low-pass does.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from .data import Trial


def _rows(trial: Trial, keep: np.ndarray, t: np.ndarray | None = None) -> Trial:
    """The trial at sample indices ``keep`` (time ``t``, default the trial's own at those samples)."""
    def pick(a):
        return None if a is None else np.asarray(a)[keep]

    extra = {k: pick(v) if np.shape(v)[:1] == trial.t.shape else v for k, v in trial.extra.items()}
    return Trial(t=trial.t[keep] if t is None else t, ref=pick(trial.ref), pos=pick(trial.pos), u=pick(trial.u),
                 axes=trial.axes, ff=pick(trial.ff), extra=extra, meta=dict(trial.meta))


def drop(trial: Trial, gaps: Sequence[tuple[float, float]]) -> Trial:
    """``trial`` without the samples of each gap (start [s], duration [s]): logging dropouts."""
    lost = np.zeros(trial.n_samples, dtype=bool)
    for start, duration in gaps:
        lost |= (trial.t > start) & (trial.t < start + duration)
    return _rows(trial, np.flatnonzero(~lost))


def jittered(trial: Trial, fs: float, jitter: float = 0.0, rng: np.random.Generator | None = None) -> Trial:
    """``trial`` read at ``fs`` [Hz], each instant k / fs off its grid by a uniform amount within
    +-``jitter`` [s] (less than half a step), reading the latest sample of the run at or before it
    and stamped with the instant itself; ``jitter`` 0: every (trial.fs / fs)-th sample, exactly."""
    if not (fs > 0 and 0 <= jitter < 0.5 / fs):
        raise ValueError(f"need fs > 0 and 0 <= jitter < half a step, got {fs} Hz, {jitter} s")
    t = trial.t[0] + np.arange(int(np.floor((trial.t[-1] - trial.t[0]) * fs + 1e-9)) + 1) / fs
    if jitter:
        t = np.clip(t + rng.uniform(-jitter, jitter, t.size), trial.t[0], trial.t[-1])
    keep = np.searchsorted(trial.t, t + 1e-9, side="right") - 1
    return _rows(trial, keep, t)


def without_reference(trial: Trial) -> Trial:
    """``trial`` with no reference (and no feedforward): positions and inputs only."""
    return dataclasses.replace(trial, ref=None, ff=None)


def held_at_rest(trial: Trial, before: float, after: float, levels: Sequence[float], rng: np.random.Generator) -> Trial:
    """``trial`` with ``before`` s of standstill added at its start and ``after`` s at its end (at the
    first and last position, reference and encoder reading; time shifted accordingly). The input
    there is the run's first (last) input plus a constant drawn uniformly within +-``levels``
    [input unit] per axis: the share of the load that static friction holds is unknown."""
    fs = trial.fs
    nb, na = int(round(before * fs)), int(round(after * fs))
    levels = np.broadcast_to(np.asarray(levels, dtype=float), (len(trial.axes),))

    def pad(a, shift_first, shift_last):
        if a is None:
            return None
        a = np.asarray(a, dtype=float)
        return np.concatenate([np.repeat(a[:1] + shift_first, nb, axis=0), a, np.repeat(a[-1:] + shift_last, na, axis=0)])

    zero = np.zeros(len(trial.axes))
    share_first, share_last = rng.uniform(-1, 1, (2, len(trial.axes))) * levels
    t = trial.t[0] + np.arange(nb + trial.n_samples + na) / fs
    extra = {k: pad(v, 0.0, 0.0) if np.shape(v)[:1] == trial.t.shape else v for k, v in trial.extra.items()}
    return Trial(t=t, ref=pad(trial.ref, zero, zero), pos=pad(trial.pos, zero, zero),
                 u=pad(trial.u, share_first, share_last), axes=trial.axes, ff=pad(trial.ff, zero, zero), extra=extra,
                 meta={**trial.meta, "held_at_rest": [before, after]})


def cut(trial: Trial, start: float, stop: float) -> Trial:
    """The part of ``trial`` from ``start`` to ``stop`` [s] (time restarting at 0)."""
    keep = np.flatnonzero((trial.t >= start) & (trial.t < stop))
    return _rows(trial, keep, trial.t[keep] - trial.t[keep[0]])


def lowpassed(trial: Trial, input_hz: float | None, position_hz: float | None, order: int = 2) -> Trial:
    """``trial`` with its input and its measured positions through a causal Butterworth low-pass of
    ``order`` at ``input_hz`` and ``position_hz`` [Hz] (None: that signal as it was), started at rest
    at the first sample: a logger that filters what it records (the delay included). The
    reference is not filtered (a controller's own signal)."""
    from scipy.signal import butter, lfilter, lfilter_zi

    def filtered(x, hz):
        if hz is None or x is None:
            return x
        if not 0 < hz < trial.fs / 2:
            raise ValueError(f"a low-pass corner must lie in (0, {trial.fs / 2:g}) Hz, got {hz}")
        b, a = butter(order, hz, fs=trial.fs)
        x = np.asarray(x, dtype=float)
        return lfilter(b, a, x, axis=0, zi=lfilter_zi(b, a)[:, None] * x[:1])[0]

    return dataclasses.replace(trial, u=filtered(trial.u, input_hz), pos=filtered(trial.pos, position_hz),
                               meta={**trial.meta, "lowpassed": [input_hz, position_hz]})


__all__ = ["cut", "drop", "held_at_rest", "jittered", "lowpassed", "without_reference"]
