"""How much tracking error each hidden effect of the default IX plant leaves behind the fitted
rigid-model feedforward (each effect's size alone, and what all but it leave).

For each group of default effects, a plant carrying only that group is built; the rigid model
is fitted on its training runs (feedback only) and applied to the validation references. The
last rows use all effects, and all effects but one group. Prints RMS tracking errors in deg.

Run:  .venv/bin/python studies/effect_sizes.py [--seed 0]
"""

from __future__ import annotations

import argparse

import numpy as np
from tqdm import tqdm

from lcgym.methods import PhysicalFeedforward
from lcgym.systems.ix.plant import IXPlant, default_hidden_effects
from lcgym.systems.ix.references import reference_set

GROUPS = {
    "roll friction (level, Stribeck, stiction)": lambda e: e.axis == "roll" and "friction" in e.name or e.key == "stiction@roll",
    "propeller friction": lambda e: e.axis == "propeller" and ("friction" in e.name or e.name == "stiction"),
    "cable spring (roll)": lambda e: e.name == "cable_spring",
    "cable inertia (roll)": lambda e: e.name == "cable_inertia",
    "gear harmonic (propeller)": lambda e: e.name == "gear_harmonic",
    "cable drape (propeller)": lambda e: e.name == "cable_drape",
    "drivetrain flexibility": lambda e: e.name == "drivetrain_flexibility",
    "torque ripple": lambda e: e.name == "torque_ripple",
}


def rms_deg(trials) -> np.ndarray:
    e = np.concatenate([t.error for t in trials])
    return np.degrees(np.sqrt(np.mean(e**2, axis=0)))


def evaluate(effects, seed):
    plant = IXPlant(effects=tuple(effects))
    train = plant.run(reference_set("train", seed))
    val = reference_set("validation", seed)
    ctrl = PhysicalFeedforward(system="ix").fit(train)
    return rms_deg(plant.run(val, [ctrl.feedforward(r) for r in val]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    effects = default_hidden_effects()
    rows = [("no hidden effect", [])]
    rows += [(name, [e for e in effects if pick(e)]) for name, pick in GROUPS.items()]
    rows += [("all default effects", list(effects))]
    rows += [(f"all but {name}", [e for e in effects if not pick(e)]) for name, pick in GROUPS.items()]
    print(f"fitted rigid-model feedforward, validation RMS tracking error [deg], seed {args.seed}")
    print(f"{'plant effects':48s} {'propeller':>10s} {'roll':>10s}")
    for name, effs in tqdm(rows, leave=False):
        r = evaluate(effs, args.seed)
        tqdm.write(f"{name:48s} {r[0]:10.4f} {r[1]:10.4f}")


if __name__ == "__main__":
    main()
