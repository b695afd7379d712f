"""Bad measurement files, on purpose: every case the reader must refuse, with what and where.

``lcgym.data.read_trials`` raises ``MeasurementFileError`` naming the file, the column and the
first offending data row (row 1 = the first row after the header); reading writes nothing, so
nothing can be half-written. Every test here runs twice, reading the whole file as one chunk
and in chunks of 3 rows, so that the streamed reader names the same row as a whole-file read.

The cases of issue 11 and where they are:

- missing columns: ``test_missing_column``, ``test_missing_reference_column_of_one_axis`` (references
  are optional: ``test_a_file_without_references_reads``), ``test_axes_the_file_lacks``;
  renamed or misspelled ones: ``test_renamed_column_is_named_with_the_near_miss``;
- extra columns are *not* an error: logs carry extra sensors (the FlexArm's accelerometer), so
  they are kept in ``Trial.extra`` (``test_extra_columns_are_kept``); an ``ff_<axis>`` column is
  checked like the signals, also one without its partner (``test_bad_value_in_ff_column_is_rejected``);
- NaN, inf, empty cells, strings: ``test_bad_value`` and the tests after it;
- empty file, header only, one row, too few samples: ``test_empty_file`` to ``test_min_samples``;
- non-uniform, decreasing or repeated time: ``test_non_uniform_time`` to ``test_repeated_time``;
- degrees instead of radians: a warning naming the column (``test_degrees_warning``); an angle
  beyond 2 pi can be a real joint range, so it is not refused;
- several trials mixed: with a ``trial`` column they are split (also interleaved); without one,
  the restart of time is named with a hint (``test_two_runs_without_trial_column``);
- huge files streamed: ``test_a_large_file_is_read_in_chunks`` (and
  ``benchmarks/read_large.py`` for the memory);
- file type, missing file, unreadable bytes, corrupt Parquet: the tests at the end.
"""

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym import data
from lcgym.data import MeasurementFileError, read_trials

HEADER = "t,ref_propeller,ref_roll,pos_propeller,pos_roll,u_propeller,u_roll"
IX = ("propeller", "roll")  # the IX's axes


@pytest.fixture(autouse=True, params=["whole file", "3-row chunks"])
def chunking(request, monkeypatch):
    """Each test reads its file in one chunk and in chunks of 3 rows."""
    if request.param == "3-row chunks":
        monkeypatch.setattr(data, "CHUNK_ROWS", 3)
    return request.param


def rows_csv(rows: list[list]) -> str:
    return HEADER + "\n" + "\n".join(",".join(str(v) for v in r) for r in rows) + "\n"


def good_rows(n: int = 6, dt: float = 0.1) -> list[list]:
    """n clean rows; all values are small rad/V numbers."""
    return [[round(k * dt, 10), 0.1 * k, -0.05 * k, 0.1 * k - 0.01, -0.05 * k + 0.01, 0.5, -0.5] for k in range(n)]


COL = {name: i for i, name in enumerate(HEADER.split(","))}


def write_csv(tmp_path: Path, text: str, name: str = "meas.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def assert_names(exc: pytest.ExceptionInfo, path: Path, column: str | None = None, row: int | None = None):
    msg = str(exc.value)
    assert path.name in msg, msg
    if column is not None:
        assert re.search(rf"['\"]{re.escape(column)}['\"]", msg), msg
    if row is not None:
        # "row 3" but not "row 30"
        assert re.search(rf"\brow {row}\b", msg), msg
        others = [int(m) for m in re.findall(r"\brow (\d+)", msg)]
        assert others == [row], msg


def refused(path: Path, column: str | None = None, row: int | None = None, axes: tuple | None = None) -> str:
    """``read_trials(path, axes)`` must raise MeasurementFileError naming the file (and column and
    row); returns the message."""
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, axes=axes)
    assert_names(exc, path, column, row)
    return str(exc.value)


# ---------------------------------------------------------------------------------------------
# Malformed files
# ---------------------------------------------------------------------------------------------


def test_clean_hand_written_file_reads(tmp_path):
    """Control for the malformed cases below: the unmodified rows are accepted."""
    path = write_csv(tmp_path, rows_csv(good_rows()))
    (tr,) = read_trials(path, axes=IX)
    np.testing.assert_allclose(tr.t, np.arange(6) * 0.1)
    np.testing.assert_allclose(tr.u, np.tile([0.5, -0.5], (6, 1)))


def _without_column(tmp_path, column: str) -> Path:
    cols = HEADER.split(",")
    keep = [i for i, c in enumerate(cols) if c != column]
    text = ",".join(cols[i] for i in keep) + "\n"
    text += "\n".join(",".join(str(r[i]) for i in keep) for r in good_rows()) + "\n"
    return write_csv(tmp_path, text)


@pytest.mark.bad_input
@pytest.mark.parametrize("axes", [None, IX])
def test_missing_column(tmp_path, axes):
    path = _without_column(tmp_path, "u_roll")
    refused(path, "u_roll", axes=axes)


@pytest.mark.bad_input
def test_missing_reference_column_of_one_axis(tmp_path):
    """References are optional, but for every axis or none."""
    path = _without_column(tmp_path, "ref_roll")
    message = refused(path, "ref_roll", axes=IX)
    assert "for every axis, or none" in message


def test_a_file_without_references_reads(tmp_path):
    cols = [c for c in HEADER.split(",") if not c.startswith("ref_")]
    text = ",".join(cols) + "\n" + "\n".join(",".join(str(r[COL[c]]) for c in cols) for r in good_rows()) + "\n"
    (tr,) = read_trials(write_csv(tmp_path, text), axes=IX)
    assert tr.ref is None and tr.pos.shape == (6, 2)
    with pytest.raises(ValueError, match="no reference"):
        _ = tr.error


def _corrupt(row: int, column: str, value: str, n: int = 8) -> str:
    """The clean rows with data row ``row`` (1-based) of ``column`` replaced by ``value``."""
    rows = good_rows(n)
    rows[row - 1][COL[column]] = value
    return rows_csv(rows)


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("column", "row", "value"),
    [
        ("pos_propeller", 4, "NaN"),  # NaN
        ("pos_roll", 3, ""),  # empty cell
        ("ref_propeller", 5, "inf"),  # inf
        ("u_roll", 2, "-inf"),
        ("u_propeller", 6, "abc"),  # non-numeric
        ("t", 7, "0.6x"),
    ],
)
def test_bad_value(tmp_path, column, row, value):
    path = write_csv(tmp_path, _corrupt(row, column, value))
    refused(path, column, row, axes=IX)


@pytest.mark.bad_input
def test_bad_value_reports_first_offending_row(tmp_path):
    rows = good_rows(10)
    rows[2][COL["pos_propeller"]] = "nan"  # row 3
    rows[7][COL["pos_propeller"]] = "nan"  # row 8
    path = write_csv(tmp_path, rows_csv(rows))
    refused(path, "pos_propeller", 3)


@pytest.mark.bad_input
@pytest.mark.parametrize(("column", "row", "value"), [("ff_propeller", 5, "oops"), ("ff_roll", 4, "nan")])
def test_bad_value_in_ff_column_is_rejected(tmp_path, column, row, value):
    """An ff column is checked like the signals, also when the other axis has none (it is then
    kept as an extra: test_extra_columns_are_kept)."""
    rows = [r + [0.25] for r in good_rows()]
    rows[row - 1][-1] = value
    text = HEADER + f",{column}\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n"
    refused(write_csv(tmp_path, text), column, row, axes=IX)


@pytest.mark.bad_input
def test_non_uniform_time(tmp_path):
    # steps 0.1 except one doubled step from data row 4 to row 5: t = 0, .1, .2, .3, .5, .6, ...
    rows = good_rows(8)
    for k in range(4, 8):
        rows[k][0] = round(rows[k][0] + 0.1, 10)
    path = write_csv(tmp_path, rows_csv(rows))
    message = refused(path, "t", 5)
    assert "uniform" in message


def test_small_jitter_in_time_is_accepted(tmp_path):
    rows = good_rows(8)
    rows[3][0] = 0.3 + 1e-6  # 1e-5 of the step: within tolerance
    (tr,) = read_trials(write_csv(tmp_path, rows_csv(rows)))
    assert tr.n_samples == 8


@pytest.mark.bad_input
def test_decreasing_time(tmp_path):
    rows = good_rows(8)
    rows[5][0] = 0.35  # row 6 goes back from 0.4 to 0.35
    path = write_csv(tmp_path, rows_csv(rows))
    refused(path, "t", 6)


@pytest.mark.bad_input
def test_repeated_time(tmp_path):
    rows = good_rows(8)
    rows[2][0] = rows[1][0]  # row 3 repeats row 2's time
    path = write_csv(tmp_path, rows_csv(rows))
    refused(path, "t", 3)


@pytest.mark.bad_input
def test_empty_file(tmp_path):
    path = write_csv(tmp_path, "")
    message = refused(path)
    assert "empty" in message


@pytest.mark.bad_input
def test_a_bench_results_file_is_named_as_such(tmp_path):
    path = tmp_path / "results.csv"
    path.write_text("run_id,system,method,seed,reference_set,axis,signal,MA,RMS\nab12,ix-v1,ilc,0,train,roll,"
                    "tracking_error,0.1,0.2\n")
    with pytest.raises(MeasurementFileError, match=r"results.csv: an lcgym bench results file \(lcgym leaderboard "
                       r"reads it\), not a measurement log"):
        read_trials(path)


@pytest.mark.bad_input
def test_header_only(tmp_path):
    path = write_csv(tmp_path, HEADER + "\n")
    message = refused(path, axes=IX)
    assert "no data rows" in message


@pytest.mark.bad_input
def test_one_data_row(tmp_path):
    path = write_csv(tmp_path, rows_csv(good_rows(1)))
    refused(path, "t", 1)


@pytest.mark.bad_input
def test_min_samples(tmp_path):
    path = write_csv(tmp_path, rows_csv(good_rows(4)))
    assert read_trials(path, min_samples=4)[0].n_samples == 4
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, min_samples=5)
    assert_names(exc, path, "t", 1)
    assert "4 samples" in str(exc.value)


@pytest.mark.bad_input
@pytest.mark.parametrize("name", ["meas.txt", "meas.xlsx", "meas"])
def test_unknown_extension(tmp_path, name):
    path = write_csv(tmp_path, rows_csv(good_rows()), name=name)
    message = refused(path)
    assert "unknown file type" in message


@pytest.mark.bad_input
def test_missing_file(tmp_path):
    path = tmp_path / "nope.csv"
    refused(path)


@pytest.mark.bad_input
def test_axes_the_file_lacks(tmp_path):
    """One axis the file lacks is named as a missing column; a file that has none of the axes, nor a
    near-miss of one, is named the log of another machine."""
    path = write_csv(tmp_path, rows_csv(good_rows()))
    message = refused(path, "pos_carriage", axes=("carriage", "roll"))
    assert "the file's axes are propeller" in message
    message = refused(path, axes=("carriage", "elbow"))
    assert "the file's axes (propeller, roll) are not the axes expected (carriage, elbow)" in message


# ---------------------------------------------------------------------------------------------
# Degrees, multi-trial files
# ---------------------------------------------------------------------------------------------


@pytest.mark.bad_input
def test_degrees_warning(tmp_path):
    rows = good_rows(6)
    for k, r in enumerate(rows):
        r[COL["ref_roll"]] = 18.0 * k  # up to 90: degrees
        r[COL["pos_roll"]] = 18.0 * k - 0.3
    path = write_csv(tmp_path, rows_csv(rows))
    with pytest.warns(UserWarning, match="degrees") as rec:
        (tr,) = read_trials(path)
    assert any("pos_roll" in str(w.message) for w in rec)
    assert tr.pos[-1, 1] == pytest.approx(89.7)  # read as-is


def test_rad_file_gives_no_warning(tmp_path):
    rows = good_rows(6)
    for r in rows:
        r[COL["pos_roll"]] = 0.99 * math.pi  # large but plausible rad
    path = write_csv(tmp_path, rows_csv(rows))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_trials(path)


def test_two_trials_in_one_file(tmp_path):
    header = HEADER.replace("t,", "t,trial,", 1)
    a = good_rows(5, dt=0.1)  # 10 Hz
    b = good_rows(7, dt=0.02)  # 50 Hz, time restarts at 0
    lines = [header] + [",".join(map(str, [r[0], 0, *r[1:]])) for r in a]
    lines += [",".join(map(str, [r[0], 1, *r[1:]])) for r in b]
    path = write_csv(tmp_path, "\n".join(lines) + "\n")
    trials = read_trials(path, axes=IX)
    assert [tr.n_samples for tr in trials] == [5, 7]
    assert trials[0].fs == pytest.approx(10.0)
    assert trials[1].fs == pytest.approx(50.0)
    np.testing.assert_allclose(trials[1].t, np.arange(7) * 0.02)
    assert all("trial" not in tr.extra for tr in trials)


@pytest.mark.bad_input
def test_two_trials_error_names_trial_and_file_row(tmp_path):
    header = HEADER.replace("t,", "t,trial,", 1)
    a = good_rows(5)
    b = good_rows(6)
    b[3][0] = 0.25  # trial 1, its 4th row -> file data row 5 + 4 = 9: step not uniform
    lines = [header] + [",".join(map(str, [r[0], 0, *r[1:]])) for r in a]
    lines += [",".join(map(str, [r[0], 1, *r[1:]])) for r in b]
    path = write_csv(tmp_path, "\n".join(lines) + "\n")
    message = refused(path, "t", 9)
    assert "trial 1" in message



# ---------------------------------------------------------------------------------------------
# Renamed and extra columns, mixed runs
# ---------------------------------------------------------------------------------------------


@pytest.mark.bad_input
@pytest.mark.parametrize(("renamed", "to"), [("pos_roll", "pos_rol"), ("u_propeller", "U_propeller"),
                                             ("t", "time")])
def test_renamed_column_is_named_with_the_near_miss(tmp_path, renamed, to):
    path = write_csv(tmp_path, rows_csv(good_rows()).replace(renamed, to, 1))
    message = refused(path, renamed, axes=IX)
    assert f"did you mean '{to}'" in message  # "time": a name of the same role, not a near spelling


@pytest.mark.bad_input
@pytest.mark.parametrize(("extra", "suggested"), [("ff_roll,ref_roll", None), ("tau_roll,ref_roll", "tau_roll"),
                                                  ("torque_roll", "torque_roll")])
def test_a_missing_column_is_suggested_among_the_columns_of_its_role(tmp_path, extra, suggested):
    """A missing input column is looked for among the file's inputs under other names (tau_, torque_),
    never among its references or feedforwards, though ff_roll is nearer to u_roll in spelling."""
    text = rows_csv(good_rows()).replace("u_roll", "dropped", 1)
    header, *rows = text.splitlines()
    n = len(extra.split(","))
    text = "\n".join([f"{header},{extra}"] + [f"{r}{',0.5' * n}" for r in rows]) + "\n"
    message = refused(write_csv(tmp_path, text), "u_roll", axes=IX)
    assert "ff_roll" not in message and "ref_roll" not in message
    assert (f"did you mean '{suggested}'" in message) if suggested else "did you mean" not in message


def test_extra_columns_are_kept(tmp_path):
    rows = [r + [k, "ok", 0.25] for k, r in enumerate(good_rows())]
    text = HEADER + ",acc_x,status,ff_roll\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n"
    (tr,) = read_trials(write_csv(tmp_path, text), axes=IX)
    assert tr.ff is None  # ff_roll without ff_propeller: no feedforward, the column is an extra
    np.testing.assert_array_equal(tr.extra["acc_x"], np.arange(6))
    assert list(tr.extra["status"]) == ["ok"] * 6
    np.testing.assert_array_equal(tr.extra["ff_roll"], np.full(6, 0.25))


@pytest.mark.bad_input
def test_two_runs_without_trial_column(tmp_path):
    path = write_csv(tmp_path, rows_csv(good_rows(5) + good_rows(4)))  # time restarts at data row 6
    message = refused(path, "t", 6)
    assert "'trial' column" in message


def test_interleaved_trials_are_split(tmp_path):
    """Rows of two trials alternating (a logger writing two channels' runs in turn)."""
    header = HEADER.replace("t,", "t,trial,", 1)
    a, b = good_rows(5), good_rows(5, dt=0.2)
    lines = [header]
    for ra, rb in zip(a, b, strict=True):
        lines += [",".join(map(str, [ra[0], 3, *ra[1:]])), ",".join(map(str, [rb[0], 7, *rb[1:]]))]
    trials = read_trials(write_csv(tmp_path, "\n".join(lines) + "\n"), axes=IX)
    assert [tr.n_samples for tr in trials] == [5, 5]
    np.testing.assert_allclose(trials[0].t, np.arange(5) * 0.1)
    np.testing.assert_allclose(trials[1].t, np.arange(5) * 0.2)


# ---------------------------------------------------------------------------------------------
# Large files, line endings, unreadable bytes, Parquet
# ---------------------------------------------------------------------------------------------


def _large_frame(n: int) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    cols = {"t": np.arange(n) * 1e-3}
    for p in ("ref", "pos", "u", "ff"):
        for ax in ("propeller", "roll"):
            cols[f"{p}_{ax}"] = rng.normal(scale=0.5, size=n)
    cols["acc_x"] = rng.normal(size=n)
    return pd.DataFrame(cols)


@pytest.mark.bad_input
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_large_file_is_read_in_chunks(tmp_path, monkeypatch, chunking, suffix):
    """20,000 rows in chunks of 1,000: the same trial as one read; a bad value in row 17,001 is
    named and the reading stops at its chunk."""
    frame = _large_frame(20_000)
    path = tmp_path / f"large{suffix}"
    write = frame.to_csv if suffix == ".csv" else frame.to_parquet
    write(path, index=False)
    monkeypatch.setattr(data, "CHUNK_ROWS", 10**9)
    (whole,) = read_trials(path, axes=IX)
    monkeypatch.setattr(data, "CHUNK_ROWS", 1000)
    (chunked,) = read_trials(path, axes=IX)
    for name in ("t", "ref", "pos", "u", "ff"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))
    np.testing.assert_array_equal(chunked.extra["acc_x"], whole.extra["acc_x"])

    frame.loc[17_000, "u_roll"] = np.inf
    write(path, index=False)
    chunks_read = []
    real_chunks = data._chunks

    def counting(*args):
        for chunk in real_chunks(*args):
            chunks_read.append(len(chunk))
            yield chunk

    monkeypatch.setattr(data, "_chunks", counting)
    refused(path, "u_roll", 17_001, axes=IX)
    assert len(chunks_read) == 18  # rows 17,001-18,000 are the 18th chunk; two more are never read


def test_more_rows_than_the_line_count_grow_the_arrays(tmp_path, monkeypatch):
    path = write_csv(tmp_path, rows_csv(good_rows(9)))
    monkeypatch.setattr(data, "_row_bound", lambda path: 1)
    (tr,) = read_trials(path, axes=IX)
    np.testing.assert_allclose(tr.t, np.arange(9) * 0.1)
    np.testing.assert_allclose(tr.u, np.tile([0.5, -0.5], (9, 1)))


@pytest.mark.parametrize("newline", ["\r\n", "\r"])
def test_windows_and_old_mac_line_endings_read(tmp_path, newline):
    path = tmp_path / "meas.csv"
    path.write_bytes(rows_csv(good_rows(7)).replace("\n", newline).encode())
    (tr,) = read_trials(path, axes=IX)
    np.testing.assert_allclose(tr.t, np.arange(7) * 0.1)


@pytest.mark.bad_input
@pytest.mark.parametrize("content", [b"\xff\xfe\x00garbage\x00\n\x80\x81,\x82\n", b"PK\x03\x04 a zip, not a CSV"])
def test_unreadable_bytes(tmp_path, content):
    path = tmp_path / "meas.csv"
    path.write_bytes(content)
    refused(path, axes=IX)


@pytest.mark.bad_input
@pytest.mark.parametrize("content", [b"PAR1 not really parquet", b""])
def test_corrupt_parquet(tmp_path, content):
    path = tmp_path / "meas.parquet"
    path.write_bytes(content)
    message = refused(path, axes=IX)
    assert "cannot parse" in message


@pytest.mark.bad_input
def test_parquet_with_strings_and_nan(tmp_path):
    frame = _large_frame(10)
    frame["pos_roll"] = frame["pos_roll"].map(str)  # a logger that wrote text: numbers as text are read
    frame.loc[6, "pos_roll"] = "stuck"
    path = tmp_path / "meas.parquet"
    frame.to_parquet(path, index=False)
    refused(path, "pos_roll", 7, axes=IX)


def test_many_trials_in_any_row_order_are_split_in_file_order(tmp_path):
    """40 trials, once one after the other and once with their rows randomly interleaved (each
    trial's rows in order): the same trials, in the order of their first row."""
    rng = np.random.default_rng(3)
    frames = []
    for k in range(40):
        f = _large_frame(int(rng.integers(3, 30)))
        f.insert(1, "trial", k)
        frames.append(f)
    whole = pd.concat(frames, ignore_index=True)
    owner = rng.permutation(np.repeat(np.arange(40), [len(f) for f in frames]))  # which trial each row is
    taken = [0] * 40
    mixed_rows = []
    for k in owner:
        mixed_rows.append(frames[k].iloc[taken[k]])
        taken[k] += 1
    mixed = pd.DataFrame(mixed_rows)
    for name, frame in (("whole", whole), ("mixed", mixed)):
        path = tmp_path / f"{name}.csv"
        frame.to_csv(path, index=False)
        trials = read_trials(path, axes=IX)
        firsts = pd.unique(frame["trial"])
        assert len(trials) == 40
        for tr, k in zip(trials, firsts, strict=True):
            np.testing.assert_allclose(tr.t, frames[int(k)]["t"].to_numpy())
            np.testing.assert_allclose(tr.u[:, 1], frames[int(k)]["u_roll"].to_numpy())


@pytest.mark.bad_input
@pytest.mark.parametrize("sep", [";", "\t"])
def test_another_separator_is_named(tmp_path, sep):
    path = write_csv(tmp_path, rows_csv(good_rows()).replace(",", sep))
    message = refused(path, axes=IX)
    assert "lcgym reads comma-separated files" in message


@pytest.mark.bad_input
def test_a_fractional_trial_label_is_named_as_written(tmp_path):
    header = HEADER.replace("t,", "t,trial,", 1)
    rows = good_rows(6)
    rows[4][0] = 0.45  # non-uniform step in the trial labelled 0.5
    path = write_csv(tmp_path, "\n".join([header] + [",".join(map(str, [r[0], 0.5, *r[1:]])) for r in rows]) + "\n")
    message = refused(path, "t", 5)
    assert "(trial 0.5)" in message
