"""``scripts/compare_results.py``: a rerun's distance from the shipped results, cell by cell."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "compare_results.py"
spec = importlib.util.spec_from_file_location("compare_results", SCRIPT)
compare_results = importlib.util.module_from_spec(spec)
spec.loader.exec_module(compare_results)


def results(n_seeds: int = 2) -> pd.DataFrame:
    rows = []
    for method in ("physical", "pgnn"):
        for seed in range(n_seeds):
            for axis in ("propeller", "roll"):
                rows.append({"system": "ix-v1", "method": method, "seed": seed, "reference_set": "validation",
                             "axis": axis, "signal": "tracking_error", "period": "all", "MA": 0.05, "RMS": 0.1,
                             "Inf": 0.3, "env_steps": 0, "plant_trials": 8, "fit_seconds": 1.0})
    return pd.DataFrame(rows)


def test_identical_files_differ_nowhere():
    table, only = compare_results.compare(results(), results().assign(fit_seconds=2.0))
    assert table["values_differ"].sum() == 0 and table["any_max"].max() == 0 and only.empty


def test_a_changed_value_is_found_with_its_relative_size():
    b = results()
    b.loc[(b.method == "pgnn") & (b.seed == 1) & (b.axis == "roll"), "RMS"] = 0.1 * (1 + 3e-4)
    b.loc[b.method == "physical", "plant_trials"] = 9
    table, _ = compare_results.compare(results(), b)
    assert table.loc[("ix-v1", "pgnn"), "values_differ"] == 1
    assert table.loc[("ix-v1", "pgnn"), "RMS_max"] == pytest.approx(3e-4)
    assert table.loc[("ix-v1", "physical"), "values_differ"] == 0
    assert table.loc[("ix-v1", "physical"), "counts_differ"] == 4


def test_a_change_is_measured_in_the_spread_over_seeds():
    a = results()
    a.loc[(a.method == "pgnn") & (a.seed == 1), "RMS"] = 0.12  # two seeds, 0.1 and 0.12: s = 0.02 / sqrt(2)
    b = a.copy()
    b.loc[(b.method == "pgnn") & (b.seed == 0) & (b.axis == "roll"), "RMS"] = 0.1 + 0.005
    table, _ = compare_results.compare(a, b)
    assert table.loc[("ix-v1", "pgnn"), "RMS_max_in_std"] == pytest.approx(0.005 / (0.02 / np.sqrt(2)))
    assert table.loc[("ix-v1", "physical"), "RMS_max_in_std"] == 0  # equal seeds (s = 0), nothing changed


def test_failed_cells_compare_equal_and_a_new_failure_counts_as_infinite():
    a, b = results(), results()
    a.loc[0, ["MA", "RMS", "Inf"]] = np.nan
    b.loc[0, ["MA", "RMS", "Inf"]] = np.nan
    assert compare_results.compare(a, b)[0]["values_differ"].sum() == 0
    b.loc[1, "RMS"] = np.nan
    assert compare_results.compare(a, b)[0].loc[("ix-v1", "physical"), "RMS_max"] == np.inf


def test_a_value_leaving_zero_counts_as_infinite():
    a, b = results(), results()
    a.loc[0, "Inf"] = 0.0
    table, _ = compare_results.compare(a, b)
    assert table.loc[("ix-v1", "physical"), "values_differ"] == 1
    assert table.loc[("ix-v1", "physical"), "any_max"] == np.inf


def test_rows_in_one_file_only_are_listed():
    _, only = compare_results.compare(results(n_seeds=2), results(n_seeds=1))
    assert len(only) == 4 and set(only["only_in"]) == {"first"} and set(only["seed"]) == {1}


def test_not_a_results_file_or_two_runs_in_one_fail_clearly(tmp_path, capsys):
    with pytest.raises(ValueError, match="lacks the columns"):
        compare_results.compare(results().drop(columns="RMS"), results())
    with pytest.raises(ValueError, match="holds a cell twice"):
        compare_results.compare(pd.concat([results(), results()]), results())
    good = SCRIPT.parents[1] / "results" / "leaderboard.csv"
    for text in ("just text\nwith, more, fields\n", results().to_csv(index=False)):  # not CSV; not the schema
        bad = tmp_path / "b.csv"
        bad.write_text(text)
        assert compare_results.main([str(good), str(bad)]) == 2
        assert str(bad) in capsys.readouterr().err
    assert compare_results.main([str(good), str(good)]) == 0
    assert "values_differ" in capsys.readouterr().out
