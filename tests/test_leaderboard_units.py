"""Each axis's own unit in the results of a machine with a prismatic axis.

``tests/data/rail_arm/``: a user's machine file of a rail (prismatic, m) carrying a shoulder and an
elbow (revolute, rad), with a hidden Coulomb friction in the elbow. Its benchmark rows carry the
tracking error in mm on the rail and deg on the joints, and the input residual in N on the rail and
N m on the joints (not the machine's joined "N / N m"); its traces are stored in SI (m and rad).
The built-in machines' rows keep their one unit, and the store reads per-axis units of a user's
machine as well as the joined unit of files written before.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym import systems
from lcgym.leaderboard import plots
from lcgym.leaderboard.report import format_text, select, trace_figures
from lcgym.leaderboard.runner import BenchConfig, run_benchmark, stored_trace, trace_path
from lcgym.leaderboard.store import COLUMNS, ResultsFileError, append_rows, read_results

RAIL_ARM = Path(__file__).parent / "data" / "rail_arm" / "rail_arm.toml"
UNITS = {"rail": ("mm", "N"), "shoulder": ("deg", "N m"), "elbow": ("deg", "N m")}
"""axis -> (tracking-error unit, input unit)."""


def test_a_rail_arms_rows_carry_each_axis_unit(tmp_path):
    out = tmp_path / "r.csv"
    config = BenchConfig(systems=(str(RAIL_ARM),), methods=("feedback",), seeds=(0,), n_train=1, n_validation=1,
                         duration=3.0)
    assert run_benchmark(config, out, progress=False)["cells_failed"] == 0
    df = read_results(out)
    rows = df[df["reference_set"] == "validation"].set_index(["signal", "axis"])
    assert list(rows.loc["tracking_error"].index) == list(UNITS)  # the machine's order
    for axis, (error_unit, input_unit) in UNITS.items():
        assert rows.loc[("tracking_error", axis), "unit"] == error_unit
        assert rows.loc[("input_residual", axis), "unit"] == input_unit
    # the trace in SI: its rail error in m is the row's mm figure / 1000 (one reference, decimated)
    trace = pd.read_parquet(trace_path(out, str(RAIL_ARM), "feedback", 0, config.config_hash()))
    for axis, factor in (("rail", 1000.0), ("shoulder", 180 / np.pi)):
        rms = factor * float(np.sqrt(np.mean(trace[f"error_{axis}"].to_numpy(dtype=float) ** 2)))
        assert rms == pytest.approx(rows.loc[("tracking_error", axis), "RMS"], rel=0.2), axis
    text = format_text(df)
    rail = text.split(f"{RAIL_ARM} / input_residual / rail\n")[1].splitlines()[1]
    assert rail.split()[1] == "feedback" and " N " in f" {rail} " and "N m" not in rail
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.csv.traces"]  # no lock file left


def test_two_configurations_in_one_csv_keep_and_draw_their_own_traces(tmp_path, monkeypatch):
    """A short and a longer run into one CSV: each configuration's trace is kept (they share system,
    method and seed), and the figures of each configuration's rows draw its own; a trace written
    before traces were kept per configuration is still found."""
    out = tmp_path / "r.csv"
    short = BenchConfig(systems=(str(RAIL_ARM),), methods=("feedback",), seeds=(0,), n_train=1, n_validation=1,
                        duration=3.0)
    longer = replace(short, duration=6.0)
    for config in (short, longer):
        assert run_benchmark(config, out, progress=False)["cells_failed"] == 0
    lengths = {}
    for config in (short, longer):
        path = trace_path(out, str(RAIL_ARM), "feedback", 0, config.config_hash())
        lengths[config.config_hash()] = len(pd.read_parquet(path))
    assert len(set(lengths.values())) == 2  # two traces, not one overwritten
    drawn = []
    monkeypatch.setattr(plots, "trace_grid_figure", lambda traces, *a, **k: drawn.append(len(traces["feedback"])))
    df = read_results(out)
    for config_hash, length in lengths.items():
        drawn.clear()
        rows, _ = select(df, config_hash)
        assert [s for s, *_ in trace_figures(rows, out)] == [str(RAIL_ARM)]
        assert drawn == [length]
    legacy = trace_path(out, "ix-v1", "feedback", 0)
    legacy.write_bytes(b"")
    assert stored_trace(out, "ix-v1", "feedback", 0, "0123abcd") == legacy
    assert stored_trace(out, "ix-v1", "physical", 0, "0123abcd") is None


def test_built_in_machines_keep_their_one_input_unit():
    """Per-axis input units give the built-in machines' rows the unit they always had."""
    expected = {"ix": "V", "flexarm": "N m", "two_link": "N m", "emps_sim": "N"}
    assert set(expected) == set(systems.BUILT_IN)
    for name, unit in expected.items():
        assert set(systems.get(name).input_units) == {unit}


def _row(system: str, signal: str, axis: str, unit: str) -> dict:
    return {"run_id": "r1", "system": system, "method": "feedback", "seed": 0, "reference_set": "validation",
            "axis": axis, "signal": signal, "signal_label": signal.replace("_", " "), "period": "all",
            "MA": 0.1, "RMS": 0.2, "Inf": 0.5, "unit": unit,
            "plant_trials": 2, "env_steps": 0, "fit_seconds": 0.1, "status": "ok", "error": "", "config_hash": "c"}


def test_the_store_reads_per_axis_and_older_joined_units(tmp_path):
    out = tmp_path / "r.csv"
    rows = [_row("rail_arm.toml", signal, axis, unit)
            for axis, units in UNITS.items() for signal, unit in zip(("tracking_error", "input_residual"), units,
                                                                     strict=True)]
    rows.append(_row("old_arm.toml", "input_residual", "rail", "N / N m"))  # written before units were per axis
    append_rows(out, rows)
    df = read_results(out)
    assert list(df["unit"]) == [r["unit"] for r in rows]


@pytest.mark.bad_input
@pytest.mark.parametrize("units", [(" ",), ("",), ("deg", "mm")], ids=["blank", "empty", "two for one axis"])
def test_the_store_refuses_a_row_without_a_unit_or_an_axis_of_two(tmp_path, units):
    """The store knows no machine: a row's unit is what its bench wrote, and one configuration gives an
    axis's signal one unit."""
    out = tmp_path / "r.csv"
    rows = [_row("rail_arm.toml", "tracking_error", "x", unit) | {"seed": k} for k, unit in enumerate(units)]
    out.write_text(pd.DataFrame(rows).reindex(columns=COLUMNS).assign(schema=2).to_csv(index=False))
    with pytest.raises(ResultsFileError, match="column 'unit', row 1"):
        read_results(out)


def test_a_long_title_stays_within_a_one_axis_trace_figure():
    """The EMPS page's trace figure (one axis, narrow): its title wrapped, not cut at both edges."""
    from lcgym.leaderboard.plots import trace_grid_figure

    t = np.arange(200) / 100.0
    trace = pd.DataFrame({"t": t, "ref_x": np.sin(t), "error_x": 1e-4 * np.cos(t)})
    title = "emps_sim-v0: tracking error (x in mm) on the first validation reference, seed 0"
    fig = trace_grid_figure({"feedback": trace, "physical": trace}, title, units={"x": "mm"})
    fig.canvas.draw()
    box = fig._suptitle.get_window_extent()
    assert 0 <= box.x0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height
    import matplotlib.pyplot as plt

    plt.close(fig)
