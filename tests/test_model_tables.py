"""A machine file's ``[[model]]`` tables (``systems.machine``, ``System.model_effects``): effects the
physical model knows, declared without values, their parameters found by its fit
(``physics.shapes``); the user's loop closed in the benchmark (issue 48, item 4).

The machine: lcgym's two-link arm (its URDF copied here) with a hidden Coulomb friction of 2 N m on
the elbow, once without and once with that effect under ``[[model]]``. Its physical model is fitted
on feedback-only training runs, as the benchmark's ``physical`` method fits it.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from lcgym import systems
from lcgym.systems.examples import two_link_urdf
from lcgym.systems.machine import MachineFileError, load_machine

FC, EPS = 2.0, 0.02  # the hidden elbow friction [N m], its smoothing [rad/s]

ARM = f"""\
urdf = "arm.urdf"
joints = ["shoulder", "elbow"]
name = "arm"

[[hidden]]
effect = "coulomb_friction"
axis = "elbow"
Fc = {FC}
eps = {EPS}
"""

MODEL = """
[[model]]
effect = "coulomb_friction"
axis = "elbow"
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """arm.toml (the hidden friction only) and arm_model.toml (the same plant, the friction in its
    model too), with the URDF."""
    path = tmp_path_factory.mktemp("arm")
    shutil.copy(two_link_urdf(), path / "arm.urdf")
    (path / "arm.toml").write_text(ARM)
    (path / "arm_model.toml").write_text(ARM + MODEL)
    return path


@pytest.fixture(scope="module")
def runs(folder):
    """Feedback-only runs of the plant (the same for both files): two training references and two
    validation references of about 20 s (``lcgym bench --quick``'s sets, seed 0)."""
    bench = systems.resolve(str(folder / "arm.toml")).bench()
    train = bench.run(bench.references("train", 0, 2, 20.0))
    return bench, train, bench.references("validation", 0, 2, 20.0)


def _tracking_rms(bench, model, references) -> np.ndarray:
    """Tracking-error RMS [deg] per axis of the plant with ``model``'s feedforward on ``references``."""
    runs = bench.run(references, [model.predict(r) for r in references])
    e = np.concatenate([r.error for r in runs])
    return np.degrees(np.sqrt(np.mean(e**2, axis=0)))


def test_model_tables_put_their_effects_in_the_machines_models(folder):
    plain, with_model = (systems.get(str(folder / f)) for f in ("arm.toml", "arm_model.toml"))
    assert plain.model_effects == () and with_model.model_effects == ("coulomb_friction@elbow",)
    for model in (with_model.physical_model(fs=1000.0), with_model.diagnosis_model(1000.0)):
        assert [e.key for e in model.effects] == ["coulomb_friction@elbow"]
        assert model.search_shapes == ("coulomb_friction@elbow",)
    assert plain.physical_model(fs=1000.0).effects == ()
    # the plant is the file's [[hidden]] alone: [[model]] changes the model, not the machine
    assert repr(plain.make_bench().plant) == repr(with_model.make_bench().plant)


@pytest.mark.bad_input
@pytest.mark.parametrize("table, key", [
    ('[[model]]\neffect = "coulomb"\naxis = "elbow"\n', "model[0]: coulomb@elbow: unknown effect 'coulomb'"),
    ('[[model]]\neffect = "coulomb_friction"\naxis = "wrist"\n', "arm has no axis 'wrist'"),
    ('[[model]]\neffect = "coulomb_friction"\naxis = "elbow"\nFc = 2.0\n',
     "model[0] (coulomb_friction@elbow): Fc = ...: a [[model]] table takes no parameter values"),
    ('[[model]]\neffect = "coulomb_friction"\naxis = "elbow"\neps = 0.02\n', "the model's fit finds them"),
    (MODEL + MODEL, "model[1]: coulomb_friction@elbow is listed twice (model[0] and model[1])"),
    ('[[model]]\neffect = "stiction"\naxis = "elbow"\n', "model[0]: stiction@elbow: stiction exists in plants only"),
    ('[[model]]\neffect = "tabulated_force"\naxis = "elbow"\n', "no regressor to fit it"),
    ('[[model]]\neffect = "viscous_friction"\naxis = "elbow"\n', "has viscous_friction on every axis already"),
    ('[[model]]\neffect = "coulomb_friction"\n', 'model[0]: give effect = "<name>" and axis = "<axis>"'),
    ('model = "coulomb_friction@elbow"\n', "model: must be a list of tables, [[model]]"),
])
def test_a_bad_model_table_says_what_and_where(folder, tmp_path, table, key):
    shutil.copy(folder / "arm.urdf", tmp_path / "arm.urdf")
    path = tmp_path / "bad.toml"
    text = ARM + "\n" + table
    if table.startswith("model ="):  # a top-level key goes before the tables
        text = table + ARM
    path.write_text(text)
    with pytest.raises(MachineFileError) as info:
        load_machine(path)
    message = str(info.value)
    assert str(path) in message and key in message and "\n" not in message, message


def test_the_friction_in_the_model_cuts_the_physical_feedforwards_error_3x(folder, runs):
    """The acceptance of item 4: the physical model fitted on the feedback-only training runs, once
    without and once with the friction under [[model]]: the elbow's tracking-error RMS on the
    validation references falls 3x or more (docs/own-machine.md gives the figures), the shoulder's
    does not rise, and the fitted level is the hidden one. The fit leaves the model's arguments as
    given: what it found is in ``effects_`` and ``fit_info_``."""
    bench, train, validation = runs
    given = systems.get(str(folder / "arm_model.toml")).physical_model(fs=1000.0).effects
    before, after = (systems.get(str(folder / f)).physical_model(fs=1000.0).fit(train)
                     for f in ("arm.toml", "arm_model.toml"))
    assert after.effects == given and after.search_shapes == ("coulomb_friction@elbow",)
    rms_before, rms_after = _tracking_rms(bench, before, validation), _tracking_rms(bench, after, validation)
    assert rms_before[1] / rms_after[1] >= 3.0, (rms_before, rms_after)
    assert rms_after[0] <= 1.05 * rms_before[0], (rms_before, rms_after)
    (friction,) = after.effects_
    assert friction.key == "coulomb_friction@elbow" and abs(friction.Fc - FC) < 0.1 * FC, friction
    assert 0.25 * EPS < friction.eps < 4 * EPS, friction  # the shape, found on the diagnosis's grid and refined
    assert after.fit_info_["shapes"] == {"coulomb_friction@elbow": {"eps": friction.eps}}


def test_the_benchmarks_physical_row_falls_with_the_model_table(folder, tmp_path, monkeypatch):
    """``lcgym bench --quick --methods feedback,physical --systems arm.toml,arm_model.toml`` (the
    runner's API): feedback alone is the same on both (the same plant), the physical row's elbow
    error falls 3x or more."""
    from lcgym.leaderboard.runner import BenchConfig, run_benchmark
    from lcgym.leaderboard.store import read_results

    monkeypatch.chdir(folder)
    out = tmp_path / "r.csv"
    config = BenchConfig.quick(systems=("arm.toml", "arm_model.toml"), methods=("feedback", "physical"))
    assert run_benchmark(config, out, jobs=1, progress=False)["cells_failed"] == 0
    df = read_results(out)
    e = df[(df["reference_set"] == "validation") & (df["signal"] == "tracking_error")]
    rms = e.pivot_table(index=["axis", "method"], columns="system", values="RMS")
    assert np.isclose(rms.loc[("elbow", "feedback"), "arm.toml"], rms.loc[("elbow", "feedback"), "arm_model.toml"])
    assert rms.loc[("elbow", "physical"), "arm.toml"] / rms.loc[("elbow", "physical"), "arm_model.toml"] >= 3.0, rms


def test_diagnose_prints_the_model_tables_of_what_it_selects(folder, runs, tmp_path, capsys):
    """``lcgym diagnose LOG --system arm.toml`` ends with the [[model]] table of the friction it
    selects (in the JSON too); pasted into the file, the diagnosis starts from a model that has it
    and finds nothing more; ``--add`` of it is refused then; a machine of no machine file gets no
    tables."""
    import dataclasses

    from lcgym.cli import main
    from lcgym.data import write_trials
    from lcgym.diagnose import diagnose

    _, train, _ = runs
    report = diagnose(train, str(folder / "arm.toml"))
    assert report.missing == ["coulomb_friction@elbow"] and report.model_tables() == MODEL.strip()
    text = report.text()
    head = "[[model]] tables of the effects selected: paste them into " + str(folder / "arm.toml")
    assert head in text and text.endswith(MODEL.strip())
    assert report.to_dict()["model_tables"] == MODEL.strip()
    assert dataclasses.replace(report, machine_file=None).model_tables() == ""  # a URDF, a machine of Python

    log, pasted = tmp_path / "log.csv", tmp_path / "arm.toml"
    write_trials(log, train)
    shutil.copy(folder / "arm.urdf", tmp_path / "arm.urdf")
    pasted.write_text(ARM + "\n" + report.model_tables() + "\n")
    assert systems.get(str(pasted)).model_effects == ("coulomb_friction@elbow",)
    assert main(["diagnose", str(log), "--system", str(pasted)]) == 0
    text = capsys.readouterr().out
    assert "model: rigid_body, viscous_friction, coulomb_friction@elbow" in text
    assert "no missing effect found" in text and "[[model]] tables" not in text
    assert main(["diagnose", str(log), "--system", str(pasted), "--add", "coulomb_friction@elbow"]) == 1
    assert "cannot add coulomb_friction@elbow: the model already has it" in capsys.readouterr().err


def test_a_periodic_effect_in_the_model_finds_its_period(folder, tmp_path):
    """A gear harmonic under [[model]]: its period comes from the residual's spectrum, as in the
    diagnosis (0.2002 rad for the hidden 0.2), and the elbow's tracking error falls 3x or more."""
    shutil.copy(folder / "arm.urdf", tmp_path / "arm.urdf")
    gear = ('urdf = "arm.urdf"\njoints = ["shoulder", "elbow"]\n\n[[hidden]]\neffect = "gear_harmonic"\n'
            'axis = "elbow"\ns1 = 1.0\nc1 = 0.5\nperiod = 0.2\nv_ref = 0.5\n')
    (tmp_path / "gear.toml").write_text(gear)
    (tmp_path / "gear_model.toml").write_text(gear + '\n[[model]]\neffect = "gear_harmonic"\naxis = "elbow"\n')
    bench = systems.resolve(str(tmp_path / "gear.toml")).bench()
    train = bench.run(bench.references("train", 0, 2, 20.0))
    validation = bench.references("validation", 0, 2, 20.0)
    before, after = (systems.get(str(tmp_path / f)).physical_model(fs=1000.0).fit(train)
                     for f in ("gear.toml", "gear_model.toml"))
    (harmonic,) = after.effects_
    assert abs(harmonic.period - 0.2) < 0.002 and abs(harmonic.s1 - 1.0) < 0.15, harmonic
    assert _tracking_rms(bench, before, validation)[1] >= 3 * _tracking_rms(bench, after, validation)[1]


def test_the_pgnn_holds_the_models_effects_in_its_physical_part(folder, runs, tmp_path):
    """The PGNN's physical part f^M is the rigid body (trained) plus the model's effects as the
    least-squares fit found them, held fixed; saved and loaded with it."""
    from lcgym.methods.pgnn import PGNN, PGNNConfig

    _, train, validation = runs
    pgnn = PGNN(PGNNConfig(max_epochs=1, threads=1), fs=1000.0, system=str(folder / "arm_model.toml")).fit(train)
    assert [e.key for e in pgnn.fixed_.fitted_effects] == ["coulomb_friction@elbow"]
    ref = validation[0]
    pgnn.use_network = False
    physical_part = pgnn.predict(ref)
    fixed, pgnn.fixed_ = pgnn.fixed_, None
    rigid = pgnn.predict(ref)  # the trained rigid body alone
    pgnn.fixed_, pgnn.use_network = fixed, True
    friction = fixed.effects_torque(*pgnn_kinematics(pgnn, ref))
    assert np.abs(friction[:, 1]).max() > 0.5 * FC and np.all(friction[:, 0] == 0.0)
    assert np.allclose(physical_part, rigid + friction)
    loaded = PGNN.load(pgnn.save(tmp_path / "pgnn.pt"), system=systems.get(str(folder / "arm_model.toml")))
    assert np.allclose(loaded.predict(ref), pgnn.predict(ref), atol=1e-5)


def pgnn_kinematics(pgnn, reference):
    """The reference kinematics the PGNN evaluates (its config's advance)."""
    from lcgym.physics.kinematics import reference_kinematics, reference_positions

    return reference_kinematics(reference_positions(reference), pgnn.fs, pgnn.config_.advance)


def test_effects_says_model_tables_take_the_same_names(folder, capsys):
    from lcgym.cli import main

    assert main(["effects", "--system", str(folder / "arm_model.toml")]) == 0
    text = capsys.readouterr().out
    assert "a machine file's [[model]] tables take the same names, without values" in text
    assert "the model already has: rigid_body, viscous_friction; and from arm's [[model]] tables: " \
        "coulomb_friction@elbow" in text


RAIL_ARM = Path(__file__).parent / "data" / "rail_arm" / "rail_arm.toml"


def test_acceptance_the_rail_arms_physical_and_ilc_rows_fall_with_the_model_table(tmp_path):
    """Issue 48's acceptance of item 4 on ``tests/data/rail_arm`` (a rail, a shoulder and an elbow
    with a hidden 1 N m Coulomb friction): benchmarked once as it is and once with the friction under
    [[model]] (seed 0, 2 + 2 references of 6 s, physical and ILC), the physical model's validation
    tracking error on the elbow falls 3x or more (3.7x measured: RMS 0.398 -> 0.107 deg), the ILC row
    stays at or below its base (the physical model) on every axis of both files, and the other axes
    do not rise. (ILC's own row does not always fall with its base here: on the friction-modelled
    file it learns the elbow down 4.5x on the second reference, but every trial, and the mix of each
    axis's best, raises the rail's 8.0 um error to 9.2-19 um, so it keeps the base there.)"""
    from lcgym.leaderboard.runner import BenchConfig, run_benchmark
    from lcgym.leaderboard.store import read_results

    shutil.copy(RAIL_ARM.parent / "rail_arm.urdf", tmp_path)
    plain, with_model = tmp_path / "rail_arm.toml", tmp_path / "rail_arm_model.toml"
    plain.write_text(RAIL_ARM.read_text())
    with_model.write_text(RAIL_ARM.read_text() + MODEL)
    out = tmp_path / "r.csv"
    config = BenchConfig(systems=(str(plain), str(with_model)), methods=("physical", "ilc"), seeds=(0,),
                         n_train=2, n_validation=2, duration=6.0)
    assert run_benchmark(config, out, jobs=1, progress=False)["cells_failed"] == 0
    df = read_results(out)
    e = df[(df["reference_set"] == "validation") & (df["signal"] == "tracking_error") & (df["period"] == "all")]
    rms = e.pivot_table(index=["axis", "method"], columns="system", values="RMS")
    before, after = rms[str(plain)], rms[str(with_model)]
    assert before[("elbow", "physical")] >= 3.0 * after[("elbow", "physical")], rms
    for axis in ("rail", "shoulder", "elbow"):  # ILC builds on each file's physical model, never above it
        assert after[(axis, "ilc")] <= after[(axis, "physical")] and before[(axis, "ilc")] <= before[(axis, "physical")]
    for axis in ("rail", "shoulder"):
        assert after[(axis, "physical")] <= 1.05 * before[(axis, "physical")], rms


RAIL = """\
urdf = "rail_arm.urdf"
name = "rail"

[feedback]
bandwidth = 8.0

[sensors]
encoder_resolution = [1e-6, 1e-4, 1e-4]

[[hidden]]
effect = "coulomb_friction"
axis = "rail"
Fc = 20.0
eps = 0.005

[[hidden]]
effect = "cable_spring"
axis = "elbow"
k = 25.0
q0 = 0.3
width = 0.15
side = 1.0
"""


def test_a_model_table_is_fitted_as_the_diagnosis_fitted_it(tmp_path):
    """Issue 60, item 5: one fit of one effect. A rail carrying a two-link arm with a hidden rail
    friction (20 N) and a one-sided elbow spring (k 25 N m/rad from 0.3 rad, 0.15 rad wide), logged
    with feedback alone: the diagnosis names both; its [[model]] tables pasted into the file, the
    physical model's fit on the same log finds the values the diagnosis reported (and the truth).
    The control: the same fit on the reference's kinematics, which take the feedback's lag (5 deg
    RMS on the elbow) for the motion, misplaces the spring (k 16 for 25)."""
    import dataclasses

    from lcgym.diagnose import diagnose

    shutil.copy(Path(__file__).parent / "data" / "rail_arm" / "rail_arm.urdf", tmp_path / "rail_arm.urdf")
    (tmp_path / "rail.toml").write_text(RAIL)
    bench = systems.resolve(str(tmp_path / "rail.toml")).bench()
    log = bench.run(bench.references("validation", 0, 2, 20.0))
    report = diagnose(log, str(tmp_path / "rail.toml"))
    assert report.missing == ["coulomb_friction@rail", "cable_spring@elbow"], report.missing
    (tmp_path / "rail_model.toml").write_text(RAIL + "\n" + report.model_tables() + "\n")
    machine = systems.get(str(tmp_path / "rail_model.toml"))
    fitted = {e.key: e for e in machine.physical_model(fs=1000.0).fit(log).effects_}
    diagnosed = {e.key: e for e in report.suggested_model.effects_}
    # the same estimator (``physics.shapes``) on the same log: the diagnosis leaves the rests out (a real
    # drive's friction holds anything there), so the friction's smoothing, set by the speeds near zero,
    # is found from fewer of them (9.1 mm/s there, 6.2 here, for the hidden 5)
    for key, tolerance in (("coulomb_friction@rail", {"Fc": 0.02, "eps": 1.0}),
                           ("cable_spring@elbow", {"k": 0.02, "q0": 0.01, "width": 0.05})):
        for name, rel in tolerance.items():
            mine, theirs = getattr(fitted[key], name), getattr(diagnosed[key], name)
            assert abs(mine - theirs) <= rel * abs(theirs), (key, name, mine, theirs)
    spring = fitted["cable_spring@elbow"]
    assert abs(spring.k - 25.0) < 1.0 and abs(spring.q0 - 0.3) < 0.005 and abs(spring.width - 0.15) < 0.01, spring
    on_reference = dataclasses.replace(machine.physical_model(fs=1000.0), positions="reference").fit(log)
    assert on_reference.effects_[1].k < 0.8 * 25.0, on_reference.effects_[1]  # the lag taken for the motion
