"""Speed of the IX plant on the paper-size data set (paper 000, V-A: N = 1e6 samples).

Simulates the calibration sweeps (14 references, about 1.04e6 samples) with all default hidden
effects, feedback only, and prints wall time, samples per second and two ratios measured in
this same run:

* against the 10 s budget of the foundation issue;
* against a reference: the same closed loop stepped in numpy (rigid body only, via
  ``physics.ix.forward_dynamics``), timed on a short stretch and scaled to the data set.

Run:  .venv/bin/python benchmarks/bench_simulate.py
The first call compiles the kernel (numba caches it on disk); its time is printed separately.
"""

from __future__ import annotations

import time

import numpy as np

from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set

BUDGET_S = 10.0


def numpy_reference_seconds_per_sample(plant: IXPlant, n: int = 300) -> float:
    """Closed loop with the rigid body stepped by numpy RK4 (no effects): seconds per sample."""
    p = plant.rigid.to_vector()
    C = plant.gains.matrix(plant.fs)
    s = np.zeros(4)
    ufb, e_prev, ts = np.zeros(2), np.zeros(2), 1.0 / plant.fs
    h = ts / plant.substeps
    f = lambda s, u: np.concatenate([s[2:], ix.forward_dynamics(p, s[:2], s[2:], u)])  # noqa: E731
    t0 = time.perf_counter()
    for _ in range(n):
        e = -s[:2]
        ufb = C[:, 2] * ufb + (1 - C[:, 2]) * (C[:, 0] * e + C[:, 1] * (e - e_prev) / ts)
        e_prev = e
        u = np.clip(ufb, -5, 5)
        for _ in range(plant.substeps):
            k1 = f(s, u)
            k2 = f(s + h / 2 * k1, u)
            k3 = f(s + h / 2 * k2, u)
            k4 = f(s + h * k3, u)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return (time.perf_counter() - t0) / n


def main() -> None:
    plant = IXPlant()
    refs = reference_set("calibration", seed=0)
    n = sum(r.n_samples for r in refs)
    t0 = time.perf_counter()
    plant.run(refs[0].positions[:200])
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    trials = plant.run(refs)
    wall = time.perf_counter() - t0
    assert sum(t.n_samples for t in trials) == n
    ref_per_sample = numpy_reference_seconds_per_sample(plant)
    print(f"data set: {len(refs)} calibration references, {n:,} samples at {plant.fs:.0f} Hz, "
          f"{plant.substeps} RK4 substeps, {len(plant.effects)} hidden effects")
    print(f"compile (or load from cache): {compile_s:.2f} s")
    print(f"simulate: {wall:.2f} s  ({n / wall:,.0f} samples/s)")
    print(f"ratio to the {BUDGET_S:.0f} s budget: {wall / BUDGET_S:.2f}  ({'within' if wall <= BUDGET_S else 'OVER'} budget)")
    print(f"numpy reference (rigid body only): {ref_per_sample * 1e6:.0f} us/sample -> {ref_per_sample * n:.0f} s "
          f"for the data set; speed-up {ref_per_sample * n / wall:.0f}x")


if __name__ == "__main__":
    main()
