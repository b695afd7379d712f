"""Reference kinematics from sampled positions, and the zero-phase filter used before fitting.

Feedforward is computed from the *reference* (paper 000, V-A: the quantized measured
position cannot be differentiated), so velocity and acceleration come from the sampled
reference positions by central differences (second order; exact for the piecewise-cubic
third-order setpoints up to the jerk switches).

``advance`` shifts the evaluation point forward by a fraction of samples: the IX plant applies
the input computed at sample k over [t_{k+1}, t_{k+2}) (one-sample computation delay plus
zero-order hold), so the feedforward for sample k is best evaluated at t_k + 1.5 Ts.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import butter, sosfiltfilt


def reference_positions(reference) -> np.ndarray:
    """Reference positions (T, n_axes) [rad] of an array, a Trial (``ref``) or a Reference (``positions``)."""
    for attr in ("positions", "ref"):
        if hasattr(reference, attr):
            return np.asarray(getattr(reference, attr), dtype=float)
    return np.asarray(reference, dtype=float)


def reference_kinematics(positions, fs: float, advance: float = 0.0):
    """Position, velocity and acceleration of a sampled reference, evaluated at t_k + advance/fs.

    positions: (T, n_axes) [rad]; fs [Hz]; advance [samples]. Returns three (T, n_axes) arrays
    in rad, rad/s, rad/s^2. Beyond the last sample the reference is held (it ends at rest).
    """
    x = np.asarray(positions, dtype=float)
    if x.ndim != 2 or x.shape[0] < 3:
        raise ValueError(f"reference positions must be (T >= 3, n_axes), got shape {x.shape}")
    dt = 1.0 / fs
    v = np.gradient(x, dt, axis=0, edge_order=2)
    a = np.zeros_like(x)
    a[1:-1] = (x[2:] - 2.0 * x[1:-1] + x[:-2]) / dt**2
    if advance:
        k = np.arange(x.shape[0], dtype=float)
        shift = lambda s: np.stack([np.interp(k + advance, k, s[:, i]) for i in range(s.shape[1])], axis=1)  # noqa: E731
        x, v, a = shift(x), shift(v), shift(a)
    return x, v, a


def relay(velocity, threshold: float = 1e-9) -> np.ndarray:
    """Relay of paper 000, eq. (12), along time (axis 0): +1 while moving forward, -1 backward,
    the last value while at rest, 0 before the first motion. |v| <= threshold [rad/s] counts as rest
    (round-off of a sampled dwell)."""
    v = np.asarray(velocity, dtype=float)
    sign = np.where(v > threshold, 1.0, np.where(v < -threshold, -1.0, np.nan))
    out = np.empty_like(sign)
    for i in np.ndindex(sign.shape[1:]):  # forward fill per column
        col = sign[(slice(None), *i)]
        idx = np.where(np.isnan(col), 0, np.arange(col.size))
        np.maximum.accumulate(idx, out=idx)
        filled = col[idx]
        out[(slice(None), *i)] = np.where(np.isnan(filled), 0.0, filled)
    return out


def lowpass_zero_phase(signal, fs: float, cutoff_hz: float, order: int = 2, axis: int = 0):
    """Butterworth low-pass applied forward and backward (zero phase), along ``axis``.

    Paper 000 (V-A) filters the measured input with order 2 at 1 Hz. Applying the same filter to
    the input and to every regressor column keeps a least-squares fit consistent.
    """
    sos = _butterworth(order, float(cutoff_hz), float(fs))
    x = np.asarray(signal, dtype=float)
    padlen = min(x.shape[axis] - 1, 3 * (2 * len(sos) + 1) * 20)
    return sosfiltfilt(sos, x, axis=axis, padlen=padlen)


@lru_cache(maxsize=64)
def _butterworth(order: int, cutoff_hz: float, fs: float) -> np.ndarray:
    """Second-order sections of the Butterworth low-pass, designed once per setting (scipy's filters
    read it and never write it; its Cython code needs a writable buffer)."""
    return butter(order, cutoff_hz, fs=fs, output="sos")
