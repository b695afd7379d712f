"""Trials and the measurement-file format (lcgym/data.py): round trips and atomic writing.

The reading rules, with every malformed file the reader must refuse, are in test_bad_files.py.
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym.data import Trial, read_trials, write_trials
from lcgym.systems.ix import IX

AXES = ("propeller", "roll")


def make_trial(seed: int, n: int = 50, fs: float = 500.0, with_ff: bool = True, extra: bool = True) -> Trial:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs + 0.25 * seed
    ref = rng.uniform(-1.0, 1.0, size=(n, 2))
    pos = ref + rng.normal(0.0, 1e-2, size=(n, 2))
    u = rng.normal(0.0, 2.0, size=(n, 2))
    ff = u + rng.normal(0.0, 0.1, size=(n, 2)) if with_ff else None
    ex = {"acc_x": rng.normal(size=n), "motor_angle": rng.uniform(-3, 3, size=n)} if extra else {}
    return Trial(t=t, ref=ref, pos=pos, u=u, axes=AXES, ff=ff, extra=ex, meta={"run": seed, "note": f"trial {seed}"})


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

    back = read_trials(path, axes=IX)
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
    path = tmp_path / "meas.csv"
    make_trial(0).to_frame().to_csv(path, index=False)  # no sidecar
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


RAIL_ARM = Path(__file__).parent / "data" / "rail_arm" / "rail_arm.toml"


def _rail_arm_log(path: Path, rail_scale: float = 1.0, angle_scale: float = 1.0, sidecar: dict | None = None) -> Path:
    t = np.arange(300) / 100.0
    pos = np.column_stack([0.3 * np.sin(t) * rail_scale, 0.8 * np.sin(t) * angle_scale, 1.2 * np.cos(t) * angle_scale])
    write_trials(path, [Trial(t=t, ref=pos, pos=pos, u=np.zeros_like(pos), axes=("rail", "shoulder", "elbow"))],
                 meta=sidecar)
    return path


def test_units_are_settled_before_the_data_are_read(tmp_path):
    """A log in degrees or mm is refused, naming the column and the fix (a prismatic axis speaks of
    lengths); --units, or a sidecar's "units", converts on reading to what the SI log reads."""
    from lcgym import systems
    from lcgym.data import MeasurementFileError

    machine = systems.get(str(RAIL_ARM))
    si = read_trials(_rail_arm_log(tmp_path / "si.csv"), axes=machine)[0].pos
    degrees = _rail_arm_log(tmp_path / "deg.csv", angle_scale=180 / np.pi)
    with pytest.raises(MeasurementFileError, match=r"column 'ref_shoulder' reaches 45.8, beyond 2 pi rad: the file's "
                                                   r"angles look like degrees; give --units deg"):
        read_trials(degrees, axes=machine)
    millimetres = _rail_arm_log(tmp_path / "mm.csv", rail_scale=1000.0)
    with pytest.raises(MeasurementFileError, match=r"column 'ref_rail' reaches 300, beyond 10 m: the file's lengths "
                                                   r"look like millimetres; give --units mm"):
        read_trials(millimetres, axes=machine)
    np.testing.assert_allclose(read_trials(degrees, axes=machine, units="deg")[0].pos, si, rtol=1e-9)
    np.testing.assert_allclose(read_trials(millimetres, axes=machine, units="mm")[0].pos, si, rtol=1e-9)
    both = _rail_arm_log(tmp_path / "both.csv", 1000.0, 180 / np.pi, sidecar={"units": "deg,mm"})
    np.testing.assert_allclose(read_trials(both, axes=machine)[0].pos, si, rtol=1e-9)
    assert read_trials(degrees, axes=machine, units="rad")[0].pos.max() > 40  # rad confirmed: read as it is
    with pytest.raises(ValueError, match="names the revolute axes' unit twice"):
        read_trials(degrees, axes=machine, units="deg,rad")


def test_a_log_whose_sidecar_names_another_machine_is_refused_naming_both(tmp_path):
    """The rail arm's log read as the two-link arm's (its shoulder and elbow columns are there): the
    sidecar's machine and --system are named, unless --system wins."""
    from lcgym import systems
    from lcgym.data import MeasurementFileError
    from lcgym.diagnose.machines import check_log_axes

    log = _rail_arm_log(tmp_path / "run.csv", sidecar={"system": str(RAIL_ARM)})
    two_link = systems.get("two_link")
    with pytest.raises(MeasurementFileError, match=r"its sidecar says it is a log of machine .*rail_arm.toml \(axes rail, "
                                                   r"shoulder, elbow\), not of two_link \(axes shoulder, elbow\); give "
                                                   r"--system .*, or --system-wins"):
        check_log_axes(log, two_link, "two_link")
    check_log_axes(log, two_link, "two_link", system_wins=True)
    check_log_axes(log, systems.get(str(RAIL_ARM)), str(RAIL_ARM))  # its own machine


def test_a_validation_log_is_read_on_the_datas_grid_and_the_report_says_so(tmp_path):
    """A validation log with jittered stamps read at the rate of the data (``lcgym diagnose
    --validate``): it lands on the data's grid, and the report's line names both resamplings."""
    from lcgym.diagnose.workflow import _resampled_notes

    rng = np.random.default_rng(0)
    t = np.arange(400) / 94.7 + rng.uniform(-2e-4, 2e-4, 400)
    pos = np.column_stack([np.sin(t), np.cos(t)])
    write_trials(tmp_path / "other.csv", [Trial(t=t, ref=pos, pos=pos, u=0 * pos, axes=("propeller", "roll"))])
    data = read_trials(tmp_path / "other.csv", resample="auto")  # as the data were read: their own rate
    other = read_trials(tmp_path / "other.csv", resample=100.0)  # the validation log, on the data's rate
    assert data[0].fs == pytest.approx(94.7) and other[0].fs == pytest.approx(100.0)
    note = _resampled_notes(data, other)
    assert "resampled to 94.7 Hz" in note and "the validation log, read as the data: 1 trial(s)" in note
    assert "resampled to 100 Hz" in note and _resampled_notes(data, None).count("resampled") == 1
