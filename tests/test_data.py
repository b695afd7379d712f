"""Trials and the measurement-file format (lcgym/data.py): round trips and the strict reading rules.

Every malformed file is a small hand-written CSV; the error must be a MeasurementFileError whose
message names the file, the column and the first offending data row (row 1 = first row after
the header).
"""

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym.data import MeasurementFileError, Trial, read_trials, write_trials

AXES = ("propeller", "roll")
HEADER = "t,ref_propeller,ref_roll,pos_propeller,pos_roll,u_propeller,u_roll"


def make_trial(seed: int, n: int = 50, fs: float = 500.0, with_ff: bool = True, extra: bool = True) -> Trial:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs + 0.25 * seed
    ref = rng.uniform(-1.0, 1.0, size=(n, 2))
    pos = ref + rng.normal(0.0, 1e-2, size=(n, 2))
    u = rng.normal(0.0, 2.0, size=(n, 2))
    ff = u + rng.normal(0.0, 0.1, size=(n, 2)) if with_ff else None
    ex = {"acc_x": rng.normal(size=n), "motor_angle": rng.uniform(-3, 3, size=n)} if extra else {}
    return Trial(t=t, ref=ref, pos=pos, u=u, axes=AXES, ff=ff, extra=ex, meta={"run": seed, "note": f"trial {seed}"})


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


# ---------------------------------------------------------------------------------------------
# Trial
# ---------------------------------------------------------------------------------------------


def test_trial_properties():
    tr = make_trial(0, n=10, fs=200.0)
    assert tr.fs == pytest.approx(200.0, rel=1e-12)
    assert tr.n_samples == 10
    np.testing.assert_allclose(tr.error, tr.ref - tr.pos)
    np.testing.assert_allclose(tr.fb, tr.u - tr.ff)
    assert make_trial(0, n=10, with_ff=False).fb is None


@pytest.mark.bad_input
def test_trial_rejects_wrong_shape():
    with pytest.raises(ValueError, match="pos"):
        Trial(t=np.arange(5.0), ref=np.zeros((5, 2)), pos=np.zeros((4, 2)), u=np.zeros((5, 2)), axes=AXES)
    with pytest.raises(ValueError, match="ff"):
        Trial(t=np.arange(5.0), ref=np.zeros((5, 2)), pos=np.zeros((5, 2)), u=np.zeros((5, 2)), axes=AXES,
              ff=np.zeros((5, 1)))


# ---------------------------------------------------------------------------------------------
# Round trips
# ---------------------------------------------------------------------------------------------


def assert_same_trial(a: Trial, b: Trial, tol: float):
    assert a.axes == b.axes
    assert a.n_samples == b.n_samples
    for name in ("t", "ref", "pos", "u", "ff"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=tol, atol=tol, err_msg=name)
    assert set(b.extra) == set(a.extra)
    for k in a.extra:
        np.testing.assert_allclose(np.asarray(b.extra[k], dtype=float), a.extra[k], rtol=tol, atol=tol, err_msg=k)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_several_trials(tmp_path, suffix):
    trials = [make_trial(s, n=40 + 7 * s) for s in range(3)]
    path = tmp_path / f"run{suffix}"
    out = write_trials(path, trials, meta={"system": "ix", "operator": "test"})
    assert Path(out) == path and path.exists()
    assert Path(f"{path}.json").exists()

    frame = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    assert "trial" in frame.columns
    assert sorted(frame["trial"].unique().tolist()) == [0, 1, 2]
    assert len(frame) == sum(tr.n_samples for tr in trials)
    for c in ("ff_propeller", "ff_roll", "acc_x", "motor_angle"):
        assert c in frame.columns

    back = read_trials(path, system="ix")
    assert len(back) == 3
    tol = 1e-9 if suffix == ".csv" else 0.0
    for a, b in zip(trials, back, strict=True):
        assert_same_trial(a, b, tol)
        assert "trial" not in b.extra
        assert b.meta["run"] == a.meta["run"]
        assert b.meta["note"] == a.meta["note"]
        assert b.meta["system"] == "ix" and b.meta["operator"] == "test"
        assert b.meta["fs"] == pytest.approx(500.0)
        assert b.meta["source"] == str(path)
        assert b.fs == pytest.approx(500.0, rel=1e-6)


def test_round_trip_single_trial_without_ff(tmp_path):
    tr = make_trial(4, n=20, with_ff=False, extra=False)
    path = write_trials(tmp_path / "one.csv", [tr])
    frame = pd.read_csv(path)
    assert "trial" not in frame.columns
    assert not any(c.startswith("ff_") for c in frame.columns)
    (back,) = read_trials(path)
    assert back.axes == AXES  # axes found from the ref_ columns
    assert back.ff is None and back.fb is None
    assert back.extra == {}
    np.testing.assert_allclose(back.pos, tr.pos, rtol=1e-9, atol=1e-12)
    assert back.meta["run"] == 4


def test_sidecar_metadata_is_optional(tmp_path):
    path = write_csv(tmp_path, rows_csv(good_rows()))
    (tr,) = read_trials(path)
    assert tr.meta == {"source": str(path)}
    Path(f"{path}.json").write_text(json.dumps({"rig": "IX-2", "trials": [{"gain": 3}]}))
    (tr,) = read_trials(path)
    assert tr.meta == {"rig": "IX-2", "gain": 3, "source": str(path)}


@pytest.mark.bad_input
def test_write_rejects_no_trials_and_bad_extension(tmp_path):
    with pytest.raises(ValueError):
        write_trials(tmp_path / "x.csv", [])
    with pytest.raises(ValueError, match="csv"):
        write_trials(tmp_path / "x.txt", [make_trial(0)])
    assert not (tmp_path / "x.txt").exists()


# ---------------------------------------------------------------------------------------------
# Malformed files
# ---------------------------------------------------------------------------------------------


def test_clean_hand_written_file_reads(tmp_path):
    """Control for the malformed cases below: the unmodified rows are accepted."""
    path = write_csv(tmp_path, rows_csv(good_rows()))
    (tr,) = read_trials(path, system="ix")
    np.testing.assert_allclose(tr.t, np.arange(6) * 0.1)
    np.testing.assert_allclose(tr.u, np.tile([0.5, -0.5], (6, 1)))


def _without_column(tmp_path, column: str) -> Path:
    cols = HEADER.split(",")
    keep = [i for i, c in enumerate(cols) if c != column]
    text = ",".join(cols[i] for i in keep) + "\n"
    text += "\n".join(",".join(str(r[i]) for i in keep) for r in good_rows()) + "\n"
    return write_csv(tmp_path, text)


@pytest.mark.bad_input
@pytest.mark.parametrize("system", [None, "ix"])
def test_missing_column(tmp_path, system):
    path = _without_column(tmp_path, "u_roll")
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, system=system)
    assert_names(exc, path, "u_roll")


@pytest.mark.bad_input
def test_missing_reference_column_with_system(tmp_path):
    path = _without_column(tmp_path, "ref_roll")
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, system="ix")
    assert_names(exc, path, "ref_roll")


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
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, system="ix")
    assert_names(exc, path, column, row)


@pytest.mark.bad_input
def test_bad_value_reports_first_offending_row(tmp_path):
    rows = good_rows(10)
    rows[2][COL["pos_propeller"]] = "nan"  # row 3
    rows[7][COL["pos_propeller"]] = "nan"  # row 8
    path = write_csv(tmp_path, rows_csv(rows))
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "pos_propeller", 3)


@pytest.mark.bad_input
def test_bad_value_in_ff_column_is_rejected(tmp_path):
    rows = [r + [0.25] for r in good_rows()]
    rows[4][-1] = "oops"
    text = HEADER + ",ff_propeller\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n"
    path = write_csv(tmp_path, text)
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "ff_propeller", 5)


@pytest.mark.bad_input
def test_non_uniform_time(tmp_path):
    # steps 0.1 except one doubled step from data row 4 to row 5: t = 0, .1, .2, .3, .5, .6, ...
    rows = good_rows(8)
    for k in range(4, 8):
        rows[k][0] = round(rows[k][0] + 0.1, 10)
    path = write_csv(tmp_path, rows_csv(rows))
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "t", 5)
    assert "uniform" in str(exc.value)


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
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "t", 6)


@pytest.mark.bad_input
def test_repeated_time(tmp_path):
    rows = good_rows(8)
    rows[2][0] = rows[1][0]  # row 3 repeats row 2's time
    path = write_csv(tmp_path, rows_csv(rows))
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "t", 3)


@pytest.mark.bad_input
def test_empty_file(tmp_path):
    path = write_csv(tmp_path, "")
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path)
    assert "empty" in str(exc.value)


@pytest.mark.bad_input
def test_header_only(tmp_path):
    path = write_csv(tmp_path, HEADER + "\n")
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, system="ix")
    assert_names(exc, path)
    assert "no data rows" in str(exc.value)


@pytest.mark.bad_input
def test_one_data_row(tmp_path):
    path = write_csv(tmp_path, rows_csv(good_rows(1)))
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "t", 1)


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
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path)
    assert "unknown file type" in str(exc.value)


@pytest.mark.bad_input
def test_missing_file(tmp_path):
    path = tmp_path / "nope.csv"
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path)


@pytest.mark.bad_input
def test_unknown_system(tmp_path):
    path = write_csv(tmp_path, rows_csv(good_rows()))
    with pytest.raises(ValueError, match="system"):
        read_trials(path, system="scara")


# ---------------------------------------------------------------------------------------------
# Degrees, multi-trial files
# ---------------------------------------------------------------------------------------------


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
    trials = read_trials(path, system="ix")
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
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path)
    assert_names(exc, path, "t", 9)
    assert "trial 1" in str(exc.value)


# ---------------------------------------------------------------------------------------------
# Atomic writing
# ---------------------------------------------------------------------------------------------


@pytest.mark.fault
def test_failed_write_keeps_old_file(tmp_path, monkeypatch):
    path = tmp_path / "keep.csv"
    write_trials(path, [make_trial(0, n=12)], meta={"version": 1})
    old = path.read_bytes()
    old_sidecar = Path(f"{path}.json").read_bytes()
    before = sorted(p.name for p in tmp_path.iterdir())

    real_to_csv = pd.DataFrame.to_csv

    def broken_to_csv(self, target, *args, **kwargs):
        real_to_csv(self.iloc[: len(self) // 2], target, *args, **kwargs)  # half the file is out...
        raise OSError("disk full")  # ...then the write fails

    monkeypatch.setattr(pd.DataFrame, "to_csv", broken_to_csv)
    with pytest.raises(OSError, match="disk full"):
        write_trials(path, [make_trial(1, n=40), make_trial(2, n=40)], meta={"version": 2})
    monkeypatch.undo()

    assert path.read_bytes() == old
    assert Path(f"{path}.json").read_bytes() == old_sidecar
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no temp file left behind
    (back,) = read_trials(path)
    assert back.meta["version"] == 1


def test_successful_overwrite_leaves_no_temp_file(tmp_path):
    path = tmp_path / "over.parquet"
    write_trials(path, [make_trial(0, n=12)])
    write_trials(path, [make_trial(1, n=30)])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["over.parquet", "over.parquet.json"]
    (back,) = read_trials(path)
    assert back.n_samples == 30


@pytest.mark.bad_input
def test_write_into_missing_folder(tmp_path):
    path = tmp_path / "missing" / "x.csv"
    with pytest.raises(FileNotFoundError):
        write_trials(path, [make_trial(0)])
    assert not (tmp_path / "missing").exists()
