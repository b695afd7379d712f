"""The diagnosis on a URDF machine (issue acceptance): the docs' worked example, a friction of no
textbook shape on one joint of the two-link arm, named, added, and the joint's residual at most
half of before; with a one-sided spring on the other joint as well, both selected; nothing claimed
without a hidden effect. Also: the CLI on URDF files, position-only logs, jittered logs
(resampled at their own rate; short gaps bridged, long ones split), and the PGNN fitted on a URDF machine's trials.

The worked example's code is read from the docs page ``docs/own-machine.md`` (the block that starts
with ``# two_link_data.py``), so the page cannot rot.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym import systems
from lcgym.cli import main
from lcgym.data import MeasurementFileError, read_trials, write_trials
from lcgym.diagnose import diagnose
from lcgym.diagnose.workflow import bridged_gap
from lcgym.physics import effects as fx
from lcgym.systems.examples import two_link_urdf
from lcgym.systems.urdf_plant import URDFPlant, random_references

PAGE = Path(__file__).resolve().parents[1] / "docs" / "own-machine.md"
URDF = str(two_link_urdf())
JOINTS = ("shoulder", "elbow")


def readme_example() -> str:
    blocks = re.findall(r"```python\n(# two_link_data\.py.*?)```", PAGE.read_text(), flags=re.S)
    assert len(blocks) == 1, "docs/own-machine.md has one code block starting with '# two_link_data.py'"
    return blocks[0]


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    """The page's data: feedback-only runs of the two-link arm with the hidden elbow friction."""
    folder = tmp_path_factory.mktemp("two_link")
    cwd = Path.cwd()
    try:
        import os

        os.chdir(folder)
        exec(compile(readme_example(), "docs/own-machine.md two_link_data.py", "exec"), {"__name__": "readme_example"})
    finally:
        os.chdir(cwd)
    return folder / "two_link.csv"


def _rms(report, axis, key="residual"):
    return (report.after if key == "after" else report.__dict__)["residual"][axis]["RMS"]


def test_readme_example_names_the_friction_and_adding_it_halves_the_elbow_residual(example, capsys):
    assert main(["diagnose", str(example), "--system", URDF, "--add", "coulomb_friction@elbow"]) == 0
    out = capsys.readouterr().out
    first = re.search(r"  1\. (\S+) \[(\w+)\]", out)
    assert first and first.groups() == ("coulomb_friction@elbow", "friction"), out
    before, after = map(float, re.search(r"  elbow\s+([\d.]+)\s+([\d.]+)\s+-\d+%", out).groups())
    assert after <= 0.5 * before, out
    assert "identified: 8 combinations of the model's 22" in out  # the planar arm's base parameters, stated
    assert f"--system {URDF} --add" in out  # the hint names the machine as the user gave it


def test_friction_and_a_one_sided_spring_on_another_joint_are_both_selected(tmp_path):
    arm = systems.get(URDF, joints=JOINTS)

    def friction(v):  # the page's curve
        return 2.0 * (2 / np.pi) * np.arctan(v / 0.02) + 0.8 * np.exp(-((v / 0.08) ** 2)) * np.tanh(v / 0.005)

    hidden = (fx.TabulatedForce.from_function("elbow", "velocity", friction, -1.5, 1.5, 601),
              fx.CableSpring("shoulder", k=40.0, q0=math.radians(20), width=math.radians(3)))
    runs = URDFPlant(arm, effects=hidden, encoder_resolution=2 * math.pi / 2**16).run(
        random_references(arm, n=3, duration=20.0, seed=0))
    report = diagnose(runs, arm)
    picked = {(c.axis, c.family) for c in report.candidates if c.selected}
    assert {("shoulder", "spring"), ("elbow", "friction")} <= picked, report.text()
    assert report.missing[0] == "cable_spring@shoulder"


def test_the_report_states_each_effects_fitted_range_and_where_validation_data_leave_it():
    """Fitted on slow runs, validated on one twice as fast: the selected friction's fitted velocity
    range is the data's, and the validation says how far the fast run goes beyond it and how often;
    validated on the data fitted, nothing is outside."""
    arm = systems.get(URDF, joints=JOINTS)
    plant = URDFPlant(arm, effects=(fx.CoulombFriction("elbow", Fc=2.0, eps=0.01),), encoder_resolution=2 * math.pi / 2**16)
    slow = plant.run(random_references(arm, n=2, duration=20.0, seed=0, speed=0.25))
    fast = plant.run(random_references(arm, n=1, duration=20.0, seed=1, speed=0.5))
    report = diagnose(slow, arm, validate=fast)
    assert report.missing == ["coulomb_friction@elbow"], report.text()
    r = report.ranges["coulomb_friction@elbow"]
    speed = np.concatenate([np.gradient(tr.ref[:, 1], 1 / tr.fs) for tr in slow])
    assert r["variable"] == "velocity" and r["lo"] < 0 < r["hi"]
    assert r["hi"] == pytest.approx(speed.max(), rel=0.1) and r["lo"] == pytest.approx(speed.min(), rel=0.1)
    (o,) = report.validation["outside"]
    assert o["effect"] == "coulomb_friction@elbow" and (o["max"] > 1.3 * r["hi"] or o["min"] < 1.3 * r["lo"])
    assert 0.01 < o["share"] < 0.9
    text = report.text()
    assert "fitted over velocity" in text and "coulomb_friction@elbow: velocity" in text
    assert f"{100 * o['share']:.1f}% of the samples outside" in text
    same = diagnose(slow, arm, validate=slow)
    assert same.validation["outside"] == [] and "every sample within the effects' fitted ranges" in same.text()


def test_nothing_is_claimed_without_a_hidden_effect():
    arm = systems.get(URDF, joints=JOINTS)
    runs = URDFPlant(arm, encoder_resolution=2 * math.pi / 2**16).run(random_references(arm, n=3, duration=20.0, seed=0))
    report = diagnose(runs, arm)
    assert report.missing == [], report.text()


def test_a_log_without_references_is_diagnosed_from_its_measured_positions(example, tmp_path):
    frame = pd.read_csv(example)
    log = tmp_path / "positions_only.csv"
    frame.drop(columns=[c for c in frame.columns if c.startswith("ref_")]).to_csv(log, index=False)
    trials = read_trials(log, axes=JOINTS)
    assert all(t.ref is None for t in trials)
    report = diagnose(trials, systems.get(URDF, joints=JOINTS), add=["coulomb_friction@elbow"])
    assert "measured position" in report.kinematics and report.missing[0] == "coulomb_friction@elbow"
    assert _rms(report, "elbow", "after") <= 0.55 * _rms(report, "elbow")


def _jittered(example: Path, tmp_path: Path, gap_at: int | None = None, steps: int = 10) -> Path:
    """The example's first trial with time stamps off their grid by up to 30 % of a step (a
    controller's logging jitter); with ``gap_at`` a gap of ``steps`` steps at that row."""
    frame = pd.read_csv(example)
    frame = frame[frame["trial"] == 0].drop(columns=["trial"]).reset_index(drop=True)
    rng = np.random.default_rng(0)
    frame["t"] = frame["t"] + rng.uniform(-0.3e-3, 0.3e-3, len(frame))
    if gap_at is not None:
        frame = frame.drop(index=range(gap_at, gap_at + steps - 1)).reset_index(drop=True)
    path = tmp_path / "jittered.csv"
    frame.to_csv(path, index=False)
    return path


def test_a_jittered_log_is_resampled_at_its_own_rate_and_the_report_says_so(example, tmp_path, capsys):
    log = _jittered(example, tmp_path)
    json_path = tmp_path / "r.json"
    assert main(["diagnose", str(log), "--system", URDF, "--json", str(json_path)]) == 0
    out = capsys.readouterr().out
    assert "1 trial(s) with non-uniform time stamps resampled to 1000 Hz by linear interpolation" in out
    assert "coulomb_friction@elbow" in out and json_path.exists()
    assert main(["diagnose", str(log), "--system", URDF, "--resample", "500"]) == 0  # the rate chosen by the user
    assert "resampled to 500 Hz" in capsys.readouterr().out


@pytest.mark.bad_input
def test_read_trials_alone_still_refuses_jitter_naming_the_row(example, tmp_path):
    with pytest.raises(MeasurementFileError, match="row 2: non-uniform sampling"):
        read_trials(_jittered(example, tmp_path))


@pytest.mark.parametrize("steps, bridged", [(10, True), (40, False)])
def test_a_short_gap_is_bridged_and_a_long_one_splits_the_trial(example, tmp_path, capsys, steps, bridged):
    """Dropouts of 10 ms (under the 12.5 ms that the analysis's 10 Hz low-pass cannot tell from
    nothing) are interpolated; one of 40 ms splits the log into two trials there."""
    log = _jittered(example, tmp_path, gap_at=5000, steps=steps)
    trials = read_trials(log, resample="auto", max_gap=bridged_gap())
    assert len(trials) == (1 if bridged else 2)
    note = trials[0].meta["resampled"]
    assert (note["gaps_bridged"], note["splits"]) == ((1, 0) if bridged else (0, 1))
    assert note["largest_gap"] == pytest.approx(steps * 1e-3, abs=0.7e-3)  # the jitter moves the stamps by 0.3 ms
    assert main(["diagnose", str(log), "--system", URDF]) == 0
    out = capsys.readouterr().out
    expected = "1 gap(s) bridged (the largest " if bridged else "split at 1 gap(s) too long to bridge (the largest "
    assert expected in out, out


@pytest.mark.bad_input
@pytest.mark.parametrize("case", ["unparsable", "missing", "joint the URDF lacks"])
def test_bad_urdf_input_is_one_line_and_writes_nothing(example, tmp_path, capsys, case):
    data, urdf = example, URDF
    if case == "unparsable":
        urdf = tmp_path / "broken.urdf"
        urdf.write_text("<robot name='x'><link name='a'></robot")
    elif case == "missing":
        urdf = tmp_path / "nowhere.urdf"
    else:
        frame = pd.read_csv(example).rename(columns={"pos_elbow": "pos_wrist", "u_elbow": "u_wrist",
                                                      "ref_elbow": "ref_wrist"})
        data = tmp_path / "other.csv"
        frame.to_csv(data, index=False)
    listing = sorted(p.name for p in tmp_path.iterdir())
    assert main(["diagnose", str(data), "--system", str(urdf), "--json", str(tmp_path / "r.json")]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    expected = {"unparsable": "does not parse", "missing": "no such file", "joint the URDF lacks": "wrist"}[case]
    assert expected in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == listing


def test_effects_lists_a_urdf_machine(example, capsys):
    assert main(["effects", "--system", URDF, "--data", str(example)]) == 0
    out = capsys.readouterr().out
    assert "axes: shoulder, elbow" in out and "coulomb_friction" in out and "rotor_inertia" in out
    assert main(["effects", "--system", URDF]) == 0  # without data: every movable joint of the URDF
    assert "axes: shoulder, elbow, finger" in capsys.readouterr().out


def test_pgnn_fits_a_urdf_machine_and_predicts_a_new_reference(example):
    from lcgym.methods.pgnn import PGNN, PGNNConfig

    arm = systems.get(URDF, joints=JOINTS)
    trials = read_trials(example, axes=arm)
    pgnn = PGNN(PGNNConfig(max_epochs=3, threads=1, advance=arm.advance), fs=trials[0].fs, system=arm).fit(trials)
    new = random_references(arm, n=1, duration=5.0, seed=7)[0]
    f = pgnn.predict(new)
    assert f.shape == new.positions.shape and np.all(np.isfinite(f))
    physical = pgnn.physical_.predict(new)
    # the physical part starts at the least-squares fit and the network adds a correction of its size or less
    assert np.sqrt(np.mean((f - physical) ** 2)) < np.sqrt(np.mean(physical**2))
    assert pgnn.params_.names == arm.param_names


def test_write_read_round_trip_keeps_urdf_axes(tmp_path):
    arm = systems.get(URDF, joints=JOINTS)
    run = URDFPlant(arm).run(random_references(arm, n=1, duration=3.0, seed=1))[0]
    (back,) = read_trials(write_trials(tmp_path / "r.parquet", [run]), axes=arm)
    assert back.axes == JOINTS and np.array_equal(back.pos, run.pos)


def test_a_larger_start_model_is_searched_from(example):
    """The page's start-model recipe: the friction already in the model is not offered again."""
    arm = systems.get(URDF, joints=JOINTS)
    trials = read_trials(example, axes=arm)
    start = arm.diagnosis_model(trials[0].fs).with_effect("coulomb_friction@elbow")
    report = diagnose(trials, arm, model=start)
    assert "coulomb_friction@elbow" in report.model_effects and "coulomb_friction@elbow" not in report.missing
    assert report.residual["elbow"]["RMS"] < 0.4  # N m: the friction is in from the start (0.67 without it)
