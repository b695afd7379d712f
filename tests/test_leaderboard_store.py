"""The results store's lock and its reading of files that are not results files.

``store.locked`` locks the results CSV itself (no ``<csv>.lock`` beside it): concurrent appends of
several processes keep every row, and a writer that won the lock on a file another writer has
since replaced (``atomic_write``'s rename) takes it again on the file now at the path. A CSV that
is not a results file (a measurement) is named as such.
"""

from __future__ import annotations

import multiprocessing
import threading
import time
from pathlib import Path

import pytest

from lcgym.cli import main
from lcgym.data import atomic_write
from lcgym.leaderboard.store import ResultsFileError, append_rows, locked, read_results

PROCESSES, APPENDS = 4, 8


def _failed_row(writer: int, k: int) -> dict:
    """The smallest valid results row: a failed cell (no metrics), named by its writer and number."""
    return {"run_id": f"w{writer}", "system": "ix-v1", "method": f"m{k}", "seed": writer, "status": "failed",
            "error": f"writer {writer}, append {k}"}


def _append_many(path: str, writer: int) -> None:
    for k in range(APPENDS):
        append_rows(path, [_failed_row(writer, k)])


def test_concurrent_appends_keep_every_row_and_leave_no_lock_file(tmp_path):
    out = tmp_path / "r.csv"
    context = multiprocessing.get_context("fork")  # a fork starts in milliseconds: lcgym is imported already
    writers = [context.Process(target=_append_many, args=(str(out), w)) for w in range(PROCESSES)]
    for p in writers:
        p.start()
    for p in writers:
        p.join(timeout=120)
        assert p.exitcode == 0
    df = read_results(out)
    assert len(df) == PROCESSES * APPENDS
    assert sorted(set(df["error"])) == sorted(f"writer {w}, append {k}" for w in range(PROCESSES) for k in range(APPENDS))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]  # no r.csv.lock, no temporary file


def test_a_lock_won_on_a_replaced_file_is_taken_again(tmp_path):
    """B waits for the lock on the CSV while A holds it and replaces the file; C comes after the
    replacement. A lock on the old file would let B and C in together; they must take turns."""
    path = tmp_path / "r.csv"
    path.write_text("x\n")
    events: list[str] = []

    def hold(name: str) -> None:
        with locked(path):
            events.append(f"{name} in")
            time.sleep(0.3)
            events.append(f"{name} out")

    waiter = threading.Thread(target=hold, args=("B",))  # flock: separate opens exclude each other, threads too
    with locked(path):
        waiter.start()
        time.sleep(0.2)  # B now waits on the file about to be replaced
        atomic_write(path, lambda tmp: Path(tmp).write_text("y\n"))
    late = threading.Thread(target=hold, args=("C",))
    late.start()
    waiter.join(timeout=10)
    late.join(timeout=10)
    assert events in (["B in", "B out", "C in", "C out"], ["C in", "C out", "B in", "B out"]), events
    assert path.read_text() == "y\n" and sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]


@pytest.mark.bad_input
def test_a_measurement_file_is_named_not_a_results_file(tmp_path, capsys):
    data = tmp_path / "some_measurement.csv"
    data.write_text("t,ref_x,pos_x,u_x\n0,0,0,0\n0.001,0,0,0\n")
    with pytest.raises(ResultsFileError, match=r"some_measurement.csv: not an lcgym results file \(no column 'run_id', "
                                               r"'system', 'method', 'signal'; its columns: t, ref_x, pos_x, u_x\); "
                                               r"lcgym bench writes one"):
        read_results(data)
    assert main(["leaderboard", str(data)]) == 1
    assert "not an lcgym results file" in capsys.readouterr().err


@pytest.mark.bad_input
def test_a_results_file_short_of_one_column_names_the_column(tmp_path):
    out = tmp_path / "r.csv"
    append_rows(out, [_failed_row(0, 0)])
    text = out.read_text().splitlines()
    header = text[0].split(",")
    keep = [i for i, c in enumerate(header) if c != "nn_rms"]
    out.write_text("\n".join(",".join(line.split(",")[i] for i in keep) for line in text) + "\n")
    with pytest.raises(ResultsFileError, match="column 'nn_rms' missing"):
        read_results(out)
