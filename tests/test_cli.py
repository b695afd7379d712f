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
