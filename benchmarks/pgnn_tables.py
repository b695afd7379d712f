"""Our versions of paper 000's Tables II-V on the IX plant, and the PGNN's training time on the
paper-size data set.

Training data: the calibration sweeps (paper 000, V-A; 14 references, 1.04e6 samples) run with
feedback only. Methods: physical model (least squares), PGNN trained with J (R1 and R2), PGNN
trained with J_LS only. Printed:

* training time and epochs of each PGNN on the 1e6 samples;
* Tables II/III: norms of the input residual eps = u - f [V] on feedback-only runs of the
  validation references (u low-pass filtered as for training), and RMS of the network's output f^C;
* Tables IV/V: norms of the tracking error [deg] with each feedforward on the validation
  references, and with feedback only.

Run:  .venv/bin/python benchmarks/pgnn_tables.py [--seed 0] [--max-epochs 300] [--mu1 1e-5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lcgym.envs.ix import IXPlant
from lcgym.envs.references import reference_set
from lcgym.leaderboard.metrics import norms
from lcgym.pgnn import PGNN, PGNNConfig
from lcgym.physics.kinematics import lowpass_zero_phase
from lcgym.physics.model import PhysicalModel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-epochs", type=int, default=300)
    parser.add_argument("--mu1", type=float, default=1e-5)
    parser.add_argument("--filter-hz", type=float, default=1.0)
    args = parser.parse_args()
    plant = IXPlant()
    t0 = time.perf_counter()
    calibration = plant.run(reference_set("calibration", args.seed))
    n = sum(t.n_samples for t in calibration)
    print(f"calibration data: {len(calibration)} runs, {n:,} samples, simulated in {time.perf_counter() - t0:.1f} s")
    val_refs = reference_set("validation", args.seed)
    val_fb = plant.run(val_refs)

    physical = PhysicalModel().fit(calibration)
    models = {"physical model": physical}
    for label, reg in (("PGNN with J", True), ("PGNN with J_LS", False)):
        cfg = PGNNConfig(regularize=reg, mu1=args.mu1, max_epochs=args.max_epochs, filter_hz=args.filter_hz,
                         seed=args.seed)
        t1 = time.perf_counter()
        m = PGNN(cfg, physical=PhysicalModel()).fit(calibration, progress=True)
        print(f"{label}: trained on {m.info_['n_samples']:,} samples in {time.perf_counter() - t1:.1f} s "
              f"({m.info_['seconds']:.1f} s in Algorithm 1, {m.info_['epochs']} epochs)")
        models[label] = m

    def ff(model, ref):
        return model.predict(ref)

    print("\nTables II/III: input residual eps = u - f [V] on feedback-only validation runs (u filtered)")
    print(f"{'':18s} {'axis':9s} {'MA':>7s} {'RMS':>7s} {'Inf':>7s} {'RMS(f^C)':>9s}")
    for label, model in models.items():
        eps = np.concatenate([lowpass_zero_phase(t.u, plant.fs, args.filter_hz) - ff(model, t) for t in val_fb])
        fc = (np.concatenate([model.nn_contribution(t) for t in val_fb]) if hasattr(model, "nn_contribution")
              else np.zeros_like(eps))
        nm, rc = norms(eps), np.sqrt(np.mean(fc**2, axis=0))
        for i, ax in enumerate(plant.axes):
            print(f"{label:18s} {ax:9s} {nm['MA'][i]:7.3f} {nm['RMS'][i]:7.3f} {nm['Inf'][i]:7.3f} {rc[i]:9.3f}")

    print("\nTables IV/V: tracking error e [deg] on the validation references")
    print(f"{'':18s} {'axis':9s} {'MA':>7s} {'RMS':>7s} {'Inf':>7s}")
    runs = {"feedback only": val_fb}
    runs.update({label: plant.run(val_refs, [ff(m, r) for r in val_refs]) for label, m in models.items()})
    for label, trials in runs.items():
        nm = norms(np.degrees(np.concatenate([t.error for t in trials])))
        for i, ax in enumerate(plant.axes):
            print(f"{label:18s} {ax:9s} {nm['MA'][i]:7.3f} {nm['RMS'][i]:7.3f} {nm['Inf'][i]:7.3f}")


if __name__ == "__main__":
    main()
