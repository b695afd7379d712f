"""What every built-in benchmark machine provides to the runner (``System.bench``), and the trace helper.

A bench machine (``systems/ix/bench.py``, ``systems/flexarm/bench.py``) has

* ``plant``: the closed-loop simulator (what ``learn(plant, reference)`` of a method gets);
* ``references(set_name, seed, n, duration)``: the seeded references of a set;
* ``run(references, feedforward=None, offsets=None)``: closed-loop trials, one per reference, with
  the methods' feedforward (T, n_axes) and, where the machine has that channel, reference offsets;
* ``tables(trials, feedforward, references=None)``: the norm tables (``metrics``) the cell stores
  (with the references, also any per-period rows the machine reports);
* ``trace(trial)``: the tracking error of one trial to plot, per scored axis;
* ``scored``: the indices of the axes it scores (None: all);
* ``signals``: the signals its tables score (``metrics.Signal``: name and label), in the order its
  rows are stored and shown;
* ``tracking_error(trial)``: a class-level function, the tracking error (T, n_axes) [rad or m] its
  tables score (the encoders' on the IX and a URDF machine, the true load angles' on the FlexArm).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from ..metrics import Signal

TRACE_DECIMATION = 5  # samples per stored trace point
TRACKING_ERROR = Signal("tracking_error", "tracking error")
INPUT_RESIDUAL = Signal("input_residual", "input residual u - f")
"""The two signals every bench scores: reference minus position, and input minus feedforward."""


def trace_frame(trial, axes: Sequence[str], error: np.ndarray, columns: Sequence[int]) -> pd.DataFrame:
    """Every TRACE_DECIMATION-th sample of the reference and the tracking error of ``axes`` (the
    columns ``columns`` of the trial), float32."""
    k = slice(None, None, TRACE_DECIMATION)
    cols = {"t": trial.t[k]}
    for ax, i in zip(axes, columns, strict=True):
        cols[f"ref_{ax}"] = trial.ref[k, i]
        cols[f"error_{ax}"] = error[k, i]
    return pd.DataFrame(cols).astype("float32")  # plotting precision; halves the files
