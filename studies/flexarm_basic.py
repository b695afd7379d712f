"""FlexArm with the nominal feedforward only ("Basic" of paper 002): joint model-following error
and TCP error on the validation TCP lines, as MA / RMS / Inf, and a plot.

e_pl = P_lu mu - qdd_l (rad/s^2, joints 2, 3, 5) with the true load acceleration of the
simulation (low-passed at 50 Hz, as the accelerometer estimate is); TCP error = Euclidean
distance [mm] between the true TCP and the TCP of the
reference. Feedback only is printed beside it. The plot shows e_pl of joint 3 and the TCP error
over time with the scaled reference velocity of joint 3 (residual vibration after each stop, peaks
at motion start and stop).

Run:  .venv/bin/python studies/flexarm_basic.py [--seed 0] [--plot flexarm_basic.png] [--version v1|v0]
"""

from __future__ import annotations

import argparse

import numpy as np

from lcgym.metrics import norms
from lcgym.systems.flexarm.errors import paper_errors
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import MOVING, arm_reference_set


def evaluate(plant, ref, use_ff: bool):
    """(trial, e_pl (T, 3) of joints 2, 3, 5 from the true load acceleration, TCP error (T,) [mm]):
    ``errors.paper_errors`` of a Basic run, or of a feedback-only run (no feedforward)."""
    if use_ff:
        tr = BasicFeedforward().run(plant, ref)
        errors = paper_errors(plant, tr, ref)
    else:
        tr = plant.run(ref)
        errors = paper_errors(plant, tr, ref, np.zeros_like(tr.u))
    return tr, errors["joint"], errors["tcp"][:, 0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", default="flexarm_basic.png")
    parser.add_argument("--version", default="v1", help="the FlexArm's version (FlexArmPlant.of_version)")
    args = parser.parse_args()
    refs = arm_reference_set("validation", args.seed)
    plant = FlexArmPlant.of_version(args.version)
    print(f"FlexArm-{args.version} validation lines (seed {args.seed}, {len(refs)} references), MA / RMS / Inf")
    print(f"{'controller':10s} {'signal':24s} {'MA':>8s} {'RMS':>8s} {'Inf':>8s}")
    keep = None
    for use_ff, label in ((False, "feedback"), (True, "Basic")):
        epls, tcps = [], []
        for ref in refs:
            tr, epl, tcp = evaluate(plant, ref, use_ff)
            epls.append(epl)
            tcps.append(tcp)
            if use_ff and keep is None:
                keep = (ref, epl, tcp)
        epl, tcp = np.concatenate(epls), np.concatenate(tcps)
        for k, j in enumerate(MOVING):
            n = norms(epl[:, k])
            print(f"{label:10s} {'e_pl joint ' + str(j + 1) + ' [rad/s^2]':24s} {n['MA']:8.3f} {n['RMS']:8.3f} {n['Inf']:8.3f}")
        n = norms(tcp)
        print(f"{label:10s} {'TCP error [mm]':24s} {n['MA']:8.3f} {n['RMS']:8.3f} {n['Inf']:8.3f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ref, epl, tcp = keep
    fig, axs = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    v = ref.velocities[:, 2]
    for ax, y, lab in ((axs[0], epl[:, 1], "e_pl joint 3 [rad/s^2]"), (axs[1], tcp, "TCP error [mm]")):
        ax.plot(ref.t, y, lw=0.7, label=lab)
        ax.plot(ref.t, v / np.abs(v).max() * np.abs(y).max(), "k--", lw=0.6, alpha=0.6,
                label="joint 3 reference velocity (scaled)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    axs[1].set_xlabel("time [s]")
    fig.suptitle(f"FlexArm, Basic feedforward: {ref.name}")
    fig.savefig(args.plot, dpi=100)
    print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
