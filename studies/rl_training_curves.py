"""The ``rl`` cells' training curves of a benchmark run, one panel per machine.

Each trained model in the RL cache (``$LCGYM_CACHE/rl``, ``methods.rl``) has its training curve
beside it (``<key>.csv``: per training episode, run with the exploring policy, the RMS tracking
error per scored axis). This draws them all, one shade per cell, the machine told by its axes.

Run:  LCGYM_CACHE=/tmp/cache lcgym bench --out /tmp/run.csv
      .venv/bin/python studies/rl_training_curves.py /tmp/cache/rl docs/img/rl_training_curves.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

MACHINES = {frozenset(("propeller", "roll")): "ix-v1", frozenset(("j2", "j3", "j5")): "flexarm-v1",
            frozenset(("elbow", "shoulder")): "two_link-v0", frozenset(("x",)): "emps_sim-v0"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cache", type=Path, help="the run's RL cache folder ($LCGYM_CACHE/rl)")
    parser.add_argument("out", type=Path, help="the PNG to write")
    args = parser.parse_args()
    curves: dict[str, list[pd.DataFrame]] = {}
    for csv in sorted(args.cache.glob("*.csv"), key=lambda p: p.stat().st_mtime):
        c = pd.read_csv(csv)
        axes = frozenset(col.removeprefix("rms_").rsplit("_", 1)[0] for col in c.columns if col.startswith("rms_"))
        if axes in MACHINES and len(c):
            curves.setdefault(MACHINES[axes], []).append(c)
    if not curves:
        raise SystemExit(f"no training curves of the built-in machines in {args.cache}")
    fig, panels = plt.subplots(1, len(curves), figsize=(5 * len(curves), 3.8), squeeze=False)
    for ax, (name, runs) in zip(panels[0], curves.items(), strict=True):
        for k, c in enumerate(runs):
            for i, col in enumerate([x for x in c.columns if x.startswith("rms_")]):
                label = col.removeprefix("rms_").rsplit("_", 1)[0] if k == 0 else None
                ax.plot(c["env_steps"], c[col], "o", ms=3, color=f"C{i}", alpha=0.9 - 0.25 * k, label=label)
        ax.set_title(f"rl (PPO, default budget) on {name}: {len(runs)} cells", fontsize=9)
        ax.set_xlabel("env steps")
        units = sorted({col.rsplit("_", 1)[1] for c in runs for col in c.columns if col.startswith("rms_")})
        ax.set_ylabel(f"training episode RMS [{', '.join(units)}]")
        ax.set_yscale("log")
        ax.ticklabel_format(axis="x", style="sci", scilimits=(0, 0))
        ax.legend(fontsize=8)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    from lcgym.data import atomic_write

    atomic_write(args.out, lambda tmp: fig.savefig(tmp, dpi=90, format="png"))
    print(args.out, {k: len(v) for k, v in curves.items()})


if __name__ == "__main__":
    main()
