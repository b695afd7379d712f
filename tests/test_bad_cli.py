"""Bad command-line options, on purpose: every ``lcgym`` command refuses them with a reason and
writes nothing.

Each case runs ``lcgym.cli.main`` in this process (argparse errors exit with status 2, the
library's errors return 1) and checks: a non-zero status, the reason on stderr, no file created
in the case's folder, and an output file that existed before left byte for byte as it was.
One test runs the installed entry point as a user would (``python -m lcgym.cli``).

Cases of issue 11: unknown system, method, controller or effect (and axis); negative seeds;
unwritable output paths (missing folder, a file where the folder should be, a folder given as
the file); plus bad numbers (timeouts, durations, significance levels, job counts), a
measurement file of the wrong system, missing or malformed, and an unknown configuration hash.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lcgym.cli import main
from lcgym.data import Trial, write_trials
from lcgym.leaderboard.runner import BenchConfig, run_benchmark


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A valid IX measurement file, one with a NaN in data row 5 of pos_roll, one of another machine
    (a two-link arm's axes), and a results CSV."""
    folder = tmp_path_factory.mktemp("inputs")
    n = 200
    t = np.arange(n) / 500.0
    ref = np.column_stack([np.sin(t), np.cos(t)])
    trial = Trial(t=t, ref=ref, pos=ref * 0.99, u=np.zeros((n, 2)), axes=("propeller", "roll"))
    write_trials(folder / "run.csv", [trial])
    bad = trial.to_frame()
    bad.loc[4, "pos_roll"] = np.nan
    bad.to_csv(folder / "bad.csv", index=False)
    degrees = Trial(t=t, ref=np.degrees(ref), pos=np.degrees(ref), u=np.zeros((n, 2)), axes=("propeller", "roll"))
    write_trials(folder / "degrees.csv", [degrees, degrees])  # two trials: one warning line per trial and column
    arm = Trial(t=t, ref=ref, pos=ref, u=np.zeros((n, 2)), axes=("shoulder", "elbow"))  # another machine's log
    write_trials(folder / "arm.csv", [arm])
    run_benchmark(BenchConfig(methods=("feedback",), systems=("ix",), seeds=(0,), n_train=1, n_validation=1,
                              duration=4.0), folder / "results.csv", progress=False)
    return {"data": str(folder / "run.csv"), "bad": str(folder / "bad.csv"), "degrees": str(folder / "degrees.csv"),
            "arm": str(folder / "arm.csv"), "results": str(folder / "results.csv")}


CASES = [
    # simulate
    (["simulate", "--controller", "magic"], "unknown controller"),
    (["simulate", "--controller", "basic"], "unknown controller basic on ix"),  # the FlexArm's; and ilc, rl: bench only
    (["simulate", "--controller", "ilc"], "unknown controller ilc"),
    (["simulate", "--controller", "physical,physical"], "physical listed twice"),
    (["simulate", "--out", "{tmp}/run.txt"], "use a file name ending in .csv or .parquet or .pq"),
    (["simulate", "--plot", "{tmp}/errors.txt"], "use a file name ending in .png or .pdf or .svg"),
    (["simulate", "--seed", "-1"], "must be >= 0"),
    (["simulate", "--system", "crane"], "unknown system 'crane'"),
    (["simulate", "--n-train", "0"], "must be >= 1"),
    (["simulate", "--n-validation", "two"], "must be an integer, got 'two'"),
    (["simulate", "--duration", "-1"], "--duration: must be within 1..3600 s"),
    (["simulate", "--duration", "nan"], "--duration: must be within 1..3600 s"),
    (["simulate", "--out", "{tmp}/missing/run.csv"], "does not exist"),
    (["simulate", "--out", "{tmp}/out.csv/run.csv"], "does not exist"),  # a file where the folder should be
    (["simulate", "--out", "{tmp}"], "is a folder"),
    # bench
    (["bench", "--methods", "magic", "--quick", "--out", "{tmp}/out.csv"], "unknown method"),
    (["bench", "--methods", "no_such_module:Thing", "--quick", "--out", "{tmp}/out.csv"], "cannot import"),
    (["bench", "--systems", "crane", "--quick", "--out", "{tmp}/out.csv"], "unknown system"),
    (["bench", "--seeds", "0,-1", "--out", "{tmp}/out.csv"], "must be >= 0"),
    (["bench", "--seeds", "zero", "--out", "{tmp}/out.csv"], "must be integers"),
    (["bench", "--seeds", ",", "--out", "{tmp}/out.csv"], "no seed given"),
    (["bench", "--methods", "physical,physical", "--out", "{tmp}/out.csv"], "physical listed twice"),
    (["bench", "--jobs", "0", "--out", "{tmp}/out.csv"], "must be >= 1"),
    (["bench", "--timeout", "0", "--quick", "--out", "{tmp}/out.csv"], "must be > 0"),
    (["bench", "--timeout", "nan", "--quick", "--out", "{tmp}/out.csv"], "must be > 0"),
    (["bench", "--timeout", "inf", "--quick", "--out", "{tmp}/out.csv"], "must be > 0"),
    (["bench", "--timeout", "soon", "--quick", "--out", "{tmp}/out.csv"], "must be a number of seconds"),
    (["bench", "--out", "{tmp}/missing/r.csv"], "does not exist"),
    (["bench", "--out", "{tmp}/out.csv/r.csv", "--quick"], "does not exist"),
    (["bench", "--out", "{tmp}", "--quick"], "is a folder"),
    # leaderboard
    (["leaderboard", "{tmp}/missing.csv"], "no such results file"),
    (["leaderboard", "{results}", "--config", "deadbeef"], "configuration 'deadbeef' not in the results"),
    (["leaderboard", "{data}"], "column"),  # a measurement file is not a results file
    (["leaderboard", "{results}", "--markdown", "{tmp}/missing/board.md"], "does not exist"),
    (["leaderboard", "{results}", "--reference-set", "holdout"], "invalid choice"),
    # diagnose and effects
    (["diagnose", "{data}", "--system", "ix", "--add", "magic@roll"], "'magic' is not an effect"),
    (["diagnose", "{data}", "--system", "ix", "--add", "coulomb_friction@elbow"], "ix has no axis 'elbow'"),
    (["diagnose", "{data}", "--system", "ix", "--min-explained", "nan"], "argument --min-explained: must be a share in (0, 1)"),
    (["diagnose", "{data}", "--system", "ix", "--min-explained", "3"], "argument --min-explained: must be a share in (0, 1)"),
    (["diagnose", "{data}", "--system", "flexarm"], "the file's axes (propeller, roll) are not those of machine flexarm "
                                                    "(j1, j2, j3, j4, j5, j6): it is a log of another machine; give "
                                                    "--system ix"),
    (["diagnose", "{data}", "--system", "ix", "--validate", "{arm}"], "{arm}: the file's axes (shoulder, elbow) are "
                                                                      "not those of machine ix"),
    (["diagnose", "{data}", "--system", "crane"], "unknown machine 'crane'"),
    (["diagnose", "{tmp}/missing.csv", "--system", "ix"], "file not found"),
    (["diagnose", "{bad}", "--system", "ix"], "column 'pos_roll', row 5"),
    (["diagnose", "{data}", "--system", "ix", "--json", "{tmp}/missing/report.json"], "does not exist"),
    (["diagnose", "{data}", "--system", "ix", "--plots", "{tmp}/out.csv"], "exists and is not a folder"),
    (["diagnose", "{degrees}", "--system", "ix"], "lcgym diagnose: {degrees} (trial 0): column 'ref_propeller' "
                                                   "reaches 22.2, beyond 2 pi rad: the file's angles look like degrees; "
                                                   "give --units deg"),
    (["diagnose", "{degrees}", "--system", "ix", "--units", "inch"], "units: 'inch' is none of rad, deg, m, mm"),
    (["effects", "--system", "crane"], "unknown machine 'crane'"),
]
if Path("/proc").is_dir():  # a place where no folder can be made, even by root
    CASES.append((["diagnose", "{data}", "--system", "ix", "--plots", "/proc/lcgym-plots"],
                  "--plots /proc/lcgym-plots: cannot make a folder in /proc"))


@pytest.mark.bad_input
@pytest.mark.parametrize(("args", "message"), CASES, ids=[" ".join(a)[:60] for a, _ in CASES])
def test_bad_option_is_refused_with_a_reason_and_writes_nothing(tmp_path, capsys, inputs, args, message):
    kept = tmp_path / "out.csv"
    kept.write_text("a file the command must not touch\n")
    argv = [a.format(tmp=tmp_path, **inputs) for a in args]
    message = message.format(**inputs)
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse
        status = exc.code
    err = capsys.readouterr().err
    assert status not in (0, None), err
    assert message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    assert kept.read_text() == "a file the command must not touch\n"


@pytest.mark.bad_input
def test_the_installed_command_exits_non_zero_with_the_reason(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "lcgym.cli", "bench", "--methods", "magic", "--quick", "--out",
                           str(tmp_path / "r.csv")], capture_output=True, text=True)
    assert proc.returncode == 1 and "lcgym bench: unknown method" in proc.stderr
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.bad_input
@pytest.mark.parametrize("args", [["bench", "--quick", "--out"], ["simulate", "--out"],
                                  ["diagnose", "{data}", "--system", "ix", "--json"]])
def test_an_unwritable_folder_is_refused_before_any_work(tmp_path, capsys, monkeypatch, inputs, args):
    """The tests run as root here, for whom every folder is writable: the permission check is made
    to answer no, as it does for a user without write access."""
    import lcgym.cli

    monkeypatch.setattr(lcgym.cli.os, "access", lambda path, mode: False)
    with pytest.raises(SystemExit) as exc:
        main([a.format(**inputs) for a in args] + [str(tmp_path / "out.file")])
    assert exc.value.code == 2
    assert f"folder {tmp_path} is not writable" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
