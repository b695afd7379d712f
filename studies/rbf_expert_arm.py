"""Paper 002's NN prediction (NNP) against one iteration of learning with the accelerometer (LCS),
both from Basic, on FlexArm validation lines: Table 6 and Fig. 7.

Training (the paper's factory stage): Basic runs of ``--train-lines`` training lines (seed 0) give
the model-following error e_pl from the accelerometer; the predictor (``lcgym.methods.rbf_expert``) learns
it from the references. Then, per validation line (seeds ``--seeds``, lines the predictor never
saw): Basic; LCS = eq. (16) once with e_pl measured on that line; NNP = eq. (17) with e_pl predicted
from the reference alone. Printed per period (dynamic: the reference moves; static; overall):

* RMS of the joint model-following error e_pl (true load acceleration) of joints 2, 3, 5 and of the
  three stacked, of the end-effector acceleration error (accelerometer minus its known bias, minus
  the reference's specific force at the sensor) [m/s^2], and of the TCP position error [mm];
* Table 6's share |RMS_NNP - RMS_Basic| / |RMS_LCS - RMS_Basic| (as the paper, absolute values:
  a worsening counts like an improvement) and the signed share (RMS_Basic - RMS_NNP) /
  (RMS_Basic - RMS_LCS), which says whether NNP moved the error the same way as LCS;
* for the dynamic period, a 90 % bootstrap interval of the signed share over the validation lines
  (how much the share depends on which lines were drawn);
* the same shares for an *oracle* of the paper's architecture: eq. (17) with the measured e_pl
  where a network is active and zero elsewhere (static periods, long constant velocity), i.e. a
  perfect predictor: what the predictor could reach at best.

Fig. 7 (``--plot``): joint 5's training error over the reference (velocity, acceleration; and
position) before preprocessing, and over the network inputs (v22, v33; v11) after.
``--tune``: the configuration comparison that chose the predictor's defaults (on seed 0's
validation lines, which the report above does not use).

Run:  .venv/bin/python studies/rbf_expert_arm.py [--train-lines 24] [--seeds 1,2,5,6] [--lines 4] [--version v1|v0]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from tqdm import tqdm

from lcgym.methods.ilc.method import ILCConfig
from lcgym.methods.rbf_expert.expert import ExpertConfig
from lcgym.methods.rbf_expert.influence import task_influence
from lcgym.methods.rbf_expert.predictor import RBFExpertConfig, RBFExpertPredictor
from lcgym.methods.rbf_expert.preprocess import PreprocessConfig
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.flexarm.errors import paper_errors, period_mask
from lcgym.systems.flexarm.learning import nominal_update
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import MOVING, arm_reference_set

JOINTS = [f"j{j + 1}" for j in MOVING]
TUNE = {  # the configurations compared by --tune
    "3D 20x10x11, paper grid": RBFExpertConfig(dims=3),
    "2D, 20 levels": RBFExpertConfig(preprocess=PreprocessConfig(levels=20)),
    "2D, no long-period rule": RBFExpertConfig(expert=ExpertConfig(long_period=1e3)),
    "2D, ridge 1": RBFExpertConfig(ridge=1.0),
    "2D, no safety rule": RBFExpertConfig(support=None),
    "default (2D, 10 levels, 0.5 s, ridge 10)": RBFExpertConfig(),
}


def e_pl(trial, kind: str = "e_pl") -> np.ndarray:
    return np.column_stack([trial.extra[f"{kind}_{a}"] for a in trial.axes])


def tau_nl_update(reference, e: np.ndarray) -> np.ndarray:
    """Eq. (16) / (17) from Basic: the change of tau_nl (T, 6) [N m] for the error e."""
    tau_nl = BasicFeedforward().compute(reference.positions, reference.fs)["tau_nl"]
    return nominal_update(BasicFeedforward(), tau_nl, e, reference.fs, ILCConfig()) - tau_nl


def rms(x: np.ndarray, stacked: bool = False):
    return float(np.sqrt(np.mean(x**2))) if stacked else np.sqrt(np.mean(x**2, axis=0))


def run_lines(plant, predictor, lines, measured=None, progress: bool = True, oracle: bool = False):
    """Per line and controller (basic, lcs, nnp, oracle): the signals and the moving mask;
    ``measured``: the Basic runs of the lines if already done."""
    out = []
    for k, ref in enumerate(tqdm(lines, desc="validation lines", disable=not progress)):
        basic = measured[k] if measured else BasicFeedforward().run(plant, ref)
        runs = {"basic": basic, "lcs": BasicFeedforward().run(plant, ref, tau_nl_update(ref, e_pl(basic))),
                "nnp": BasicFeedforward().run(plant, ref, tau_nl_update(ref, predictor.predict(ref)))}
        outside = dict(predictor.outside_share_)
        if oracle:
            perfect = np.zeros_like(e_pl(basic))
            for j in MOVING:
                active = predictor.inputs(ref, j)[1] > 0
                perfect[active, j] = e_pl(basic)[active, j]
            runs["oracle"] = BasicFeedforward().run(plant, ref, tau_nl_update(ref, perfect))
        moving = period_mask(ref, "dynamic")
        out.append(({name: paper_errors(plant, tr, ref) for name, tr in runs.items()}, moving, outside))
    return out


def table6(results) -> dict:
    """{(signal, period): {controller: (per-axis RMS, stacked RMS)}}."""
    table = {}
    for sig in ("joint", "ee_acc", "tcp"):
        for period in ("dynamic", "static", "overall"):
            row = {}
            for ctrl in results[0][0]:
                x = np.concatenate([in_period(s[ctrl][sig], m, period) for s, m, _ in results])
                row[ctrl] = (rms(x), rms(x, stacked=True))
            table[sig, period] = row
    return table


def share_interval(results, sig: str, period: str, n: int = 2000, level: float = 0.9) -> tuple[float, float]:
    """The ``level`` bootstrap interval [%] of the NNP's Table 6 share (signed) over the validation
    lines: lines drawn with replacement, the share of their pooled RMS, ``n`` times."""
    ctrls = ("basic", "lcs", "nnp")
    parts = [[in_period(s[c][sig], m, period) for c in ctrls] for s, m, _ in results]
    ss = np.array([[np.sum(x**2) for x in line] for line in parts])  # (lines, controllers)
    count = np.array([line[0].size for line in parts])
    pick = np.random.default_rng(0).integers(0, len(results), (n, len(results)))
    b, c, nnp = np.sqrt(ss[pick].sum(axis=1) / count[pick].sum(axis=1)[:, None]).T
    return tuple(np.percentile((b - nnp) / (b - c) * 100, [50 * (1 - level), 50 * (1 + level)]))


def in_period(x: np.ndarray, moving: np.ndarray, period: str) -> np.ndarray:
    """The samples of x in ``period`` ("dynamic": where the reference moves, "static", "overall")."""
    return x[moving if period == "dynamic" else ~moving if period == "static" else slice(None)]


def shares(row, i: int, method: str = "nnp") -> tuple[float, float]:
    b, c, n = row["basic"][i], row["lcs"][i], row[method][i]
    return np.abs(n - b) / np.abs(c - b) * 100, (b - n) / (b - c) * 100


def fig7(references, errors, phi, path: str, joint: int = 4) -> None:
    """Fig. 7 of paper 002 for one joint (default joint 5): the training error over the reference
    before preprocessing and over the network inputs after."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pre = RBFExpertPredictor(phi, (joint,), RBFExpertConfig(dims=3)).fit(references, errors)
    q = np.concatenate([r.positions[:, joint] for r in references])
    qd = np.concatenate([r.velocities[:, joint] for r in references])
    qdd = np.concatenate([r.accelerations[:, joint] for r in references])
    X, types = zip(*((x, t) for x, t, _ in (pre.inputs(r, joint) for r in references)), strict=True)
    X, types = np.concatenate(X), np.concatenate(types)
    e = np.concatenate([err[:, joint] for err in errors])
    lim = np.percentile(np.abs(e), 99)
    kw = dict(c=e, cmap="jet", vmin=-lim, vmax=lim, s=1)
    moving = np.abs(qd) > 1e-6
    act = types > 0
    fig = plt.figure(figsize=(12, 10))
    ax = fig.add_subplot(2, 2, 1)
    ax.scatter(qd[moving], qdd[moving], **kw_sel(kw, moving))
    ax.set(xlabel="velocity reference [rad/s]", ylabel="acceleration reference [rad/s^2]", title="(a) 2D, reference")
    ax = fig.add_subplot(2, 2, 2, projection="3d")
    ax.scatter(q[moving], qd[moving], qdd[moving], **kw_sel(kw, moving))
    ax.set(xlabel="position [rad]", ylabel="velocity [rad/s]", zlabel="acceleration [rad/s^2]", title="(b) 3D, reference")
    ax = fig.add_subplot(2, 2, 3)
    ax.scatter(X[act, 1], X[act, 2], **kw_sel(kw, act))
    ax.set(xlabel="v22 (velocity motion influence, per level)", ylabel="v33 (2/pi arctan ratio)",
           title="(c) 2D, after preprocessing")
    ax = fig.add_subplot(2, 2, 4, projection="3d")
    sc = ax.scatter(X[act, 0], X[act, 1], X[act, 2], **kw_sel(kw, act))
    ax.set(xlabel="v11", ylabel="v22", zlabel="v33", title="(d) 3D, after preprocessing")
    fig.colorbar(sc, ax=fig.axes, shrink=0.6, label=f"e_pl of joint {joint + 1} [rad/s^2]")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"Fig. 7 written to {path} (colour limit: the 99th percentile of |e_pl| of joint {joint + 1}, {lim:.2f} rad/s^2)")


def kw_sel(kw: dict, sel: np.ndarray) -> dict:
    return {**kw, "c": kw["c"][sel]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train-lines", type=int, default=24)
    parser.add_argument("--seeds", default="1,2,5,6",
                        help="validation seeds (seed 0's lines chose the predictor's defaults, seeds 0, 3, 4's "
                             "FlexArm-v1's friction)")
    parser.add_argument("--lines", type=int, default=4, help="validation lines per seed")
    parser.add_argument("--plot", default="results/rbf_expert_fig7.png")
    parser.add_argument("--tune", action="store_true", help="compare the configurations on seed 0's lines")
    parser.add_argument("--version", default="v1", help="the FlexArm's version (v1: settled start; v0)")
    args = parser.parse_args()
    plant = FlexArmPlant.of_version(args.version)
    print(f"FlexArm-{args.version}")
    train = arm_reference_set("train", 0, args.train_lines)
    basic_runs = [BasicFeedforward().run(plant, r) for r in tqdm(train, desc="training lines (Basic)")]
    errors = [e_pl(tr) for tr in basic_runs]
    phi = task_influence(train, FLEXARM.joint_axes())
    print("motion influence Phi (eqs. 22-25, Table 1):\n", phi.astype(int))
    if args.tune:
        lines = arm_reference_set("validation", 0, 8)
        measured = [BasicFeedforward().run(plant, r) for r in lines]
        for label, cfg in TUNE.items():
            pred = RBFExpertPredictor(phi, MOVING, cfg).fit(train, errors)
            row = table6(run_lines(plant, pred, lines, measured, progress=False))["joint", "dynamic"]
            print(f"{label:42s} dynamic joint share {shares(row, 1)[1]:6.1f} %  per joint "
                  f"{np.round(shares(row, 0)[1], 1)}")
        return
    t0 = time.perf_counter()
    predictor = RBFExpertPredictor(phi, MOVING).fit(train, errors)
    fit_s = time.perf_counter() - t0
    lines = [r for s in map(int, args.seeds.split(",")) for r in arm_reference_set("validation", s, args.lines)]
    results = run_lines(plant, predictor, lines, oracle=True)
    print(f"{args.train_lines} training lines (seed 0), networks trained in {fit_s:.2f} s; {len(lines)} validation "
          f"lines (seeds {args.seeds})")
    outside = np.array([[o[j] for j in MOVING] for _, _, o in results])
    print(f"share of each line's moving samples outside the training data, joints {', '.join(JOINTS)}: "
          f"mean {np.round(100 * outside.mean(axis=0), 1)} %, max {np.round(100 * outside.max(axis=0), 1)} %")
    names = {"joint": f"joint e_pl [rad/s^2] ({', '.join(JOINTS)})", "ee_acc": "EE acceleration error [m/s^2] (x, y, z)",
             "tcp": "TCP position error [mm]"}
    for (sig, period), row in table6(results).items():
        paper, signed = shares(row, 1)
        per_axis = np.round(shares(row, 0)[1], 1)
        print(f"{names[sig]:44s} {period:8s} RMS Basic {row['basic'][1]:.4f} LCS {row['lcs'][1]:.4f} "
              f"NNP {row['nnp'][1]:.4f} | Table 6 share {paper:6.1f} %, signed {signed:6.1f} %"
              + (f" (per axis {per_axis})" if sig != "tcp" else ""))
        if period == "dynamic":
            lo, hi = share_interval(results, sig, period)
            print(f"{'':44s} {'':8s} 90 % bootstrap interval of the signed share over the {len(results)} lines: "
                  f"{lo:.1f} to {hi:.1f} %")
        if sig == "joint":
            print(f"{'':44s} {'':8s} oracle (perfect prediction where the paper predicts): RMS {row['oracle'][1]:.4f}, "
                  f"Table 6 share {shares(row, 1, 'oracle')[0]:6.1f} %, signed {shares(row, 1, 'oracle')[1]:6.1f} %")
    safety(train, errors, phi, lines)
    if args.plot:
        fig7(train, errors, phi, args.plot)


def safety(train, errors, phi, lines) -> None:
    """The safety rule on lines outside the trained workspace: trained on the slower half of the
    training lines only, the predictor meets the faster validation lines."""
    speed = [np.abs(r.velocities).max() for r in train]
    slow = [k for k, v in enumerate(speed) if v <= np.median(speed)]
    pred = RBFExpertPredictor(phi, MOVING).fit([train[k] for k in slow], [errors[k] for k in slow])
    limit = max(speed[k] for k in slow)
    print(f"safety: trained on the {len(slow)} slower training lines (max joint speed {limit:.2f} rad/s); on the "
          f"validation lines, share of moving samples outside the training data (joints {', '.join(JOINTS)}):")
    for r in lines:
        pred.predict(r)
        share = np.round([100 * pred.outside_share_[j] for j in MOVING], 1)
        print(f"  {r.name}: max joint speed {np.abs(r.velocities).max():.2f} rad/s, outside {share} %")


if __name__ == "__main__":
    main()
