"""Method ``rl``: the numpy actor, rollout = replay, budget and cost, cache (and its safety),
training curve, the error-blind policy, SB3 adapter extras, and a benchmark cell."""

import dataclasses
import json

import numpy as np
import pytest
import torch
from stable_baselines3 import PPO, SAC, TD3

from lcgym.envs.sb3 import HideError, make_sb3_vec_env
from lcgym.leaderboard.runner import BenchConfig, run_cell
from lcgym.methods.rl import HYPERPARAMETERS, RLConfig, RLFeedforward, deterministic_actor, ppo_rollout
from lcgym.physics.model import PhysicalModel
from lcgym.systems.ix import IX
from lcgym.systems.ix.env import IXEnv
from lcgym.systems.ix.plant import IX_GAINS, IXPlant
from lcgym.systems.ix.references import reference_set

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def ix_data():
    """A short IX task: 2 training references of 4 s of moves, 1 validation reference."""
    bench = IX.make_bench()
    train = bench.references("train", 0, 2, 4.0)
    val = bench.references("validation", 0, 1, 4.0)
    return bench, bench.run(train), val


def trained(ix_data, tmp_path, **config):
    bench, trials, val = ix_data
    cfg = RLConfig(**{"total_steps": 2048, "cache_dir": str(tmp_path), "safeguard": False,
                      "hyperparameters": {"n_steps": 128, "batch_size": 256, "n_epochs": 2}, **config})
    return RLFeedforward(cfg, system=IX).fit(trials).learn(bench.plant, val[0])


@pytest.mark.parametrize("algorithm", [PPO, SAC, TD3])
def test_numpy_actor_equals_sb3_predict(algorithm):
    env = IXEnv(references="validation", base_feedforward="physical", n_references=1, duration=4.0)
    model = algorithm("MlpPolicy", env, seed=1, device="cpu", policy_kwargs=dict(net_arch=[16, 16]))
    if algorithm is PPO:  # a mean far from zero, so that clipping to the bounds is exercised too
        torch.nn.init.normal_(model.policy.action_net.weight, std=3.0)
    act = deterministic_actor(model)
    obs = np.random.default_rng(0).normal(scale=3.0, size=(40, env.observation_space.shape[0])).astype(np.float32)
    expected = model.predict(obs, deterministic=True)[0]
    got = np.array([act(o) for o in obs])
    np.testing.assert_allclose(got, expected, atol=1e-5)
    assert np.any(np.abs(got) > 0.01)  # not a trivially zero policy


def test_replay_of_the_rollout_is_the_rollout(ix_data, tmp_path):
    bench, _, val = ix_data
    rl = trained(ix_data, tmp_path)
    rollout = rl.rollouts_[val[0].name]
    ff = rl.feedforward(val[0])
    replay = bench.run(val, [ff])[0]
    np.testing.assert_array_equal(replay.pos, rollout.pos)
    np.testing.assert_array_equal(replay.u, rollout.u)
    residual = ff - rl.base_.predict(val[0].positions)
    assert np.all(residual[0] == 0) and np.all(np.abs(residual) <= 1.0 + 1e-9) and np.any(residual != 0)


def test_budget_and_cost(ix_data, tmp_path):
    bench, trials, val = ix_data
    rl = trained(ix_data, tmp_path)
    steps = rl.record_["env_steps"]
    assert steps >= 2048 and rl.cost_.env_steps == steps + val[0].n_samples  # training + one rollout
    assert rl.cost_.plant_trials == rl.record_["episodes"] + 1
    rl.learn(bench.plant, val[0])  # a second reference: one more rollout, no training
    assert rl.cost_.env_steps == steps + 2 * val[0].n_samples
    samples = sum(t.ref.shape[0] for t in trials)
    by_passes = RLFeedforward(RLConfig(passes=2.5), system=IX).fit(trials)
    assert by_passes.budget() == round(2.5 * samples)


@pytest.mark.fault
def test_cache_reuses_verified_models_only(ix_data, tmp_path):
    bench, trials, val = ix_data
    first = trained(ix_data, tmp_path)
    key = first.record_["key"]
    assert {p.suffix for p in tmp_path.iterdir() if p.stem == key} >= {".zip", ".csv", ".json"}
    second = trained(ix_data, tmp_path)
    assert second.record_ == json.loads((tmp_path / f"{key}.json").read_text())
    assert second.cost_.env_steps == first.cost_.env_steps and second.cost_.cached_seconds == first.record_["seconds"]
    np.testing.assert_array_equal(second.feedforward(val[0]), first.feedforward(val[0]))
    other = trained(ix_data, tmp_path, seed=1)  # another configuration: another key, trained anew
    assert other.record_["key"] != key and other.cost_.cached_seconds == 0
    zip_path = tmp_path / f"{key}.zip"
    zip_path.write_bytes(zip_path.read_bytes()[:-10] + b"0123456789")  # tampered or corrupt
    with pytest.raises(ValueError, match="does not match its record"):
        trained(ix_data, tmp_path)
    no_cache = tmp_path / "off"
    trained(ix_data, no_cache, cache=False)
    assert not no_cache.exists()


def test_training_curve_rows_and_plot(tmp_path):
    short = reference_set("train", 0, 1, 0.5)  # episodes of about 1,600 samples
    bench = IX.make_bench()
    trials = bench.run(short)
    rl = RLFeedforward(RLConfig(total_steps=8192, num_envs=2, cache_dir=str(tmp_path),
                                hyperparameters={"n_steps": 512, "batch_size": 512, "n_epochs": 1}), system=IX)
    rl.fit(trials).learn(bench.plant, short[0])
    curve = rl.curve_
    assert list(curve.columns) == ["env_steps", "return", "rms_propeller_deg", "rms_roll_deg"]
    assert len(curve) >= 8192 // short[0].n_samples - 2
    assert curve["env_steps"].is_monotonic_increasing
    assert np.all(curve[["rms_propeller_deg", "rms_roll_deg"]].to_numpy() > 0) and np.all(curve["return"] < 0)
    png = rl.plot_curve(tmp_path / "curve.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / f"{rl.record_['key']}.png").is_file()


def test_training_leaves_no_folder_in_the_temp_dir(ix_data, tmp_path, monkeypatch):
    import tempfile
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    trained(ix_data, tmp_path / "cache", cache=False)
    assert list(temp.glob("SB3-*")) == []  # SB3's default logger made an SB3-<date> folder per training


def test_error_blind_policy_is_a_pure_feedforward(ix_data, tmp_path):
    bench, trials, val = ix_data
    rl = trained(ix_data, tmp_path, observe_error=False)
    assert rl.cost_.plant_trials == rl.record_["episodes"]  # the rollout ran no counted plant trial
    ff = rl.feedforward(val[0])
    stiff = IXPlant(gains=dataclasses.replace(IX_GAINS, kp=(340.0, 240.0)))
    rl.learn(stiff, val[0])  # another plant, other errors: the same feedforward
    np.testing.assert_array_equal(rl.feedforward(val[0]), ff)


def test_sb3_adapter_reports_episode_rms_and_hides_error():
    refs = reference_set("train", 0, 1, 0.5)
    venv = make_sb3_vec_env("lcgym/IX-v0", num_envs=1, references=refs, episode_steps=None)
    env = IXEnv(references=refs, version="v0", episode_steps=None)
    venv.reset()
    env.reset(options={"reference": 0})
    zero = np.zeros((1, 2), dtype=np.float32)
    for _ in range(refs[0].n_samples):
        _, reward, done, infos = venv.step(zero)
        _, _, _, _, info = env.step(zero[0])
    assert done[0]
    np.testing.assert_allclose(infos[0]["tracking_rms"], np.sqrt(np.mean(info["trial"].error ** 2, axis=0)))
    assert infos[0]["episode"]["l"] == refs[0].n_samples
    hidden = HideError(make_sb3_vec_env("lcgym/IX-v0", num_envs=2, references=refs), IX.bench.observation_error)
    obs = hidden.reset()
    for _ in range(20):
        obs, *_ = hidden.step(np.ones((2, 2), dtype=np.float32))
    assert np.all(obs[:, 34:36] == 0) and np.any(obs[:, :34] != 0)


def test_env_takes_a_fitted_model_as_base():
    refs = reference_set("validation", 0, 1, 4.0)
    model = PhysicalModel(IX).fit(IXPlant().run(reference_set("train", 3, 1, 4.0)))
    env = IXEnv(references=refs, base_feedforward=model)
    np.testing.assert_allclose(env.task.base_ff[0, : refs[0].n_samples], model.predict(refs[0].positions))
    assert env.action_space.high[0] == 1.0
    with pytest.raises(ValueError, match="fitted model"):
        IXEnv(references=refs, base_feedforward=object())


@pytest.mark.bad_input
def test_config_errors():
    with pytest.raises(ValueError, match="algorithm"):
        RLConfig(algorithm="dqn")
    with pytest.raises(ValueError, match="passes"):
        RLConfig(passes=0.0)
    with pytest.raises(ValueError, match="total_steps"):
        RLConfig(total_steps=0)
    for rate in (-50.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="agent_rate"):
            RLConfig(agent_rate=rate)


def test_the_agent_rate_is_the_machines_unless_given():
    """The IX's agent acts at 50 Hz (its settings): 10 samples of 2 ms per action; 0 or a rate above
    the plant's acts on every sample; the FlexArm, which sets none, on every sample."""
    from lcgym.systems.flexarm import FLEXARM

    def hold(config, system):
        rl = RLFeedforward(config, system=system)
        rl.system_ = system
        return rl.hold()

    assert hold(RLConfig(), IX) == 10 and hold(RLConfig(agent_rate=100.0), IX) == 5
    assert hold(RLConfig(agent_rate=0.0), IX) == 1 and hold(RLConfig(agent_rate=1e4), IX) == 1
    assert hold(RLConfig(), FLEXARM) == 1
    with pytest.raises(RuntimeError, match="fit"):
        RLFeedforward(system=IX).learn(IXPlant(), reference_set("validation", 0, 1, 4.0)[0])


def test_bench_cell_counts_env_steps(monkeypatch, tmp_path):
    monkeypatch.setenv("LCGYM_CACHE", str(tmp_path))
    config = BenchConfig(methods=("rl",), systems=("ix",), seeds=(0,), n_train=1, n_validation=1, duration=2.0)
    rows, trace = run_cell("ix", "rl", 0, config)
    assert {r["status"] for r in rows} == {"ok"}, rows[0].get("error")
    steps, trials = {r["env_steps"] for r in rows}, {r["plant_trials"] for r in rows}
    bench = IX.make_bench()
    train, val = (bench.references(s, 0, 1, 2.0)[0].n_samples for s in ("train", "validation"))
    budget = round(RLConfig().on(IX).passes * train)
    # the IX's agent acts at 50 Hz: each action held 10 samples, and the last of an episode's holds
    # shorter (the reference's samples are not a multiple of 10); PPO trains in whole rollouts of
    # n_steps agent steps per env, 8 envs, which run their episodes in step
    hold = 10
    agent_steps = -(-budget // hold)  # the budget counts samples, rounded up to whole holds
    n_steps = ppo_rollout(HYPERPARAMETERS["ppo"]["n_steps"], HYPERPARAMETERS["ppo"]["batch_size"], agent_steps, 8)
    assert n_steps < HYPERPARAMETERS["ppo"]["n_steps"]  # one short rollout covers this small budget
    per_env = -(-agent_steps // (8 * n_steps)) * n_steps  # agent steps per env
    per_episode = -(-train // hold)
    trained_steps = 8 * (per_env * hold - (per_env // per_episode) * (per_episode * hold - train))
    # training; the safeguard's rollouts on the training reference (base alone, the policy, and the
    # policy masked where it was worse, if it was on one axis only); one rollout per evaluated reference
    guard = steps.pop() - (trained_steps + train + val)
    assert guard in (2 * train, 3 * train)
    assert len(trials) == 1 and trials.pop() >= 1 + 8 + 2 + 2  # shared run, episodes begun, safeguard, rollouts
    assert len({r["note"] for r in rows}) == 1
    assert trace is not None and any(tmp_path.rglob("*.zip"))


def test_trains_under_a_callers_float64_and_threads_and_restores_them(ix_data, tmp_path):
    before = torch.get_default_dtype(), torch.get_num_threads()
    torch.set_default_dtype(torch.float64)
    try:
        rl = trained(ix_data, tmp_path, cache=False)
        assert torch.get_default_dtype() == torch.float64 and torch.get_num_threads() == before[1]
        assert np.all(np.isfinite(rl.feedforward(ix_data[2][0])))
    finally:
        torch.set_default_dtype(before[0])


def _constant_policy(residual) -> PPO:
    """A PPO agent whose deterministic action is the constant ``residual`` [V] (zero weights)."""
    env = IXEnv(references="validation", base_feedforward="physical", n_references=1, duration=4.0)
    model = PPO("MlpPolicy", env, seed=0, device="cpu", policy_kwargs=dict(net_arch=[8]))
    with torch.no_grad():
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.copy_(torch.tensor(residual, dtype=torch.float32))
    return model


def test_safeguard_drops_a_residual_that_raises_the_training_error(ix_data):
    """A policy that adds 0.6 V to the propeller's feedforward raises its training error: the
    safeguard drops it there, the base acts alone (the feedforward is the base's, exactly), the note
    says so, and its rollouts are counted."""
    bench, trials, val = ix_data
    rl = RLFeedforward(RLConfig(cache=False), system=IX).fit(trials)
    rl.model_ = _constant_policy([0.6, 0.0])
    rl.learn(bench.plant, val[0])
    assert not rl.kept_[0]
    assert rl.safeguard_["policy"][0] > rl.safeguard_["base"][0]
    assert "residual dropped on propeller" in rl.note_
    np.testing.assert_array_equal(rl.feedforward(val[0]), rl.base_.predict(val[0].positions))
    samples = sum(t.ref.shape[0] for t in trials)
    assert rl.cost_.env_steps >= 2 * samples + val[0].n_samples  # base and policy on each training reference


def test_safeguard_keeps_a_residual_that_does_not_raise_the_error(ix_data):
    """The control: a policy whose residual is zero is no worse than the base, and is kept."""
    bench, trials, val = ix_data
    rl = RLFeedforward(RLConfig(cache=False), system=IX).fit(trials)
    rl.model_ = _constant_policy([0.0, 0.0])
    rl.learn(bench.plant, val[0])
    assert rl.kept_.all() and rl.note_ == ""
    assert rl.safeguard_["policy"] == rl.safeguard_["base"]


def test_safeguard_judges_each_training_reference(ix_data):
    """A residual better over all training references but worse on one of them is dropped on that
    axis (the per-reference rule: such a policy did not generalize on the IX); kept where it is
    better on every reference. The rollouts are replaced by given RMS figures (references x axes)."""
    bench, trials, val = ix_data
    rl = RLFeedforward(RLConfig(cache=False), system=IX).fit(trials)
    rl.model_ = _constant_policy([0.0, 0.0])
    n = len(rl.training_)
    base = np.ones((n, 2))
    policy = np.full((n, 2), 0.5)
    policy[-1, 0] = 1.01  # worse on the last reference only: over all of them, far better
    figures = {(False, False): base, (True, True): policy, (False, True): np.where([[1, 0]], base, policy)}
    rl._training_rms = lambda plant, kept: figures[tuple(bool(k) for k in kept)]
    rl._safeguard(bench.plant)
    assert rl.kept_.tolist() == [False, True]
    assert rl.safeguard_["policy"][0] < rl.safeguard_["base"][0]  # better on the whole: dropped all the same
    assert rl.safeguard_["references_worse"] == 1
    assert f"residual dropped on propeller (it raised the tracking error on 1 of {n} training references)" in rl.note_


def test_ppo_rollout_no_longer_than_the_budget():
    assert ppo_rollout(2048, 64, 10_000_000, 8) == 2048  # a large budget: SB3's rollout
    assert ppo_rollout(2048, 64, 6_000, 8) == 752  # 750 per env, rounded up to whole minibatches
    assert ppo_rollout(2048, 64, 2_100, 4) * 4 % 64 == 0 and ppo_rollout(2048, 64, 2_100, 4) * 4 >= 2_100
    assert RLConfig().agent_kwargs(6_000, 8)["n_steps"] == 752
    assert RLConfig(hyperparameters={"n_steps": 100}).agent_kwargs(6_000, 8)["n_steps"] == 100  # given: kept
    assert RLConfig(algorithm="sac").agent_kwargs(6_000, 8).get("n_steps") is None
