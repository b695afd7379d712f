"""LCS on the FlexArm (paper 002, eq. 16 once, section 5.3): the joint model-following error e_pl of
joints 2, 3, 5 in the dynamic periods (reference moving), the static periods and overall, and the
TCP error, for Basic and for Basic plus one learning iteration, on validation lines.

e_pl is shown from the simulation's true load acceleration (the accelerometer estimate is what the
learning uses). Like the paper's footnote 6, the static periods can get worse after one iteration:
the update corrects the dynamic error and overshoots where the reference rests.

Run:  .venv/bin/python studies/ilc_arm.py [--seeds 0,1,2] [--lines 4]
"""

from __future__ import annotations

import argparse

import numpy as np
from tqdm import tqdm

from lcgym.baselines.ilc import IterativeLearningControl
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set, tcp_positions

JOINTS = ("j2", "j3", "j5")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--lines", type=int, default=4)
    args = parser.parse_args()
    plant = FlexArmPlant()
    parts = {k: {"dynamic": [], "static": [], "overall": [], "tcp": []} for k in ("basic", "lcs")}
    refs = [r for s in map(int, args.seeds.split(",")) for r in arm_reference_set("validation", s, args.lines)]
    ilc = IterativeLearningControl().fit([plant.run(refs[0])])  # the arm's ILC starts from Basic: nothing to fit
    for ref in tqdm(refs, desc="lines"):
        ilc.learn(plant, ref)
        moving = np.any(np.abs(ref.velocities) > 1e-6, axis=1)
        tau_ff = BasicFeedforward().compute(ref.positions, ref.fs)["tau_ff"]
        for label, update in (("basic", None), ("lcs", ilc.feedforward(ref) - tau_ff)):
            tr = BasicFeedforward().run(plant, ref, update)
            e = np.column_stack([tr.extra[f"e_pl_true_{a}"] for a in JOINTS])
            parts[label]["dynamic"].append(e[moving])
            parts[label]["static"].append(e[~moving])
            parts[label]["overall"].append(e)
            tcp = np.column_stack([tr.extra[f"tcp_{c}"] for c in "xyz"]) - tcp_positions(ref.positions)
            parts[label]["tcp"].append(1000 * np.linalg.norm(tcp, axis=1))
    rms = {k: {p: np.sqrt(np.mean(np.concatenate(v) ** 2, axis=0)) for p, v in d.items()} for k, d in parts.items()}
    print(f"{len(refs)} validation lines; e_pl RMS [rad/s^2] of joints {', '.join(JOINTS)}, TCP error RMS [mm]")
    for period in ("dynamic", "static", "overall"):
        b, c = rms["basic"][period], rms["lcs"][period]
        print(f"  {period:8s} Basic {np.round(b, 3)}  LCS {np.round(c, 3)}  LCS / Basic {np.round(c / b, 2)}")
    b, c = rms["basic"]["tcp"], rms["lcs"]["tcp"]
    print(f"  TCP      Basic {b:.3f}  LCS {c:.3f}  LCS / Basic {c / b:.2f}")


if __name__ == "__main__":
    main()
