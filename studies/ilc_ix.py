"""ILC on the IX: the tracking error per trial on each validation reference of the benchmark, against
the physical-model feedforward it starts from, and the convergence curve as a plot.

For each seed and validation reference (40 s of moves, as ``lcgym bench``): the physical model is
fitted on the seed's 8 feedback-only training runs; ILC (``lcgym.methods.ilc.method``, default Q and
gain) runs ``--trials`` trials on the reference. Printed per axis: the RMS tracking error [deg] as
the encoders measure it (trial 0 = physical model) after 10 trials and after all, and the true
error of the load angle, which the encoder quantization (propeller: 0.0669 deg counts) does not
limit.

Run:  .venv/bin/python studies/ilc_ix.py [--seeds 0,1,2] [--trials 30] [--plot ilc_ix.png]
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from lcgym.methods.ilc.method import ILCConfig, IterativeLearningControl  # noqa: E402
from lcgym.systems.ix.plant import IXPlant  # noqa: E402
from lcgym.systems.ix.references import reference_set  # noqa: E402


def axis_rms(trial, true: bool = False) -> np.ndarray:
    pos = np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes]) if true else trial.pos
    return np.degrees(np.sqrt(np.mean((trial.ref - pos) ** 2, axis=0)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--trials", type=int, default=30)
    parser.add_argument("--plot", default="ilc_ix.png")
    parser.add_argument("--gain", type=float, default=ILCConfig.gain)
    parser.add_argument("--q-hz", type=float, default=ILCConfig.q_hz)
    args = parser.parse_args()
    plant = IXPlant()
    measured, true, names = [], [], []
    for seed in tqdm([int(s) for s in args.seeds.split(",")], desc="seeds"):
        train = plant.run(reference_set("train", seed, 8, 40.0, plant.fs))
        for ref in reference_set("validation", seed, 4, 40.0, plant.fs):
            config = ILCConfig(trials=args.trials, gain=args.gain, q_hz=args.q_hz)
            ilc = IterativeLearningControl(config, system="ix").fit(train).learn(plant, ref)
            measured.append(np.degrees(ilc.history_[ref.name]))
            true.append(np.degrees(ilc.true_history_[ref.name]))
            names.append(ref.name)
    measured, true = np.array(measured), np.array(true)  # (references, trials + 1, 2) [deg]
    print(f"{'reference':18s} {'axis':9s} {'physical':>9s} {'ILC 10':>8s} {'ratio':>6s} {'ILC ' + str(args.trials):>8s}"
          f"   true: {'physical':>9s} {'ILC 10':>8s} {'ratio':>6s}")
    for k, name in enumerate(names):
        for a, ax in enumerate(("propeller", "roll")):
            m, t = measured[k, :, a], true[k, :, a]
            print(f"{name:18s} {ax:9s} {m[0]:9.4f} {m[10]:8.4f} {m[0] / m[10]:5.1f}x {m[-1]:8.4f}   "
                  f"      {t[0]:9.4f} {t[10]:8.4f} {t[0] / t[10]:5.1f}x")
    for a, ax in enumerate(("propeller", "roll")):
        r = measured[:, 0, a] / measured[:, 10, a]
        rt = true[:, 0, a] / true[:, 10, a]
        rise = (measured[:, 4:, a] / np.minimum.accumulate(measured[:, :, a], axis=1)[:, 3:-1]).max()
        print(f"{ax}: measured error cut {r.min():.1f}-{r.max():.1f}x after 10 trials (median {np.median(r):.1f}x), "
              f"true error {rt.min():.1f}-{rt.max():.1f}x; after trial 3 at most {rise:.2f}x the best trial so far")
    fig, axes = plt.subplots(figsize=(6, 3.5))
    for a, name in enumerate(("propeller", "roll")):
        axes.semilogy(measured[:, :, a].mean(axis=0), marker="o", ms=3, label=f"{name}, measured")
        axes.semilogy(true[:, :, a].mean(axis=0), ls="--", label=f"{name}, true load angle")
    axes.axhline(0.0669 / np.sqrt(12), color="grey", ls=":", label="propeller encoder quantization (RMS)")
    axes.set_xlabel("ILC trial (0: physical-model feedforward)")
    axes.set_ylabel("tracking error RMS [deg]")
    axes.set_title(f"IX, ILC: mean of {len(names)} validation references", fontsize=9)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.plot, dpi=120)
    print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
