"""The diagnosis on the EMPS benchmark's real files (docs/emps.md): the selection on each file, the
residual on the other file (``--validate``), the
fitted parameters against the benchmark's published IDIM-LS values, and how they move with the
low-pass of the measured position (``PhysicalModel.position_filter_hz``), on the real files and
on a simulated carriage with the published parameters (the data of ``tests/test_diagnose_emps.py``).

Run:  .venv/bin/python studies/diagnose_emps.py --data DIR   (DIR holds DATA_EMPS.mat and
      DATA_EMPS_PULSES.mat from https://www.nonlinearbenchmark.org)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_diagnose_emps import CARRIAGE, SYMMETRIC  # noqa: E402  (the simulated carriage lives with the tests)

from lcgym import datasets, systems  # noqa: E402
from lcgym.diagnose import diagnose  # noqa: E402
from lcgym.systems.examples.emps import EMPS  # noqa: E402
from lcgym.systems.urdf_plant import URDFPlant, random_references  # noqa: E402

PUBLISHED = {"M": 95.1, "Fv": 203.5, "Fc": 20.39, "offset": -3.16}  # IDIM-LS, the benchmark's description
PUBLISHED_ASYMMETRIC = {"Fc+": 20.14, "Fc-": 20.63, "Fv+": 166.7, "Fv-": 240.4}
FILES = ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")


def symmetric_fit(trial, position_filter_hz=None) -> dict:
    model = EMPS.diagnosis_model(trial.fs)
    model.positions, model.position_filter_hz = "position", position_filter_hz
    rep = diagnose([trial], EMPS, model=model, add=["coulomb_friction@x", "offset@x"])
    e = {d["effect"]: d for d in rep.after["effects"]}
    return {"M": rep.after["parameters"]["M"], "Fv": rep.after["parameters"]["Fv"], "Fc": e["coulomb_friction@x"]["Fc"],
            "offset": e["offset@x"]["c"]}


def shape_left(trial) -> float:
    """Largest |mean| [N] of the residual, after the asymmetric friction, over 10 mm/s bins of the
    velocity (bins with at least 20 reduced rows, 0.2 s of data): what a further friction form
    could take; and the residual's largest |value| [N] with its time [s] and velocity [m/s]."""
    model = diagnose([trial], EMPS, kinematics="measured", add=["asymmetric_friction@x"]).after_model
    r = model.residual([trial])[:, 0]
    kin, lengths = model.preprocessing.kinematics([trial])
    v = model.preprocessing.reduce(kin[1], lengths)[:, 0]
    k = np.floor(v / 0.01).astype(int)
    worst = int(np.argmax(np.abs(r)))
    t = worst * model.decimate / trial.fs
    return max(abs(r[k == b].mean()) for b in np.unique(k) if (k == b).sum() >= 20), abs(r[worst]), t, v[worst]


def show(values: dict, truth: dict) -> str:
    return ", ".join(f"{k} {v:.2f} ({100 * (v - truth[k]) / abs(truth[k]):+.1f} %)" for k, v in values.items())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True, help="folder with the EMPS .mat files")
    args = parser.parse_args()
    trials = [datasets.emps(args.data / f) for f in FILES]
    for k, name in enumerate(FILES):
        rep = diagnose([trials[k]], EMPS, kinematics="measured", validate=[trials[1 - k]])
        after = diagnose([trials[k]], EMPS, kinematics="measured", add=rep.missing).after
        v = rep.validation
        print(f"{name}: selected {', '.join(rep.missing) or 'nothing'}; residual RMS {rep.residual['x']['RMS']:.2f} -> "
              f"{after['residual']['x']['RMS']:.2f} N; on {FILES[1 - k]} (not fitted) {v['residual']['x']['RMS']:.2f} -> "
              f"{v['residual_after']['x']['RMS']:.2f} N")
        asym = diagnose([trials[k]], EMPS, kinematics="measured", add=["asymmetric_friction@x"]).after
        (e,), fv = asym["effects"], asym["parameters"]["Fv"]
        print("  symmetric + offset: " + show(symmetric_fit(trials[k]), PUBLISHED))
        mean, peak, when, speed = shape_left(trials[k])
        print(f"  after the asymmetric friction, mean residual per 10 mm/s velocity bin: at most {mean:.2f} N; "
              f"largest residual {peak:.1f} N at t = {when:.2f} s, {1000 * speed:.0f} mm/s")
        print("  asymmetric: " + show({"Fc+": e["Fc_pos"], "Fc-": e["Fc_neg"], "Fv+": fv + e["dFv"], "Fv-": fv - e["dFv"]},
                                      PUBLISHED_ASYMMETRIC))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "carriage.urdf"
        path.write_text(CARRIAGE)
        carriage = systems.get(str(path), joints=("x",))
        simulated = URDFPlant(carriage, effects=SYMMETRIC, encoder_resolution=1e-6).run(
            random_references(carriage, n=1, duration=25.0, seed=0))[0]
    print("low-pass of the measured position [Hz]: fitted values (against the published ones)")
    for hz in (5.0, 10.0, 12.5, 20.0, 40.0):
        print(f"  {hz:4g} real      " + show(symmetric_fit(trials[0], hz), PUBLISHED))
        print(f"  {hz:4g} simulated " + show(symmetric_fit(simulated, hz), PUBLISHED))


if __name__ == "__main__":
    main()
