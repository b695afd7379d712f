"""The lcgym command: simulate writes a measurement file, a plot and the metric table."""

import subprocess
import sys

import pytest

from lcgym.cli import main
from lcgym.data import read_trials


def test_simulate_writes_file_plot_and_table(tmp_path, capsys):
    out, png = tmp_path / "run.csv", tmp_path / "run.png"
    rc = main(["simulate", "--system", "ix", "--controller", "feedback,physical", "--n-train", "2",
               "--n-validation", "1", "--duration", "12", "--out", str(out), "--plot", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "tracking_error" in text and "input_residual" in text and "physical" in text
    trials = read_trials(out, system="ix")
    assert [t.meta["controller"] for t in trials] == ["feedback", "physical"]
    assert png.stat().st_size > 10_000


@pytest.mark.bad_input
@pytest.mark.parametrize(
    "args, message",
    [
        (["--controller", "magic"], "unknown controller"),
        (["--seed", "-1"], "must be >= 0"),
        (["--system", "crane"], "invalid choice"),
        (["--out", "/nonexistent-folder/run.csv"], "does not exist"),
    ],
)
def test_bad_options_are_refused_with_a_reason(args, message):
    proc = subprocess.run([sys.executable, "-m", "lcgym.cli", "simulate", *args], capture_output=True, text=True)
    assert proc.returncode != 0
    assert message in proc.stderr


@pytest.mark.bad_input
@pytest.mark.parametrize(
    "args, message",
    [
        (["bench", "--methods", "magic", "--quick"], "unknown method"),
        (["bench", "--systems", "crane", "--quick"], "unknown system"),
        (["bench", "--seeds", "0,-1"], "must be >= 0"),
        (["bench", "--out", "/nonexistent-folder/r.csv"], "does not exist"),
        (["leaderboard", "/nonexistent-folder/r.csv"], "no such results file"),
        (["bench", "--timeout", "0", "--quick"], "must be > 0"),
        (["bench", "--timeout", "nan", "--quick"], "must be > 0"),
        (["bench", "--timeout", "soon", "--quick"], "must be a number of seconds"),
        (["bench", "--out", "/etc/hostname/r.csv", "--quick"], "does not exist"),  # a file where the folder is
    ],
)
def test_bench_and_leaderboard_refuse_bad_options(args, message):
    proc = subprocess.run([sys.executable, "-m", "lcgym.cli", *args], capture_output=True, text=True)
    assert proc.returncode != 0
    assert message in proc.stderr
