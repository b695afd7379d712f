"""The EMPS benchmark as a worked example (issue acceptance, on data the tests can make): the
reader of the benchmark's ``.mat`` layout (``lcgym.datasets.emps``, ``lcgym import emps``), the
EMPS machine (``--system emps``) and the diagnosis on a simulated carriage with the benchmark's
published parameters (Janot, Gautier and Brunot 2019: M 95.1 kg, Fv 203.5 N s/m, Fc 20.39 N,
offset -3.16 N; asymmetric: Fc+ 20.14 N, Fc- 20.63 N, Fv+ 166.7 N s/m, Fv- 240.4 N s/m).

The carriage is a one-prismatic-joint URDF simulated by ``URDFPlant`` (the plant side of the
effects), written as a ``.mat`` file of the benchmark's layout, read back and diagnosed on the
Python EMPS machine: the data path a user with the real files takes. The real files are not in
the repository (their licence is not stated); ``docs/emps.md`` shows the diagnosis on them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from lcgym import datasets, systems
from lcgym.cli import main
from lcgym.data import MeasurementFileError, read_trials
from lcgym.diagnose import diagnose
from lcgym.physics import effects as fx
from lcgym.systems.examples.emps import EMPS
from lcgym.systems.urdf_plant import URDFPlant, random_references

GTAU = 35.15  # N/V, the benchmark files' drive gain
CARRIAGE = """<?xml version="1.0"?>
<robot name="carriage">
  <link name="base"/>
  <link name="carriage"><inertial><origin xyz="0 0 0"/><mass value="95.1"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="x" type="prismatic"><parent link="base"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.25" effort="500" velocity="0.25"/></joint>
</robot>
"""
SYMMETRIC = (fx.ViscousFriction("x", d=203.5), fx.CoulombFriction("x", Fc=20.39, eps=1e-3), fx.Offset("x", c=-3.16))
ASYMMETRIC = (fx.ViscousFriction("x", d=(166.7 + 240.4) / 2),
              fx.AsymmetricFriction("x", Fc_pos=20.14, Fc_neg=20.63, dFv=(166.7 - 240.4) / 2, eps=1e-3))


def write_mat(path: Path, t, qm, qg, vir, gtau=GTAU, **extra) -> Path:
    scipy.io.savemat(path, {"t": np.asarray(t)[:, None], "qm": np.asarray(qm)[:, None], "qg": np.asarray(qg)[:, None],
                            "vir": np.asarray(vir)[:, None], "gtau": np.array([[gtau]]), "kp": np.array([[160.18]]),
                            **extra})
    return path


@pytest.fixture(scope="module")
def carriage(tmp_path_factory):
    path = tmp_path_factory.mktemp("carriage") / "carriage.urdf"
    path.write_text(CARRIAGE)
    return systems.get(str(path), joints=("x",))


@pytest.fixture(scope="module")
def experiments(carriage, tmp_path_factory):
    """``.mat`` files of the simulated carriage: {(hidden set, seed): path}."""
    folder = tmp_path_factory.mktemp("emps")
    out = {}
    for name, hidden in (("symmetric", SYMMETRIC), ("asymmetric", ASYMMETRIC)):
        for seed in (0, 1):
            run = URDFPlant(carriage, effects=hidden, encoder_resolution=1e-6, seed=seed).run(
                random_references(carriage, n=1, duration=25.0, seed=seed))[0]
            out[name, seed] = write_mat(folder / f"{name}_{seed}.mat", run.t, run.pos[:, 0], run.ref[:, 0],
                                        run.u[:, 0] / GTAU)
    return out


def test_reader_maps_the_benchmark_layout(tmp_path):
    n = 500
    t = np.arange(n) * 1e-3 + 0.25  # a file's time need not start at 0
    qm, qg, vir = np.linspace(0, 0.1, n), np.linspace(0, 0.1, n) + 1e-4, np.sin(np.arange(n) / 50)
    trial = datasets.emps(write_mat(tmp_path / "d.mat", t, qm, qg, vir))
    assert trial.axes == ("x",) and trial.n_samples == n and trial.fs == pytest.approx(1000.0, rel=1e-9)
    assert trial.t[0] == 0.0
    np.testing.assert_array_equal(trial.pos[:, 0], qm)
    np.testing.assert_array_equal(trial.ref[:, 0], qg)
    np.testing.assert_allclose(trial.u[:, 0], GTAU * vir, rtol=1e-15)  # u = gtau * vir [N]
    assert trial.meta["gtau"] == GTAU and "d.mat" in trial.meta["source"]
    assert systems.get("emps") is EMPS and EMPS.axes[0].kind == "prismatic" and EMPS.input_unit == "N"


@pytest.mark.parametrize("change, message", [
    ({"drop": "vir"}, "missing vir"),
    ({"qm": np.ones(10)}, "'qm' has 10 samples, 't' has 500"),
    ({"qg": np.r_[np.zeros(41), np.nan, np.zeros(458)]}, "'qg': value nan at sample 42"),
    ({"t": np.r_[np.arange(300) * 1e-3, 0.5 + np.arange(200) * 1e-3]}, "uniform step"),
    ({"gtau": -1.0}, "'gtau' must be one positive number"),
    ({"vir": np.ones((500, 2))}, "'vir' must be a numeric vector"),
    ({"t": np.arange(50) * 1e-3, "qm": np.zeros(50), "qg": np.zeros(50), "vir": np.zeros(50)}, "50 samples"),
])
def test_reader_refuses_a_malformed_file(tmp_path, tally, change, message):
    fields = {"t": np.arange(500) * 1e-3, "qm": np.zeros(500), "qg": np.zeros(500), "vir": np.zeros(500), "gtau": GTAU}
    fields.update({k: v for k, v in change.items() if k != "drop"})
    data = {k: (np.atleast_2d(v).T if np.ndim(v) == 1 else v) for k, v in fields.items() if k != change.get("drop")}
    path = tmp_path / "bad.mat"
    scipy.io.savemat(path, data)
    with pytest.raises(MeasurementFileError, match=re.escape(message)) as info:
        datasets.emps(path)
    assert str(path) in str(info.value)
    tally("bad_input")


def test_reader_refuses_what_is_not_a_mat_file(tmp_path, tally):
    (tmp_path / "x.mat").write_text("t,qm\n0,0\n")
    for path, message in ((tmp_path / "x.mat", "not a MATLAB .mat file"), (tmp_path / "none.mat", "no such file")):
        with pytest.raises(MeasurementFileError, match=message):
            datasets.emps(path)
        tally("bad_input")


def test_symmetric_friction_and_offset_come_back_within_two_percent(experiments):
    trial = datasets.emps(experiments["symmetric", 0])
    rep = diagnose([trial], "emps", kinematics="measured", add=["coulomb_friction@x", "offset@x"])
    assert rep.missing[0] in ("coulomb_friction@x", "asymmetric_friction@x")  # a friction first
    assert rep.after["residual"]["x"]["RMS"] <= 0.2 * rep.residual["x"]["RMS"]
    p = rep.after["parameters"]
    fitted = {e["effect"]: e for e in rep.after["effects"]}
    # 95.5 kg, 204.8 N s/m, 20.27 N, -3.17 N measured
    for value, truth in ((p["M"], 95.1), (p["Fv"], 203.5), (fitted["coulomb_friction@x"]["Fc"], 20.39),
                         (fitted["offset@x"]["c"], -3.16)):
        assert value == pytest.approx(truth, rel=0.02)
    assert not [m for m in rep.missing if m.split("@")[0] in ("cable_spring", "cable_inertia", "rotor_inertia",
                                                               "torque_ripple", "gear_harmonic")]


def test_asymmetric_friction_is_selected_and_its_levels_come_back(experiments):
    trial = datasets.emps(experiments["asymmetric", 0])
    rep = diagnose([trial], "emps", kinematics="measured", add=["asymmetric_friction@x"])
    assert rep.missing == ["asymmetric_friction@x"]
    p, (e,) = rep.after["parameters"], rep.after["effects"]
    # Fc+ 20.01, Fc- 20.52 N, Fv+ 167.9, Fv- 241.7 N s/m measured
    assert e["Fc_pos"] == pytest.approx(20.14, rel=0.02) and e["Fc_neg"] == pytest.approx(20.63, rel=0.02)
    assert p["Fv"] + e["dFv"] == pytest.approx(166.7, rel=0.02) and p["Fv"] - e["dFv"] == pytest.approx(240.4, rel=0.02)


def test_import_then_diagnose_with_validation_on_the_other_experiment(experiments, tmp_path, capsys):
    out = tmp_path / "emps.csv"
    assert main(["import", "emps", str(experiments["asymmetric", 0]), "--out", str(out)]) == 0
    assert main(["import", "emps", str(experiments["asymmetric", 1]), "--out", str(tmp_path / "other.csv")]) == 0
    assert "wrote" in capsys.readouterr().out
    trial, = read_trials(out)
    np.testing.assert_allclose(trial.u, datasets.emps(experiments["asymmetric", 0]).u)
    report = tmp_path / "r.json"
    assert main(["diagnose", str(out), "--system", "emps", "--kinematics", "measured",
                 "--validate", str(tmp_path / "other.csv"), "--json", str(report)]) == 0
    text = capsys.readouterr().out
    assert re.search(r"validation on \d+ samples of other data", text) and "with asymmetric_friction@x" in text
    v = json.loads(report.read_text())["validation"]
    before, after = v["residual"]["x"]["RMS"], v["residual_after"]["x"]["RMS"]
    assert after <= 0.2 * before  # on the experiment not fitted


def test_validation_data_must_fit_the_machine(experiments, tally):
    trial = datasets.emps(experiments["symmetric", 0])
    other = trial.__class__(t=trial.t[::2], ref=trial.ref[::2], pos=trial.pos[::2], u=trial.u[::2], axes=trial.axes)
    with pytest.raises(ValueError, match="validation data are sampled at 500 Hz"):
        diagnose([trial], "emps", validate=[other])
    tally("bad_input")


def test_residual_on_the_fitted_data_is_the_diagnosis_residual(experiments):
    """``PhysicalModel.residual`` (used for --validate) computes what the diagnosis reports."""
    trial = datasets.emps(experiments["symmetric", 0])
    rep = diagnose([trial], "emps", kinematics="measured", validate=[trial])
    assert rep.validation["residual"]["x"]["RMS"] == pytest.approx(rep.residual["x"]["RMS"], rel=1e-9)
