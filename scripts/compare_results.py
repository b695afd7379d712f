"""Compare two results CSVs of ``lcgym bench`` cell by cell: how far a rerun (another machine,
another commit) is from the shipped ``results/leaderboard.csv``.

Rows are matched on (system, method, seed, reference_set, axis, signal, period); per (system,
method) it prints how many of the MA, RMS and Inf values differ at all, the median and the largest
relative difference |a - b| / |a| of RMS, the largest of all three norms, and the largest change
of RMS in units of its spread over seeds in the first file (``RMS_max_in_std``: |a - b| / s, s the
sample standard deviation of a's RMS over the seeds of that system, method, reference set, axis,
signal and period; NaN with one seed). Rows in only one of
the files are counted and listed by cell. Counts (env steps, plant trials) are compared exactly;
``fit_seconds``, run ids and timestamps are not compared.

Run:  .venv/bin/python scripts/compare_results.py results/leaderboard.csv OTHER.csv
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import pandas as pd

from lcgym.leaderboard.store import ResultsFileError, read_results

KEY = ["system", "method", "seed", "reference_set", "axis", "signal", "period"]
NORMS = ["MA", "RMS", "Inf"]
COUNTS = ["env_steps", "plant_trials"]


def relative(a: pd.Series, b: pd.Series) -> pd.Series:
    """|a - b| / |a|: 0 where both are equal (zeros and NaN of failed cells included), infinite where
    a is 0 or NaN and b is not (or the other way round)."""
    a, b = a.astype(float), b.astype(float)
    same = (a == b) | (a.isna() & b.isna())
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = (a - b).abs() / a.abs()
    return rel.where(~same, 0.0).fillna(np.inf).replace(np.nan, np.inf)


def compare(a: pd.DataFrame, b: pd.DataFrame, names: tuple[str, str] = ("first", "second")
            ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(per-method table, rows found in one file only: ``only_in`` names the file, "first" or "second";
    ``names``: the files' names in error messages)."""
    for name, frame in zip(names, (a, b), strict=True):
        missing = [c for c in KEY + NORMS + COUNTS if c not in frame.columns]
        if missing:
            raise ValueError(f"{name} lacks the columns {missing}: not a results CSV of lcgym bench")
        if frame.duplicated(KEY).any():
            raise ValueError(f"{name} holds a cell twice (several runs or configurations): "
                             "compare CSVs of one run each")
    both = a.merge(b, on=KEY, suffixes=("_a", "_b"), how="outer", indicator=True)
    only = both[both["_merge"] != "both"].assign(only_in=lambda d: d["_merge"].map({"left_only": "first",
                                                                                  "right_only": "second"}))
    m = both[both["_merge"] == "both"].copy()
    rel = pd.DataFrame({c: relative(m[f"{c}_a"], m[f"{c}_b"]) for c in NORMS}, index=m.index)
    counts_differ = sum((m[f"{c}_a"] != m[f"{c}_b"]) for c in COUNTS)
    over_seeds = [k for k in KEY if k != "seed"]
    spread = m.groupby(over_seeds, dropna=False)["RMS_a"].transform("std")
    in_std = ((m["RMS_a"] - m["RMS_b"]).abs() / spread).where(rel["RMS"] > 0, 0.0)
    table = pd.DataFrame({
        "rows": m.groupby(["system", "method"]).size(),
        "values_differ": (rel > 0).sum(axis=1).groupby([m["system"], m["method"]]).sum(),
        "RMS_median": rel["RMS"].groupby([m["system"], m["method"]]).median(),
        "RMS_max": rel["RMS"].groupby([m["system"], m["method"]]).max(),
        "any_max": rel.max(axis=1).groupby([m["system"], m["method"]]).max(),
        "RMS_max_in_std": in_std.groupby([m["system"], m["method"]]).max(),
        "counts_differ": counts_differ.groupby([m["system"], m["method"]]).sum(),
    })
    return table, only[KEY + ["only_in"]]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first")
    parser.add_argument("second")
    args = parser.parse_args(argv)
    frames = []
    for path in (args.first, args.second):
        try:
            frames.append(read_results(path))  # the benchmark's own reader: schema and values checked
        except ResultsFileError as exc:  # names the file, column and row
            print(f"compare_results: {exc}", file=sys.stderr)
            return 2
        except (OSError, UnicodeDecodeError, pd.errors.ParserError) as exc:
            print(f"compare_results: cannot read {path}: {exc}", file=sys.stderr)
            return 2
    try:
        table, only = compare(*frames, names=(args.first, args.second))
    except ValueError as exc:
        print(f"compare_results: {exc}", file=sys.stderr)
        return 2
    with pd.option_context("display.width", 200):
        print(table.to_string(float_format=lambda x: f"{x:.1e}"))
    if len(only):
        cells = only.groupby(["only_in", "system", "method", "seed"]).size()
        print(f"\n{len(only)} rows in one file only:\n{cells.to_string()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
