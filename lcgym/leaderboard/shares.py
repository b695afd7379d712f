"""The share of the learnable: how much of what can be learned on its base a learner takes.

Per machine, reference set, signal, period and axis:

    share = (RMS_base - RMS_method) / (RMS_base - RMS_bound)

with RMS_base the RMS of the learner's base (the method its ``base`` column names: ``physical``,
``basic``) and RMS_bound that of ILC on the same base (``BOUND``: ``ilc``, ``ilc@basic``). ILC learns
on each reference it is scored on, so it shows what is learnable there: the empirical bound a
learner that predicts for unseen references is measured against. 1: the learner takes all of it
(ILC itself); 0: none, it ends at its base; below 0: it ends worse than its base. The share is
empty where ILC is no better than the base (nothing learnable to take a share of), where the
base's or ILC's rows are missing, and for a method without a base.

``row_shares`` computes it for each row of a results CSV, from the rows of the same seed (the
runner stores it in the rows' ``share`` column); ``mean_shares`` for the leaderboard's ranking,
from the means over seeds (as ``vs_base`` is a ratio of means).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..metrics import RANKED_BY

BOUND = "ilc"
"""The method whose per-reference learning bounds what is learnable on a base: ILC on that base."""
CELL = ("config_hash", "system", "seed", "reference_set", "signal", "period", "axis")
"""What one seed's rows of a share have in common (``row_shares``)."""


def bound_of(base: str) -> str:
    """The results' name of ILC on ``base`` ("ilc" on the default base, "ilc@basic")."""
    from ..methods.protocol import display_name  # the methods import their dependencies when used: light

    return display_name(BOUND, base)


def share(base: np.ndarray, method: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """(base - method) / (base - bound), NaN where the bound is not below the base or a value is
    missing (module docstring)."""
    base, method, bound = (np.asarray(x, dtype=float) for x in (base, method, bound))
    gap = base - bound
    with np.errstate(divide="ignore", invalid="ignore"):
        out = (base - method) / gap
    return np.where(gap > 0, out, np.nan) + 0.0  # + 0.0: no -0


def _rms(frame: pd.DataFrame, keys: list[str]) -> pd.Series:
    """The RMS of ``frame``'s rows by (``keys``..., method) as text; of duplicates, the last row's."""
    values = pd.Series(frame[RANKED_BY].to_numpy(dtype=float),
                       index=pd.MultiIndex.from_frame(frame[[*keys, "method"]].astype(str)))
    return values[~values.index.duplicated(keep="last")]


def _looked_up(rms: pd.Series, rows: pd.DataFrame, keys: list[str], methods) -> np.ndarray:
    """The RMS of the row of each of ``rows``' ``keys`` and the method in ``methods`` (NaN where none)."""
    wanted = pd.MultiIndex.from_frame(rows[keys].astype(str).assign(method=[str(m) for m in methods]))
    return rms.reindex(wanted).to_numpy(dtype=float)


def _shares(rms: pd.Series, rows: pd.DataFrame, keys: list[str]) -> np.ndarray:
    """``share`` of each of ``rows`` (each with a base) against its base and its bound in ``rms``."""
    base = rows["base"].astype(str).tolist()
    return share(_looked_up(rms, rows, keys, base), rows[RANKED_BY],
                 _looked_up(rms, rows, keys, [bound_of(b) for b in base]))


def mean_shares(table: pd.DataFrame, keys: list[str]) -> pd.Series:
    """Each ranking row's share from the mean RMS of its base's and its bound's rows of the same
    ``keys`` (system, signal, period, axis); NaN for a row without a base."""
    out = pd.Series(np.nan, index=table.index, dtype=float)
    learners = table[table["base"].fillna("").astype(str).ne("")]
    if not learners.empty:
        out.loc[learners.index] = _shares(_rms(table, keys), learners, keys)
    return out


def row_shares(df: pd.DataFrame) -> pd.Series:
    """Each ok row's share among the rows of its seed (``CELL``; the newest run of each cell counts),
    NaN for failed rows and rows without a base: the results CSV's ``share`` column."""
    out = pd.Series(np.nan, index=df.index, dtype=float)
    done = df[df["status"] == "ok"].sort_values("timestamp", kind="stable")
    learners = done[done["base"].fillna("").astype(str).ne("")]
    if not learners.empty:
        out.loc[learners.index] = _shares(_rms(done, list(CELL)), learners, list(CELL))
    return out


__all__ = ["BOUND", "bound_of", "mean_shares", "row_shares", "share"]
