"""A URDF machine in the benchmark (``machine.benchmark_machine``, a machine file): its plant, its
reference sets and what it scores, the contract of ``systems/bench.py``.

Feedforward = joint torques [N m] or forces [N], one column per axis; no reference-offset
channel. References: random point-to-point moves of every axis within the URDF's joint limits
(``references.random_moves`` with the machine's ``ReferenceSettings``), about ``duration`` s of
moves each, each set from its own random stream (``references.stream``: train, validation and test
never share a reference). Scored on every axis: the tracking error reference - encoder [deg, or mm
on a prismatic axis: reported in the units the machine's ``Axis.display`` gives] and the input
residual u - f - C r [the machine's input unit]: the input minus what the loop commands along the
reference, C r the feedback's output when the encoders follow it (``URDFPlant.reference_feedback``;
zero unless the loop differentiates the measurement: then it is labelled so, ``signals``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..metrics import input_residual_table, norms_table
from ..references import DEG, AxisLimits, stream, sweeps
from .bench import INPUT_RESIDUAL, INPUT_RESIDUAL_LOOP, TRACKING_ERROR, Bench, trace_frame
from .system import System

VERSIONS = ("v0",)  # a machine of a machine file has one plant: the file's


class URDFBench(Bench):
    """The bench of a URDF machine (``machine.benchmark_machine``): its plant is what ``settings``
    (``MachineSettings``) give the machine; scored on every axis."""

    versions = VERSIONS

    def __init__(self, system: System, version: str, settings):
        self.system, self.version, self.settings = system, version, settings
        self.name = f"{system.name}-{version}"
        self.plant = settings.plant(system)
        self.axes = system.axis_names

    @property
    def signals(self):
        """The tracking error and the input residual, labelled u - f - C r where the loop reacts to
        the motion itself (``URDFPlant.reference_feedback``), u - f where it does not."""
        reacts = self.plant.gains.derivative != "error"
        return (TRACKING_ERROR, INPUT_RESIDUAL_LOOP if reacts else INPUT_RESIDUAL)

    def references(self, set_name: str, seed: int, n: int = 8, duration: float = 20.0):
        """The seeded set ``set_name``: "train", "validation", "test" (``n`` references of random moves
        of about ``duration`` s), or "calibration" (each axis swept over its range and back at four
        speeds, the others parked at seven positions: ``references.sweeps``)."""
        from .urdf_plant import random_references

        r, rng = self.settings.references, stream(set_name, seed)
        if set_name == "calibration":
            robot = self.plant.robot
            lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
            hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
            v = self.speed_limits()
            limits = [AxisLimits(a, b, s, s / r.accel_time, s / r.accel_time / r.jerk_time)
                      for a, b, s in zip(lo, hi, v, strict=True)]
            jitter = [DEG if a.revolute else 1e-3 for a in self.system.axes]
            return sweeps(rng, limits, self.axes, self.plant.fs, margin=r.margin * (hi - lo), jitter=jitter)
        return random_references(self.system, n, duration, self.plant.fs, speed=r.speed, accel_time=r.accel_time,
                                 jerk_time=r.jerk_time, margin=r.margin, velocity_fallback=r.velocity_fallback,
                                 rng=rng, prefix=f"{set_name}-{seed}")

    def speed_limits(self) -> np.ndarray:
        """The references' top speed per axis [rad/s or m/s]: ``speed`` x the URDF's velocity limit
        (``velocity_fallback`` where it gives none)."""
        from .urdf_plant import reference_speeds

        r = self.settings.references
        return reference_speeds(self.plant.robot, r.speed, r.velocity_fallback)

    def run(self, references, feedforward=None, offsets=None):
        if offsets is not None and any(o is not None for o in offsets):
            raise ValueError(f"{self.system.name} has no reference-offset channel: reference_offset must return None")
        return self.plant.run(list(references), None if feedforward is None else list(feedforward))

    def tables(self, trials, feedforward, references=None) -> list[pd.DataFrame]:
        """The tracking error per axis [deg or mm] and the input residual u - f - C r [each axis's input
        unit: N m on a revolute joint, N on a prismatic one]."""
        factors, units = zip(*(a.display for a in self.system.axes), strict=True)
        e = np.asarray(factors) * np.concatenate([t.error for t in trials])
        commanded = [np.asarray(f, dtype=float) + self.plant.reference_feedback(t.ref)
                     for t, f in zip(trials, feedforward, strict=True)]
        return [norms_table(e, self.axes, "tracking_error", units),
                input_residual_table(trials, commanded, unit=self.system.input_units)]

    def trace(self, trial) -> pd.DataFrame:
        """Every TRACE_DECIMATION-th sample of the reference and the tracking error [rad or m]."""
        return trace_frame(trial, self.axes, trial.error, range(len(self.axes)))
