"""``diagnose`` on the FlexArm: the hidden payload (on the joints it loads: 2, 3 and the wrist 5) and
the Coulomb friction that the engineer's model (CAD inertia, fitted motor inertia and viscous
friction) lacks are found; nothing else is."""

import numpy as np
import pytest

from lcgym.cli import main
from lcgym.data import write_trials
from lcgym.diagnose import diagnose
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.effects import Payload
from lcgym.systems.flexarm.model import ArmModel
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set


def _trials(plant):
    return [plant.run(r) for r in arm_reference_set("train", 0, 4)]  # 4 lines, 22 s: the fewest for 4 s blocks


@pytest.fixture(scope="module")
def with_payload():
    return _trials(FlexArmPlant())


def _selected(report) -> set[str]:
    return {c.key for c in report.candidates if c.selected}


def test_finds_the_payload_and_the_coulomb_friction(with_payload):
    report = diagnose(with_payload, system="flexarm", add=["payload@j2", "payload@j3"])
    # the payload loads the wrist too: once the frictions are in, payload@j5 removes 99 % of what j5 has left
    assert _selected(report) == {"payload@j2", "payload@j3", "coulomb_friction@j2", "coulomb_friction@j3",
                                 "coulomb_friction@j5", "payload@j5"}
    assert report.candidates[0].effect == "payload"  # the largest effect first
    assert report.model_effects[0] == "rigid_body (inertial parameters as given)"
    for joint in ("j2", "j3"):  # the payload alone removes most of the residual of the joints that carry it
        assert report.after["residual"][joint]["RMS"] < 0.5 * report.residual[joint]["RMS"]
    assert set(report.residual) == set(arm.AXES)  # standing joints are reported, not searched
    assert not any(c.axis in ("j1", "j4", "j6") for c in report.candidates)


def test_no_payload_is_claimed_without_one():
    report = diagnose(_trials(FlexArmPlant(true_arm=arm.ArmParameters())), system="flexarm")
    assert _selected(report) == {"coulomb_friction@j2", "coulomb_friction@j3", "coulomb_friction@j5"}


def test_diagnosis_model_holds_the_cad_inertia(with_payload):
    model = FLEXARM.diagnosis_model(1000.0).fit(with_payload)
    assert model.params_.pi == ArmModel(FLEXARM).params.pi and model.params_.c == (0.0,) * 6
    assert model.parts() == ("rigid_body (inertial parameters as given)", "motor_inertia", "viscous_friction")
    assert ArmModel(FLEXARM).parts()[-1] == "coulomb_friction"


def test_cli_on_an_arm_file(tmp_path, capsys, with_payload):
    data = write_trials(tmp_path / "arm.parquet", with_payload)
    assert main(["diagnose", str(data), "--system", "flexarm", "--add", "payload@j2", "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "payload@j2" in out and "N m" in out and (tmp_path / "r.json").exists()
    for bad, message in (("cable_drape@j2", "not an effect diagnose can add on flexarm"),
                         ("payload@roll", "flexarm has no axis 'roll'"),
                         ("coulomb_friction@roll", "flexarm has no axis 'roll'"),
                         ("coulomb_friction@j7", "flexarm has no axis 'j7'")):
        assert main(["diagnose", str(data), "--system", "flexarm", "--add", bad]) == 1
        assert message in capsys.readouterr().err
    assert main(["effects", "--system", "flexarm"]) == 0
    listed = capsys.readouterr().out.split("a machine file's [[hidden]]")[0]  # diagnose's list, not a plant's
    assert "payload" in listed and "cable_drape" not in listed


@pytest.mark.bad_input
def test_effects_stay_on_their_system():
    from lcgym.physics import effects as fx
    from lcgym.systems.ix import IX
    from lcgym.systems.ix.plant import IXPlant

    with pytest.raises(ValueError, match="unknown effect 'payload' on ix"):
        IX.effect("payload@roll")
    with pytest.raises(ValueError, match="flexarm has no axis 'roll'"):
        FLEXARM.effect(Payload("roll"))
    with pytest.raises(ValueError, match="not an effect of the IX"):
        IXPlant(effects=(fx.CoulombFriction("j2", Fc=0.1),))
    with pytest.raises(ValueError, match="not bound to a machine"):
        fx.CoulombFriction("j5").torque(np.zeros((2, 6)), np.zeros((2, 6)), np.zeros((2, 6)))
    assert FLEXARM.effect("coulomb_friction@j5").index == 4 and IX.effect("coulomb_friction@roll").index == 1
    cols = FLEXARM.effect(Payload("j3", m=1.0)).columns(*(np.zeros((2, 6)) for _ in range(3)))
    assert cols.shape == (2, 10)
