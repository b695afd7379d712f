"""How well ``lcgym diagnose`` names a hidden effect: plants with one (or two, or no) hidden
effect, feedback-only runs of the training references, diagnosis with the true effect added.

For each case and seed it prints the effects selected (best first), whether the truth is ranked
first (or its family, for effects of another functional form), the residual RMS of the true
axis before and after adding the true effect, and the wall time. The cases are those of
tests/test_diagnose.py, over more seeds.

Run:  .venv/bin/python studies/diagnose_hidden_effects.py [--seeds 0,1,2] [--references 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_diagnose import OTHER_FORMS, SINGLE  # noqa: E402  (the cases live with the tests)

from lcgym.diagnose import diagnose  # noqa: E402
from lcgym.physics import effects as fx  # noqa: E402
from lcgym.systems.ix.plant import IXPlant  # noqa: E402
from lcgym.systems.ix.references import reference_set  # noqa: E402

DEG = 3.141592653589793 / 180


def cases():
    for key, e in SINGLE.items():
        yield key, (e,), key, None
    yield "stribeck_friction@roll", (fx.StribeckFriction("roll", dF=0.15, vs=6.0 * DEG),), "stribeck_friction@roll", None
    for name, (family, axis, e) in OTHER_FORMS.items():
        yield name, (e,), None, (family, axis)
    yield "coulomb_friction@roll + cable_spring@roll", (SINGLE["coulomb_friction@roll"], SINGLE["cable_spring@roll"]), None, None
    yield "coulomb_friction@roll + gear_harmonic@propeller", (SINGLE["coulomb_friction@roll"],
                                                              SINGLE["gear_harmonic@propeller"]), None, None
    yield "no hidden effect", (), None, None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--references", type=int, default=3)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    all_cases = list(cases())
    print(f"{'case':52s} {'seed':>4s} {'first right':>11s} {'RMS before':>10s} {'after':>8s} {'cut':>5s} {'time':>6s}  selected")
    for name, effects, truth, family in tqdm(all_cases, leave=False):
        for seed in seeds:
            trials = IXPlant(effects=effects).run(reference_set("train", seed, args.references))
            t0 = time.perf_counter()
            rep = diagnose(trials, add=[truth] if truth else [])
            dt = time.perf_counter() - t0
            first = rep.candidates[0] if rep.candidates else None
            if truth:
                ok = first is not None and f"{first.effect}@{first.axis}" == truth
                ax = truth.split("@")[1]
                b, a = rep.residual[ax]["RMS"], rep.after["residual"][ax]["RMS"]
                nums = f"{b:10.4f} {a:8.4f} {100 * (1 - a / b):4.0f}%"
            elif family:
                ok = first is not None and (first.family, first.axis) == family
                nums = f"{'':10s} {'':8s} {'':5s}"
            else:
                keys = {f"{e.name}@{e.axis}" for e in effects}
                ok = keys <= set(rep.missing[:3]) if keys else not rep.candidates
                nums = f"{'':10s} {'':8s} {'':5s}"
            tqdm.write(f"{name[:52]:52s} {seed:4d} {'yes' if ok else 'NO':>11s} {nums} {dt:5.1f}s  "
                       f"{', '.join(rep.missing) or 'no missing effect found'}")


if __name__ == "__main__":
    main()
