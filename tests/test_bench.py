"""Benchmark runner, results store and report: schema, determinism, failures, resume, kills,
concurrent writers, Dask."""

import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym.cli import main
from lcgym.leaderboard.page import write_html
from lcgym.leaderboard.report import ranking, share_table, write_markdown
from lcgym.leaderboard.runner import BenchConfig, run_benchmark
from lcgym.leaderboard.store import COLUMNS, ResultsFileError, append_rows, read_results

TINY = {"systems": ("ix",), "seeds": (0,), "n_train": 1, "n_validation": 1, "duration": 6.0}
BASE = ("feedback", "physical")  # the fast methods; the PGNN has its own tests
METRICS = ["MA", "RMS", "Inf"]
REPO = Path(__file__).resolve().parents[1]


# `lcgym` as a user's terminal starts it: Ctrl-C raises KeyboardInterrupt. A test run started in the
# background of a non-interactive shell ignores SIGINT, and a child would inherit that.
LCGYM_WITH_CTRL_C = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
                     "from lcgym.cli import main; sys.exit(main())")


def cli(*args, **kwargs):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), kwargs.pop("pythonpath", "")]),
           **kwargs.pop("env_extra", {})}
    return subprocess.Popen([sys.executable, "-c", LCGYM_WITH_CTRL_C, *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def test_tiny_benchmark_rows_and_schema(tmp_path):
    out = tmp_path / "r.csv"
    summary = run_benchmark(BenchConfig(methods=BASE, **TINY), out, progress=False)
    df = read_results(out)
    assert summary["cells_run"] == 2 and summary["cells_failed"] == 0
    assert list(df.columns) == list(COLUMNS)
    # 2 methods x 1 seed x 2 reference sets x 2 axes x 2 signals
    assert len(df) == 16 and set(df["method"]) == {"feedback", "physical"}
    assert set(df["unit"]) == {"deg", "V"} and (df["status"] == "ok").all()
    val = df[(df.reference_set == "validation") & (df.signal == "tracking_error")].set_index(["method", "axis"])
    assert (val.loc["physical", "RMS"] < val.loc["feedback", "RMS"]).all()
    assert (df.loc[df.method == "feedback", "fit_seconds"] < 0.1).all()
    assert (df["plant_trials"] == 1).all()
    (trace_file,) = (out.parent / "r.csv.traces").glob("*/ix-v1_physical_0.parquet")  # in its configuration's folder
    trace = pd.read_parquet(trace_file)
    assert list(trace.columns) == ["t", "ref_propeller", "error_propeller", "ref_roll", "error_roll"]
    assert len(trace) > 100 and np.isfinite(trace.to_numpy()).all()


def test_rbf_expert_cells_run_on_both_systems(tmp_path):
    """Paper 002's NN prediction as a leaderboard method: its training runs (one per training
    reference, with its base's feedforward) count as plant trials, and so do its safeguard's (the
    base and the corrected feedforward on each training reference: 2 more here)."""
    out = tmp_path / "r.csv"
    summary = run_benchmark(BenchConfig(methods=("rbf-expert",), **{**TINY, "systems": ("ix", "flexarm")}), out,
                            progress=False)
    df = read_results(out)
    assert summary["cells_failed"] == 0 and (df["status"] == "ok").all(), df["error"].unique()
    assert set(df["system"]) == {"ix-v1", "flexarm-v1"} and set(df["plant_trials"]) <= {4, 5}
    assert np.isfinite(df["RMS"]).all()


def test_flexarm_cells_score_load_side_and_tcp_errors(tmp_path, capsys):
    """On the arm: load-side tracking error and input residual of joints 2, 3, 5, and the TCP error;
    the fitted physical model (with its joint-torsion reference offset) beats feedback on all."""
    out = tmp_path / "r.csv"
    config = BenchConfig(methods=(*BASE, "basic"), **{**TINY, "systems": ("flexarm", "ix")})
    assert ("ix-v1", "basic", 0) not in config.cells()  # basic is the arm's nominal structure only
    summary = run_benchmark(replace(config, systems=("flexarm",)), out, progress=False)
    df = read_results(out)
    assert summary["cells_failed"] == 0 and (df["status"] == "ok").all()
    val = df[df.reference_set == "validation"]
    periods = ("all", "dynamic", "static")
    assert set(zip(val.signal, val.period, val.axis, val.unit, strict=True)) == {
        *(("tracking_error", "all", j, "deg") for j in ("j2", "j3", "j5")),
        *(("input_residual", "all", j, "N m") for j in ("j2", "j3", "j5")),
        *(("tcp_position_error", p, "tcp", "mm") for p in periods),
        *(("model_following_error", p, j, "rad/s^2") for p in periods for j in ("j2", "j3", "j5")),
        *(("ee_acceleration_error", p, "ee", "m/s^2") for p in periods)}
    shares = share_table(df, of="physical", base="basic").set_index(["signal", "period", "method"])
    for name, axes in (("model_following_error", ["j2", "j3", "j5"]), ("ee_acceleration_error", ["ee"])):
        part = val[(val.signal == name) & (val.period == "dynamic")].set_index(["method", "axis"])["RMS"]
        stacked = {m: np.sqrt(np.mean([part[m, a] ** 2 for a in axes])) for m in ("basic", "physical", "feedback")}
        expected = (stacked["basic"] - stacked["feedback"]) / (stacked["basic"] - stacked["physical"]) * 100
        assert shares.loc[(name, "dynamic", "feedback"), "signed_share"] == pytest.approx(expected)
        assert shares.loc[(name, "dynamic", "physical"), "share"] == pytest.approx(100.0)
        assert shares.loc[(name, "dynamic", "basic"), "share"] == 0.0
    with pytest.raises(ValueError, match="--share-of ilc: no such method"):
        share_table(df, of="ilc", base="basic")
    assert main(["leaderboard", str(out), "--share-of", "physical"]) == 0
    printed = capsys.readouterr().out
    assert "share of what physical changed against basic" in printed
    assert "flexarm-v1 / model_following_error (dynamic) / j2" in printed
    assert main(["leaderboard", str(out), "--share-of", "ilc"]) == 1
    assert "--share-of ilc: no such method" in capsys.readouterr().err
    val = val[val.period == "all"]
    rms = val.set_index(["signal", "axis", "method"])["RMS"].unstack()
    assert (rms["physical"] < rms["feedback"]).all(), rms
    assert rms.loc[("tcp_position_error", "tcp"), "physical"] < rms.loc[("tcp_position_error", "tcp"), "basic"]
    with pytest.raises(ValueError, match="runs on flexarm only"):
        BenchConfig(methods=("basic",), **TINY)
    (trace_file,) = (out.parent / "r.csv.traces").glob("*/flexarm-v1_physical_0.parquet")
    trace = pd.read_parquet(trace_file)
    assert list(trace.columns) == ["t", "ref_j2", "error_j2", "ref_j3", "error_j3", "ref_j5", "error_j5"]


def test_same_seeds_same_numbers(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    run_benchmark(BenchConfig(methods=BASE, **TINY), a, progress=False)
    run_benchmark(BenchConfig(methods=BASE, **TINY), b, progress=False)
    cols = ["system", "method", "seed", "reference_set", "axis", "signal", *METRICS]
    pd.testing.assert_frame_equal(read_results(a)[cols], read_results(b)[cols])


def test_resume_skips_stored_cells(tmp_path):
    out = tmp_path / "r.csv"
    run_benchmark(BenchConfig(methods=("feedback",), **TINY), out, progress=False)
    summary = run_benchmark(BenchConfig(methods=("feedback",), **{**TINY, "seeds": (0, 1)}), out, resume=True,
                            progress=False)
    assert summary["cells_skipped"] == 1 and summary["cells_run"] == 1
    df = read_results(out)
    assert sorted(set(df["seed"])) == [0, 1] and len(df) == 16


@pytest.mark.bad_input
def test_store_refuses_a_corrupt_csv(tmp_path):
    out = tmp_path / "r.csv"
    run_benchmark(BenchConfig(methods=("feedback",), **TINY), out, progress=False)
    df = pd.read_csv(out)
    df.loc[3, "RMS"] = np.nan
    df.to_csv(out, index=False)
    with pytest.raises(ResultsFileError, match="column 'RMS', row 4"):
        read_results(out)
    with pytest.raises(ResultsFileError, match="row 4"):
        append_rows(out, [{c: "x" for c in ("system", "method")}])


@pytest.mark.bad_input
def test_store_reads_files_of_schema_1_and_refuses_an_unknown_period(tmp_path):
    """A file written before the ``schema`` column (and before ``period``, ``note`` and ``base``) reads
    in today's columns, its rows marked schema 1, each signal labelled by its name in words."""
    out = tmp_path / "r.csv"
    run_benchmark(BenchConfig(methods=("feedback",), **TINY), out, progress=False)
    # as text, so that the file written back holds what it held (a commit such as 0913454 is no number)
    df = pd.read_csv(out, dtype=str, keep_default_na=False)
    df.drop(columns=["period", "note", "base", "signal_label", "schema"]).to_csv(tmp_path / "old.csv", index=False)
    old, new = read_results(tmp_path / "old.csv"), read_results(out)
    assert list(old.columns) == list(COLUMNS) and (old["period"] == "all").all() and (old["schema"] == 1).all()
    assert set(new["schema"]) == {3} and set(old["signal_label"]) == {"tracking error", "input residual"}
    assert set(new["signal_label"]) == {"tracking error", "input residual u - f"}
    same = [c for c in COLUMNS if c not in ("signal_label", "schema")]
    pd.testing.assert_frame_equal(old[same], new[same])
    df.loc[2, "period"] = "moving"
    df.to_csv(out, index=False)
    with pytest.raises(ResultsFileError, match="column 'period', row 3: invalid value 'moving'"):
        read_results(out)


def _cells_in(path: Path) -> int:
    if not path.exists() or path.stat().st_size == 0:  # the bench creates the CSV to lock it, then writes rows
        return 0
    df = pd.read_csv(path)
    return df.groupby(["method", "seed"]).ngroups


def _session(sid: int) -> list[int]:
    """The live (not zombie) processes of session ``sid`` (Linux's /proc)."""
    pids = []
    for entry in os.listdir("/proc"):
        try:
            if entry.isdigit() and os.getsid(int(entry)) == sid:
                state = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[0]
                pids += [int(entry)] if state != "Z" else []
        except (OSError, ProcessLookupError):
            continue
    return pids


_DOCS_BENCHMARK = Path(__file__).resolve().parents[1] / "docs" / "benchmark.md"


def _stop_message(text: str) -> str:
    """A stopped bench's line with what differs between runs taken out: the counts, the CSV's path,
    the cells named."""
    line = next(x for x in text.splitlines() if x.startswith("lcgym bench: stopped:"))
    line = re.sub(r"stored in \S+;", "stored in CSV;", line)
    line = re.sub(r"[\w.-]+/[\w.:-]+/\d+(, [\w.-]+/[\w.:-]+/\d+)*", "CELLS", line)
    return re.sub(r"\d+ finished cells?", "N finished cells", line)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the processes of a session from /proc")
def test_sigterm_stops_the_workers_names_the_cells_in_flight_and_resume_runs_them(tmp_path, tally):
    """SIGTERM to a parallel bench after its first finished cell: the finished cell is kept, the cells
    in flight are named, no process of the bench is left 10 s later (its workers are killed, not
    orphaned), no leaked-semaphore warning, and --resume runs what was in flight and the rest."""
    out = tmp_path / "r.csv"
    args = ["bench", "--quick", "--systems", "ix", "--methods", "feedback,physical,ilc,pgnn", "--out", str(out),
            "--jobs", "2", "--no-html"]
    proc = cli(*args, start_new_session=True)
    deadline = time.time() + 120
    while _cells_in(out) < 1 and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    workers = [p for p in _session(proc.pid) if p != proc.pid]
    assert len(workers) >= 2, "the bench should have its workers"
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "semaphore" not in stderr, stderr
    in_flight = stderr.split("in flight, not stored: ")[1].split(";")[0].split(", ")
    assert _stop_message(stderr) == _stop_message(_DOCS_BENCHMARK.read_text()), "docs/benchmark.md shows another message"
    done = _cells_in(out)
    assert done >= 1 and in_flight and all(c.startswith("ix-v1/") for c in in_flight), stderr
    stored = {f"ix-v1/{m}/0" for m in read_results(out)["method"]}
    assert not stored & set(in_flight)
    deadline = time.time() + 10
    while _session(proc.pid) and time.time() < deadline:
        time.sleep(0.1)
    assert not _session(proc.pid), "a process of the stopped bench is left"
    finish = cli(*args, "--resume")
    stdout, stderr = finish.communicate(timeout=300)
    assert finish.returncode == 0, stderr
    assert f"{4 - done} cells run, {done} skipped" in stdout
    assert set(read_results(out)["method"]) == {"feedback", "physical", "ilc", "pgnn"}
    tally("fault")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_killed_bench_leaves_valid_csv_and_resume_completes(tmp_path, tally, sig):
    out = tmp_path / "r.csv"
    # physical cells (about 0.5 s each, not feedback's 0.1 s) leave the kill a window of seconds;
    # one process (parallel workers orphaned by kill -9 would hold the pipes until their cell ends)
    args = ["bench", "--quick", "--systems", "ix", "--methods", "physical", "--seeds", "0,1,2,3,4,5,6,7", "--out", str(out),
            "--jobs", "1"]
    proc = cli(*args)
    deadline = time.time() + 120
    while _cells_in(out) < 1 and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=60)
    if sig == signal.SIGINT:
        assert proc.returncode == 130 and "--resume" in stderr
    done = _cells_in(out)
    assert 1 <= done < 8, "the kill should land mid-run"
    read_results(out)  # a valid CSV with the finished cells
    finish = cli(*args, "--resume")
    stdout, stderr = finish.communicate(timeout=300)
    assert finish.returncode == 0, stderr
    assert f"{8 - done} cells run, {done} skipped" in stdout
    df = read_results(out)
    assert df.groupby(["method", "seed"]).ngroups == 8
    assert not df.duplicated(["method", "seed", "reference_set", "axis", "signal"]).any()
    tally("fault")
    tally("rows_checked", len(df))


def test_concurrent_writers_lose_no_row(tmp_path, tally):
    out = tmp_path / "r.csv"
    procs = [cli("bench", "--quick", "--systems", "ix", "--methods", "feedback", "--seeds", str(s), "--out", str(out))
             for s in range(4)]
    for p in procs:
        _, stderr = p.communicate(timeout=300)
        assert p.returncode == 0, stderr
    df = read_results(out)
    assert sorted(set(df["seed"])) == [0, 1, 2, 3] and len(df) == 4 * 8
    tally("rows_checked", len(df))


def test_dask_local_cluster(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        out = tmp_path / "r.csv"
        summary = run_benchmark(BenchConfig(methods=BASE, **TINY), out, dask=cluster.scheduler_address, progress=False)
    assert summary["cells_run"] == 2
    local = tmp_path / "local.csv"
    run_benchmark(BenchConfig(methods=BASE, **TINY), local, progress=False)
    cols = ["method", "reference_set", "axis", "signal", *METRICS]
    key = cols[:4]
    pd.testing.assert_frame_equal(read_results(out)[cols].sort_values(key).reset_index(drop=True),
                                  read_results(local)[cols].sort_values(key).reset_index(drop=True))


def test_report_pages_escape_strings(tmp_path, monkeypatch):
    (tmp_path / "evil.py").write_text(textwrap.dedent("""
        class Evil:
            name = "evil"
            def fit(self, trials):
                raise RuntimeError("<script>alert(1)</script>")
            def feedforward(self, reference):
                return None
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "r.csv"
    run_benchmark(BenchConfig(methods=("feedback", "physical", "evil:Evil"), **TINY), out, progress=False)
    df = read_results(out)
    page = write_html(df, tmp_path / "board.html").read_text()
    assert "<script>alert" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert page.count("<script>") == 1  # the page's own sorting script, nothing from the CSV
    site = write_html(df, tmp_path / "site", source=str(out))  # a folder: its index.html, figures inside
    assert site == tmp_path / "site" / "index.html" and sorted(p.name for p in site.parent.iterdir()) == ["index.html"]
    text = site.read_text()
    assert "data:image/png;base64," in text and "ix-v1_traces" in text and str(tmp_path) not in text
    md = write_markdown(df, tmp_path / "board.md", source=str(out)).read_text()
    assert "| 1 | physical |" in md and (tmp_path / "board_figures" / "ix-v1_tracking_error.png").exists()
    assert "ix-v1_traces.png" in md and (tmp_path / "board_figures" / "ix-v1_traces.png").exists()
    assert not list((tmp_path / "r.csv.traces").rglob("ix-v1_evil_Evil_0.parquet"))  # failed cells leave no trace
    table = ranking(df)
    top = table[(table.signal == "tracking_error")].groupby("axis").first()["method"]
    assert (top == "physical").all()


def test_shipped_leaderboard_is_valid():
    shipped = REPO / "results" / "leaderboard.csv"
    df = read_results(shipped)
    assert {"feedback", "physical", "pgnn", "pgnn-ls"} <= set(df["method"]) and sorted(set(df["seed"])) == [0, 1, 2]
    assert (df["status"] == "ok").all()


def test_the_ranking_does_not_depend_on_the_order_the_cells_finished_in():
    """A parallel run appends its cells in the order they finish: the means over seeds, the ranks
    (ties included: methods that fall back to their base score its values to the last bit) and the
    notes are those of any other order of the same rows."""
    from lcgym.leaderboard.report import notes

    df = read_results(REPO / "results" / "leaderboard.csv")
    cells = [part for _, part in df.groupby(["system", "method", "seed"], sort=False)]

    def finished(k: int) -> pd.DataFrame:  # the same cells, each with its rows, in another order
        return pd.concat([cells[i] for i in np.random.default_rng(k).permutation(len(cells))], ignore_index=True)

    tables = [ranking(df)] + [ranking(finished(k)) for k in range(3)]
    for other in tables[1:]:
        pd.testing.assert_frame_equal(tables[0], other)
    pd.testing.assert_frame_equal(notes(df), notes(finished(0)))
    ties = tables[0].groupby(["system", "signal", "period", "axis", "rank"]).size()
    assert (ties > 1).any()  # the file has ties, the case a row order could break


def test_parallel_jobs_give_the_serial_numbers(tmp_path):
    serial, parallel = tmp_path / "s.csv", tmp_path / "p.csv"
    config = BenchConfig(methods=BASE, **{**TINY, "seeds": (0, 1)})
    run_benchmark(config, serial, progress=False)
    run_benchmark(config, parallel, jobs=2, progress=False)
    cols = ["method", "seed", "reference_set", "axis", "signal", *METRICS]
    key = cols[:5]
    pd.testing.assert_frame_equal(read_results(serial)[cols].sort_values(key).reset_index(drop=True),
                                  read_results(parallel)[cols].sort_values(key).reset_index(drop=True))


def test_parallel_workers_take_the_costliest_methods_first(tmp_path, monkeypatch):
    """Dispatch order only: methods by ``relative_cost`` from the costliest down, each method's cells
    in the machines' and seeds' order; a user's method without a cost counts as 1 s."""
    from lcgym.leaderboard.runner import costliest_first

    (tmp_path / "costless.py").write_text("class WithoutCost:\n    def fit(self, trials):\n        return self\n\n"
                                          "    def feedforward(self, reference):\n        return None\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    cells = BenchConfig(systems=("ix-v1", "flexarm-v1"), methods=("feedback", "pgnn", "physical", "rl",
                                                                   "costless:WithoutCost"), seeds=(0, 1)).cells()
    order = costliest_first(cells)
    assert sorted(order) == sorted(cells)
    assert [c[1] for c in order[:4]] == ["rl"] * 4 and [c[1] for c in order[-4:]] == ["feedback"] * 4
    assert [c for c in order if c[1] == "pgnn"] == [c for c in cells if c[1] == "pgnn"]
    assert [c[1] for c in order][8:12] == ["costless:WithoutCost"] * 4  # 1 s: after pgnn, before physical


def test_leaderboard_ranks_one_configuration_and_the_newest_run_per_cell(tmp_path):
    from lcgym.leaderboard.report import select

    out = tmp_path / "r.csv"
    run_benchmark(BenchConfig(methods=BASE, **TINY), out, progress=False)
    run_benchmark(BenchConfig(methods=BASE, **TINY), out, progress=False)  # the same cells again
    df, others = select(read_results(out))
    assert df["run_id"].nunique() == 1 and not others and len(df) == 16
    run_benchmark(BenchConfig(methods=BASE, **{**TINY, "n_train": 2}), out, progress=False)  # another configuration
    full = read_results(out)
    newest, others = select(full)
    assert len(others) == 1 and (newest["plant_trials"] == 2).all()
    older, _ = select(full, others[0])
    assert (older["plant_trials"] == 1).all() and len(older) == 16


NUMBERS = ["system", "method", "seed", "reference_set", "axis", "signal", *METRICS, "unit", "plant_trials", "env_steps",
           "nn_rms", "status", "error", "config_hash"]


def _quick(out: Path, cache: Path, *args: str, **kwargs) -> subprocess.Popen:
    return cli("bench", "--quick", "--out", str(out), *args, env_extra={"LCGYM_CACHE": str(cache)}, **kwargs)


@pytest.mark.slow
def test_quick_benchmark_twice_gives_every_number_bit_for_bit(tmp_path, tally):
    """Two `lcgym bench --quick` runs (the default: one worker per core), each training `rl` anew
    (own cache): every stored number equal."""
    frames = []
    for i in range(2):
        proc = _quick(tmp_path / f"{i}.csv", tmp_path / f"cache{i}")
        _, err = proc.communicate(timeout=900)
        assert proc.returncode == 0, err[-2000:]
        frames.append(read_results(tmp_path / f"{i}.csv")[NUMBERS].sort_values(NUMBERS[:6]).reset_index(drop=True))
    pd.testing.assert_frame_equal(frames[0], frames[1], check_exact=True)
    assert (frames[0].status == "ok").all() and len(frames[0]) > 100
    tally("rows_checked", 2 * len(frames[0]))


@pytest.mark.slow
def test_eight_concurrent_quick_benchmarks_share_one_csv(tmp_path, tally):
    """8 `lcgym bench --quick` processes append to one CSV at once: no row lost, none corrupt (every
    run's numbers equal the others'), every trace file readable."""
    out = tmp_path / "shared.csv"
    procs = [_quick(out, tmp_path / "cache", "--jobs", "1") for _ in range(8)]  # 8 writers, not 16 workers
    for p in procs:
        _, err = p.communicate(timeout=1800)
        assert p.returncode == 0, err[-2000:]
    df = read_results(out)
    runs = df.groupby("run_id")
    assert runs.ngroups == 8 and runs.size().nunique() == 1 and (df.status == "ok").all()
    first = None
    for _, run in runs:
        numbers = run[NUMBERS].sort_values(NUMBERS[:6]).reset_index(drop=True)
        if first is None:
            first = numbers
        pd.testing.assert_frame_equal(numbers, first, check_exact=True)
    traces = list((tmp_path / "shared.csv.traces").rglob("*.parquet"))
    assert traces and all(len(pd.read_parquet(trace)) > 0 for trace in traces)
    tally("rows_checked", len(df))


def test_a_commit_of_digits_only_reads_back_as_written(tmp_path, monkeypatch):
    """A short hash like 0913454... parses as a number; the store keeps it text, leading zero included."""
    from lcgym.leaderboard import runner

    monkeypatch.setattr(runner, "git_commit", lambda: "012345678901")
    out = tmp_path / "r.csv"
    for _ in range(2):  # the second run appends: the store reads the first one back
        run_benchmark(BenchConfig(methods=("feedback",), **TINY), out, progress=False)
    df = read_results(out)
    assert len(df) > 0 and (df["git_commit"] == "012345678901").all()


def test_leaderboard_takes_each_machines_newest_configuration(tmp_path):
    """A file that collects machines benchmarked at different times ranks each machine's newest
    configuration; an older configuration of a machine stays out (and is listed)."""
    from lcgym.leaderboard.report import select

    out = tmp_path / "r.csv"
    run_benchmark(BenchConfig(methods=BASE, **TINY), out, progress=False)
    run_benchmark(BenchConfig(methods=BASE, **{**TINY, "n_train": 2}), out, progress=False)
    df = read_results(out)
    other = df.assign(system="my_arm.toml", config_hash="0123456789ab", timestamp="2000-01-01T00:00:00+00:00")
    both = pd.concat([df, other[other["plant_trials"] == 1]], ignore_index=True)
    chosen, others = select(both)
    assert set(chosen["system"]) == {*df["system"], "my_arm.toml"}
    mine = chosen[chosen["system"] != "my_arm.toml"]
    assert (mine["plant_trials"] == 2).all() and len(others) == 1
    assert (chosen[chosen["system"] == "my_arm.toml"]["config_hash"] == "0123456789ab").all()


def test_bench_from_another_folder_with_a_relative_machine_path(tmp_path):
    """A machine file named by a relative path (``../mine/arm.toml``), the CSV in the working folder:
    the run is stored, and the traces lie in the CSV's own traces folder, not beside the machine."""
    mine, work = tmp_path / "mine", tmp_path / "work"
    mine.mkdir()
    work.mkdir()
    folder = REPO / "lcgym" / "systems" / "two_link"
    (mine / "two_link.urdf").write_text((folder / "two_link.urdf").read_text())
    (mine / "arm.toml").write_text((folder / "machine.toml").read_text().replace('name = "two_link"\n', ""))
    proc = cli("bench", "--quick", "--systems", "../mine/arm.toml", "--methods", "feedback", "--out", "r.csv",
               cwd=work)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    df = read_results(work / "r.csv")
    assert set(df["system"]) == {"../mine/arm.toml"} and (df["status"] == "ok").all()
    traces = list((work / "r.csv.traces").rglob("*.parquet"))
    assert len(traces) == 1 and traces[0].suffix == ".parquet" and traces[0].name.startswith("arm.toml-")
    assert sorted(p.name for p in mine.iterdir()) == ["arm.toml", "two_link.urdf"]  # nothing written beside it
    # the output ends with the summary and where the results and the page went
    tail = out.rstrip().splitlines()[-8:]
    assert any(line.startswith("best on each machine") for line in tail)
    assert any("../mine/arm.toml" in line and "feedback" in line for line in tail)
    assert f"results: {work / 'r.csv'}" in out and f"page:    {work / 'r.html'}" in out
    assert (work / "r.html").stat().st_size > 10_000 and sorted(p.name for p in work.iterdir()) == [
        "r.csv", "r.csv.traces", "r.html"]  # no lock file left beside the CSV


def test_the_summary_names_each_machines_best_method_against_the_physical_model():
    """Per machine the method of the lowest RMS tracking error, its gain as the geometric mean of the
    per-axis ratios to the physical model's RMS (so that a mm axis and a deg axis weigh alike);
    where the physical model is best, it says so and names the runner-up; without a physical row it
    compares with nothing."""
    from lcgym.leaderboard.report import format_summary, summary

    def row(system, method, axis, rms, unit="deg"):
        return {"run_id": "r", "system": system, "method": method, "seed": 0, "reference_set": "validation",
                "axis": axis, "signal": "tracking_error", "signal_label": "tracking error", "period": "all",
                "base": "", "MA": rms, "RMS": rms, "Inf": rms,
                "unit": unit, "plant_trials": 1, "env_steps": 0, "fit_seconds": 0.0, "status": "ok", "error": "",
                "config_hash": "c", "note": ""}

    df = pd.DataFrame([
        row("rail", "physical", "x", 0.4, "mm"), row("rail", "physical", "q", 2.0),
        row("rail", "pgnn", "x", 0.1, "mm"), row("rail", "pgnn", "q", 2.0),      # 4x and 1x: 2x in all
        row("rail", "feedback", "x", 4.0, "mm"), row("rail", "feedback", "q", 0.5),  # 0.1x and 4x: 1.58x worse
        row("arm", "physical", "j", 1.0), row("arm", "rl", "j", 1.25),
        row("bare", "feedback", "j", 3.0), row("bare", "pgnn", "j", 2.0),
    ])
    table = summary(df).set_index("system")
    assert table.loc["rail", "best"] == "pgnn" and table.loc["rail", "ratio"] == pytest.approx(0.5)
    assert table.loc["arm", "best"] == "physical" and table.loc["arm", "runner_up"] == "rl"
    assert table.loc["bare", "best"] == "pgnn" and table.loc["bare", "against"] == ""
    text = format_summary(df)
    assert "rail  pgnn      2.0x lower than the physical model's; x 0.1 mm, q 2 deg" in text
    assert "no method beats the physical model (rl: 1.25x its RMS)" in text
    assert "(no physical-model row to compare with)" in text


def _grow_and_report(mb: int, setup: bool) -> int:
    """A loky task: optionally widen the leak guard, keep ``mb`` MB in this worker (and then wait past
    loky's 1 s between checks), return the worker's pid."""
    from lcgym.leaderboard import runner

    if setup:
        runner._widen_leak_guard()
    kept = getattr(runner, "_test_kept", [])
    kept.append(np.ones(mb * 2**20 // 8))
    runner._test_kept = kept
    if mb > 1:
        time.sleep(1.2)
    return os.getpid()


@pytest.mark.parametrize("setup", [False, True])
def test_a_worker_keeping_what_it_remembers_is_not_restarted_as_leaking(setup):
    """Loky stops a worker grown 300 MB past its first task (psutil installed). A bench worker widens
    that bound (``_widen_leak_guard``), so the regressors and runs it keeps do not cost it its life;
    the control, without it, is restarted."""
    pytest.importorskip("psutil")
    from joblib.externals.loky import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=1) as pool:
        first = pool.submit(_grow_and_report, 1, setup).result()
        pool.submit(_grow_and_report, 400, setup).result()
        time.sleep(0.5)  # the leak check runs after the task's result is sent
        last = pool.submit(_grow_and_report, 1, setup).result()
    assert (first == last) == setup


def test_an_edited_machine_file_or_its_urdf_is_another_configuration(tmp_path):
    """--resume and the leaderboard keep runs of a machine file apart once it or its URDF changed."""
    import shutil

    folder = shutil.copytree(Path(__file__).parent / "data" / "rail_arm", tmp_path / "rail_arm")
    machine = folder / "rail_arm.toml"
    config = BenchConfig(systems=(str(machine),), methods=("feedback",), seeds=(0,))
    before = config.config_hash()
    assert config.config_hash() == before
    machine.write_text(machine.read_text() + "\n")
    edited = config.config_hash()
    assert edited != before
    urdf = next(folder.glob("*.urdf"))
    urdf.write_text(urdf.read_text().replace("</robot>", "<!-- edited -->\n</robot>"))
    assert config.config_hash() not in (before, edited)
