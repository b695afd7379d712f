"""IX-v1's calibration: the rows of the benchmark that describe the machine, beside paper 000's.

The rows (the benchmark's protocol: seed 0, the physical model fitted on the 8 feedback-only
training runs, scored on the 4 validation references, 40 s of moves each):

* feedback only: RMS tracking error per axis (paper Tables IV/V: 0.507 / 0.522 deg);
* physical model: RMS and Inf tracking error (0.089 / 0.117 and 0.351 / 0.279 deg);
* physical model: RMS and Inf of the input residual u - f (Tables II/III: 0.219 / 0.321 and
  1.877 / 1.131 V).

Only these rows are calibrated; the PGNN's rows are an outcome (``benchmarks/pgnn_tables.py``).

Run:
    .venv/bin/python studies/calibrate_ix.py                 # IX-v1 and IX-v0 beside the paper (10 s)
    .venv/bin/python studies/calibrate_ix.py --seeds 0,1,2   # the same rows on other seeds
    .venv/bin/python studies/calibrate_ix.py --sensitivity 1.2   # which knob moves which row (40 s)
    .venv/bin/python studies/calibrate_ix.py --plot results/ix_v1_calibration.png

How IX-v1 was chosen: by hand, on seed 0, from v0, one mechanism per row (``--sensitivity``
shows each knob's effect). The feedback-only error fixed the propeller's kp; the roll's residual
and tracking error its guidance friction and cable spring (the spring alone put the roll's Inf at
the ends of its range); the Inf rows a stiction breakaway on the propeller; the propeller's
residual RMS its derivative low-pass (encoder chatter) and gear harmonic. Beside the rows, the
propeller's split between static and dynamic error was kept near the paper's (Figs. 8, 9: the
network learns the position-dependent friction, not the stiction after standstill): a first choice
whose breakaway was long (2 V below 0.2 deg/s) met all ten rows but left a static function of the
reference only 1.24x below the physical model on the propeller, where the paper's PGNN gets
1.93x; the propeller's sliding friction was raised and its breakaway made short and stiff instead
(printed: the plant's own static feedforward, ``IXPlant.static_model``). Seeds 1 and 2 were looked
at after the choice, not used for it. ``V1_SIZES`` and ``V1_GAINS`` (in
``lcgym/systems/ix/plant.py``) say what changed against v0.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from tqdm import tqdm

from lcgym.methods import PhysicalFeedforward
from lcgym.systems import SimulationDiverged
from lcgym.systems.ix import IX
from lcgym.systems.ix.plant import V1_GAINS, V1_SIZES, FeedbackGains, HiddenEffectSizes, IXPlant
from lcgym.systems.ix.references import reference_set

PAPER = {  # (propeller, roll), paper 000 Tables II-V
    "feedback only: tracking RMS [deg]": (0.507, 0.522),
    "physical model: tracking RMS [deg]": (0.089, 0.117),
    "physical model: tracking Inf [deg]": (0.351, 0.279),
    "physical model: residual RMS [V]": (0.219, 0.321),
    "physical model: residual Inf [V]": (1.877, 1.131),
}
TOLERANCE = 0.25  # the acceptance: every row within 25 % of the paper

# knob -> (where, fields): an effect-size knob scales HiddenEffectSizes fields (several share one
# factor), a gain knob one entry of FeedbackGains' per-axis tuples
KNOBS = {
    "roll guidance friction": ("sizes", ("roll_normal_cos", "roll_normal_cos_roll", "roll_normal_sin")),
    "roll cable spring": ("sizes", ("roll_spring",)),
    "roll Stribeck rise": ("sizes", ("roll_stribeck",)),
    "propeller breakaway (Stribeck rise)": ("sizes", ("propeller_stribeck",)),
    "propeller gear harmonic": ("sizes", ("propeller_harmonic", "propeller_harmonic_2")),
    "propeller guidance friction": ("sizes", ("propeller_normal_cos",)),
    "propeller kp": ("gains", ("kp", 0)),
    "propeller kd": ("gains", ("kd", 0)),
    "propeller derivative low-pass": ("gains", ("f_lp", 0)),
    "roll kp": ("gains", ("kp", 1)),
    "roll kd": ("gains", ("kd", 1)),
}
SHORT = ("fb RMS", "RMS", "Inf", "res RMS", "res Inf")


def machine_rows(plant: IXPlant, seed: int = 0) -> dict[str, np.ndarray]:
    """The rows of ``PAPER`` on ``plant``, by the benchmark's protocol (see the module docstring)."""
    train = plant.run(reference_set("train", seed))
    validation = reference_set("validation", seed)
    physical = PhysicalFeedforward(system="ix").fit(train)
    ffs = [physical.feedforward(r) for r in validation]
    with_model = plant.run(validation, ffs)
    feedback_only = plant.run(validation)
    e_fb = np.degrees(np.concatenate([t.error for t in feedback_only]))
    e = np.degrees(np.concatenate([t.error for t in with_model]))
    eps = np.concatenate([t.u - f for t, f in zip(with_model, ffs, strict=True)])
    rms = lambda x: np.sqrt(np.mean(x * x, axis=0))  # noqa: E731
    values = (rms(e_fb), rms(e), np.abs(e).max(axis=0), rms(eps), np.abs(eps).max(axis=0))
    return dict(zip(PAPER, values, strict=True))


def static_oracle(plant: IXPlant, seed: int = 0) -> np.ndarray:
    """RMS tracking error [deg] per axis on the validation references with the plant's own static
    feedforward (``IXPlant.static_model``): what a static function of the PGNN's inputs can reach."""
    validation = reference_set("validation", seed)
    oracle = plant.static_model(IX)
    e = np.degrees(np.concatenate([t.error for t in plant.run(validation, [oracle.predict(r) for r in validation])]))
    return np.sqrt(np.mean(e * e, axis=0))


def print_rows(title: str, rows: dict[str, np.ndarray]) -> bool:
    """Print the rows beside the paper's; True when every one is within TOLERANCE."""
    print(f"\n{title}")
    print(f"{'row':38s} {'propeller':>9s} {'paper':>7s} {'ratio':>6s}   {'roll':>9s} {'paper':>7s} {'ratio':>6s}")
    ok = True
    for name, paper in PAPER.items():
        cells = []
        for a in range(2):
            ratio = rows[name][a] / paper[a]
            inside = abs(ratio - 1) <= TOLERANCE
            ok &= inside
            cells.append(f"{rows[name][a]:9.3f} {paper[a]:7.3f} {ratio:6.2f}{' ' if inside else '*'}")
        print(f"{name:38s} {'  '.join(cells)}")
    print("all rows within 25 % of the paper" if ok else "* outside 25 % of the paper")
    return ok


def build(knob: str, factor: float, sizes: HiddenEffectSizes = V1_SIZES, gains: FeedbackGains = V1_GAINS) -> IXPlant:
    """IX-v1's plant with one knob's fields multiplied by ``factor``."""
    where, what = KNOBS[knob]
    if where == "sizes":
        sizes = dataclasses.replace(sizes, **{f: getattr(sizes, f) * factor for f in what})
    else:
        values = list(getattr(gains, what[0]))
        values[what[1]] *= factor
        gains = dataclasses.replace(gains, **{what[0]: tuple(values)})
    return IXPlant(effects=sizes.effects(), gains=gains)


def sensitivity(seed: int, factor: float) -> None:
    """Each row's change [%] when one knob of IX-v1 is multiplied by ``factor``: what moves what."""
    base = machine_rows(IXPlant.of_version("v1"), seed)
    print(f"\nsensitivity, seed {seed}: change of each row [%] when a knob is multiplied by {factor:g}")
    head = "  ".join(f"{s:>8s}" for s in SHORT)
    print(f"{'knob':38s} propeller: {head}   roll: {head}")
    for knob in tqdm(KNOBS, leave=False):
        try:
            rows = machine_rows(build(knob, factor), seed)
        except SimulationDiverged as exc:
            tqdm.write(f"{knob:38s} diverged: {exc}")
            continue
        cells = ["  ".join(f"{100 * (rows[k][a] / base[k][a] - 1):+8.1f}" for k in PAPER) for a in range(2)]
        tqdm.write(f"{knob:38s}            {cells[0]}         {cells[1]}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0", help="comma-separated seeds (default 0, the acceptance's)")
    parser.add_argument("--sensitivity", type=float, metavar="FACTOR",
                        help="print how each row moves when each knob of IX-v1 is multiplied by FACTOR (40 s)")
    parser.add_argument("--plot", metavar="PNG", help="save the tracking errors and residuals of seed 0 here")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    if args.sensitivity:
        sensitivity(seeds[0], args.sensitivity)
        return
    for seed in seeds:
        for version in ("v1", "v0"):
            plant = IXPlant.of_version(version)
            rows = machine_rows(plant, seed)
            print_rows(f"IX-{version}, seed {seed}", rows)
            oracle = static_oracle(plant, seed)
            ratio = rows["physical model: tracking RMS [deg]"] / oracle
            print(f"(not calibrated on) the plant's static feedforward: tracking RMS {oracle[0]:.3f} / {oracle[1]:.3f} deg, "
                  f"physical / static {ratio[0]:.2f}x / {ratio[1]:.2f}x (paper: PGNN 1.93x / 4.03x)")
    if args.plot:
        plot(args.plot)


def plot(path: str) -> None:
    """Fig. 9's view on IX-v1: tracking error of feedback only and of the physical model, and the
    physical model's residual, on the first validation reference of seed 0."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plant = IXPlant.of_version("v1")
    physical = PhysicalFeedforward(system="ix").fit(plant.run(reference_set("train", 0)))
    ref = reference_set("validation", 0)[0]
    ff = physical.feedforward(ref)
    with_model, feedback_only = plant.run(ref, ff), plant.run(ref)
    fig, axes = plt.subplots(3, 2, figsize=(12, 8), sharex=True)
    for a, name in enumerate(plant.axes):
        speed = np.gradient(ref.positions[:, a]) * plant.fs
        axes[0, a].plot(with_model.t, np.degrees(feedback_only.error[:, a]), lw=0.7, label="feedback only")
        axes[1, a].plot(with_model.t, np.degrees(with_model.error[:, a]), lw=0.7, color="C1", label="physical model")
        axes[2, a].plot(with_model.t, with_model.u[:, a] - ff[:, a], lw=0.5, color="C2", label="residual u - f")
        for row, scale in ((0, 1.0), (1, 0.2), (2, 1.0)):
            lim = np.abs(axes[row, a].get_lines()[0].get_ydata()).max()
            axes[row, a].plot(with_model.t, speed / np.abs(speed).max() * lim * scale, "k--", lw=0.5, label="scaled speed")
            axes[row, a].legend(loc="upper right", fontsize=7)
        axes[0, a].set_title(f"{name} (IX-v1, {ref.name})")
        axes[0, a].set_ylabel("error [deg]")
        axes[1, a].set_ylabel("error [deg]")
        axes[2, a].set_ylabel("u - f [V]")
        axes[2, a].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
