"""The bench: what a benchmark machine gives the runner, ``lcgym simulate`` and the envs.

``Bench`` is the contract, as an abstract base class: a bench of one plant version holds the
closed-loop plant, makes the seeded reference sets, runs trials with a method's feedforward and
scores them. ``System.bench`` is the machine's ``BenchFactory``: it makes a fresh bench of a
version (``System.make_bench``), and tells what the bench scores without building a plant.
Machines: ``ix/bench.py``, ``flexarm/bench.py``, ``urdf_bench.py`` (a URDF or a machine file).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from ..metrics import Signal

TRACE_DECIMATION = 5  # samples per stored trace point
TRACKING_ERROR = Signal("tracking_error", "tracking error")
INPUT_RESIDUAL = Signal("input_residual", "input residual u - f")
"""The two signals every bench scores: reference minus position, and the input residual: the input
minus what the loop commands along the reference, u - (f + C r), C r the feedback's output when the
measurement follows the reference exactly (``plant.reference_feedback``). It is zero when a method
tracks exactly. Where the loop acts on the tracking error alone (the IX, the FlexArm), C r = 0 and
it is paper 000's u - f (eq. 34-36's eps); where the loop reacts to the motion itself (a velocity
loop on the measured position, the EMPS), the bench labels it ``INPUT_RESIDUAL_LOOP``."""
INPUT_RESIDUAL_LOOP = Signal("input_residual", "input residual u - f - C r")


def trace_frame(trial, axes: Sequence[str], error: np.ndarray, columns: Sequence[int]) -> pd.DataFrame:
    """Every TRACE_DECIMATION-th sample of the reference and the tracking error of ``axes`` (the
    columns ``columns`` of the trial), float32."""
    k = slice(None, None, TRACE_DECIMATION)
    cols = {"t": trial.t[k]}
    for ax, i in zip(axes, columns, strict=True):
        cols[f"ref_{ax}"] = trial.ref[k, i]
        cols[f"error_{ax}"] = error[k, i]
    return pd.DataFrame(cols).astype("float32")  # plotting precision; halves the files


class Bench(ABC):
    """A benchmark machine with the plant of one version (the module docstring).

    Made by the machine's ``BenchFactory`` (``System.make_bench``) with the machine and the
    version; each bench builds its own plant: a plant may carry state from run to run (a URDF
    plant's noise stream), so benches are not shared between benchmark cells.

    Class attributes: ``versions``, the plant's versions, oldest first; ``scored``, the indices of
    the axes it scores (None: all); ``signals``, the signals its tables score (name and label), in
    the order its rows are stored and shown. Instance attributes: ``system``, ``version``,
    ``name`` ("ix-v1"), ``plant`` (the closed-loop simulator a method's ``learn(plant, reference)``
    gets) and ``axes`` (the plant's axis names).
    """

    versions: ClassVar[tuple[str, ...]]
    scored: ClassVar[tuple[int, ...] | None] = None
    signals: ClassVar[tuple[Signal, ...]] = (TRACKING_ERROR, INPUT_RESIDUAL)

    system: Any  # the machine (``System``)
    version: str
    name: str
    plant: Any
    axes: tuple[str, ...]

    @staticmethod
    def tracking_error(trial) -> np.ndarray:
        """The tracking error (T, n_axes) [rad or m] the tables score: reference minus encoder
        (the FlexArm's: minus the true load angles)."""
        return trial.error

    @abstractmethod
    def references(self, set_name: str, seed: int, n: int, duration: float) -> list:
        """The seeded references of a set ("train", "validation", "test"): ``n`` of about
        ``duration`` s of moves each."""

    @abstractmethod
    def run(self, references, feedforward=None, offsets=None) -> list:
        """Closed-loop trials, one per reference, with the feedforward (T, n_axes) of each and,
        where the machine has that channel, its reference offset; None: feedback only."""

    @abstractmethod
    def tables(self, trials, feedforward, references=None) -> list[pd.DataFrame]:
        """The norm tables (``metrics``) of the trials, one row per signal and axis (with the
        references, also the per-period rows the machine reports)."""

    @abstractmethod
    def trace(self, trial) -> pd.DataFrame:
        """The reference and tracking error of one trial to plot, per scored axis."""

    def plant_from_record(self, record: dict):
        """The plant a simulated log's record describes (``meta["plant"]``), for ``lcgym diagnose
        --replay``; a machine that cannot rebuild one says so."""
        raise ValueError(f"machine {self.system.name} cannot rebuild a plant from a record (the IX and machine files can)")


@dataclass(frozen=True)
class BenchFactory:
    """How a machine makes its bench, and which Gymnasium envs run its plant (``System.bench``).

    ``kind``: the ``Bench`` subclass, built with the machine, a version and, where given,
    ``settings`` (a machine file's ``MachineSettings``: what its plant carries beyond the URDF).
    ``envs``: the machine's Gymnasium ids and entry points, oldest version first;
    ``observation_error``: where the tracking error sits in an env's observation (the columns an RL
    agent that does not observe its error is not shown)."""

    kind: type[Bench]
    settings: Any = None
    envs: Mapping[str, Mapping] = field(default_factory=dict)
    observation_error: slice | None = None

    def __post_init__(self):
        object.__setattr__(self, "envs", {k: dict(v) for k, v in self.envs.items()})

    def __call__(self, system, version: str | None = None) -> Bench:
        """A fresh bench of ``system`` with the plant of ``version`` (None: the newest)."""
        version = self.kind.versions[-1] if version is None else version
        if version not in self.kind.versions:
            raise ValueError(f"{system.name} has plant versions {', '.join(self.kind.versions)}, not {version!r}")
        if self.settings is None:
            return self.kind(system, version)
        return self.kind(system, version, self.settings)

    @property
    def versions(self) -> tuple[str, ...]:
        return self.kind.versions

    @property
    def scored(self) -> tuple[int, ...] | None:
        return self.kind.scored

    @property
    def replays(self) -> bool:
        """Whether its bench rebuilds a plant from a simulated log's record (``Bench.plant_from_record``)."""
        return self.kind.plant_from_record is not Bench.plant_from_record

    def tracking_error(self, trial) -> np.ndarray:
        return self.kind.tracking_error(trial)
