"""What the data's spectra can show: each axis's bandwidth, and whether a candidate's torque could be
in the input at all.

A logger that low-passes what it records (a drive's current filter, a torque sensor's) leaves the
input with nothing above its corner. An effect whose torque lies mostly above it cannot be seen
there, whatever a fit of its low-frequency remnants says: a gear's ripple at 12-18 Hz in torques
low-passed at 2 Hz is fitted, if at all, on the few moments the axis moves slowly, and there it
takes up whatever else is left.

- ``bandwidths``: per axis, the frequency below which ``ENERGY_SHARE`` of a signal's energy (about its
  mean) lies, in the input and in the position: a logger's filter shows as an input bandwidth at or
  under its corner. It is reported, not used as a threshold: it follows the motion as much as any
  filter (slow moves give a narrow band unfiltered too; on the simulated cobot the input's band
  was 3-15 Hz unfiltered and 2-4 Hz low-passed at 2 Hz, both at 99.9 %).
- ``unheld_share``: the rule the search applies (``search.rank``). A candidate's torque as fitted,
  y = c(q, qd, qdd) theta at the full rate, is compared frequency by frequency with the input: where
  y's power exceeds ``HELD_MARGIN`` times the input's, the input does not hold it (an input holds
  at least the power of an effect it carries, up to what other components cancel). Where that
  holds more than ``UNHELD_SHARE`` of y's energy, the candidate's signature lies above what the
  data show, and it is refused with the share and the frequency above which the input falls short.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.signal import welch

ENERGY_SHARE = 0.999  # a signal's bandwidth: the frequency below which this share of its energy lies
SEGMENT = 4.0  # s, the spectra's segments (0.25 Hz resolution), or the shortest trial where shorter
HELD_MARGIN = 4.0  # the input holds a frequency where it has at least 1/this of the candidate's power there
UNHELD_SHARE = 0.5  # a candidate whose torque has more than this share of its energy where the input falls short is refused


def power_spectra(x: np.ndarray, lengths: Sequence[int], fs: float) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies (F,) [Hz], power spectral density (F, A)) of ``x`` (T, A), the trials of
    ``lengths`` samples concatenated: Welch's average over each trial's segments of ``SEGMENT`` s
    (or of the shortest trial), linear trend removed per segment, trials weighted by length."""
    x = np.asarray(x, dtype=float).reshape(len(x), -1)
    n = max(8, min(int(SEGMENT * fs), min(lengths)))
    total, weight, start = 0.0, 0, 0
    for m in lengths:
        if m >= n:
            f, P = welch(x[start : start + m], fs=fs, nperseg=n, axis=0, detrend="linear")
            total, weight = total + m * P, weight + m
        start += m
    return f, total / weight


def bandwidths(x: np.ndarray, lengths: Sequence[int], fs: float) -> np.ndarray:
    """Per axis, the frequency [Hz] below which ``ENERGY_SHARE`` of the energy of ``x`` (T, A) lies
    (``power_spectra``)."""
    f, P = power_spectra(x, lengths, fs)
    share = np.cumsum(P, axis=0) / np.maximum(P.sum(axis=0), 1e-300)
    return np.array([f[min(np.searchsorted(share[:, i], ENERGY_SHARE), len(f) - 1)] for i in range(P.shape[1])])


def unheld_share(y: np.ndarray, u: np.ndarray, lengths: Sequence[int], fs: float) -> tuple[float, float]:
    """(the share of the energy of ``y`` (T,) lying at frequencies where its power exceeds
    ``HELD_MARGIN`` times that of ``u`` (T,), the lowest such frequency above which that holds for
    most of that energy [Hz]) (module docstring)."""
    f, P = power_spectra(np.column_stack([y, u]), lengths, fs)
    py, pu = P[:, 0], P[:, 1]
    total = float(py.sum())
    if total <= 0:
        return 0.0, float(f[-1])
    short = py > HELD_MARGIN * pu
    share = float(py[short].sum()) / total
    if not short.any():
        return 0.0, float(f[-1])
    unheld = np.cumsum((py * short)[::-1])[::-1]  # the unheld energy at and above each frequency
    above = f[np.flatnonzero(unheld >= 0.5 * unheld[0])[-1]]
    return share, float(above)
