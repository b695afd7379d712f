"""A machine of the user's own in the benchmark: the machine file (``systems.machine``), its bench
(``systems.urdf_bench``), its Gymnasium env (``lcgym/Machine-v0``), the built-in TwoLink-v0 made
the same way, and the nominal closed loop that ILC inverts (``URDFPlant.process_sensitivity``)
checked against a simulation.

The machines here are written by the tests (URDF and machine file), not shipped with lcgym.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import lcgym  # noqa: F401  (registers the envs)
from lcgym import systems
from lcgym.systems.machine import MachineFileError, load_machine
from lcgym.systems.urdf_plant import URDFPlant

YAW_PITCH_URDF = """<?xml version="1.0"?>
<!-- written by tests/test_machine.py: a turret turning about z (yaw) carrying a boom that pitches about y -->
<robot name="yaw_pitch">
  <link name="base"/>
  <link name="turret">
    <inertial><origin xyz="0 0 0.1"/><mass value="3.0"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.015"/></inertial>
  </link>
  <link name="boom">
    <inertial><origin xyz="0.25 0 0"/><mass value="2.0"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.045" iyz="0" izz="0.045"/></inertial>
  </link>
  <joint name="yaw" type="revolute">
    <parent link="base"/><child link="turret"/><origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" effort="60" velocity="2.0"/>
  </joint>
  <joint name="pitch" type="revolute">
    <parent link="turret"/><child link="boom"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1.2" upper="1.2" effort="40" velocity="2.0"/>
  </joint>
</robot>
"""

MACHINE_FILE = """\
urdf = "yaw_pitch.urdf"
fs = 1000.0

[feedback]
bandwidth = 8.0

[sensors]
encoder_resolution = 1e-4

[[hidden]]
effect = "coulomb_friction"
axis = "yaw"
Fc = 1.5
eps = 0.02

[[hidden]]
effect = "cable_spring"
axis = "pitch"
k = 20.0
q0 = 0.2
width = 0.2
"""


def write_machine(folder: Path, text: str = MACHINE_FILE) -> Path:
    """The test's URDF and machine file in ``folder``; returns the machine file."""
    (folder / "yaw_pitch.urdf").write_text(YAW_PITCH_URDF)
    path = folder / "yaw_pitch.toml"
    path.write_text(text)
    return path


@pytest.fixture()
def machine_file(tmp_path) -> Path:
    return write_machine(tmp_path)


def test_machine_file_makes_a_benchmark_machine(machine_file):
    m = systems.get(str(machine_file))
    assert m.name == "yaw_pitch" and m.axis_names == ("yaw", "pitch") and m.fs == 1000.0
    assert m.env_id == "lcgym/Machine-v0" and m.bench is not None
    assert systems.resolve(str(machine_file)).name == str(machine_file)
    assert systems.resolve(str(machine_file)).machine == str(machine_file)
    bench = systems.resolve(str(machine_file)).bench()
    assert [e.key for e in bench.plant.bound_effects] == ["coulomb_friction@yaw", "cable_spring@pitch"]
    assert np.allclose(bench.plant.encoder_resolution, 1e-4)
    assert np.allclose(bench.plant.u_max, [60.0, 40.0])  # the URDF's effort limits


def test_a_machine_is_resolved_once_and_again_when_its_file_changes(machine_file, monkeypatch):
    """``systems.resolve`` loads a machine file once (its URDF parsed once), gives each caller a
    bench of its own, and loads the file again once its content changed."""
    import pinocchio as pin

    parses = []
    parse = pin.buildModelFromUrdf
    monkeypatch.setattr(pin, "buildModelFromUrdf", lambda *a, **k: parses.append(a) or parse(*a, **k))
    first = systems.resolve(str(machine_file))
    loaded = len(parses)
    assert loaded >= 1 and systems.resolve(str(machine_file)) is first and len(parses) == loaded
    one, two = first.bench(), first.bench()
    assert one is not two and one.plant is not two.plant and len(parses) == loaded
    machine_file.write_text(machine_file.read_text().replace("Fc = 1.5", "Fc = 3.0"))
    edited = systems.resolve(str(machine_file))
    assert edited is not first and len(parses) > loaded
    assert edited.bench().plant.bound_effects[0].Fc == 3.0


def test_reference_sets_are_seeded_disjoint_and_within_limits(machine_file):
    bench = systems.resolve(str(machine_file)).bench()
    train = bench.references("train", 0, 2, 6.0)
    again = bench.references("train", 0, 2, 6.0)
    val = bench.references("validation", 0, 2, 6.0)
    assert [r.name for r in train] == ["train-0-0", "train-0-1"]
    assert all(np.array_equal(a.positions, b.positions) for a, b in zip(train, again, strict=True))
    assert not np.allclose(train[0].positions[: val[0].n_samples], val[0].positions[: train[0].n_samples])
    q = np.concatenate([r.positions for r in train + val])
    assert np.all(q[:, 0] > -2.5 * 0.8 - 1e-9) and np.all(q[:, 0] < 2.5 * 0.8 + 1e-9)  # 10 % margin of the range
    assert np.all(np.abs(q[:, 1]) < 1.2 * 0.8 + 1e-9)
    assert all(r.n_samples >= 6.0 * 1000 for r in train)


@pytest.mark.parametrize("text, key", [
    ("urdf = 'yaw_pitch.urdf'\nspeed = 3\n", "speed: unknown key"),
    ("fs = 1000.0\n", "urdf: give the URDF"),
    ("urdf = 'yaw_pitch.urdf'\n[feedback]\nbandwith = 5\n", "feedback.bandwith: unknown key"),
    ("urdf = 'yaw_pitch.urdf'\n[[hidden]]\neffect = 'coulomb'\naxis = 'yaw'\n", "unknown effect 'coulomb'"),
    ("urdf = 'yaw_pitch.urdf'\n[[hidden]]\neffect = 'coulomb_friction'\naxis = 'yaw'\nF = 1\n", "unknown parameter 'F'"),
    ("urdf = 'yaw_pitch.urdf'\n[[hidden]]\neffect = 'coulomb_friction'\naxis = 'roll'\nFc = 1\n", "no axis 'roll'"),
    ("urdf = 'yaw_pitch.urdf'\n[[hidden]]\neffect = 'stiction'\naxis = 'yaw'\n", "internal state"),
    ("urdf = 'yaw_pitch.urdf'\n[sensors]\nencoder_resolution = [1e-4, 1e-4, 1e-4]\n", "encoder_resolution"),
    ("urdf = 'missing.urdf'\n", "missing.urdf"),
    ("urdf = 'yaw_pitch.urdf\n", "not a readable TOML file"),
    # values no machine has: the table, the key and the rule
    (MACHINE_FILE.replace("Fc = 1.5", "Fc = -20.0"), "hidden[0] (coulomb_friction@yaw): Fc = -20: must be >= 0"),
    (MACHINE_FILE.replace("eps = 0.02", "eps = 0.0"), "hidden[0] (coulomb_friction@yaw): eps = 0: must be > 0"),
    (MACHINE_FILE.replace("k = 20.0", "k = -20.0"), "hidden[1] (cable_spring@pitch): k = -20: must be >= 0"),
    (MACHINE_FILE.replace("width = 0.2", "width = 0.0"), "hidden[1] (cable_spring@pitch): width = 0: must be > 0"),
    (MACHINE_FILE + "side = 0.5\n", "hidden[1] (cable_spring@pitch): side = 0.5: must be +1 or -1"),
    (MACHINE_FILE + "[[hidden]]\neffect = 'viscous_friction'\naxis = 'yaw'\nd = -1.0\n", "d = -1: must be >= 0"),
    (MACHINE_FILE.replace("bandwidth = 8.0", "kp = [-50.0, 20.0]"), "feedback.kp = (-50.0, 20.0): must be > 0"),
    (MACHINE_FILE.replace("bandwidth = 8.0", "kp = [50.0, 20.0]\nkd = [1.0, -1.0]"), "feedback.kd"),
    (MACHINE_FILE.replace("bandwidth = 8.0", "bandwidth = 0.0"), "feedback.bandwidth = 0.0: must be > 0"),
    (MACHINE_FILE + "[references]\nvelocity_fallback = [0.0, 0.1]\n", "references.velocity_fallback"),
])
def test_a_bad_machine_file_says_what_and_where(tmp_path, text, key):
    path = write_machine(tmp_path, text)
    with pytest.raises(MachineFileError) as info:
        load_machine(path)
    message = str(info.value)
    assert str(path) in message and key in message and "\n" not in message


@pytest.mark.parametrize("old, new, key", [
    ('<mass value="2.0"/>', '<mass value="-2.0"/>', "link boom (moved by joint pitch): mass -2 kg: a mass must be >= 0"),
    ('iyy="0.045"', 'iyy="-0.045"', "link boom (moved by joint pitch): its <inertia> has a negative principal moment"),
    ('ixx="0.002"', 'ixx="0.2"', "link boom (moved by joint pitch): its <inertia>'s principal moments"),
    ('lower="-1.2" upper="1.2"', 'lower="1.2" upper="-1.2"', "joint pitch: <limit lower=1.2 upper=-1.2>"),
    ('effort="40"', 'effort="-40"', "joint pitch: <limit effort=-40>: a limit [N m or N] must be >= 0"),
    # a link without <inertial>: the joint that moves it is named
    ('<inertial><origin xyz="0.25 0 0"/><mass value="2.0"/>\n      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.045" '
     'iyz="0" izz="0.045"/></inertial>', "", "joint pitch moves no mass"),
])
def test_a_urdf_a_machine_cannot_have_names_the_link_or_joint(tmp_path, old, new, key):
    path = write_machine(tmp_path)
    urdf = tmp_path / "yaw_pitch.urdf"
    assert old in urdf.read_text()
    urdf.write_text(urdf.read_text().replace(old, new))
    with pytest.raises(MachineFileError) as info:
        load_machine(path)
    assert key in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_hidden_effects_of_python_are_checked_as_a_files_are():
    from lcgym.physics.effects import CoulombFriction
    from lcgym.systems.machine import MachineSettings

    with pytest.raises(ValueError, match=r"hidden effect coulomb_friction@yaw: Fc = -1: must be >= 0"):
        MachineSettings(hidden=(CoulombFriction("yaw", Fc=-1.0),))
    assert CoulombFriction("yaw", Fc=0.0).impossible() == ""  # no friction is a machine too


def test_env_episode_is_the_plants_run(machine_file):
    """A zero action replays what the plant's own run gives, bit for bit; the checker passes."""
    bench = systems.resolve(str(machine_file)).bench()
    ref = bench.references("validation", 1, 1, 3.0)[0]
    env = gym.make("lcgym/Machine-v0", machine=str(machine_file), references=[ref], episode_steps=None)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs) and info["reference"] == ref.name and info["sample"] == 0
    done, rewards = False, []
    while not done:
        obs, reward, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
        rewards.append(reward)
        done = terminated or truncated
    assert truncated and not terminated and len(rewards) == ref.n_samples
    run = bench.plant.run(ref)
    assert np.array_equal(info["trial"].pos, run.pos) and np.array_equal(info["trial"].u, run.u)
    np.testing.assert_allclose(info["tracking_rms"], np.sqrt(np.mean(run.error**2, axis=0)))


def test_env_residual_on_the_physical_model_and_bad_actions(machine_file):
    import copy

    from lcgym.systems.machine_env import REWARD_SCALE, base_scales

    env = gym.make("lcgym/Machine-v0", machine=str(machine_file), references="validation", n_references=1,
                   duration=2.0, base_feedforward="physical")
    env.reset(seed=0)
    # the residual's scale by default: the peak of what the feedback supplies along the base's runs of
    # the env's references (``machine_env.base_scales``, as a learner takes it), far below 0.2 x the limits
    task = env.unwrapped.task
    scales = base_scales(copy.deepcopy(task.plant), task.positions, task.base_ff)
    np.testing.assert_allclose(env.unwrapped.action_scale, scales["residual_bound"])
    assert np.all(env.unwrapped.action_scale < 0.2 * np.array([60.0, 40.0]))
    # the reward's scale per axis: the base's own RMS error there (the base scores -1/2 per axis and sample)
    np.testing.assert_allclose(task.reward_scale, scales["axis_errors"])
    np.testing.assert_allclose(task.err_scale, 5.0 * scales["axis_errors"])
    assert not np.allclose(task.reward_scale, REWARD_SCALE["rad"])
    _, _, _, _, info = env.step(np.array([1.5, 0.0], dtype=np.float32))
    assert info["clipped_actions"] == 1 and info["ff"][0] != 0.0
    with pytest.raises(ValueError, match="NaN or inf"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))


def test_env_takes_a_learners_residual_bound_and_balances_its_axes(machine_file):
    """``residual_bound`` sets the action's scale per axis; ``axis_errors`` scales each axis's reward
    so that those errors count alike, at the geometric mean of the default scale (one axis: the
    default); ``methods.rl.env_scales`` reads both off the base's runs; bad values are refused."""
    from lcgym.methods.loop import machine_loop
    from lcgym.methods.rl import env_scales
    from lcgym.systems.machine_env import REWARD_SCALE

    kwargs = dict(machine=str(machine_file), references="validation", n_references=1, duration=2.0)
    env = gym.make("lcgym/Machine-v0", base_feedforward="physical", residual_bound=[6.0, 2.0],
                   axis_errors=[1e-3, 4e-3], **kwargs).unwrapped
    np.testing.assert_allclose(env.action_scale, [6.0, 2.0])
    scale = env.task.reward_scale
    np.testing.assert_allclose(scale, [0.5 * REWARD_SCALE["rad"], 2.0 * REWARD_SCALE["rad"]])  # 1e-3 / s = 4e-3 / s'
    plain = gym.make("lcgym/Machine-v0", base_feedforward="none", **kwargs).unwrapped  # no base: the fixed scale
    np.testing.assert_allclose(plain.task.reward_scale, REWARD_SCALE["rad"])
    for bad in ({"residual_bound": [1.0, -1.0]}, {"axis_errors": [0.0, 1.0]}, {"residual_bound": [1.0, 2.0, 3.0]}):
        with pytest.raises(ValueError, match="must be one value or 2 values > 0"):
            gym.make("lcgym/Machine-v0", base_feedforward="physical", **kwargs, **bad)
    with pytest.raises(ValueError, match="needs a base feedforward"):
        gym.make("lcgym/Machine-v0", residual_bound=1.0, **kwargs)
    machine = systems.resolve(str(machine_file))
    bench = machine.bench()
    refs = bench.references("train", 0, 1, 2.0)
    base = machine.system.physical_model(fs=1000.0).fit(bench.run(refs))
    scales = env_scales(bench.plant, refs, base, machine_loop(machine.system))
    run = bench.plant.run(refs[0], base.predict(refs[0]))
    np.testing.assert_allclose(scales["residual_bound"], np.abs(run.u - run.ff).max(axis=0))
    np.testing.assert_allclose(scales["axis_errors"], np.sqrt(np.mean(run.error**2, axis=0)))


def test_vector_env_steps_its_sub_envs_as_single_envs(machine_file):
    refs = systems.resolve(str(machine_file)).bench().references("train", 0, 2, 1.0)
    venv = gym.make_vec("lcgym/Machine-v0", num_envs=2, machine=str(machine_file), references=refs,
                        vectorization_mode="vector_entry_point")
    env = gym.make("lcgym/Machine-v0", machine=str(machine_file), references=refs)
    obs, _ = venv.reset(seed=3)
    chosen = [int(np.flatnonzero([np.array_equal(o, env.unwrapped.task.feats[r][0].tolist() + o[-2:].tolist())
                                  for r in range(2)])[0]) for o in obs]
    single, _ = env.reset(options={"reference": chosen[1]})
    np.testing.assert_array_equal(obs[1], single)
    for _ in range(50):
        actions = np.full((2, 2), 0.5, dtype=np.float32)
        obs, reward, terminated, truncated, info = venv.step(actions)
        single, r1, *_ = env.step(actions[1])
    np.testing.assert_array_equal(obs[1], single)
    assert reward[1] == pytest.approx(r1) and info["_error"].all()


def test_process_sensitivity_matches_a_simulated_axis(tmp_path):
    """P S of one rigid axis under the plant's PID: the plant's own closed loop, driven by a sine
    feedforward at reference zero, answers with the predicted amplitude and phase (an independent
    check: the simulation integrates the URDF's dynamics with RK4, the formula is the z-domain
    product of the ZOH plant and the controller)."""
    urdf = tmp_path / "disc.urdf"
    urdf.write_text("""<robot name="disc"><link name="base"/><link name="disc"><inertial><origin xyz="0 0 0"/>
        <mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.05"/></inertial></link>
        <joint name="turn" type="revolute"><parent link="base"/><child link="disc"/><axis xyz="0 0 1"/>
        <limit lower="-3" upper="3" effort="10" velocity="5"/></joint></robot>""")
    from lcgym.systems.urdf_plant import FeedbackGains

    system = systems.get(str(urdf))
    fs, n = 1000.0, 4000
    for ki in (0.0, 20.0):
        gains = FeedbackGains((40.0,), (1.2,), (ki,), f_lp=80.0, filtered="derivative")
        plant = URDFPlant(system, gains=gains, fs=fs, preroll=0.0, max_error=1.0)
        ps = plant.process_sensitivity(n, np.zeros((10, 1)))
        for k in (8, 40, 160):  # 2, 10, 40 Hz: whole periods in n samples
            f = k * fs / n
            t = np.arange(3 * n) / fs
            ff = 0.05 * np.sin(2 * math.pi * f * t)[:, None]
            y = plant.run(np.zeros((3 * n, 1)), ff).extra["load_turn"][-n:]  # settled: the last n samples
            measured = 2 * np.fft.rfft(y)[k] / n / (0.05 * -1j * np.exp(2j * math.pi * f * (2 * n) / fs))
            assert abs(measured / ps[k, 0] - 1) < 2e-3, (ki, f, measured, ps[k, 0])
        assert (ps[0, 0] == 0.0) == (ki > 0)  # an integrator leaves no constant error


def test_hidden_effects_are_exactly_those_the_plant_accepts(machine_file):
    """``hidden_effects`` (what ``lcgym effects`` lists for [[hidden]]) against the plant's own gate,
    ``bind_effects``, for every effect the machine knows; a name outside it is refused listing them."""
    from lcgym.systems.machine import hidden_effects
    from lcgym.systems.urdf_plant import bind_effects

    m = systems.get(str(machine_file))
    accepted = set()
    for name, cls in m.effect_classes().items():
        try:
            bind_effects([cls(axis="yaw")], m)
        except ValueError as exc:
            assert "URDFPlant simulates" in str(exc), exc
        else:
            accepted.add(name)
    assert set(hidden_effects(m)) == accepted and {"tabulated_force", "viscous_friction"} <= accepted
    assert not {"stiction", "drivetrain_flexibility", "friction_curve"} & accepted
    bad = write_machine(machine_file.parent, "urdf = 'yaw_pitch.urdf'\n[[hidden]]\neffect = 'coulomb'\naxis = 'yaw'\n")
    with pytest.raises(MachineFileError) as info:
        load_machine(bad)
    assert f"a machine file's plant simulates {', '.join(hidden_effects(m))}" in str(info.value)


def test_a_machine_files_runs_record_the_plant_and_rebuild_it(machine_file, tmp_path):
    """Each run of the bench carries ``meta["plant"]``; the bench rebuilds that plant from it, and
    refuses a record of another machine or of a plant the file no longer describes."""
    from lcgym.data import read_trials, write_trials

    bench = systems.resolve(str(machine_file)).bench()
    runs = bench.run(bench.references("validation", 0, 1, 2.0))
    back = read_trials(write_trials(tmp_path / "run.csv", runs), axes=bench.axes)
    record = back[0].meta["plant"]
    assert record["system"] == "yaw_pitch" and record["machine_file"] == str(machine_file)
    plant = bench.plant_from_record(record)
    assert repr(plant) == repr(bench.plant)
    with pytest.raises(ValueError, match="simulated on machine 'other'"):
        bench.plant_from_record({**record, "system": "other"})
    with pytest.raises(ValueError, match="its URDF"):
        bench.plant_from_record({**record, "urdf_sha256": "0" * 64})
    with pytest.raises(ValueError, match="its hidden effects"):
        bench.plant_from_record({**record, "description": "URDFPlant('yaw_pitch', effects=[])"})


def test_two_link_is_a_built_in_machine_from_one_folder():
    m = systems.get("two_link")
    assert m.env_id == "lcgym/TwoLink-v0" and systems.resolve("two_link").name == "two_link-v0"
    assert "two_link-v0" in systems.newest_benchmarks()
    bench = systems.resolve("two_link-v0").bench()
    assert [e.key for e in bench.plant.bound_effects] == ["coulomb_friction@elbow", "cable_spring@shoulder"]
    env = gym.make("lcgym/TwoLink-v0", references="validation", n_references=1, duration=1.0)
    assert env.reset(seed=0)[0].shape == env.observation_space.shape
    folder = Path(systems.__file__).parent / "two_link"
    assert sorted(p.name for p in folder.iterdir() if not p.name.startswith("__pycache__")) == [
        "__init__.py", "machine.toml", "two_link.urdf"]
    with pytest.raises(ValueError, match="built-in machine"):
        systems.get("two_link", joints=("finger", "shoulder", "elbow"))


def test_the_documented_machine_file_is_a_valid_machine_file(tmp_path):
    """The machine file of every key (docs/own-machine-bench.md, "Every key of a machine file"), as
    written there, loads (with the test's URDF)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "own-machine-bench.md").read_text()
    section = page[page.index("## Every key of a machine file"):]
    block = section[section.index("```text\n") + len("```text\n"):section.index("\n```", section.index("```text"))]
    assert block.startswith("# my_arm.toml") and "[[model]]" in block and "[benchmark.rl]" in block
    text = block.replace('"my_arm.urdf"', '"yaw_pitch.urdf"').replace('["shoulder", "elbow"]', '["yaw", "pitch"]')
    text = text.replace('axis = "elbow"', 'axis = "pitch"')
    m = load_machine(write_machine(tmp_path, text))
    assert m.name == "my_arm" and m.settings["rl"]["passes"] == 1.0


@pytest.mark.slow
def test_every_method_on_a_machine_the_test_writes(tmp_path, monkeypatch):
    """The acceptance run of issue 36 on the quick budgets: every method on the test's machine over
    seeds 0-2, rows in the CSV and on the results page; on every axis and seed the physical model
    tracks better than feedback alone, and ILC (learning each validation reference) better than
    the physical model. (The note's figures: the same at the default budgets,
    ``lcgym bench --systems yaw_pitch.toml``.)"""
    from lcgym.leaderboard.page import write_html
    from lcgym.leaderboard.report import select
    from lcgym.leaderboard.runner import BenchConfig, run_benchmark
    from lcgym.leaderboard.store import read_results
    from lcgym.methods import CONTROLLERS

    monkeypatch.setenv("LCGYM_CACHE", str(tmp_path / "cache"))
    spec = str(write_machine(tmp_path))
    out = tmp_path / "r.csv"
    summary = run_benchmark(BenchConfig.quick(systems=(spec,), seeds=(0, 1, 2)), out, jobs=2, progress=False)
    df = read_results(out)
    methods = [m for m, c in CONTROLLERS.items() if getattr(c, "systems", None) is None]
    assert summary["cells_failed"] == 0 and summary["cells_run"] == 3 * len(methods)
    assert set(df["method"]) == set(methods) and set(df["system"]) == {spec}
    e = df[(df["reference_set"] == "validation") & (df["signal"] == "tracking_error")]
    rms = e.pivot_table(index=["seed", "axis"], columns="method", values="RMS")
    assert (rms["physical"] < rms["feedback"]).all(), rms
    assert (rms["ilc"] < rms["physical"]).all(), rms
    text = write_html(select(df)[0], tmp_path / "board.html", source=str(out)).read_text()
    assert spec in text and all(f">{m}<" in text for m in methods)


def test_one_feedback_type_for_every_plant(tmp_path):
    """``systems.feedback.FeedbackGains`` serves the IX and every URDF plant: where the low-pass
    sits is named, never assumed, and a plant refuses the other place; an IX plant record written
    before the field existed reads as the IX's (its output low-passed)."""
    import dataclasses

    from lcgym.systems.feedback import FeedbackGains
    from lcgym.systems.ix.plant import IX_GAINS, IXPlant

    with pytest.raises(ValueError, match="filtered"):
        FeedbackGains((1.0,), (0.1,))
    with pytest.raises(ValueError, match="one per axis"):
        FeedbackGains((1.0, 2.0), (0.1,), filtered="derivative")
    with pytest.raises(ValueError, match="low-passes the output"):
        IXPlant(gains=dataclasses.replace(IX_GAINS, filtered="derivative"))
    machine = systems.get(str(write_machine(tmp_path)))
    from lcgym.systems.urdf_plant import tuned_gains

    tuned = tuned_gains(machine)
    assert tuned.filtered == "derivative" and tuned.f_lp == (100.0, 100.0)
    with pytest.raises(ValueError, match="derivative term"):
        URDFPlant(machine, gains=dataclasses.replace(tuned, filtered="output"))
    record = IXPlant().record()
    record["gains"] = {k: record["gains"][k] for k in ("kp", "kd", "f_lp", "u_max")}  # as written before
    assert IXPlant.from_record(record).gains == IX_GAINS


TINY = {"seeds": (0,), "n_train": 1, "n_validation": 1, "duration": 2.0}


def _cells(out: Path):
    from lcgym.leaderboard.store import read_results

    df = read_results(out)
    return df, df[(df["reference_set"] == "validation") & (df["signal"] == "tracking_error")]


def test_bench_on_a_urdf_alone_and_on_a_machine_of_python(tmp_path, monkeypatch):
    """``--systems my_arm.urdf`` (a plant with the defaults: no hidden effect, 10 Hz PD) and
    ``--systems module:attr`` (a System made by ``benchmark_machine`` in a user's module) run the
    methods like a machine file; the CSV names each machine as given."""
    from lcgym.leaderboard.runner import BenchConfig, run_benchmark

    write_machine(tmp_path)
    (tmp_path / "my_machine.py").write_text(textwrap.dedent("""
        from lcgym.physics.effects import CoulombFriction
        from lcgym.systems.machine import benchmark_machine

        MACHINE = benchmark_machine("yaw_pitch.urdf", hidden=(CoulombFriction(axis="yaw", Fc=1.0, eps=0.02),),
                                    encoder_resolution=1e-4)
    """))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "r.csv"
    config = BenchConfig(systems=("yaw_pitch.urdf", "my_machine:MACHINE"), methods=("feedback", "physical"), **TINY)
    assert config.systems == ("yaw_pitch.urdf", "my_machine:MACHINE")
    assert run_benchmark(config, out, progress=False)["cells_failed"] == 0
    df, e = _cells(out)
    assert set(df["system"]) == {"yaw_pitch.urdf", "my_machine:MACHINE"}
    rms = e.pivot_table(index=["system", "axis"], columns="method", values="RMS")
    assert (rms["physical"] < rms["feedback"]).all(), rms
    bench = systems.resolve("my_machine:MACHINE").bench()
    assert [e.key for e in bench.plant.bound_effects] == ["coulomb_friction@yaw"]
    assert not systems.resolve("yaw_pitch.urdf").bench().plant.bound_effects


def test_simulate_and_the_command_line_take_a_machine_file(machine_file, tmp_path, capsys):
    from lcgym.cli import main
    from lcgym.simulate import metric_table, simulate

    results = simulate(["feedback", "physical"], system=str(machine_file), n_train=1, n_validation=1, duration=2.0,
                       progress=False)
    table = metric_table(results)
    assert set(table["axis"]) == {"yaw", "pitch"} and set(table["controller"]) == {"feedback", "physical"}
    bad = tmp_path / "bad.toml"
    bad.write_text("urdf = 'yaw_pitch.urdf'\n[[hidden]]\neffect = 'coulomb_friction'\naxis = 'roll'\n")
    for args in (["bench", "--quick", "--systems", str(bad), "--out", str(tmp_path / "o.csv")],
                 ["simulate", "--system", str(bad)]):
        try:
            status = main(args)
        except SystemExit as exc:  # argparse refuses the option
            status = exc.code
        assert status not in (0, None)
        err = capsys.readouterr().err
        assert str(bad) in err and "no axis 'roll'" in err
    assert not (tmp_path / "o.csv").exists()


def test_machine_env_passes_the_checkers_and_ppo_learns_on_its_vector_env(machine_file):
    """Gymnasium's and stable-baselines3's env checkers on ``lcgym/Machine-v0`` and
    ``lcgym/TwoLink-v0``; PPO runs on the vector env through ``make_sb3_vec_env`` and reports the
    episodes' tracking error (what the ``rl`` method's training curve reads)."""
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    from lcgym.envs.sb3 import make_sb3_vec_env

    short = {"references": "train", "n_references": 2, "duration": 0.3}
    for env_id, kwargs in (("lcgym/Machine-v0", {"machine": str(machine_file)}), ("lcgym/TwoLink-v0", {})):
        gym_check_env(gym.make(env_id, **kwargs, **short).unwrapped, skip_render_check=True)
        sb3_check_env(gym.make(env_id, **kwargs, **short).unwrapped, warn=False)
    venv = make_sb3_vec_env("lcgym/Machine-v0", num_envs=2, machine=str(machine_file), **short)
    episodes = []

    from stable_baselines3.common.callbacks import BaseCallback

    class Episodes(BaseCallback):
        def _on_step(self) -> bool:
            episodes.extend(info["tracking_rms"] for info in self.locals["infos"] if "tracking_rms" in info)
            return True

    PPO("MlpPolicy", venv, n_steps=512, batch_size=256, n_epochs=1, seed=0, device="cpu").learn(2048, callback=Episodes())
    assert len(episodes) >= 2 and all(np.shape(e) == (2,) and np.all(np.isfinite(e)) for e in episodes)
    env = gym.make("lcgym/Machine-v0", machine=str(machine_file), render_mode="rgb_array", **short)
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    assert env.render().ndim == 3
