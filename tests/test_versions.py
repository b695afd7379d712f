"""Machine versions: -v0 stays the first release's plant, -v1 the recalibrated one; names resolve
to the newest; the CSV names the version."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import lcgym  # noqa: F401  (registers the envs)
from lcgym import systems
from lcgym.leaderboard.runner import BenchConfig
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.plant import FlexArmPlant, true_arm_v1, true_drive_v1
from lcgym.systems.ix.plant import IX_GAINS, V1_GAINS, V1_SIZES, HiddenEffectSizes, IXPlant, default_hidden_effects


def test_names_resolve_to_the_newest_version():
    assert systems.resolve("ix").name == "ix-v1" and systems.resolve("ix-v0").name == "ix-v0"
    assert systems.newest_benchmarks() == ("ix-v1", "flexarm-v1", "two_link-v0", "emps_sim-v0")
    assert BenchConfig(systems=("ix", "flexarm-v0", "ix-v1")).systems == ("ix-v1", "flexarm-v0")
    assert systems.get("ix-v0") is systems.get("ix")  # one machine (its model), versions of its plant
    for bad in ("ix-v7", "crane", "ix-"):
        with pytest.raises(ValueError, match="unknown system"):
            systems.resolve(bad)


def test_the_version_lists_agree():
    """``systems.VERSIONS`` (read without importing the machines) names exactly each built-in machine's
    plant versions, and ``systems.ENVS`` its Gymnasium ids (and those only), for every machine
    ``BUILT_IN`` registers."""
    ids = {"lcgym/Machine-v0"}
    for name, entry in systems.BUILT_IN.items():
        machine = systems.get(name)
        assert systems.VERSIONS[name] == machine.bench.versions
        own = {f"lcgym/{entry.env}-{v}" for v in machine.bench.versions}
        assert set(machine.bench.envs) == own and machine.env_id == f"lcgym/{entry.env}-{machine.bench.versions[-1]}"
        ids |= own
    assert ids == set(systems.ENVS)


def test_v0_is_the_first_release_and_v1_the_calibrated_plant():
    v0, v1 = IXPlant.of_version("v0"), IXPlant.of_version("v1")
    assert v0.effects == default_hidden_effects() == HiddenEffectSizes().effects() and v0.gains == IX_GAINS
    assert v1.effects == V1_SIZES.effects() and v1.gains == V1_GAINS
    assert [type(e) for e in v1.effects] == [type(e) for e in v0.effects]  # the same forms, other sizes
    assert not FlexArmPlant.of_version("v0").settled_start and FlexArmPlant.of_version("v1").settled_start
    assert FlexArmPlant.of_version("v0") == FlexArmPlant()
    arm_v0, arm_v1 = FlexArmPlant.of_version("v0"), FlexArmPlant.of_version("v1")
    assert arm_v1.true_arm == true_arm_v1() and arm_v1.true_drive == true_drive_v1()
    nominal = arm.DriveParameters()
    np.testing.assert_allclose(np.divide(arm_v1.true_drive.KJ, nominal.KJ), [0.97] * 3 + [0.85] * 3)
    np.testing.assert_allclose(np.divide(arm_v0.true_drive.KJ, nominal.KJ), [0.85] * 6)
    assert arm_v1.true_drive.DJ == arm_v0.true_drive.DJ and arm_v1.true_drive.Jm == arm_v0.true_drive.Jm
    for name in ("Fmc", "Flc"):  # Coulomb friction: v0 30 % above nominal, v1 15 % below
        np.testing.assert_allclose(np.divide(getattr(arm_v0.true_drive, name), getattr(nominal, name)), [1.3] * 6)
        np.testing.assert_allclose(np.divide(getattr(arm_v1.true_drive, name), getattr(nominal, name)), [0.85] * 6)
    payload = np.subtract(arm_v1.true_arm.pi, arm.ArmParameters().pi)[-10:]  # link 6's parameters: m, m c, I (origin)
    np.testing.assert_allclose(payload[:4], [12.0, 0.0, 0.0, 12.0 * 0.20], atol=1e-12)  # 12 kg, centre 20 cm out
    assert IXPlant.of_version("v1", preroll=0.5).preroll == 0.5
    with pytest.raises(ValueError, match="unknown IX version 'v9'"):
        IXPlant.of_version("v9")
    assert systems.resolve("ix-v0").bench().plant.effects == v0.effects
    assert systems.resolve("flexarm").bench().plant.settled_start


@pytest.mark.parametrize("env_id, version", [("lcgym/IX-v0", "v0"), ("lcgym/IX-v1", "v1"),
                                             ("lcgym/FlexArm-v0", "v0"), ("lcgym/FlexArm-v1", "v1")])
def test_registered_ids_carry_their_version(env_id, version):
    kwargs = {"n_references": 1, "duration": 2.0} if "IX" in env_id else {"n_references": 1}
    env = gym.make(env_id, **kwargs).unwrapped
    plant = env.task.plant if "IX" in env_id else env.plant
    expected = (IXPlant if "IX" in env_id else FlexArmPlant).of_version(version)
    if "IX" in env_id:
        assert plant.effects == expected.effects and plant.gains == expected.gains
    else:
        assert dataclasses.asdict(plant) == dataclasses.asdict(expected)
    if "IX" in env_id:
        venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
        assert venv.task.plant.gains == expected.gains
        venv.close()
    env.close()


@pytest.mark.parametrize("env_id, kwargs", [("lcgym/IX-v1", {"n_references": 1, "duration": 2.0}),
                                            ("lcgym/FlexArm-v1", {"n_references": 1}),
                                            ("lcgym/TwoLink-v0", {"n_references": 1, "duration": 2.0})])
def test_every_machine_resets_with_its_reference_and_renders_its_episode(env_id, kwargs):
    """The same habits on every machine: the reset info names the reference, and
    ``render_mode="rgb_array"`` draws the episode so far; rendering leaves the episode unchanged."""
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    twin = gym.make(env_id, **kwargs)
    _, info = env.reset(seed=0)
    twin.reset(seed=0)
    assert isinstance(info["reference"], str) and info["reference"]
    for _ in range(20):
        obs, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        same, *_ = twin.step(np.zeros(twin.action_space.shape, dtype=np.float32))
    image = env.render()
    assert image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.uint8 and image.std() > 0
    obs, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    same, *_ = twin.step(np.zeros(twin.action_space.shape, dtype=np.float32))
    np.testing.assert_array_equal(obs, same)
    env.close()
    twin.close()


def test_every_benchmark_machine_makes_a_bench_of_the_contract():
    """``System.make_bench`` gives a ``Bench`` (the abstract base class: a bench lacking one of its
    methods cannot be made) of the version asked for, and refuses a version the machine lacks."""
    from lcgym.systems.bench import Bench

    for name in systems.newest_benchmarks():
        machine = systems.resolve(name)
        bench = machine.bench()
        assert isinstance(bench, Bench) and bench.name == name and bench.version == machine.version
        assert bench.system is machine.system and tuple(bench.axes) == tuple(bench.plant.axes)
        with pytest.raises(ValueError, match="plant versions"):
            machine.system.make_bench("v9")

    class NoTables(Bench):
        versions = ("v0",)

        def references(self, set_name, seed, n, duration):
            return []

        def run(self, references, feedforward=None, offsets=None):
            return []

        def trace(self, trial):
            return None

    with pytest.raises(TypeError, match="tables"):
        NoTables()
