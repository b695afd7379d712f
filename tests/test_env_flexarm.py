"""lcgym/FlexArm-v0: conformance, agreement with the plant, the base feedforwards (bad actions:
test_bad_actions.py)."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import lcgym  # noqa: F401  (registers the ids)
from lcgym.references import Reference
from lcgym.systems.flexarm.env import FlexArmEnv, FlexArmVectorEnv
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set


@pytest.fixture(scope="module")
def refs():
    return arm_reference_set("validation", seed=0, n_references=1)


@pytest.mark.parametrize("base", ["basic", "none", "physical"])
def test_check_env_gymnasium_and_sb3(refs, base):
    gym_check_env(gym.make("lcgym/FlexArm-v0", references=refs, base_feedforward=base).unwrapped, skip_render_check=True)
    sb3_check_env(FlexArmEnv(references=refs, base_feedforward=base), warn=False)


def test_zero_action_episode_is_the_plant_run_with_the_basic_feedforward(refs):
    env = FlexArmEnv(references=refs, episode_steps=None)
    env.reset(seed=0)
    done, steps, info = False, 0, {}
    while not done:
        _, reward, terminated, truncated, info = env.step(np.zeros(6, dtype=np.float32))
        assert np.isfinite(reward)
        done = terminated or truncated
        steps += 1
    assert truncated and steps == refs[0].n_samples
    b = BasicFeedforward().compute(refs[0].positions, refs[0].fs)
    run = FlexArmPlant.of_version("v1").run(refs[0], b["tau_ff"], b["motor_offset"])  # the class default: v1
    trial = info["trial"]
    np.testing.assert_array_equal(trial.u, run.u)
    np.testing.assert_array_equal(trial.extra["load_j3"], run.extra["load_j3"])


def test_sync_vector_env_steps_each_copy_like_a_single_env(refs):
    """``gym.make_vec`` (sync) runs independent copies; each matches a single env step for step."""
    vec = gym.make_vec("lcgym/FlexArm-v0", num_envs=2, vectorization_mode="sync", references=refs)
    single = FlexArmEnv(references=refs, version="v0")
    obs_v, _ = vec.reset(seed=0, options={"reference": 0})
    obs_s, _ = single.reset(seed=0, options={"reference": 0})
    rng = np.random.default_rng(0)
    for _ in range(30):
        a = rng.uniform(-1, 1, (2, 6)).astype(np.float32)
        obs_v, r_v, *_ = vec.step(a)
        obs_s, r_s, *_ = single.step(a[1])
        np.testing.assert_array_equal(obs_v[1], obs_s)
        assert r_v[1] == r_s
    assert not np.array_equal(obs_v[0], obs_v[1])  # the copies took different actions
    vec.close()


def _short_lines():
    """Two pieces of a validation line from inside its first move (500 and 300 samples): short
    episodes that end at different steps, so the vector env autoresets within a test."""
    r = arm_reference_set("validation", seed=0, n_references=1)[0]
    return [Reference(f"piece-{a}", r.fs, r.positions[a:b], r.velocities[a:b], r.accelerations[a:b], r.axes)
            for a, b in ((600, 1100), (700, 1000))]


@pytest.mark.parametrize("num_envs, mode, base, steps", [(3, AutoresetMode.NEXT_STEP, "basic", None),
                                                          (10, AutoresetMode.SAME_STEP, "basic", None),
                                                          (9, AutoresetMode.NEXT_STEP, "none", None),
                                                          (3, AutoresetMode.NEXT_STEP, "basic", 120),
                                                          (10, AutoresetMode.SAME_STEP, "basic", 120),
                                                          (3, AutoresetMode.NEXT_STEP, "physical", None),
                                                          (8, AutoresetMode.SAME_STEP, "physical", 120)],
                         ids=["serial-next-step", "parallel-same-step", "parallel-feedback-only",
                              "windows-next-step", "windows-same-step", "serial-physical", "parallel-physical-windows"])
def test_vector_env_is_n_single_envs_bit_for_bit(num_envs, mode, base, steps):
    """``FlexArmVectorEnv``: every sub-env's observation, reward, episode end and motor torque equal
    those of a single ``FlexArmEnv`` on the same reference with the same actions, bit for bit,
    through episode ends and Gymnasium's autoreset (both modes); actions out of bounds included.
    With windows of 120 samples, a sub-env whose window ends goes on with its run as a single env
    does at ``reset()`` (``envs.episodes``)."""
    lines = _short_lines()
    venv = gym.make_vec("lcgym/FlexArm-v1", num_envs=num_envs, vectorization_mode="vector_entry_point",
                        references=lines, base_feedforward=base, autoreset_mode=mode, episode_steps=steps)
    inner = venv.unwrapped if hasattr(venv, "unwrapped") else venv
    singles = [FlexArmEnv(references=lines, base_feedforward=base, episode_steps=steps) for _ in range(num_envs)]

    went_on = []

    def single_reset(i, e):  # the open run goes on, or the reference the vector env drew starts
        went_on.append(e._window.run_open)
        return e.reset()[0] if e._window.run_open else e.reset(options={"reference": int(inner._ref_idx[i])})[0]

    obs, _ = venv.reset(seed=3)
    first = [e.reset(options={"reference": int(inner._ref_idx[i])})[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(obs, np.array(first))
    rng = np.random.default_rng(1)
    bound = float(venv.single_action_space.high[0])
    pending = np.zeros(num_envs, dtype=bool)  # NEXT_STEP: the sub-env resets in this step
    ends = 0
    for t in range(700):
        a = (rng.uniform(-1.2, 1.2, (num_envs, 6)) * bound).astype(np.float32)  # bound 1: normalized
        obs, reward, terminated, truncated, info = venv.step(a)
        done = terminated | truncated
        for i, e in enumerate(singles):
            if pending[i]:  # reset by the vector env: the action was ignored
                assert reward[i] == 0.0 and not done[i]
                np.testing.assert_array_equal(obs[i], single_reset(i, e))
                continue
            o, r, term, trunc, single_info = e.step(a[i])
            assert (reward[i], terminated[i], truncated[i]) == (r, term, trunc), (t, i)
            np.testing.assert_array_equal(info["u"][i], single_info["u"])
            last = info["final_obs"][i] if mode == AutoresetMode.SAME_STEP and done[i] else obs[i]
            np.testing.assert_array_equal(last, o)
            if done[i] and mode == AutoresetMode.SAME_STEP:
                np.testing.assert_array_equal(obs[i], single_reset(i, e))
        ends += int(done.sum())
        pending = done if mode == AutoresetMode.NEXT_STEP else pending
    assert ends >= num_envs and info["clipped_actions"].sum() > 0
    assert any(went_on) == (steps is not None) and (steps is None or not all(went_on))  # both kinds of reset met


def test_physical_base_observes_the_fitted_model_and_runs_it_as_the_benchmark_does():
    """``base_feedforward="physical"``: the physical model fitted on feedback-only runs of the
    training references (``methods.PhysicalFeedforward``'s fit on the benchmark's training
    trials); the first observation's base-feedforward entries are its torque / FF_SCALE, and an
    all-zero action episode is ``FlexArmBench.run`` with the model's feedforward and offset."""
    from lcgym.systems.flexarm import FLEXARM
    from lcgym.systems.flexarm.bench import FlexArmBench
    from lcgym.systems.flexarm.env import ACTION_BOUND, FF_SCALE, physical_model

    line = _short_lines()[0]
    env = FlexArmEnv(references=[line], base_feedforward="physical", episode_steps=None)
    model = physical_model(env.plant, 0)
    assert isinstance(model, FLEXARM.model) and env.base_feedforward == "physical"
    assert env.bound == ACTION_BOUND and np.all(env.action_scale == np.float32(ACTION_BOUND))
    ff, offset = model.predict(line), model.reference_offset(line)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs[18:24], (ff[0] / FF_SCALE).astype(np.float32))
    assert np.any(obs[18:24] != 0) and np.any(offset != 0)
    done, info = False, {}
    while not done:
        _, _, terminated, truncated, info = env.step(np.zeros(6, dtype=np.float32))
        done = terminated or truncated
    assert truncated and not terminated
    trial = info["trial"]
    assert trial.meta["base_feedforward"] == "physical"
    run = FLEXARM.make_bench().run([line], [ff], [offset])[0]
    np.testing.assert_array_equal(trial.u, run.u)
    np.testing.assert_array_equal(FlexArmBench.load_error(trial), FlexArmBench.load_error(run))


def test_a_given_model_is_the_base():
    """A fitted model object (``predict``, optional ``reference_offset``) or a fitted controller
    (``feedforward`` and ``reference_offset``, as ``PhysicalFeedforward``) is the base, named
    "physical (given model)"; a model without ``reference_offset`` leaves the motor reference alone."""
    from lcgym.systems.flexarm.env import physical_model

    lines = _short_lines()
    model = physical_model(FlexArmPlant.of_version("v1"), 0)

    class Controller:  # a fitted PhysicalFeedforward's interface
        def feedforward(self, reference):
            return model.predict(reference)

        def reference_offset(self, reference):
            return model.reference_offset(reference)

    class TorqueOnly:
        def predict(self, reference):
            return model.predict(reference)

    physical = FlexArmEnv(references=lines, base_feedforward="physical")
    first = [physical.reset(options={"reference": i})[0] for i in range(2)]
    for given in (model, Controller()):
        env = FlexArmEnv(references=lines, base_feedforward=given)
        assert env.base_feedforward == "physical (given model)"
        for i in range(2):
            np.testing.assert_array_equal(env.reset(options={"reference": i})[0], first[i])
            np.testing.assert_array_equal(env._base_of(i)[1], physical._base_of(i)[1])
    env = FlexArmEnv(references=lines, base_feedforward=TorqueOnly())
    np.testing.assert_array_equal(env._base_of(0)[0], physical._base_of(0)[0])
    assert not np.any(env._base_of(0)[1]) and np.any(physical._base_of(0)[1])
    gym_check_env(FlexArmEnv(references=lines, base_feedforward=model), skip_render_check=True)


@pytest.mark.parametrize("base, match", [("Physical", "'basic', 'none', 'physical' or a fitted model, got 'Physical'"),
                                         ("nominal", "got 'nominal'"), (object(), "with predict.*got object"),
                                         (None, "got NoneType"), (3, "got int")])
def test_bad_base_feedforward_is_refused(base, match):
    lines = _short_lines()
    for make in (lambda: FlexArmEnv(references=lines, base_feedforward=base),
                 lambda: FlexArmVectorEnv(2, references=lines, base_feedforward=base),
                 lambda: gym.make("lcgym/FlexArm-v1", references=lines, base_feedforward=base)):
        with pytest.raises(ValueError, match=match):
            make()


def test_a_model_of_the_wrong_shape_is_refused():
    class Wrong:
        def predict(self, reference):
            return np.zeros((reference.n_samples, 2))

    env = FlexArmEnv(references=_short_lines(), base_feedforward=Wrong())
    with pytest.raises(ValueError, match=r"feedforward \(predict\) of piece-600 must be finite with shape \(500, 6\)"):
        env.reset(options={"reference": 0})


def test_vector_env_refuses_nan_and_trains_sb3():
    """A NaN action is refused before any arm moves, naming step and sub-env; the stable-baselines3
    adapter steps the vector env and reports an episode's return and tracking error at its end."""
    from lcgym.envs.sb3 import make_sb3_vec_env

    lines = _short_lines()
    venv = FlexArmVectorEnv(4, references=lines)
    venv.reset(seed=0)
    a = np.zeros((4, 6), dtype=np.float32)
    a[2, 1] = np.nan
    before = venv._st.copy()
    with pytest.raises(ValueError, match="step 0 contains NaN or inf for sub-env 2"):
        venv.step(a)
    np.testing.assert_array_equal(venv._st, before)
    sb3 = make_sb3_vec_env("lcgym/FlexArm-v1", num_envs=2, references=lines)
    sb3.reset()
    infos = []
    for _ in range(500):
        _, _, done, step_infos = sb3.step(np.zeros((2, 6), dtype=np.float32))
        infos += [i for i, d in zip(step_infos, done, strict=True) if d]
    assert infos and all(i["episode"]["l"] in (300, 500) and i["tracking_rms"].shape == (3,) for i in infos)


def test_vector_sub_env_i_draws_the_references_of_a_single_env_seeded_seed_plus_i():
    """As Gymnasium's sync vector env and SB3's DummyVecEnv seed their copies, episode after episode
    (a single env's episode trial draws accelerometer noise at its end; the vector env draws it
    too): the RL baseline meets the same references on the vector env as on DummyVecEnv copies."""
    lines = _short_lines() * 4  # 8 references
    venv = FlexArmVectorEnv(5, references=lines, autoreset_mode=AutoresetMode.SAME_STEP)
    venv.reset(seed=7)
    drawn = [[int(r)] for r in venv._ref_idx]
    while min(len(d) for d in drawn) < 4:
        _, _, terminated, truncated, _ = venv.step(np.zeros((5, 6), dtype=np.float32))
        for i in np.flatnonzero(terminated | truncated):
            drawn[i].append(int(venv._ref_idx[i]))
    for i, d in enumerate(drawn):
        e = FlexArmEnv(references=lines)
        e.reset(seed=7 + i)
        single = [e._idx]
        for _ in range(3):
            done = False
            while not done:
                _, _, terminated, truncated, _ = e.step(np.zeros(6, dtype=np.float32))
                done = terminated or truncated
            e.reset()
            single.append(e._idx)
        assert d[:4] == single, (i, d, single)


def test_parallel_kernel_runs_in_threads():
    """The vector env's parallel kernel is loaded as a parallel one: in a fresh process (where
    nothing else started numba's threads), one step of FlexArmVectorEnv.PARALLEL_FROM arms starts
    the threading layer. A parallel and a serial compilation of one function share numba's cache
    entry, which once loaded the serial kernel for both."""
    import subprocess
    import sys

    code = ("import gymnasium as gym, numba, numpy as np, lcgym\n"
            "from lcgym.systems.flexarm.env import FlexArmVectorEnv\n"
            "n = FlexArmVectorEnv.PARALLEL_FROM\n"
            "env = gym.make_vec('lcgym/FlexArm-v1', n, vectorization_mode='vector_entry_point')\n"
            "env.reset(seed=0)\n"
            "try:\n"
            "    numba.threading_layer()\n"
            "    raise SystemExit('threads already started before the step')\n"
            "except ValueError:\n"
            "    pass\n"
            "env.step(np.zeros((n, 6), np.float32))\n"
            "print(numba.threading_layer())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() in ("omp", "tbb", "workqueue")
