"""Gymnasium environments of the IX: conformance, determinism, vector autoreset, PPO (bad actions:
test_bad_actions.py)."""

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import lcgym  # noqa: F401  (registers the ids)
from lcgym.envs.sb3 import make_sb3_vec_env
from lcgym.systems.ix import env as ix_env
from lcgym.systems.ix.plant import IX_GAINS, IXPlant
from lcgym.systems.ix.references import random_moves

SHORT = {"n_references": 2, "duration": 4.0}  # small reference sets keep the tests fast
IDS = [env_id for env_id in gym.registry if env_id.startswith("lcgym/IX")]


def test_ids_registered_and_reachable_without_import():
    assert "lcgym/IX-v0" in IDS
    env = gym.make("lcgym:lcgym/IX-v0", **SHORT)
    assert isinstance(env.unwrapped, ix_env.IXEnv)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("base", ["none", "physical"])
def test_check_env_gymnasium_and_sb3(env_id, base):
    env = gym.make(env_id, base_feedforward=base, **SHORT).unwrapped
    gym_check_env(env, skip_render_check=True)
    sb3_check_env(gym.make(env_id, base_feedforward=base, **SHORT).unwrapped, warn=False)


def test_spaces_and_documented_bounds():
    env = gym.make("lcgym/IX-v0", **SHORT)
    assert env.action_space.shape == (2,) and env.action_space.high[0] == 1.0  # normalized
    assert env.unwrapped.action_scale.tolist() == [5.0, 5.0]  # V, the amplifier limit
    _, info = env.reset(seed=0)
    assert info["action_scale"].tolist() == [5.0, 5.0] and info["sample"] == 0
    units = gym.make("lcgym/IX-v0", normalize_actions=False, **SHORT)
    assert units.action_space.high[0] == 5.0 and units.unwrapped.action_scale.tolist() == [1.0, 1.0]
    assert env.observation_space.shape == (ix_env.N_OBS,) and env.observation_space.dtype == np.float32
    residual = gym.make("lcgym/IX-v0", base_feedforward="physical", **SHORT)
    assert residual.unwrapped.action_scale.tolist() == [ix_env.RESIDUAL_BOUND] * 2


def _rollout(env, seed, steps=300):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(1)
    out = [obs]
    for _ in range(steps):
        obs, r, term, trunc, _ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        out.append(np.append(obs, r))
        if term or trunc:
            break
    return out


def test_same_seed_same_episode():
    a = _rollout(gym.make("lcgym/IX-v0", **SHORT), seed=3)
    b = _rollout(gym.make("lcgym/IX-v0", **SHORT), seed=3)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_episode_matches_plant_run_and_ends_with_trial():
    """Zero actions with the physical base: the episode is the plant's run with that feedforward."""
    env = gym.make("lcgym/IX-v0", base_feedforward="physical", episode_steps=None, **SHORT)
    env.reset(seed=0, options={"reference": 1})
    task = env.unwrapped.task
    steps, done, info = 0, False, {}
    while not done:
        _, _, term, trunc, info = env.step(np.zeros(2, dtype=np.float32))
        done, steps = term or trunc, steps + 1
    assert trunc and not term and steps == task.lengths[1]
    trial = info["trial"]
    ref = task.ref_pos[1, : task.lengths[1]]
    expected = task.plant.run(ref, task.base_ff[1, : task.lengths[1]])
    np.testing.assert_array_equal(trial.pos, expected.pos)
    np.testing.assert_array_equal(trial.u, expected.u)


@pytest.mark.fault
def test_terminated_when_plant_leaves_safe_range():
    plant = IXPlant(gains=dataclasses.replace(IX_GAINS, kp=(-170.0, 120.0)))  # destabilizing propeller feedback
    env = gym.make("lcgym/IX-v0", plant=plant, **SHORT)
    env.reset(seed=0)
    for _ in range(3000):
        _, _, term, trunc, _ = env.step(np.zeros(2, dtype=np.float32))
        if term or trunc:
            break
    assert term and not trunc


def test_explicit_reference_list_and_render():
    refs = [random_moves("mine", np.random.default_rng(0), duration=2.0)]
    env = gym.make("lcgym/IX-v0", references=refs, render_mode="rgb_array")
    _, info = env.reset(seed=0)
    assert info["reference"] == "mine"
    for _ in range(50):
        env.step(np.zeros(2, dtype=np.float32))
    image = env.render()
    assert image.dtype == np.uint8 and image.ndim == 3 and image.shape[2] == 3
    assert image.std() > 5  # not a blank canvas


def test_vector_env_matches_single_envs_and_autoresets():
    N = 3
    venv = gym.make_vec("lcgym/IX-v0", num_envs=N, vectorization_mode="vector_entry_point", episode_steps=None,
                        references=[random_moves(f"r{i}", np.random.default_rng(i), duration=0.2) for i in range(2)])
    inner = venv.unwrapped if hasattr(venv, "unwrapped") else venv
    obs, _ = venv.reset(seed=0)
    assert obs.shape == (N, ix_env.N_OBS)
    lengths = inner.task.lengths[inner._ref_idx].copy()
    a = np.zeros((N, 2), dtype=np.float32)
    ended_at = {}
    for step in range(int(lengths.max()) + 2):
        obs, reward, term, trunc, info = venv.step(a)
        for i in np.flatnonzero(term | trunc):
            ended_at.setdefault(i, (step, obs[i].copy()))
        if len(ended_at) == N:
            break
    for i, (step, _) in ended_at.items():
        assert step + 1 == lengths[i]  # truncated on the last sample of its reference
    # next-step autoreset: the step after the end returns the first observation, reward 0
    obs, reward, term, trunc, _ = venv.step(a)
    done_last = [i for i, (s, _) in ended_at.items() if s + 1 == int(lengths.max())]
    for i in done_last:
        assert reward[i] == 0.0 and not term[i] and not trunc[i]
        np.testing.assert_array_equal(obs[i], inner.task.first_observation(inner._ref_idx[i]))


def test_vector_env_same_step_autoreset_gives_final_obs():
    from gymnasium.vector import AutoresetMode

    refs = [random_moves("r", np.random.default_rng(0), duration=0.1)]
    venv = gym.make_vec("lcgym/IX-v0", num_envs=2, vectorization_mode="vector_entry_point", references=refs,
                        autoreset_mode=AutoresetMode.SAME_STEP, episode_steps=None)
    inner = venv.unwrapped if hasattr(venv, "unwrapped") else venv
    venv.reset(seed=0)
    n = int(inner.task.lengths[0])
    for _ in range(n - 1):
        _, _, term, trunc, info = venv.step(np.zeros((2, 2)))
        assert not (term | trunc).any()
    obs, reward, term, trunc, info = venv.step(np.zeros((2, 2)))
    assert trunc.all() and info["_final_obs"].all()
    np.testing.assert_array_equal(obs[0], inner.task.first_observation(0))  # already reset
    assert not np.array_equal(info["final_obs"][0], obs[0])


def test_ppo_runs_on_single_and_vector_env():
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecEnv

    torch.set_num_threads(1)
    env = gym.make("lcgym/IX-v0", base_feedforward="physical", **SHORT)
    PPO("MlpPolicy", env, n_steps=500, batch_size=100, n_epochs=1, seed=0, device="cpu").learn(2000)
    venv = make_sb3_vec_env("lcgym/IX-v0", num_envs=4, **SHORT)
    assert isinstance(venv, VecEnv)
    model = PPO("MlpPolicy", venv, n_steps=125, batch_size=100, n_epochs=1, seed=0, device="cpu")
    model.learn(2000)
    assert model.num_timesteps >= 2000



def test_observation_layout_and_reward_as_documented():
    env = gym.make("lcgym/IX-v0", base_feedforward="physical", **SHORT)
    env.reset(seed=0, options={"reference": 0})
    task = env.unwrapped.task
    for _ in range(700):  # into the first move
        obs, reward, _, _, info = env.step(np.zeros(2, dtype=np.float32))
    k = int(env.unwrapped._k[0])  # the observation describes sample k
    from lcgym.physics.kinematics import reference_kinematics

    q, qd, qdd = reference_kinematics(task.ref_pos[0, : task.lengths[0]], 500.0)
    np.testing.assert_allclose(obs[0], q[k, 0] / (np.pi / 2), rtol=1e-6)  # propeller position now
    np.testing.assert_allclose(obs[5 + 2], q[k + 25, 1] / (np.pi / 2), rtol=1e-6)  # roll, 25 samples ahead
    np.testing.assert_allclose(obs[10], qd[k, 0] / np.radians(20), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(obs[20 + 5], qdd[k, 1] / np.radians(40), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(obs[32:34], task.base_ff[0, k] / 5.0, rtol=1e-6)
    e = obs[34:36] * np.radians(0.5)  # tracking error at sample k, the result of the last action
    assert reward == pytest.approx(-0.5 * np.sum((e / np.radians(0.1)) ** 2), rel=1e-5)
    assert np.any(np.abs(obs[10:12]) > 0.01)  # the axes do move by now


@pytest.mark.bad_input
def test_misuse_gets_clear_errors():
    venv = gym.make_vec("lcgym/IX-v0", num_envs=2, vectorization_mode="vector_entry_point", **SHORT)
    with pytest.raises(RuntimeError, match="reset"):
        venv.step(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="duration"):
        gym.make("lcgym/IX-v0", n_references=1, duration=0.0)
    with pytest.raises(ValueError, match="base_feedforward"):
        gym.make("lcgym/IX-v0", base_feedforward="magic", **SHORT)
    with pytest.raises(ValueError, match="unknown reference set"):
        gym.make("lcgym/IX-v0", references="bogus")
    one = random_moves("solo", np.random.default_rng(0), duration=1.0).positions
    env = gym.make("lcgym/IX-v0", references=one)  # a single array is one reference
    assert env.unwrapped.task.n_references == 1
    with pytest.warns(UserWarning, match="degrees"):
        env = gym.make("lcgym/IX-v0", references=[np.degrees(one)])
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
