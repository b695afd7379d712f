"""The lcgym command: simulate writes a measurement file, a plot and the metric table on every
built-in machine (bad options: test_bad_cli.py)."""

import pytest

from lcgym.cli import main
from lcgym.data import read_trials
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.ix import IX


@pytest.mark.parametrize("machine, controllers, options, expected", [
    (IX, "feedback,physical", ["--n-train", "2", "--duration", "12"],
     ("ix-v1, 1 validation", "tracking_error", "input_residual")),  # the header names the version
    # the arm: reference offsets (basic) and its score, the load-side error of joints 2, 3, 5, the TCP error
    # and paper 002's errors per period
    (FLEXARM, "feedback,basic", ["--n-train", "1"],
     ("flexarm-v1, 1 validation reference (seed 0)", "tcp_position_error", "model_following_error", "dynamic")),
], ids=["ix", "flexarm"])
def test_simulate_writes_file_plot_and_table(tmp_path, capsys, machine, controllers, options, expected):
    out, png = tmp_path / "run.csv", tmp_path / "run.png"
    rc = main(["simulate", "--system", machine.name, "--controller", controllers, *options, "--n-validation", "1",
               "--out", str(out), "--plot", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    assert all(e in text for e in expected) and controllers.split(",")[1] in text
    trials = read_trials(out, axes=machine)
    assert [t.meta["controller"] for t in trials] == controllers.split(",")
    assert png.stat().st_size > 10_000
