"""Our versions of paper 000's Tables II-V on the IX plant, the PGNN's training time on the
paper-size data set (N = 1e6), and the acceptance figures of the PGNN issue.

Training data (``--data``): "train" (default): seeded training references of the same kind as
the validation references (random third-order moves, paper 000 V-D: "a new but similar
reference"), as many as make N ~ 1e6 samples; "calibration": the 14 calibration sweeps of V-A
(N = 1.04e6), which cover the operating range but not the validation moves' kinematics. The
physical model is fitted on a feedback-only run of these references; the PGNNs learn from a
second run recorded with that model's feedforward on (``--collect-with physical``, default) or
from the feedback-only run (``--collect-with feedback``). Why the default: the PGNN learns u as a
function of the reference theta_d, which stands in for the measured angle (V-A, assumption of
"negligible discrepancy"); with feedback only the axes lag the reference by 0.3-0.6 deg, a 20-40
deg phase error of the 5 deg gear harmonic, and the map learned from such data is wrong where the
feedforward makes the axes track.

Methods: physical model (least squares), PGNN trained with J (R1 and R2), PGNN trained with J_LS
only (both with u filtered at ``--filter-hz``, default 5 Hz, the leaderboard's; the paper's is 1 Hz),
and three variants trained with J: u at 1 Hz, the ``history`` option (reference velocities
0.02-0.4 s ago, for the Inf norm after standstill), and 10 Hz plus the ``periods`` option (sin/cos
of the propeller angle over the gear period, 5 deg). Printed:

* per PGNN: wall time of the whole fit (physical least squares + Algorithm 1) and epochs;
* the physical parameters' drift from the physical-model-only fit on the same data (max over parameters of
  |zeta - zeta0| / |zeta0| for those with |zeta0| > 1 % of the largest of their kind, and
  ||zeta - zeta0|| / ||zeta0||);
* Tables II/III: norms of the input residual eps = u - f [V] on runs of the validation references
  recorded like the training data (u low-pass filtered like the training data), and RMS of the
  network's output f^C; the plant's static feedforward (below) as an oracle row, and the residuals
  of the physical model and that oracle on runs recorded with the oracle's feedforward on (where
  the axes track the reference);
* where f^C lies: per PGNN and axis on the same runs, the share of f^C's energy inside the column
  space of the physical model's regressor X(theta) (eq. 21, at zeta^0: the part the physical model
  could have produced itself, which R1 penalizes), and the RMS of the physical part's change
  f^M(zeta) - f^M(zeta^0) (what the training moved from the physical model);
* Tables IV/V: norms of the tracking error [deg] with each feedforward on the validation
  references, and with feedback only; the ratio physical / method of the RMS.

Beside each row the paper's (``PAPER``: Tables II-V), and in Tables IV/V the plant's own static
feedforward (``IXPlant.static_model``: the true rigid body and hidden effects that are functions
of the reference; what a static function of the PGNN's inputs can reach at best).

Run:  .venv/bin/python benchmarks/pgnn_tables.py [--version v1] [--seed 0] [--data train] [--samples 1e6] [--quick]
      [--variants J,J_LS,1hz,history,periods] [--fixed-batches]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lcgym.methods.pgnn import PGNN, PGNNConfig
from lcgym.methods.pgnn.objective import projected_norm2
from lcgym.metrics import norms
from lcgym.physics.kinematics import lowpass_zero_phase, reference_kinematics
from lcgym.physics.model import PhysicalModel
from lcgym.systems.ix import IX
from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set

HISTORY = (0.02, 0.05, 0.1, 0.2, 0.4)  # s
PAPER = {  # (MA, RMS, Inf[, RMS f^C]) per axis: paper 000 Tables II/III (residual [V]) and IV/V (tracking [deg])
    "residual": {"physical model": ((0.162, 0.219, 1.877), (0.262, 0.321, 1.131)),
                 "PGNN with J": ((0.031, 0.071, 1.439, 0.235), (0.016, 0.038, 0.842, 0.325)),
                 "PGNN with J_LS": ((0.030, 0.064, 1.423, 2.953), (0.020, 0.046, 0.711, 1.410))},
    "tracking": {"feedback only": ((0.428, 0.507, 1.073), (0.402, 0.522, 1.401)),
                 "physical model": ((0.072, 0.089, 0.351), (0.095, 0.117, 0.279)),
                 "PGNN with J": ((0.031, 0.046, 0.423), (0.020, 0.029, 0.269))},
}


def paper_cell(table: str, label: str, axis: int) -> str:
    """The paper's numbers of a row, or blank."""
    row = PAPER[table].get(label)
    return "  paper " + " ".join(f"{v:.3f}" for v in row[axis]) if row else ""
GEAR_PERIOD = np.radians(5.0)


def drift(p: np.ndarray, p0: np.ndarray) -> tuple[float, float]:
    """(max relative change over the parameters that are not ~0, relative change of the vector).
    'Not ~0': |p0| above 1 % of the largest |p0| among the linear ones (masses, inertias,
    damping) or among the centre-of-mass coordinates, respectively."""
    rel = []
    for part in (slice(0, ix.N_LINEAR), slice(ix.N_LINEAR, None)):
        a, b = p[part], p0[part]
        big = np.abs(b) > 0.01 * np.abs(b).max()
        rel.append(np.abs(a - b)[big] / np.abs(b)[big])
    return float(np.concatenate(rel).max()), float(np.linalg.norm(p - p0) / np.linalg.norm(p0))


def where_fc_lies(model: PGNN, trials) -> tuple[np.ndarray, np.ndarray]:
    """Per axis on ``trials``: the share of ||f^C||^2 inside the column space of the regressor
    X(zeta_n^0) of the initial physical fit (eq. 21; R1's projection on the whole set), and the RMS
    of the physical part's change f^M(zeta) - f^M(zeta^0) [V]."""
    system = model.physical_.system
    zeta0 = model.physical_.params_.to_vector()
    q, qd, qdd = (np.concatenate(a) for a in zip(*(reference_kinematics(t.ref, t.fs, model.config_.advance)
                                                    for t in trials), strict=True))
    X = system.regressor(zeta0[system.n_linear:], q, qd, qdd)
    fc = np.concatenate([model.nn_contribution(t) for t in trials])
    share = np.array([projected_norm2(X[:, i, :], fc[:, i]) / max(np.sum(fc[:, i] ** 2), 1e-300)
                      for i in range(fc.shape[1])])
    moved = np.concatenate([model.predict(t) - model.nn_contribution(t) - model.physical_.predict(t) for t in trials])
    return share, np.sqrt(np.mean(moved**2, axis=0))


VARIANTS = {"J": "PGNN with J", "J_LS": "PGNN with J_LS", "1hz": "PGNN J, u at 1 Hz", "history": "PGNN J + history",
            "periods": "PGNN J 10 Hz+periods"}
"""The PGNNs fitted (``--variants``): short name -> label in the tables."""


def config(variant: str, base: dict) -> PGNNConfig:
    """The configuration of one of ``VARIANTS`` on top of the common settings ``base``."""
    return {"J": lambda: PGNNConfig(**base),
            "J_LS": lambda: PGNNConfig(regularize=False, **base),
            "1hz": lambda: PGNNConfig(**{**base, "filter_hz": 1.0}),  # the paper's filter
            "history": lambda: PGNNConfig(history=HISTORY, **base),
            "periods": lambda: PGNNConfig(periods=((0, GEAR_PERIOD),), **{**base, "filter_hz": 10.0})}[variant]()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--data", choices=("train", "calibration"), default="train")
    parser.add_argument("--samples", type=float, default=1e6, help="size of the 'train' data set")
    parser.add_argument("--collect-with", choices=("physical", "feedback"), default="physical",
                        help="controller on while the training data are recorded: the physical-model feedforward "
                             "(fitted on a feedback-only run of the same references) or feedback only")
    parser.add_argument("--max-epochs", type=int, default=300)
    parser.add_argument("--mu1", type=float, default=PGNNConfig.mu1, help="weight of R1 / N (see lcgym.methods.pgnn.training)")
    parser.add_argument("--filter-hz", type=float, default=5.0, help="low-pass of u [Hz] (the leaderboard's 5; the paper's 1)")
    parser.add_argument("--version", default="v1", help="the IX's version (IXPlant.of_version)")
    parser.add_argument("--budget", type=float, default=60.0,
                        help="wall-time budget [s] of each whole PGNN fit (physical least squares + Algorithm 1; "
                             "PGNNConfig.max_seconds); 0: no budget, early stopping alone")
    parser.add_argument("--quick", action="store_true", help="1e5 samples and the two paper variants only")
    parser.add_argument("--variants", default=",".join(VARIANTS),
                        help=f"comma-separated PGNNs to fit, of {','.join(VARIANTS)} (default all)")
    parser.add_argument("--fixed-batches", action="store_true",
                        help="fixed minibatches (PGNNConfig.reshuffle=False) instead of a reshuffle at each pass")
    args = parser.parse_args()
    plant = IXPlant.of_version(args.version)
    print(f"IX-{args.version}")
    t0 = time.perf_counter()
    if args.data == "calibration":
        refs = reference_set("calibration", args.seed)
    else:
        samples = 1e5 if args.quick else args.samples
        per_reference = 40.0 * plant.fs + plant.preroll_samples
        refs = reference_set("train", args.seed, n_references=max(1, round(samples / per_reference)))
    data = plant.run(refs)
    t1 = time.perf_counter()
    physical = PhysicalModel(IX).fit(data)
    physical_seconds = time.perf_counter() - t1
    if args.collect_with == "physical":
        data = plant.run(refs, [physical.predict(r) for r in refs])
    n = sum(t.n_samples for t in data)
    print(f"training data ({args.data}, recorded with {args.collect_with} feedforward): {len(data)} runs, {n:,} samples, "
          f"simulated in {time.perf_counter() - t0 - physical_seconds:.1f} s")
    print(f"physical model: least squares on {n:,} feedback-only samples in {physical_seconds:.1f} s")
    val_refs = reference_set("validation", args.seed)
    val_fb = plant.run(val_refs)
    val_data = plant.run(val_refs, [physical.predict(r) for r in val_refs]) if args.collect_with == "physical" else val_fb

    budget = args.budget if args.budget > 0 else None
    base = dict(mu1=args.mu1, max_epochs=args.max_epochs, filter_hz=args.filter_hz, seed=args.seed, max_seconds=budget,
                reshuffle=not args.fixed_batches)
    chosen = args.variants.split(",")
    if unknown := set(chosen) - set(VARIANTS):
        parser.error(f"unknown variants {sorted(unknown)}; choose of {','.join(VARIANTS)}")
    variants = {VARIANTS[v]: config(v, base) for v in VARIANTS if v in chosen and (not args.quick or v in ("J", "J_LS"))}
    models = {"physical model": physical}
    for label, cfg in variants.items():
        m = PGNN(cfg, system=IX).fit(data)
        d_max, d_norm = drift(m.params_.to_vector(), m.physical_.params_.to_vector())
        print(f"{label}: fit on {m.info_['n_samples']:,} samples in {m.info_['fit_seconds']:.1f} s "
              f"({m.info_['seconds']:.1f} s in Algorithm 1, {m.info_['epochs']} epochs); "
              f"parameter drift: max {100 * d_max:.1f} %, vector {100 * d_norm:.1f} %")
        models[label] = m

    print(f"\nTables II/III: input residual eps = u - f [V] on validation runs recorded like the training data "
          f"(u filtered at {args.filter_hz} Hz)")
    print(f"{'':18s} {'axis':9s} {'MA':>7s} {'RMS':>7s} {'Inf':>7s} {'RMS(f^C)':>9s}")
    oracle = plant.static_model(IX)
    for label, model in {**models, "static (oracle)": oracle}.items():
        eps = np.concatenate([lowpass_zero_phase(t.u, plant.fs, args.filter_hz) - model.predict(t) for t in val_data])
        fc = (np.concatenate([model.nn_contribution(t) for t in val_data]) if hasattr(model, "nn_contribution")
              else np.zeros_like(eps))
        nm, rc = norms(eps), np.sqrt(np.mean(fc**2, axis=0))
        for i, ax in enumerate(plant.axes):
            print(f"{label:18s} {ax:9s} {nm['MA'][i]:7.3f} {nm['RMS'][i]:7.3f} {nm['Inf'][i]:7.3f} {rc[i]:9.4f}"
                  f"{paper_cell('residual', label, i)}")
    # the same oracle on runs recorded with its own feedforward on, where the axes track theta_d:
    # how much of u is a static function of the reference when the reference is what the axes do
    own = plant.run(val_refs, [oracle.predict(r) for r in val_refs])
    for label, model in (("physical, o. runs", physical), ("oracle, own runs", oracle)):
        nm = norms(np.concatenate([lowpass_zero_phase(t.u, plant.fs, args.filter_hz) - model.predict(t) for t in own]))
        for i, ax in enumerate(plant.axes):
            print(f"{label:18s} {ax:9s} {nm['MA'][i]:7.3f} {nm['RMS'][i]:7.3f} {nm['Inf'][i]:7.3f}")

    print("\nTables IV/V: tracking error e [deg] on the validation references")
    print(f"{'':18s} {'axis':9s} {'MA':>7s} {'RMS':>7s} {'Inf':>7s} {'physical/this RMS':>18s}")
    runs = {"feedback only": val_fb}
    runs.update({label: plant.run(val_refs, [m.predict(r) for r in val_refs]) for label, m in models.items()})
    runs["static (oracle)"] = plant.run(val_refs, [oracle.predict(r) for r in val_refs])
    table = {label: norms(np.degrees(np.concatenate([t.error for t in trials]))) for label, trials in runs.items()}
    for label, nm in table.items():
        for i, ax in enumerate(plant.axes):
            ratio = table["physical model"]["RMS"][i] / nm["RMS"][i]
            print(f"{label:18s} {ax:9s} {nm['MA'][i]:7.3f} {nm['RMS'][i]:7.3f} {nm['Inf'][i]:7.3f} {ratio:18.2f}"
                  f"{paper_cell('tracking', label, i)}")
    if {"PGNN with J", "PGNN with J_LS"} <= set(models):
        fc = {label: np.sqrt(np.mean(np.concatenate([models[label].nn_contribution(t) for t in val_data]) ** 2, axis=0))
              for label in ("PGNN with J", "PGNN with J_LS")}
        ratio = fc["PGNN with J_LS"] / fc["PGNN with J"]
        print(f"\nNN contribution RMS(f^C) J_LS / J: {ratio[0]:.2f}x / {ratio[1]:.2f}x (paper 12.6x / 4.3x)")
    print("where f^C lies (validation runs): share of ||f^C||^2 in the column space of X(zeta^0); "
          "RMS of f^M(zeta) - f^M(zeta^0) [V]")
    for label, model in models.items():
        if isinstance(model, PGNN):
            share, moved = where_fc_lies(model, val_data)
            print(f"{label:22s} " + "  ".join(f"{ax}: {100 * share[i]:5.1f} %, {moved[i]:.4f} V"
                                              for i, ax in enumerate(plant.axes)))


if __name__ == "__main__":
    main()
