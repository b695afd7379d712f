"""Actions held for several control samples (``lcgym.envs.hold``): one agent step is the same as
the held samples stepped one by one, rewards summed; an episode's end inside a hold ends the step."""

import gymnasium as gym
import numpy as np
import pytest

import lcgym  # noqa: F401  (registers the ids)
from lcgym.envs.hold import AGENT_RATE, HoldAction, VecHoldAction, hold_samples, sample_rate
from lcgym.envs.sb3 import SB3VecAdapter, make_sb3_vec_env

SHORT = {"n_references": 2, "duration": 4.0}


def _actions(n: int, shape, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, size=(n, *shape)).astype(np.float32)


def test_a_held_step_is_its_samples_one_by_one():
    """HoldAction(env, 7) against the env stepped 7 times with the same action: the last sample's
    observation and the sum of the rewards, bit for bit; an episode of 25 samples ends inside the
    fourth hold, which then holds 4 samples and is truncated."""
    make = lambda: gym.make("lcgym/IX-v1", episode_steps=25, **SHORT)  # noqa: E731
    held, plain = HoldAction(make(), 7), make()
    obs_h, _ = held.reset(seed=3)
    obs_p, _ = plain.reset(seed=3)
    assert np.array_equal(obs_h, obs_p)
    for k, action in enumerate(_actions(4, held.action_space.shape)):
        obs_h, r_h, term_h, trunc_h, info = held.step(action)
        total = 0.0
        for _ in range(info["held_samples"]):
            obs_p, r, term_p, trunc_p, _ = plain.step(action)
            total += float(r)
        assert info["held_samples"] == (7 if k < 3 else 4)
        assert np.array_equal(obs_h, obs_p) and r_h == total and (term_h, trunc_h) == (term_p, trunc_p)
    assert trunc_h


@pytest.mark.parametrize("episode_steps", [25, None])
def test_a_machine_env_holds_in_compiled_code_what_it_steps_one_by_one(episode_steps):
    """A URDF machine's env holds the action itself (``step_held``, the plant's samples in one compiled
    loop): against the same env stepped sample by sample, the observations, flags, info and the
    whole run bit for bit, the summed rewards to round-off; through windows of 25 samples (a hold
    cut at the window's end) or one whole reference, with actions that the bound clips."""
    from lcgym.envs import make_env

    make = lambda: make_env("lcgym/TwoLink-v0", references="validation", episode_steps=episode_steps,  # noqa: E731
                            n_references=1, duration=2.0, base_feedforward="none")
    fast, plain = HoldAction(make(), 7), make()
    assert hasattr(type(fast.env), "step_held")
    fast.reset(seed=1)
    plain.reset(seed=1)
    for action in 1.5 * _actions(2000, fast.action_space.shape, seed=2):
        obs_f, r_f, term_f, trunc_f, info_f = fast.step(action)
        total = 0.0
        for _ in range(info_f["held_samples"]):
            obs_p, r, term_p, trunc_p, info_p = plain.step(action)
            total += float(r)
        assert np.array_equal(obs_f, obs_p) and (term_f, trunc_f) == (term_p, trunc_p)
        assert r_f == pytest.approx(total, rel=1e-12)
        for key in ("pos", "u", "ff", "error", "clipped_actions"):
            assert np.array_equal(info_f[key], info_p[key]), key
        if "trial" in info_p:
            assert np.array_equal(info_f["trial"].pos, info_p["trial"].pos)
            assert np.array_equal(info_f["trial"].ff, info_p["trial"].ff)
            break
        if term_f or trunc_f:
            fast.reset()
            plain.reset()
    assert info_f["clipped_actions"] > 0 and "trial" in info_f


def test_a_machine_env_hold_that_leaves_the_safe_range_ends_where_the_steps_end():
    """Full torque on both axes until the plant leaves its safe range inside a hold: the held step is
    terminated at the same sample, with the same observation and reward, as the steps one by one."""
    from lcgym import systems
    from lcgym.envs import make_env
    from lcgym.systems.urdf_plant import URDFPlant

    machine = systems.get("two_link")
    make = lambda: make_env("lcgym/TwoLink-v0", references="validation", n_references=1, duration=2.0,  # noqa: E731
                            episode_steps=None, plant=URDFPlant(machine, u_max=150.0, max_error=0.05))
    fast, plain = HoldAction(make(), 9), make()
    fast.reset(seed=0)
    plain.reset(seed=0)
    action = np.ones(fast.action_space.shape, dtype=np.float32)
    for _ in range(2000):
        obs_f, r_f, term_f, trunc_f, info_f = fast.step(action)
        total, steps = 0.0, 0
        while steps < info_f["held_samples"]:
            obs_p, r, term_p, trunc_p, _ = plain.step(action)
            total, steps = total + float(r), steps + 1
        assert np.array_equal(obs_f, obs_p) and (term_f, trunc_f) == (term_p, trunc_p)
        assert r_f == pytest.approx(total, rel=1e-12)
        if term_f:
            break
    assert term_f and 0 < info_f["held_samples"] < 9 and np.array_equal(info_f["trial"].pos, plain.unwrapped._episode.trial().pos)


def test_the_vector_hold_equals_the_adapter_stepped_sample_by_sample():
    """make_sb3_vec_env(agent_rate=50) on the IX (500 Hz) holds 10 samples: its steps equal the
    unheld adapter's, 10 samples at a time, with the rewards summed, and episodes of 1000 samples
    end at the 100th agent step."""
    held = make_sb3_vec_env("lcgym/IX-v1", num_envs=2, agent_rate=AGENT_RATE, **SHORT)
    plain = make_sb3_vec_env("lcgym/IX-v1", num_envs=2, **SHORT)
    assert isinstance(held, VecHoldAction) and held.samples == 10 and isinstance(plain, SB3VecAdapter)
    held.seed(5)
    plain.seed(5)
    assert np.array_equal(held.reset(), plain.reset())
    for step, action in enumerate(_actions(100, (2, 2), seed=1), start=1):
        held.step_async(action)
        obs_h, r_h, done_h, infos = held.step_wait()
        total = np.zeros(2, dtype=np.float32)
        for _ in range(10):
            plain.step_async(action)
            obs_p, r, done_p, _ = plain.step_wait()
            total += r
        assert np.array_equal(obs_h, obs_p) and np.array_equal(r_h, total) and np.array_equal(done_h, done_p)
        assert list(done_h) == [step == 100] * 2
    assert all("episode" in info for info in infos)
    assert infos[0]["episode"]["l"] == 1000  # samples, as the plant ran them


def test_samples_per_action_follow_the_machine_rate():
    assert sample_rate(gym.make("lcgym/IX-v1", **SHORT)) == 500.0
    assert hold_samples(gym.make("lcgym/IX-v1", **SHORT)) == 10
    assert hold_samples(gym.make("lcgym/EMPS-v0", n_references=1, duration=2.0)) == 20
    assert hold_samples(gym.make("lcgym/IX-v1", **SHORT), 2000.0) == 1  # faster than the plant: every sample
    assert hold_samples(object(), None) == 1


@pytest.mark.bad_input
@pytest.mark.parametrize("rate", [0.0, -50.0, float("nan"), float("inf")])
def test_a_bad_agent_rate_is_refused(rate):
    with pytest.raises(ValueError, match="agent_rate"):
        hold_samples(gym.make("lcgym/IX-v1", **SHORT), rate)


@pytest.mark.bad_input
@pytest.mark.parametrize("samples", [0, -1, 2.5, True, "10"])
def test_a_bad_hold_is_refused(samples):
    with pytest.raises(ValueError, match="samples"):
        HoldAction(gym.make("lcgym/IX-v1", **SHORT), samples)


@pytest.mark.bad_input
def test_an_env_without_a_plant_has_no_rate():
    with pytest.raises(ValueError, match="sample rate"):
        hold_samples(gym.make("CartPole-v1"))
