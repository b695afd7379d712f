"""Speed of the FlexArm plant (target: a 10 s validation move in at most 1/30 of real time).

Simulates the validation TCP lines (feedback only, default hidden effects, 4 RK4 steps per 1 ms
sample) and prints the wall time per 10 s of motion, the real-time factor (motion time / wall
time; target 30x), and, as a reference measured in the same run, the IX plant's wall time per 10 s
(500 Hz, 16 hidden effects).

Run:  .venv/bin/python benchmarks/flexarm_speed.py
The first run compiles the kernel (cached on disk); its time is printed separately.
"""

from __future__ import annotations

import time

from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import arm_reference_set
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set

TARGET = 30.0  # x real time


def main() -> None:
    refs = arm_reference_set("validation", seed=0, n_references=4)
    plant = FlexArmPlant()
    t0 = time.perf_counter()
    plant.run(refs[0])
    print(f"first run (compiles or loads the kernel): {time.perf_counter() - t0:.1f} s")
    t0 = time.perf_counter()
    for r in refs:
        plant.run(r)
    wall = time.perf_counter() - t0
    seconds = sum(r.n_samples for r in refs) / plant.fs
    per10 = wall / seconds * 10
    ix_refs = reference_set("validation", 0, 2, duration=10.0)
    ix = IXPlant()
    ix.run(ix_refs[:1])
    t0 = time.perf_counter()
    for r in ix_refs:
        ix.run(r)
    ix_per10 = (time.perf_counter() - t0) / (sum(r.n_samples for r in ix_refs) / ix.fs) * 10
    print(f"FlexArm: {seconds:.1f} s of motion in {wall:.2f} s: {per10:.3f} s per 10 s move, "
          f"{10 / per10:.1f}x real time (target {TARGET:.0f}x)")
    print(f"IX plant, same run: {ix_per10:.3f} s per 10 s (FlexArm / IX = {per10 / ix_per10:.0f}x)")


if __name__ == "__main__":
    main()
