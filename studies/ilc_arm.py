"""LCS on the FlexArm (paper 002, eq. 16 once, section 5.3): paper 002's three errors (the joint
model-following error e_pl of joints 2, 3, 5, the end-effector acceleration error and the TCP
error; ``systems/flexarm/errors.py``) over all samples, the dynamic periods (reference moving) and
the static ones, for Basic and for Basic plus one learning iteration, on validation lines.

e_pl is shown from the simulation's true load acceleration (the accelerometer estimate is what the
learning uses). The paper's footnote 6 reports that one iteration can overcorrect where the
reference rests; here the static periods improve too since Q holds tau_nl's edges and e_pl starts
from the held first sample (``methods/ilc/method.py``, ``systems/flexarm/nominal.py``).

Run:  .venv/bin/python studies/ilc_arm.py [--seeds 0,1,2] [--lines 4] [--version v1|v0]
"""

from __future__ import annotations

import argparse

import numpy as np
from tqdm import tqdm

from lcgym.methods.ilc.method import PaperLCS
from lcgym.metrics import PERIODS
from lcgym.systems.flexarm.errors import paper_errors, period_mask
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set

JOINTS = ("j2", "j3", "j5")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--lines", type=int, default=4)
    parser.add_argument("--version", default="v1", help="the FlexArm's version (FlexArmPlant.of_version)")
    args = parser.parse_args()
    plant = FlexArmPlant.of_version(args.version)
    print(f"FlexArm-{args.version}")
    signals = {"joint": f"e_pl [rad/s^2] of joints {', '.join(JOINTS)}", "ee_acc": "EE acceleration error [m/s^2]",
               "tcp": "TCP error [mm]"}
    parts = {(k, sig, p): [] for k in ("basic", "lcs") for sig in signals for p in PERIODS}
    refs = [r for s in map(int, args.seeds.split(",")) for r in arm_reference_set("validation", s, args.lines)]
    ilc = PaperLCS(system="flexarm").fit([plant.run(refs[0])])  # paper 002's LCS starts from Basic: nothing to fit
    for ref in tqdm(refs, desc="lines"):
        ilc.learn(plant, ref)
        tau_ff = BasicFeedforward().compute(ref.positions, ref.fs)["tau_ff"]
        for label, update in (("basic", None), ("lcs", ilc.feedforward(ref) - tau_ff)):
            errors = paper_errors(plant, BasicFeedforward().run(plant, ref, update), ref)
            errors["ee_acc"] = np.linalg.norm(errors["ee_acc"], axis=1)[:, None]  # the Euclidean error, as the leaderboard
            for sig, e in errors.items():
                for period in PERIODS:
                    parts[label, sig, period].append(e[period_mask(ref, period)])
    rms = {key: np.sqrt(np.mean(np.concatenate(v) ** 2, axis=0)) for key, v in parts.items()}
    print(f"{len(refs)} validation lines; RMS")
    for sig, name in signals.items():
        print(f"  {name}")
        for period in PERIODS:
            b, c = rms["basic", sig, period], rms["lcs", sig, period]
            print(f"    {period:8s} Basic {np.round(b, 3)}  LCS {np.round(c, 3)}  LCS / Basic {np.round(c / b, 2)}")

if __name__ == "__main__":
    main()
