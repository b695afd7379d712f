"""How a physical model sees measured data: the kinematics of its fit, the input as it uses it, and
the zero-phase low-pass and decimation that its design and input both go through.

``Preprocessing`` holds the settings of a ``PhysicalModel`` that concern the data, not the
machine (``PhysicalModel.preprocessing`` gives a model's): the sample rate, how far ahead the
kinematics are evaluated, where they come from (``positions``) and the filters. The diagnosis
prepares its data with the same object the fit uses (``diagnose.search.prepare``). Why the filters
sit where they do: the module docstring of ``physics.model``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .kinematics import lowpass_zero_phase, reference_kinematics
from .memo import ArrayMemo
from .workspace import WORKSPACE

POSITIONS = ("reference", "measured", "position")
"""Where a fit's kinematics come from (``Preprocessing.positions``)."""


@dataclass(frozen=True)
class Preprocessing:
    """The data side of a ``PhysicalModel``: fs [Hz]; advance [samples]; filter_hz [Hz] (None: no
    low-pass) and decimate, the reduction both sides of the fit go through; positions ("reference",
    "measured" or "position"); error_filter_hz [Hz], the low-pass of the tracking error in
    "measured" kinematics; position_filter_hz [Hz], that of a measured position (None: twice
    ``filter_hz``)."""

    fs: float
    advance: float
    filter_hz: float | None = 5.0
    decimate: int = 10
    positions: str = "reference"
    error_filter_hz: float = 5.0
    position_filter_hz: float | None = None

    def __post_init__(self):
        if self.positions not in POSITIONS:
            raise ValueError(f"positions must be one of {', '.join(POSITIONS)}, got {self.positions!r}")

    def reduce(self, A, lengths):
        """Per-trial zero-phase low-pass along time, then decimation; A is (T, ...). Columns that are
        zero throughout (a regressor's parameters that do not act on an axis) stay zero unfiltered."""
        A = np.asarray(A, dtype=float)
        flat = A.reshape(A.shape[0], -1)
        used = np.flatnonzero(np.any(flat != 0.0, axis=0)) if flat.shape[1] > 1 else np.arange(flat.shape[1])
        out, start = [], 0
        for n in lengths:
            seg = flat[start : start + n, used]
            start += n
            if self.filter_hz:
                seg = lowpass_zero_phase(seg, self.fs, self.filter_hz, axis=0)
            out.append(seg[:: max(1, self.decimate)])
        kept = np.concatenate(out, axis=0)
        if used.size == flat.shape[1]:
            return kept.reshape(kept.shape[0], *A.shape[1:])
        full = np.zeros((kept.shape[0], flat.shape[1]))
        full[:, used] = kept
        return full.reshape(kept.shape[0], *A.shape[1:])

    def kinematics(self, trials: Sequence) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], list[int]]:
        """(q, qd, qdd) of the fit, each (sum of T, n_axes), and the trial lengths (see ``positions``;
        a trial without a reference always takes its measured position's)."""
        if not trials:
            raise ValueError("PhysicalModel.fit: no trials given")
        kins, lengths = [], []
        for tr in trials:
            if abs(tr.fs - self.fs) > 1e-6 * self.fs:
                raise ValueError(f"trial sampled at {tr.fs} Hz, model expects {self.fs} Hz")
            if self.uses_position(tr):
                q, qd, qdd = reference_kinematics(lowpass_zero_phase(tr.pos, self.fs, self.kinematics_filter_hz),
                                                  self.fs, self.advance)
            else:
                q, qd, qdd = reference_kinematics(tr.ref, self.fs, self.advance)
                if self.positions == "measured":
                    e = lowpass_zero_phase(tr.ref - tr.pos, self.fs, self.error_filter_hz)
                    e, ed, edd = reference_kinematics(e, self.fs, self.advance)
                    q, qd, qdd = q - e, qd - ed, qdd - edd
            kins.append((q, qd, qdd))
            lengths.append(tr.n_samples)
        return tuple(np.concatenate([k[i] for k in kins]) for i in range(3)), lengths

    def uses_position(self, trial) -> bool:
        """Whether the fit takes ``trial``'s kinematics from its measured position (``physics.model``'s docstring)."""
        return self.positions == "position" or trial.ref is None

    def inputs(self, trials: Sequence) -> np.ndarray:
        """The measured input u (sum of T, n_axes) as the fit uses it: where the kinematics come from
        the low-passed measured position, u low-passed the same way (``physics.model``'s docstring)."""
        return np.concatenate([lowpass_zero_phase(tr.u, self.fs, self.kinematics_filter_hz) if self.uses_position(tr)
                               else np.asarray(tr.u, dtype=float) for tr in trials])

    @property
    def kinematics_filter_hz(self) -> float:
        """Corner [Hz] of the low-pass of a measured position before it is differentiated (and of u
        then): ``position_filter_hz``, else twice ``filter_hz``, else ``error_filter_hz``."""
        if self.position_filter_hz is not None:
            return float(self.position_filter_hz)
        return 2.0 * self.filter_hz if self.filter_hz else self.error_filter_hz

    def velocity_filter_hz(self, trials: Sequence) -> float:
        """The corner [Hz] of the low-pass the fit's velocity of ``trials`` went through: that of a
        measured position where one trial's kinematics come from it, else the tracking error's."""
        return self.kinematics_filter_hz if any(self.uses_position(tr) for tr in trials) else self.error_filter_hz

    def position_spread(self, trials: Sequence) -> float:
        """How far [s] the low-pass of a measured position spreads a sample into the samples around
        it (one period of its corner) where one trial's kinematics come from it, else 0."""
        return 1.0 / self.kinematics_filter_hz if any(self.uses_position(tr) for tr in trials) else 0.0

    def reduced_rows(self, lengths: Sequence[int]) -> np.ndarray:
        """The sample (over all trials) each row of ``reduce``'s output comes from."""
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(int)
        return np.concatenate([s + np.arange(0, n, max(1, self.decimate)) for s, n in zip(starts, lengths, strict=True)])

    def kept_reduce(self, A: np.ndarray, lengths: Sequence[int], mask: np.ndarray | None) -> np.ndarray:
        """``masked_reduce``, kept for the same arrays while a ``reduction_memo`` block runs (the
        designs and inputs a diagnosis's refits share)."""
        return reductions().get(lambda: self.masked_reduce(A, lengths, mask), A, mask,
                         extra=(tuple(lengths), self.fs, self.filter_hz, self.decimate))

    def masked_reduce(self, A: np.ndarray, lengths: Sequence[int], mask: np.ndarray | None) -> np.ndarray:
        """``reduce`` of A (T, n_axes, ...) with the samples ``mask`` (T, n_axes) leaves out set to
        zero before the low-pass and their rows to zero after it (``PhysicalModel.fit``); a mask (T,) of one axis
        for its columns A (T, k); no mask: ``reduce``."""
        if mask is None:
            return self.reduce(A, lengths)
        m = mask.reshape(mask.shape + (1,) * (np.ndim(A) - mask.ndim))
        return self.reduce(A * m, lengths) * m[self.reduced_rows(lengths)]


def reductions() -> ArrayMemo:
    """A diagnosis refits one model with one effect more or less tens of times on the same data, and
    filtering its rigid regressor (tens of columns per axis, every sample) is most of a fit: kept
    here (``physics.workspace``) while a ``reduction_memo`` block runs."""
    return WORKSPACE.slot("physics.model.reductions", lambda: ArrayMemo(size=16, by_identity=True))


def reduction_memo():
    """A context in which ``Preprocessing.kept_reduce`` keeps its results for the same arrays
    (a diagnosis's refits on one set of trials)."""
    return reductions().active()
