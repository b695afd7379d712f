"""ILC on the FlexArm on its physical base (issue 48): the least-squares physical model's
feedforward and joint-torsion offset, then ``trials`` updates of the encoder ILC of
``systems/flexarm/learning.py``, each measured; the kept trial is the best one as the machine's sensors
(motor encoders, flange accelerometer) measure it. Per trial, what the sensors measure (the
load-error estimate of joints 2, 3, 5 and the EE acceleration error) beside what the benchmark
scores from the simulation's truth (load-side tracking error, TCP error in the dynamic and static
periods, EE acceleration error), for the physical model (trial 0), each trial, and the one kept.

Run:  .venv/bin/python studies/ilc_flexarm_base.py [--seeds 0] [--lines 4] [--trials 8] [--plot out.png]
      [--torque motor|lcs|none] [--offset] [--q-hz 6]  (the laws the default was chosen against)
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from tqdm import tqdm

from lcgym.methods.ilc.method import iterate
from lcgym.methods.physical import PhysicalFeedforward
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.flexarm.errors import paper_errors, period_mask
from lcgym.systems.flexarm.learning import ArmILCConfig, ArmLaw, measure, update
from lcgym.systems.flexarm.references import MOVING
from lcgym.systems.learning import Signals

JOINTS = (1, 2, 4)  # j2, j3, j5


def scored(bench, trial, reference) -> dict[str, float]:
    """The benchmark's figures of one trial: load error [mdeg] of j2, j3, j5, TCP [mm] per period, EE [m/s^2]."""
    load = np.degrees(bench.load_error(trial))[:, JOINTS] * 1e3
    parts = paper_errors(bench.plant, trial, reference, np.asarray(trial.ff))
    out = {f"j{j + 1} mdeg": float(np.sqrt(np.mean(load[:, k] ** 2))) for k, j in enumerate(JOINTS)}
    for period in ("dynamic", "static"):
        mask = period_mask(reference, period)
        out[f"TCP {period} mm"] = float(np.sqrt(np.mean(parts["tcp"][mask] ** 2)))
    out["EE m/s^2"] = float(np.sqrt(np.mean(np.sum(parts["ee_acc"] ** 2, axis=1))))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0")
    parser.add_argument("--lines", type=int, default=4, help="validation lines per seed")
    parser.add_argument("--trials", type=int, default=ArmILCConfig().trials)
    parser.add_argument("--torque", default=ArmILCConfig().torque, choices=("motor", "lcs", "none"),
                        help="the torque law (ArmILCConfig.torque)")
    parser.add_argument("--offset", action="store_true", help="also learn the reference offset from the accelerometer")
    parser.add_argument("--q-hz", type=float, default=ArmILCConfig().q_hz, help="the torque's Q corner [Hz]")
    parser.add_argument("--plot", default="", help="save the scored figures per trial to this PNG")
    args = parser.parse_args()
    bench = FLEXARM.make_bench("v1")
    config = replace(ArmILCConfig(), trials=args.trials, torque=args.torque, offset=args.offset, q_hz=args.q_hz)
    rows = []  # (line, trial, measured row, scored dict)
    kept = {}
    lines = [(s, r) for s in map(int, args.seeds.split(",")) for r in bench.references("validation", s, args.lines, 40.0)]
    physical = {}
    for seed, ref in tqdm(lines, desc="lines"):
        if seed not in physical:
            physical[seed] = PhysicalFeedforward(system="flexarm").fit(bench.run(bench.references("train", seed, 8, 40.0)))
        base = physical[seed]
        f0, o0 = base.feedforward(ref), base.reference_offset(ref)
        law = ArmLaw(bench.plant, FLEXARM.nominal, config.trials, config)
        learned = iterate(law.loop(ref, Signals(f0, o0)), ref, config.trials, MOVING)
        history = learned.history
        kept[ref.name] = learned.best
        # replay each trial's signals to score it (the plant is deterministic: the replay is that trial)
        f, o = f0, o0
        for j in range(len(history)):
            trial = bench.run([ref], [f], [o])[0]
            rows.append((ref.name, j, history[j], scored(bench, trial, ref)))
            if j < len(history) - 1:
                err = measure(trial, ref, FLEXARM.nominal, f, o, bench.plant.accel_offset, o0, config.offset_hp_hz)
                f, o = update(FLEXARM.nominal, f, o, err, trial.fs, config, base=f0)
    keys = list(rows[0][3])
    print(f"FlexArm-v1, {len(lines)} validation lines, physical base, {args.trials} updates; RMS over the lines "
          "(measured: the sensors' load-error estimate [mdeg] of j2, j3, j5 and EE [m/s^2]; scored: the truth)")
    print(f"{'trial':>5} | {'measured j2 j3 j5, EE':>30} | " + " ".join(f"{k:>14}" for k in keys))
    names = list(dict.fromkeys(r[0] for r in rows))

    def pooled(values):
        return float(np.sqrt(np.mean(np.square(values))))

    table = {}
    for j in range(args.trials + 1):
        at = [r for r in rows if r[1] == j]
        if len(at) < len(names):
            break
        meas = np.array([r[2] for r in at])
        m = [pooled(np.degrees(meas[:, i]) * 1e3) for i in JOINTS] + [pooled(meas[:, -1])]
        table[j] = {k: pooled([r[3][k] for r in at]) for k in keys}
        print(f"{j:>5} | {' '.join(f'{v:7.4g}' for v in m):>30} | " + " ".join(f"{table[j][k]:14.4g}" for k in keys))
    best = {k: pooled([r[3][k] for r in rows if r[1] == kept[r[0]]]) for k in keys}
    print(f"{'kept':>5} | {'(per line: ' + ', '.join(str(kept[n]) for n in names) + ')':>30} | "
          + " ".join(f"{best[k]:14.4g}" for k in keys))
    print(f"{'ratio':>5} | {'kept / physical':>30} | " + " ".join(f"{best[k] / table[0][k]:14.3f}" for k in keys))
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        for k in keys:
            ax.plot(list(table), [table[j][k] / table[0][k] for j in table], marker="o", label=k)
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.set_xlabel("trial (0: the physical model)")
        ax.set_ylabel("RMS / the physical model's")
        ax.set_title("FlexArm-v1: ILC on the physical base, scored figures per trial")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=100)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
