"""lcgym/FlexArm-v0: conformance, agreement with the plant (bad actions: test_bad_actions.py)."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import lcgym  # noqa: F401  (registers the ids)
from lcgym.systems.flexarm.env import FlexArmEnv
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set


@pytest.fixture(scope="module")
def refs():
    return arm_reference_set("validation", seed=0, n_references=1)


@pytest.mark.parametrize("base", ["basic", "none"])
def test_check_env_gymnasium_and_sb3(refs, base):
    gym_check_env(gym.make("lcgym/FlexArm-v0", references=refs, base_feedforward=base).unwrapped, skip_render_check=True)
    sb3_check_env(FlexArmEnv(references=refs, base_feedforward=base), warn=False)


def test_zero_action_episode_is_the_plant_run_with_the_basic_feedforward(refs):
    env = FlexArmEnv(references=refs)
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
