"""The share of the learnable (``lcgym.leaderboard.shares``): per row of the CSV from its seed's
base and ILC rows, in the ranking from the means over seeds, in the views; the runner fills the
CSV's column as the rows it needs arrive."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from lcgym.leaderboard.page import render
from lcgym.leaderboard.report import format_text, ranking, write_markdown
from lcgym.leaderboard.shares import mean_shares, row_shares, share
from lcgym.leaderboard.store import COLUMNS, append_rows, read_results


def test_share_is_the_part_of_the_gap_between_base_and_ilc():
    np.testing.assert_allclose(share([1.0, 1.0, 1.0, 1.0], [0.6, 1.2, 0.2, 0.5], [0.2, 0.2, 0.2, 1.1]),
                               [0.5, -0.25, 1.0, np.nan])
    assert np.isnan(share(1.0, 0.5, 1.0))  # ILC no better than the base: nothing learnable
    assert np.isnan(share(np.nan, 0.5, 0.2)) and np.isnan(share(1.0, 0.5, np.nan))


def _rows(rms: dict[str, tuple[float, ...]], seed: int = 0, axis: str = "x", timestamp: str = "2026-01-01",
          config: str = "c1") -> list[dict]:
    base = {"ilc": "physical", "rl": "physical", "ilc@basic": "basic", "rbf-expert@basic": "basic"}
    out = []
    for method, values in rms.items():
        for reference_set, value in zip(("train", "validation"), values, strict=True):
            out.append({"run_id": f"r-{timestamp}", "system": "m-v0", "method": method, "base": base.get(method, ""),
                        "seed": seed, "reference_set": reference_set, "axis": axis, "signal": "tracking_error",
                        "signal_label": "tracking error", "period": "all", "MA": value, "RMS": value, "Inf": value,
                        "unit": "deg", "plant_trials": 1, "env_steps": 0, "fit_seconds": 0.0, "status": "ok",
                        "error": "", "timestamp": timestamp, "config_hash": config, "note": "", "schema": 3})
    return out


def _frame(rows: list[dict]) -> pd.DataFrame:
    return pd.DataFrame(rows).reindex(columns=COLUMNS)


def test_row_shares_take_the_base_and_ilc_of_the_same_seed_and_set():
    df = _frame(_rows({"feedback": (3.0, 3.0), "physical": (1.0, 2.0), "ilc": (0.2, 0.4), "rl": (0.6, 1.2),
                       "rbf-expert@basic": (0.5, 0.5), "basic": (1.0, 1.0)})
                + _rows({"physical": (1.0, 1.0), "ilc": (1.0, 1.5), "rl": (0.9, 0.9)}, seed=1))
    got = df.assign(share=row_shares(df)).set_index(["method", "seed", "reference_set"])["share"]
    assert got[("rl", 0, "train")] == pytest.approx(0.5) and got[("rl", 0, "validation")] == pytest.approx(0.5)
    assert got[("ilc", 0, "validation")] == pytest.approx(1.0)
    assert np.isnan(got[("rl", 1, "train")])  # seed 1: ILC no better than the base
    assert np.isnan(got[("rbf-expert@basic", 0, "train")])  # no ilc@basic rows: no bound on that base
    assert got[["feedback", "physical", "basic"]].isna().all()  # no base: no share


def test_a_newer_run_of_a_cell_replaces_the_older_one():
    old = _rows({"physical": (1.0, 1.0), "ilc": (0.5, 0.5), "rl": (0.9, 0.9)}, timestamp="2026-01-01")
    new = _rows({"ilc": (0.0, 0.0)}, timestamp="2026-02-01")
    df = _frame(old + new)
    got = df.assign(share=row_shares(df))
    assert got.loc[(got.method == "rl"), "share"].tolist() == pytest.approx([0.1, 0.1])


def test_ranking_and_views_show_the_share_of_the_means(tmp_path):
    rows = (_rows({"physical": (1.0, 1.0), "ilc": (0.2, 0.2), "rl": (0.6, 0.8), "feedback": (2.0, 2.0)})
            + _rows({"physical": (1.0, 1.2), "ilc": (0.2, 0.2), "rl": (0.6, 0.6), "feedback": (2.0, 2.0)}, seed=1))
    df = _frame(rows)
    table = ranking(df).set_index("method")
    assert table.loc["rl", "share"] == pytest.approx((1.1 - 0.7) / (1.1 - 0.2))  # of the means, not of the shares
    assert table.loc["ilc", "share"] == pytest.approx(1.0) and np.isnan(table.loc["feedback", "share"])
    assert mean_shares(ranking(df), ["system", "signal", "period", "axis"]).notna().sum() == 2
    text = format_text(df)
    assert " share " in text and "0.44" in text and "share: a learner's share of the learnable" in text
    page = render(df)
    assert ">share</th>" in page and "class='share' title='x 0.44'>0.444<" in page
    md = write_markdown(df, tmp_path / "board.md").read_text()
    assert "| vs_base | share |" in md and "| 0.44 |" in md


def test_the_runner_fills_the_csvs_share_column_as_the_rows_arrive(tmp_path):
    """``append_rows`` with the runner's ``derive``: a learner stored before its bound has no share
    until ILC's rows arrive; then every row of the file has it."""
    out = tmp_path / "r.csv"
    fill = lambda table: table.assign(share=row_shares(table))  # noqa: E731  (the runner's)
    rows = _rows({"physical": (1.0, 1.0), "rl": (0.5, 0.5)})
    append_rows(out, [{k: v for k, v in r.items() if k != "schema"} for r in rows], derive=fill)
    assert read_results(out)["share"].isna().all()
    append_rows(out, [{k: v for k, v in r.items() if k != "schema"} for r in _rows({"ilc": (0.0, 0.0)})], derive=fill)
    df = read_results(out)
    assert df.loc[df.method == "rl", "share"].tolist() == pytest.approx([0.5, 0.5])
    assert list(df.columns) == list(COLUMNS) and set(df["schema"]) == {3}


def test_a_file_of_schema_2_reads_with_the_share_empty(tmp_path):
    df = _frame(_rows({"physical": (1.0, 1.0), "ilc": (0.5, 0.5)})).drop(columns=["share"]).assign(schema=2)
    df.to_csv(tmp_path / "old.csv", index=False)
    old = read_results(tmp_path / "old.csv")
    assert list(old.columns) == list(COLUMNS) and old["share"].isna().all() and set(old["schema"]) == {2}
    assert ranking(old).set_index("method").loc["ilc", "share"] == pytest.approx(1.0)  # the views compute it
