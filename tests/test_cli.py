"""The lcgym command: simulate writes a measurement file, a plot and the metric table (bad options:
test_bad_cli.py)."""

from lcgym.cli import main
from lcgym.data import read_trials
from lcgym.systems.ix import IX


def test_simulate_writes_file_plot_and_table(tmp_path, capsys):
    out, png = tmp_path / "run.csv", tmp_path / "run.png"
    rc = main(["simulate", "--system", "ix", "--controller", "feedback,physical", "--n-train", "2",
               "--n-validation", "1", "--duration", "12", "--out", str(out), "--plot", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "tracking_error" in text and "input_residual" in text and "physical" in text
    trials = read_trials(out, axes=IX)
    assert [t.meta["controller"] for t in trials] == ["feedback", "physical"]
    assert png.stat().st_size > 10_000


def test_simulate_runs_on_the_arm_too(tmp_path, capsys):
    """Every built-in machine: the FlexArm with its reference offsets (physical, basic) and its score
    (load-side error of joints 2, 3, 5 and the TCP error)."""
    from lcgym.systems.flexarm import FLEXARM

    out, png = tmp_path / "arm.csv", tmp_path / "arm.png"
    rc = main(["simulate", "--system", "flexarm", "--controller", "feedback,basic", "--n-train", "1",
               "--n-validation", "1", "--out", str(out), "--plot", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "flexarm, 1 validation references" in text and "tcp_position_error" in text and "basic" in text
    trials = read_trials(out, axes=FLEXARM)
    assert [t.meta["controller"] for t in trials] == ["feedback", "basic"]
    assert png.stat().st_size > 10_000
