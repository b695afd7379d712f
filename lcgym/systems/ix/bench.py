"""The IX of paper 000 in the benchmark: feedforward in V on both axes; scored: tracking error
(encoder) and input residual u - f per axis."""

from __future__ import annotations

import pandas as pd

from ...metrics import input_residual_table, tracking_error_table
from ..bench import Bench, trace_frame
from .plant import VERSIONS, IXPlant
from .references import reference_set


class IXBench(Bench):
    """The IX of paper 000 in the benchmark (see the module docstring); scored on both axes, the
    encoders' tracking error [rad]."""

    versions = tuple(VERSIONS)  # the plant's, oldest first (systems.VERSIONS names them without importing this)

    def __init__(self, system, version: str):
        self.system, self.version = system, version
        self.name = f"ix-{version}"
        self.plant = IXPlant.of_version(version)
        self.axes = self.plant.axes

    def references(self, set_name: str, seed: int, n: int, duration: float):
        return reference_set(set_name, seed, n, duration, self.plant.fs)

    def run(self, references, feedforward=None, offsets=None):
        if offsets is not None and any(o is not None for o in offsets):
            raise ValueError("the IX has no reference-offset channel: reference_offset must return None")
        return self.plant.run(list(references), feedforward)

    def tables(self, trials, feedforward, references=None) -> list[pd.DataFrame]:
        return [tracking_error_table(trials), input_residual_table(trials, feedforward)]

    def plant_from_record(self, record: dict) -> IXPlant:
        """The plant a ``record()`` describes (stored in simulated measurement files' sidecars)."""
        return IXPlant.from_record(record)

    def trace(self, trial) -> pd.DataFrame:
        """Every TRACE_DECIMATION-th sample (100 Hz) of the reference and the tracking error [rad]."""
        return trace_frame(trial, self.axes, trial.error, range(len(self.axes)))
