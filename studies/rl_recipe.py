"""The reinforcement-learning recipe of docs/environments.md, run on every machine: PPO and SAC of
stable-baselines3 with their default settings on each machine's vector env (``make_sb3_vec_env``,
4 envs, episodes of 1000 samples, normalized actions), residual on the machine's base feedforward,
the agent acting at ``AGENT_RATES`` (``envs.hold``: each action held for several samples; steps are
agent steps); ``--agent-rate HZ`` sets one rate for all, 0 acts on every sample.
It records each algorithm's learning curves: the mean return of the training episodes ended in
each tenth of the budget, and the return of the deterministic policy on one whole validation
reference, ten times over training, against the base feedforward alone's (zero action); it prints
when the first episodes were logged, and plots the curves.

    .venv/bin/python studies/rl_recipe.py                  # docs/img/rl_recipe.png, about 20 min here
    .venv/bin/python studies/rl_recipe.py --ppo-steps 20000 --sac-steps 4000 --machines IX-v1
    .venv/bin/python studies/rl_recipe.py --machines IX-v1 --algorithms ppo --set learning_rate=1e-3 --out /tmp/ix.png
    .venv/bin/python studies/rl_recipe.py --machines IX-v1 --algorithms ppo --agent-rate 0 --out /tmp/ix_every_sample.png
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from lcgym.envs.hold import AGENT_RATE, HoldAction, hold_samples

MACHINES = {"IX-v1": "physical", "FlexArm-v1": "basic", "TwoLink-v0": "physical", "EMPS-v0": "physical"}
AGENT_RATES = {"IX-v1": AGENT_RATE, "FlexArm-v1": None, "TwoLink-v0": AGENT_RATE, "EMPS-v0": AGENT_RATE}
"""Hz at which the recipe's agents act (None: every sample). 50 Hz (each action held 10 samples on
the IX, 20 on the 1 kHz machines) on the rigid machines, whose feedforward is as smooth as their
references; every sample (1 kHz) on the FlexArm, whose residual shapes joint resonances at 10-15 Hz
that a 50 Hz hold cannot (measured, docs/environments.md: held 20 samples, its exploration excites
them, episodes end ``terminated`` and PPO's policy does not move)."""
SHORT = {"IX-v1": dict(n_references=4, duration=20.0), "FlexArm-v1": dict(n_references=4),
         "TwoLink-v0": dict(n_references=4, duration=10.0), "EMPS-v0": dict(n_references=4, duration=10.0)}


def recipe(env_id: str, algorithm: str, steps: int, seed: int = 0, evaluations: int = 10,
           agent_kwargs: dict | None = None, agent_rate: float | None = AGENT_RATE, **env_kwargs):
    """The recipe of docs/environments.md: trains ``algorithm`` for ``steps`` agent steps and every
    ``steps / evaluations`` steps scores its deterministic policy on one whole validation reference.
    ``agent_kwargs``: settings other than SB3's defaults, passed to the agent; ``agent_rate`` [Hz]:
    how often the agent acts (``envs.hold``; None: every sample). Returns (model, finished
    training episodes as (agent step, return), evaluations as (agent step, return))."""
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import BaseCallback

    from lcgym.envs.sb3 import make_sb3_vec_env

    torch.set_num_threads(1)  # small networks: one thread is fastest, and it does not stall a busy machine
    venv = make_sb3_vec_env(env_id, agent_rate=agent_rate, **env_kwargs)  # 4 envs, actions in [-1, 1], episodes of 1000 samples
    check = validation_env(env_id, agent_rate, **env_kwargs)
    episodes: list[tuple[int, float]] = []
    scores: list[tuple[int, float]] = [(0, evaluate(None, check))]

    class Record(BaseCallback):
        def _on_step(self) -> bool:
            episodes.extend((self.num_timesteps, info["episode"]["r"]) for info in self.locals["infos"] if "episode" in info)
            if self.num_timesteps // (steps // evaluations) > len(scores) - 1:
                scores.append((self.num_timesteps, evaluate(self.model, check)))
            return True

    Agent = {"ppo": PPO, "sac": SAC}[algorithm]
    model = Agent("MlpPolicy", venv, seed=seed, device="cpu", **(agent_kwargs or {}))  # SB3's defaults unless given
    model.learn(steps, callback=Record())
    venv.close()
    return model, episodes, scores


def validation_env(env_id: str, agent_rate: float | None = AGENT_RATE, **env_kwargs):
    """One whole validation reference as a single episode (``episode_steps=None``), its actions
    held like the training envs'."""
    import gymnasium as gym

    kwargs = {k: v for k, v in env_kwargs.items() if k != "n_references"}
    env = gym.make(env_id, references="validation", n_references=1, episode_steps=None, **kwargs)
    return HoldAction(env, hold_samples(env, agent_rate))


def evaluate(model, env) -> float:
    """Return of one deterministic episode of ``model`` on ``env`` (None: the base alone, zero action)."""
    obs, _ = env.reset(seed=0, options={"reference": 0})
    total, done = 0.0, False
    while not done:
        action = np.zeros(env.action_space.shape, dtype=np.float32) if model is None else \
            model.predict(obs, deterministic=True)[0]
        obs, reward, terminated, truncated, _ = env.step(action)
        total, done = total + reward, terminated or truncated
    return total


def blocks(episodes: list[tuple[int, float]], total: int, n: int = 10) -> list[tuple[int, float]]:
    """Mean return of the episodes that ended in each of ``n`` equal blocks of env steps."""
    edges = np.linspace(0, total, n + 1)
    steps = np.array([s for s, _ in episodes])
    returns = np.array([r for _, r in episodes])
    out = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        inside = (steps > lo) & (steps <= hi)
        if inside.any():
            out.append((int(hi), float(returns[inside].mean())))
    return out


FLOOR = 3.0
"""The validation panels show returns down to -FLOOR times the base alone's."""


def plot(curves: dict, path: Path) -> None:
    """Per machine: the training episodes' returns (mean per block of steps, per step of the
    episode) and the deterministic policy's validation return against the base alone's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(2, len(curves), figsize=(4.6 * len(curves), 6.4), squeeze=False)
    for col, (machine, runs) in enumerate(curves.items()):
        top, bottom = axs[0, col], axs[1, col]
        for algorithm, (episodes, scores) in runs.items():
            color = {"ppo": "C0", "sac": "C1"}[algorithm]
            b = blocks(episodes, max((s for s, _ in episodes), default=1))
            top.plot([x for x, _ in b], [y for _, y in b], "-o", ms=3, color=color, label=algorithm.upper())
            base = abs(scores[0][1])
            bottom.plot([s for s, _ in scores], [v / base for _, v in scores], "-o", ms=3, color=color,
                        label=algorithm.upper())
        bottom.axhline(-1.0, color="k", ls="--", lw=1, label="base alone")
        ratios = [v / abs(scores[0][1]) for _, scores in runs.values() for _, v in scores]
        low = min(ratios)
        if low < -FLOOR:  # a diverging run would hide the others: clip, and say so
            top_of = max(max(ratios), -1.0)
            bottom.set_ylim(-FLOOR, top_of + 0.05 * (top_of + FLOOR))
            bottom.text(0.02, 0.02, f"clipped at -{FLOOR:g}; lowest {low:.3g}", transform=bottom.transAxes, fontsize=7)
        top.set_title(f"lcgym/{machine}", fontsize=10)
        top.set_ylabel("training episode return\n(mean per tenth of the steps)", fontsize=8)
        bottom.set_ylabel("validation return / |base alone's|\n(higher is better)", fontsize=8)
        bottom.set_xlabel("agent steps")
        top.legend(fontsize=7)
        bottom.legend(fontsize=7)
    fig.tight_layout()
    from lcgym.data import atomic_write

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))


def number(text: str) -> int | float:
    """A --set value: an integer where it reads as one (n_steps=512), else a float (1e-3)."""
    try:
        return int(text)
    except ValueError:
        return float(text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--machines", default=",".join(MACHINES))
    parser.add_argument("--ppo-steps", type=int, default=65_536)
    parser.add_argument("--sac-steps", type=int, default=12_000)
    parser.add_argument("--out", default="docs/img/rl_recipe.png")
    parser.add_argument("--algorithms", default="ppo,sac")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a setting other than SB3's default, for every agent (a number: learning_rate=1e-3, n_steps=512)")
    parser.add_argument("--agent-rate", type=float, default=None,
                        help="Hz at which every agent acts, each action held for the samples between "
                             "(0: every sample; default: AGENT_RATES, per machine)")
    parser.add_argument("--replot", type=Path, help="draw --out from a run's JSON record instead of training")
    args = parser.parse_args()
    if args.replot:
        plot(json.loads(args.replot.read_text())["curves"], Path(args.out))
        return
    import lcgym  # noqa: F401

    machines = args.machines.split(",")
    curves: dict = {m: {} for m in machines}
    summary = {}
    agent_kwargs = {key: number(value) for key, value in (item.split("=", 1) for item in args.set)}
    jobs = [(m, a, args.ppo_steps if a == "ppo" else args.sac_steps) for m in machines for a in args.algorithms.split(",")]
    for machine, algorithm, steps in tqdm(jobs, desc="recipe"):
        kwargs = dict(base_feedforward=MACHINES[machine], **SHORT[machine])
        rate = AGENT_RATES[machine] if args.agent_rate is None else (args.agent_rate or None)
        t0 = time.perf_counter()
        _, episodes, scores = recipe(f"lcgym/{machine}", algorithm, steps, agent_kwargs=agent_kwargs,
                                     agent_rate=rate, **kwargs)
        curves[machine][algorithm] = (episodes, scores)
        b = blocks(episodes, steps)
        summary[f"{machine} {algorithm}"] = {
            "steps": steps, "agent_rate_hz": rate, "seconds": round(time.perf_counter() - t0, 1), "episodes": len(episodes),
            "first_episode_at_step": episodes[0][0] if episodes else None,
            "episodes_logged_by_10000": sum(1 for s, _ in episodes if s <= 10_000),
            "training_return_first_last_block": [round(b[0][1], 1), round(b[-1][1], 1)] if b else None,
            "validation_return_base_alone": round(scores[0][1], 1),
            "validation_return_by_step": [(s, round(v, 1)) for s, v in scores[1:]],
        }
        tqdm.write(json.dumps(summary[f"{machine} {algorithm}"]))
    plot(curves, Path(args.out))
    from lcgym.data import atomic_write

    record = Path(args.out).with_suffix(".json")  # the figures, and the curves to redraw them with --replot
    atomic_write(record, lambda tmp: Path(tmp).write_text(json.dumps({"summary": summary, "curves": curves})))
    print(json.dumps(summary, indent=1))
    print(f"wrote {args.out} and {record}")


if __name__ == "__main__":
    main()
