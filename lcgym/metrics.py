"""Error norms of paper 000, eqs. (34)-(36), per axis.

    MA(x)  = 1/N sum_k |x(k)|          (34)
    RMS(x) = sqrt(1/N sum_k x(k)^2)    (35)
    Inf(x) = max_k |x(k)|              (36)

Applied to the tracking error e = theta_d - theta (reported in deg, mm on a prismatic axis) and to
the input residual eps = u - f (measured input minus feedforward, in each axis's input unit: V for
the IX, N m on a revolute joint, N on a prismatic one). A bench whose loop differentiates the
measurement passes f + C r as the feedforward (C r: the loop's own output along the reference,
``plant.reference_feedback``), so that eps is zero when a method tracks exactly (docs/benchmark.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeAlias

import numpy as np
import pandas as pd

METRICS = ("MA", "RMS", "Inf")
"""The norms of every results row, in column order (``norms`` computes them). The leaderboard takes
its columns, checks and rankings from this tuple: a new norm is added here, in ``norms``, alone."""
RANKED_BY = "RMS"
"""The norm the leaderboard ranks methods by, gives a spread over seeds and compares with a base."""
PERIODS = ("all", "dynamic", "static")  # the samples a norm is taken over: all, the reference moving, at rest
Units: TypeAlias = str | Sequence[str]
"""One unit for every axis of a table, or one per axis (a machine with revolute and prismatic axes)."""


@dataclass(frozen=True)
class Signal:
    """A signal a bench scores: ``name`` in the results (``tracking_error``) and ``label`` on the
    leaderboard ("tracking error"). Its unit is each row's, given by the bench's tables."""

    name: str
    label: str


def norms(x) -> dict[str, np.ndarray]:
    """MA, RMS and Inf of x along time (axis 0); one value per column. x: (T,) or (T, n_axes)."""
    x = np.asarray(x, dtype=float)
    if x.shape[0] == 0:
        raise ValueError("norms of an empty signal are undefined")
    if not np.all(np.isfinite(x)):
        raise ValueError("signal contains NaN or inf: metrics would be meaningless")
    a = np.abs(x)
    peak = a.max(axis=0)
    # RMS scaled by the peak: x * x would underflow below 1e-154 and overflow above 1e154
    scale = np.where(peak > 0, peak, 1.0)
    rms = peak * np.sqrt(np.mean((a / scale) ** 2, axis=0))
    return {"MA": a.mean(axis=0), "RMS": rms, "Inf": peak}


def tracking_error_table(trials: Sequence, label: str = "") -> pd.DataFrame:
    """Norms of the tracking error [deg] of trials taken together, one row per axis."""
    if not trials:
        raise ValueError("tracking_error_table: no trials given")
    e = np.degrees(np.concatenate([t.error for t in trials]))
    return norms_table(e, trials[0].axes, "tracking_error", "deg", label)


def input_residual_table(trials: Sequence, feedforward: Sequence, label: str = "", unit: Units = "V") -> pd.DataFrame:
    """Norms of eps = u - f of trials taken together, one row per axis (``feedforward``: f, or f + C r
    where the loop differentiates the measurement). ``unit``: V for the IX, N m for
    the arm, or one per axis (``System.input_units``: N m on a revolute joint, N on a prismatic one)."""
    if not trials or len(trials) != len(feedforward):
        raise ValueError(f"input_residual_table: {len(trials)} trials but {len(feedforward)} feedforward signals")
    for i, (t, f) in enumerate(zip(trials, feedforward, strict=True)):
        if np.shape(f) != t.u.shape:
            raise ValueError(f"input_residual_table: feedforward {i} has shape {np.shape(f)}, its trial's input {t.u.shape}")
    eps = np.concatenate([t.u - np.asarray(f) for t, f in zip(trials, feedforward, strict=True)])
    return norms_table(eps, trials[0].axes, "input_residual", unit, label)


def norms_table(x, axes: Sequence[str], signal: str, unit: Units, label: str = "", period: str = "all") -> pd.DataFrame:
    """One row per column of x (T, len(axes)): label, axis, signal, period, MA, RMS, Inf, unit.
    ``unit``: the unit of every column, or a sequence of one unit per axis."""
    if period not in PERIODS:
        raise ValueError(f"period must be one of {', '.join(PERIODS)}, got {period!r}")
    units = [unit] * len(axes) if isinstance(unit, str) else list(unit)
    if len(units) != len(axes) or not all(isinstance(u, str) and u.strip() for u in units):
        raise ValueError(f"norms_table of {signal}: unit must be one non-empty string or one per axis "
                         f"({len(axes)}: {', '.join(axes)}), got {unit!r}")
    n = norms(x)
    rows = [{"label": label, "axis": ax, "signal": signal, "period": period, **{m: float(n[m][i]) for m in METRICS},
             "unit": units[i]} for i, ax in enumerate(axes)]
    return pd.DataFrame(rows)
