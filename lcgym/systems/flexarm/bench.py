"""The FlexArm of paper 002 in the benchmark.

Feedforward = motor torques [N m] (T, 6); a method may also return a reference offset (T, 6) [rad,
load side] through ``reference_offset(reference)``, added to the motor loop's reference (q_mr =
N (q_lr + offset): the reference modification F1 / r_q of the paper's Fig. 1). Scored on the
moving joints 2, 3, 5: the load-side tracking error q_lr - q_l [deg] (the simulation's true load
angle: the encoders sit on the motors and cannot see the gear torsion), the input residual u - f
[N m], and the TCP position error (Euclidean distance between the true TCP and the reference's
TCP [mm], axis ``tcp``). ``duration`` does not apply: an arm reference is one TCP line out and
back (5-6 s).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
import pandas as pd

from ...metrics import Signal, input_residual_table, norms_table
from ..bench import INPUT_RESIDUAL, TRACKING_ERROR, Bench, trace_frame
from .errors import paper_errors, period_mask, tcp_error
from .plant import VERSIONS, FlexArmPlant, load_error
from .references import MOVING, arm_reference_set


class FlexArmBench(Bench):
    """The FlexArm of paper 002 in the benchmark (see the module docstring)."""

    scored = MOVING  # joints 2, 3, 5
    signals = (TRACKING_ERROR, INPUT_RESIDUAL, Signal("model_following_error", "model-following error"),
               Signal("ee_acceleration_error", "end-effector acceleration error"),
               Signal("tcp_position_error", "TCP position error"))
    versions = tuple(VERSIONS)  # the plant's, oldest first (systems.VERSIONS names them without importing this)

    def __init__(self, system, version: str):
        self.system, self.version = system, version
        self.name = f"flexarm-{version}"
        self.plant = FlexArmPlant.of_version(version)
        self.axes = self.plant.axes
        self.scored_axes = tuple(self.axes[i] for i in self.scored)

    def references(self, set_name: str, seed: int, n: int, duration: float):
        return arm_reference_set(set_name, seed, n, self.plant.fs)

    def run(self, references, feedforward=None, offsets=None):
        references = list(references)
        feedforward = [None] * len(references) if feedforward is None else list(feedforward)
        offsets = [None] * len(references) if offsets is None else list(offsets)
        N = np.asarray(self.plant.true_drive.N)
        jobs = [(r, f, None if o is None else N * np.asarray(o, dtype=float))
                for r, f, o in zip(references, feedforward, offsets, strict=True)]
        # the compiled loop releases the GIL: as many threads as numba may use (one in the
        # benchmark's parallel workers)
        with ThreadPoolExecutor(max_workers=max(1, min(len(jobs), numba.get_num_threads()))) as pool:
            return list(pool.map(lambda job: self.plant.run(*job), jobs))

    load_error = staticmethod(load_error)
    tracking_error = staticmethod(load_error)  # what ``tables`` scores: the true load angles' error

    def tcp_error(self, trial) -> np.ndarray:
        """|TCP - TCP of the reference| (T,) [mm]."""
        return tcp_error(trial, self.plant.true_arm.dh)

    def tables(self, trials, feedforward, references=None) -> list[pd.DataFrame]:
        """The norms scored (module docstring); with the trials' ``references``, also paper 002's
        errors for all samples and for the dynamic and static periods: ``model_following_error``
        of joints 2, 3, 5 [rad/s^2], ``ee_acceleration_error`` (axis ``ee``: the Euclidean norm of
        the accelerometer's error) [m/s^2] and ``tcp_position_error`` [mm] (``errors.py``)."""
        cols = list(self.scored)
        e = np.degrees(np.concatenate([self.load_error(t) for t in trials]))[:, cols]
        residual = input_residual_table(trials, feedforward, unit="N m")
        tcp = np.concatenate([self.tcp_error(t) for t in trials])[:, None]
        out = [norms_table(e, self.scored_axes, "tracking_error", "deg"),
               residual[residual["axis"].isin(self.scored_axes)].reset_index(drop=True),
               norms_table(tcp, ("tcp",), "tcp_position_error", "mm")]
        if references is None:
            return out
        parts = [(paper_errors(self.plant, t, r, f), r) for t, r, f in zip(trials, references, feedforward, strict=True)]
        for period in ("all", "dynamic", "static"):
            masks = [period_mask(r, period) for _, r in parts]
            joint = np.concatenate([p["joint"][m] for (p, _), m in zip(parts, masks, strict=True)])
            ee = np.concatenate([np.linalg.norm(p["ee_acc"][m], axis=1) for (p, _), m in zip(parts, masks, strict=True)])
            out += [norms_table(joint, self.scored_axes, "model_following_error", "rad/s^2", period=period),
                    norms_table(ee[:, None], ("ee",), "ee_acceleration_error", "m/s^2", period=period)]
            if period != "all":  # the whole trial's TCP error is the row above
                tcp_part = np.concatenate([p["tcp"][m] for (p, _), m in zip(parts, masks, strict=True)])
                out.append(norms_table(tcp_part, ("tcp",), "tcp_position_error", "mm", period=period))
        return out

    def trace(self, trial) -> pd.DataFrame:
        return trace_frame(trial, self.scored_axes, self.load_error(trial), self.scored)
