"""How robust the diagnosis is to shapes it does not know and to effects that hide each other.

For each effect of the vocabulary that a plant can carry in another shape than the library's
formula, an IX plant hides that version (a ``TabulatedForce`` curve); for pairs, one effect five
times the RMS of the other (along the references' motion), on one axis or on two. Feedback-only
runs of three training references (70,000 samples) per seed; the diagnosis runs, then the
selected effects are added. Prints, per case, how often the truth's family and axis (or, for a
pair, both effects) were named first (in the first two picks), the selected effects of seed 0,
and the range over the seeds of the truth axis's residual RMS after / before adding the
selected effects; writes the table as Markdown to ``--out`` (the table of docs/diagnosis.md).

Run:  .venv/bin/python studies/diagnose_robustness.py [--seeds 0,1,2] [--out robustness.md]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from lcgym.data import atomic_write
from lcgym.diagnose import diagnose
from lcgym.physics import effects as fx
from lcgym.systems.ix import IX
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set

DEG = math.pi / 180.0


def table(axis: str, variable: str, function, lo: float, hi: float) -> fx.TabulatedForce:
    return fx.TabulatedForce.from_function(axis, variable, function, lo, hi, 1001)


def arctan_friction(fwd: float, back: float, width: float = 0.5 * DEG):
    return lambda v: np.where(v > 0, fwd, back) * (2 / np.pi) * np.arctan(v / width)


# name -> (hidden effects, the family and axis expected first, or the keys of a pair)
OTHER_SHAPES = {
    "coulomb_friction: arctan, 0.1 V": ((table("roll", "velocity", arctan_friction(0.1, 0.1), -0.7, 0.7),),
                                        ("friction", "roll")),
    "asymmetric_friction: arctan, 0.20 / 0.15 V": ((table("roll", "velocity", arctan_friction(0.2, 0.15), -0.7, 0.7),),
                                                   ("friction", "roll")),
    "stribeck_friction: exponential hump": ((table("roll", "velocity", lambda v: (
        0.05 + 0.1 * np.exp(-np.abs(v) / (3 * DEG))) * np.tanh(v / (0.2 * DEG)), -0.7, 0.7),), ("friction", "roll")),
    "offset: 0.05 V, drifting 20 % over the range": ((table("roll", "position", lambda q: 0.05 * (1 + 0.2 * q / 1.5),
                                                            -1.6, 1.6),), ("offset", "roll")),
    "offset, the library's: 0.05 V": ((fx.Offset("roll", c=0.05),), ("offset", "roll")),
    "asymmetric_friction, the library's: 0.12 / 0.08 V": ((fx.AsymmetricFriction("roll", Fc_pos=0.12, Fc_neg=0.08,
                                                                                  eps=1e-3),), ("friction", "roll")),
    "cable_spring: quadratic beyond 10 deg": ((table("roll", "position", lambda q: 0.6 * np.maximum(0, q - 10 * DEG) ** 2,
                                                     -1.6, 1.6),), ("spring", "roll")),
    "gear_harmonic: triangle wave, 4 deg": ((table("propeller", "position", lambda q: 0.12 * 2 / np.pi * np.arcsin(
        np.sin(2 * np.pi * q / (4 * DEG))), -np.pi, np.pi),), ("periodic", "propeller")),
    "cable_drape: with a second harmonic": ((table("roll", "position", lambda q: 0.1 * np.sin(q + 0.5)
                                                   + 0.03 * np.sin(2 * q), -1.6, 1.6),), ("gravity", "roll")),
    "cable_drape: only while the roll angle is positive": ((table("roll", "position", lambda q: 0.1 * np.maximum(
        0, np.sin(q)), -1.6, 1.6),), ("gravity", "roll")),
}


def rms_along(effect, refs) -> float:
    """RMS [V] of an effect's torque on its axis along the references' motion."""
    q = np.concatenate([r.positions for r in refs])
    qd = np.concatenate([r.velocities for r in refs])
    e = IX.effect(effect)
    return float(np.sqrt(np.mean(e.torque(q, qd, 0 * qd)[:, e.index] ** 2)))


def scaled(effect, k_name: str, rms: float, refs):
    """``effect`` with its coefficient ``k_name`` set so that its RMS along ``refs`` is ``rms``."""
    unit = effect.__class__(**{**effect.__dict__, k_name: 1.0, "index": None})
    return unit.__class__(**{**unit.__dict__, k_name: rms / rms_along(unit, refs), "index": None})


def pairs(refs) -> dict:
    """Pairs with one effect five times the other's RMS: (hidden, the two keys)."""
    friction = fx.CoulombFriction("roll", Fc=0.05)
    small = rms_along(friction, refs)
    spring = lambda axis, q0: scaled(fx.CableSpring(axis, k=1.0, q0=q0, width=3 * DEG), "k", 5 * small, refs)  # noqa: E731
    return {
        "coulomb_friction@roll behind cable_spring@roll (5x)": ((friction, spring("roll", 20 * DEG)),
                                                                ("cable_spring@roll", "coulomb_friction@roll")),
        "coulomb_friction@roll, cable_spring@propeller (5x)": ((friction, spring("propeller", 10 * DEG)),
                                                               ("cable_spring@propeller", "coulomb_friction@roll")),
        "cable_spring@roll behind coulomb_friction@roll (5x)": (
            (scaled(fx.CoulombFriction("roll", Fc=1.0), "Fc", 5 * small, refs),
             scaled(fx.CableSpring("roll", k=1.0, q0=20 * DEG, width=3 * DEG), "k", small, refs)),
            ("coulomb_friction@roll", "cable_spring@roll")),
        # the propeller's viscous friction takes up most of a small Coulomb level (it turns fast, in one
        # direction for long): 0.15 V, named alone, is the small one there
        "coulomb_friction@propeller behind gear_harmonic@propeller (5x)": (
            (fx.CoulombFriction("propeller", Fc=0.15),
             gear_harmonic(5 * rms_along(fx.CoulombFriction("propeller", Fc=0.15), refs), refs)),
            ("gear_harmonic@propeller", "coulomb_friction@propeller")),
    }


def gear_harmonic(rms: float, refs) -> fx.GearHarmonic:
    """The tests' propeller gear harmonic (two harmonics, speed-dependent) scaled to ``rms`` [V]."""
    shape = lambda a: fx.GearHarmonic.from_amplitudes("propeller", a, 0.7, 0.06 / 0.14 * a, 2.0, velocity_gain=0.5)  # noqa: E731
    return shape(rms / rms_along(shape(1.0), refs))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--out", type=Path, help="write the table as Markdown")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    refs0 = reference_set("train", 0, 3)
    cases = {**OTHER_SHAPES, **pairs(refs0)}
    rows = []
    for name, (hidden, truth) in tqdm(cases.items(), desc="cases"):
        hits, cuts, picks, seconds = 0, [], None, 0.0
        for seed in seeds:
            runs = IXPlant(effects=hidden).run(reference_set("train", seed, 3))
            t0 = time.perf_counter()
            rep = diagnose(runs, IX)
            seconds = max(seconds, time.perf_counter() - t0)
            picks = picks or (", ".join(rep.missing) or "none")
            if isinstance(truth[0], str) and "@" in truth[0]:  # a pair: both among the first two picks
                hits += set(truth) <= set(rep.missing[:2])
                axes = {k.split("@")[1] for k in truth}
            else:
                first = rep.candidates[0] if rep.candidates else None
                hits += first is not None and (first["family"], first["axis"]) == truth
                axes = {truth[1]}
            if rep.missing:
                after = diagnose(runs, IX, add=rep.missing).after["residual"]
                cuts += [after[a]["RMS"] / rep.residual[a]["RMS"] for a in axes]
        cut = f"{min(cuts):.2f}-{max(cuts):.2f}x" if cuts else "-"
        rows.append((name, f"{hits} of {len(seeds)}", picks, cut, f"{seconds:.0f} s"))
        tqdm.write(f"{name:66s} {rows[-1][1]:>7s}  {cut:12s} {picks}")
    lines = ["| hidden (IX plant) | named first | selected (seed 0) | residual RMS after / before | time |",
             "|---|---|---|---|---|"] + [f"| {' | '.join(r)} |" for r in rows]
    print("\n".join(lines))
    if args.out:
        atomic_write(args.out, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
