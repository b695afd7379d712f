"""The habits of Gymnasium and stable-baselines3 on every machine's env (issue 37, item 1):
normalized actions, episodes in windows of a reference run, renders, reset info, the checkers."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import lcgym  # noqa: F401  (registers the ids)
from lcgym.envs.episodes import EPISODE_STEPS, checked_episode_steps
from lcgym.envs.sb3 import make_sb3_vec_env

MACHINES = [("lcgym/IX-v1", {"n_references": 2, "duration": 2.0}, "physical"),
            ("lcgym/FlexArm-v1", {"n_references": 1}, "basic"),
            ("lcgym/TwoLink-v0", {"n_references": 2, "duration": 1.0}, "physical")]
IDS = [m[0].split("/")[1] for m in MACHINES]


@pytest.mark.parametrize("env_id, kwargs, base", MACHINES, ids=IDS)
def test_checkers_pass_without_warnings(env_id, kwargs, base):
    """Gymnasium's and SB3's env checkers, with every warning an error: on the feedback-only and
    the residual env, with both render modes (human draws nothing here: no screen)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for b in ("none", base) if base != "basic" else ("none", "basic"):
            for mode in ("rgb_array", "human"):
                gym_check_env(gym.make(env_id, base_feedforward=b, render_mode=mode, **kwargs).unwrapped)
            sb3_check_env(gym.make(env_id, base_feedforward=b, **kwargs).unwrapped, warn=True)


def _run(env, actions, **reset):
    """Observations and rewards of one episode fed ``actions`` (cycled), and its last info."""
    obs, info = env.reset(**reset)
    out, done, k = [obs], False, 0
    while not done:
        obs, reward, terminated, truncated, info = env.step(actions[k % len(actions)])
        out.append(np.append(obs, reward))
        done, k = terminated or truncated, k + 1
    return out, info


@pytest.mark.parametrize("env_id, kwargs, base", MACHINES, ids=IDS)
def test_normalized_action_is_the_unit_action_times_the_scale(env_id, kwargs, base):
    """The default env fed a (within [-1, 1]) gives, bit for bit, the run of the env in machine
    units fed a x action_scale: normalizing only rescales."""
    plain = gym.make(env_id, base_feedforward=base, episode_steps=300, **kwargs)
    units = gym.make(env_id, base_feedforward=base, episode_steps=300, normalize_actions=False, **kwargs)
    scale = plain.unwrapped.action_scale
    assert plain.action_space.high.max() == 1.0 and np.all(units.action_space.high == scale.astype(np.float32))
    a = np.random.default_rng(0).uniform(-1, 1, (50, scale.size)).astype(np.float32)
    normalized, _ = _run(plain, a, seed=1)
    in_units, _ = _run(units, a.astype(np.float64) * scale, seed=1)
    for x, y in zip(normalized, in_units, strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("env_id, kwargs, base", MACHINES, ids=IDS)
def test_windows_cut_the_whole_reference_run_and_go_on(env_id, kwargs, base):
    """Episodes of 400 samples, each reset() going on with the open run: together they are the
    whole-reference episode (episode_steps=None) bit for bit, and the last window's info holds the
    run's trial from the first sample; reset(seed) starts afresh."""
    whole_env = gym.make(env_id, base_feedforward=base, episode_steps=None, **kwargs)
    a = np.random.default_rng(2).uniform(-0.5, 0.5, (37, whole_env.action_space.shape[0])).astype(np.float32)
    whole, whole_info = _run(whole_env, a, seed=0, options={"reference": 0})
    env = gym.make(env_id, base_feedforward=base, episode_steps=400, **kwargs)
    obs, info = env.reset(seed=0, options={"reference": 0})
    windows, starts, k = [obs], [], 0
    while "trial" not in info:
        starts.append(info["sample"])
        length, done = 0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(a[k % len(a)])
            windows.append(np.append(obs, reward))
            done, k, length = terminated or truncated, k + 1, length + 1
        assert truncated and not terminated and (length == 400 or "trial" in info)
        if "trial" not in info:
            again, info = env.reset()  # goes on: the observation the last window ended with
            np.testing.assert_array_equal(again, obs)
    assert starts == list(range(0, 400 * len(starts), 400)) and len(starts) > 1
    assert len(windows) == len(whole)
    for x, y in zip(windows, whole, strict=True):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(info["trial"].pos, whole_info["trial"].pos)
    _, fresh = env.reset(seed=0)
    assert fresh["sample"] == 0


@pytest.mark.parametrize("env_id, kwargs, base", MACHINES, ids=IDS)
def test_sb3_vector_env_logs_episodes_within_the_first_rollout(env_id, kwargs, base):
    """``make_sb3_vec_env`` with its defaults (4 envs, windows of EPISODE_STEPS): every env ends an
    episode within EPISODE_STEPS steps, with SB3's ``episode`` record; the reset info is the same
    on every machine (reference names, action scale)."""
    venv = make_sb3_vec_env(env_id, base_feedforward=base, **kwargs)
    assert venv.num_envs == 4
    venv.reset()
    ended = set()
    for _ in range(EPISODE_STEPS):
        _, _, done, infos = venv.step(np.zeros((4, *venv.action_space.shape), dtype=np.float32))
        ended |= {i for i in np.flatnonzero(done) if "episode" in infos[i]}
    assert ended == {0, 1, 2, 3}
    info = venv.venv.reset(seed=0)[1]
    assert len(info["reference"]) == 4 and info["action_scale"].shape == (4, *venv.action_space.shape)
    venv.close()


@pytest.mark.parametrize("env_id, kwargs, base", MACHINES, ids=IDS)
def test_human_render_keeps_the_picture_without_a_screen(env_id, kwargs, base):
    env = gym.make(env_id, render_mode="human", episode_steps=600, **kwargs)
    env.reset(seed=0)
    assert env.render() is None
    window = env.unwrapped._human
    first = window.image.copy()
    for _ in range(600):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert window.image.shape == first.shape and not np.array_equal(window.image, first)  # drawn again
    env.close()


@pytest.mark.bad_input
def test_bad_episode_steps_and_render_mode_are_refused():
    for bad in (0, -5, 2.5, True, "100"):
        with pytest.raises(ValueError, match="episode_steps must be a positive integer or None"):
            checked_episode_steps(bad)
    with pytest.raises(ValueError, match="episode_steps"):
        gym.make("lcgym/IX-v1", episode_steps=0, n_references=1, duration=1.0)
    with pytest.raises(ValueError, match="render_mode must be None, 'rgb_array' or 'human'"):
        gym.make("lcgym/FlexArm-v1", render_mode="ansi", n_references=1)
