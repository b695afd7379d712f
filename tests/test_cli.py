"""The lcgym command: simulate writes a measurement file, a plot and the metric table on every
built-in machine (bad options: test_bad_cli.py)."""

import contextlib
import io
import json
from pathlib import Path

import pytest

from lcgym.cli import main
from lcgym.data import read_trials
from lcgym.systems import two_link
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


# ---------------------------------------------------------------------------------------------
# A newcomer's own machine: simulate a machine file, diagnose and replay its log, list its effects
# ---------------------------------------------------------------------------------------------

TWO_LINK_FILE = Path(two_link.__file__).with_name("machine.toml")  # the shipped two-link arm's machine file


@pytest.fixture(scope="module")
def machine_log(tmp_path_factory):
    """A short log of ``lcgym simulate`` on a machine file (one 5 s validation reference, feedback only)
    and the header it printed."""
    folder = tmp_path_factory.mktemp("machine_log")
    run = folder / "run.csv"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["simulate", "--system", str(TWO_LINK_FILE), "--controller", "feedback", "--n-train", "1",
                     "--n-validation", "1", "--duration", "5", "--out", str(run)]) == 0
    return run, printed.getvalue()


def test_simulate_names_the_norms_it_prints(machine_log):
    _, printed = machine_log
    assert "norms MA, RMS, Inf (paper 000, Kon et al. 2025, eqs. (34)-(36)" in printed


def test_replay_runs_on_a_simulated_log_of_a_machine_file(machine_log, tmp_path, capsys):
    run, _ = machine_log
    report = tmp_path / "report.json"
    assert main(["diagnose", str(run), "--system", str(TWO_LINK_FILE), "--replay", "--json", str(report)]) == 0
    assert "replay on the plant, tracking-error RMS [deg] with the model's feedforward, before and with " \
        "coulomb_friction@elbow" in capsys.readouterr().out  # --replay alone: says what "after" holds
    replay = json.loads(report.read_text())["replay"]
    assert set(replay["before"]) == set(replay["after"]) == {"shoulder", "elbow"}
    assert replay["after"]["elbow"] < replay["before"]["elbow"]  # the friction found: the elbow tracks closer
    # the plant is the machine file's: a changed one, or a URDF alone, is refused with why
    (tmp_path / "two_link.urdf").write_text(TWO_LINK_FILE.with_name("two_link.urdf").read_text())
    changed = tmp_path / "changed.toml"
    changed.write_text(TWO_LINK_FILE.read_text().replace("Fc = 3.0", "Fc = 2.0"))
    for system, message in ((changed, "its hidden effects, feedback, sensors or limits differ"),
                            (tmp_path / "two_link.urdf", f"--system {TWO_LINK_FILE}")):
        assert main(["diagnose", str(run), "--system", str(system), "--replay"]) == 1
        assert message in capsys.readouterr().err


def _section(text: str, head: str) -> list[str]:
    """The names listed under the line starting with ``head`` (indented lines, up to the next other line)."""
    lines = text.splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith(head)) + 1
    names = []
    for line in lines[start:]:
        if not line.startswith("  "):
            break
        names.append(line.split()[0])
    return names


def test_effects_lists_what_diagnose_ranks_and_what_a_machine_file_accepts(capsys):
    from lcgym import systems
    from lcgym.diagnose.candidates import candidates_for
    from lcgym.systems.machine import hidden_effects

    assert main(["effects", "--system", str(TWO_LINK_FILE)]) == 0
    text = capsys.readouterr().out
    machine = systems.get(str(TWO_LINK_FILE))
    assert _section(text, "effects diagnose ranks") == [c.name for c in candidates_for(machine)]
    hidden = _section(text, "effects a machine file's [[hidden]] accepts on two_link")
    assert hidden == list(hidden_effects(machine)) and "tabulated_force" in hidden
    only_plant = set(_section(text, "only in this list"))
    only_model = set(_section(text, "only in the first list"))
    assert only_plant == set(hidden) - {c.name for c in candidates_for(machine)}
    assert only_model == {c.name for c in candidates_for(machine)} - set(hidden)


@pytest.mark.parametrize("command", ["diagnose", "effects"])
def test_system_help_lists_every_form_a_machine_takes(command, capsys):
    from lcgym import systems
    from lcgym.diagnose.figures import PLOT_FILES

    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for form in (*systems.BUILT_IN, *systems.EXAMPLES, *systems.URDF_EXAMPLES, ".urdf", ".toml", "module:attr"):
        assert form in text, form
    if command == "diagnose":  # --plots names every figure diagnose can write
        assert all(name in text for name in PLOT_FILES), text


@pytest.mark.bad_input
def test_a_log_of_another_machine_names_both_machines_axes_and_whose_it_is(machine_log, tmp_path, capsys):
    run, _ = machine_log
    assert main(["diagnose", str(run), "--system", "ix"]) == 1
    err = capsys.readouterr().err
    assert "the file's axes (shoulder, elbow) are not those of machine ix (propeller, roll)" in err
    assert f"give --system {TWO_LINK_FILE} or two_link" in err  # the sidecar's machine first, then the built-in
    assert "did you mean" not in err
    # a typo of one axis keeps the near-miss
    typo = tmp_path / "typo.csv"
    typo.write_text(run.read_text().replace("pos_elbow", "pos_elbw"))
    assert main(["diagnose", str(typo), "--system", "two_link"]) == 1
    assert "required column 'pos_elbow' missing; did you mean 'pos_elbw'" in capsys.readouterr().err


def test_replay_gives_each_axis_its_own_unit(tmp_path, capsys):
    """A machine with a prismatic rail: the replay's rail row in mm, the revolute joints' in deg."""
    machine = Path(__file__).parent / "data" / "rail_arm" / "rail_arm.toml"
    run = tmp_path / "run.csv"
    assert main(["simulate", "--system", str(machine), "--controller", "feedback", "--n-train", "1",
                 "--n-validation", "1", "--duration", "5", "--out", str(run)]) == 0
    capsys.readouterr()
    report = tmp_path / "report.json"
    assert main(["diagnose", str(run), "--system", str(machine), "--replay", "--json", str(report)]) == 0
    lines = capsys.readouterr().out.split("replay on the plant", 1)[1].splitlines()
    assert lines[0].startswith(", tracking-error RMS with")  # no one unit for all axes in the heading
    assert lines[2].split()[0] == "rail" and lines[2].endswith(" mm")
    assert lines[3].endswith(" deg") and lines[4].endswith(" deg")
    assert json.loads(report.read_text())["replay"]["unit"] == {"rail": "mm", "shoulder": "deg", "elbow": "deg"}
