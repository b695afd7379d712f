"""How close the URDF plant runs to its physics: a closed-loop run's time per sample against the
rigid body's forward dynamics alone, measured in the same run.

The plant's sample (``systems/urdf_plant.py``) is the control law, then ``substeps`` RK4 steps of
four stages, each the effects' torque and the rigid body's accelerations. The reference is what
the physics costs: the accelerations alone (``rigid_body.accelerations``) called ``4 x substeps``
times in a compiled loop, and, beside it, pinocchio's ``aba`` called from Python as often (what a
sample cost before the loop was compiled whole). Prints, per machine, microseconds per sample and
the ratios; the first run compiles the kernels (cached afterwards).

    .venv/bin/python benchmarks/urdf_plant_speed.py [--machines two_link,emps_sim,cobot6] [--repeat 5]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
import pinocchio as pin

from lcgym import systems
from lcgym.physics.compiled import NO_REFCOUNTS
from lcgym.systems import rigid_body
from lcgym.systems.urdf import urdf_robot
from lcgym.systems.urdf_plant import URDFPlant, random_references


@numba.njit(cache=False, **NO_REFCOUNTS)  # as the plant compiles its loop
def _physics_only(calls, q, qd, tau, parent, kind, axis, rotation, translation, mass, com, inertia, armature, gravity,
                  R, p, V, A, F, cm, cc, cI, M, h, T, qdd):
    """``calls`` evaluations of the accelerations at slightly moving states (so none is skipped)."""
    for _ in range(calls):
        q[0] += 1e-9
        rigid_body.accelerations(q, qd, tau, parent, kind, axis, rotation, translation, mass, com, inertia, armature,
                                 gravity, R, p, V, A, F, cm, cc, cI, M, h, T, qdd)
        qd[0] = qdd[0] * 1e-12


def measure(name: str, repeat: int) -> dict:
    plant = systems.resolve(name).bench().plant  # a machine file's plant, or a URDF's with the defaults
    if not isinstance(plant, URDFPlant):
        raise SystemExit(f"{name} is not a URDF machine")
    refs = random_references(plant.system, n=1, duration=10.0, fs=plant.fs, seed=0)
    plant.run(refs)  # compiles (or loads) the kernels
    run = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        trial = plant.run(refs)[0]
        run.append((time.perf_counter() - t0) / trial.n_samples)
    n = plant.n_axes
    calls = 4 * plant.substeps
    rng = np.random.default_rng(0)
    q, qd, tau = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    body, work, qdd = plant.body.packed(), rigid_body.scratch(n), np.zeros(n)
    _physics_only(10, q, qd, tau, *body, *work, qdd)
    physics = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        _physics_only(calls * 20_000, q, qd, tau, *body, *work, qdd)
        physics.append((time.perf_counter() - t0) / 20_000)
    model = urdf_robot(plant.system).model
    data, config = model.createData(), pin.neutral(model)
    aba = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(calls * 2_000):
            pin.aba(model, data, config, qd, tau)
        aba.append((time.perf_counter() - t0) / 2_000)
    return {"machine": name, "axes": n, "substeps": plant.substeps, "sample": float(np.median(run)),
            "physics": float(np.median(physics)), "aba": float(np.median(aba))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--machines", default="two_link,emps_sim,cobot6")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    numba.set_num_threads(1)
    print(f"{'machine':10s} {'axes':>4s} {'RK4/sample':>10s} {'plant us/sample':>16s} {'physics us':>11s} "
          f"{'plant/physics':>13s} {'aba from Python us':>19s} {'aba/plant':>9s}")
    for name in args.machines.split(","):
        m = measure(name, args.repeat)
        print(f"{m['machine']:10s} {m['axes']:4d} {m['substeps']:10d} {m['sample'] * 1e6:16.2f} {m['physics'] * 1e6:11.2f} "
              f"{m['sample'] / m['physics']:13.2f} {m['aba'] * 1e6:19.2f} {m['aba'] / m['sample']:9.2f}")


if __name__ == "__main__":
    main()
