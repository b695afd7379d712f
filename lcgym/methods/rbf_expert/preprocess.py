"""Data preprocessing of paper 002, section 3.2 (eqs. 26-30), for one joint's motion influence.

From the motion influence (Q, Qd, Qdd of ``influence.py``) of joint i to the network inputs:

1. magnitude normalization (3.2.1): v11 = Q / max|Q|, v21 = Qd / max|Qd|, v31 = Qdd / max|Qdd|,
   and beta0 = max|e| for the predicted error;
2. prediction viability (3.2.2, eqs. 27-28): a sample is viable when |v21| > eps_v or |v31| > eps_a
   (the reference moves); elsewhere there is no prediction;
3. third dimension redefined (3.2.3): v33 = (2 / pi) arctan(v31 / v21) in (-1, 1): positive while
   |velocity| grows, negative while it falls, +-1 at a velocity reversal;
4. second dimension normalized per level of the third (3.2.4, eqs. 29-30): v22 = v21 / max|v21|
   over the viable samples whose v33 lies in the same level [a_l, b_l) (``levels`` equal levels over
   [-1, 1]).

The maxima are taken over all training samples (the paper's set S of every executed trajectory)
when ``fit`` is called and kept: a new trajectory is normalized with the training's maxima, so that
an input means the same thing in training and prediction, and a new trajectory faster than the
training ones gets |v22| > 1 (outside the data; ``predictor`` then predicts nothing there). A level
without training samples has no maximum: its samples get v22 = NaN (outside).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PreprocessConfig:
    """eps_v, eps_a: the viability thresholds eps_{2,1}, eps_{3,1} of eq. (27) on the normalized
    velocity and acceleration; levels: number of v33 levels for eq. (29)."""

    eps_v: float = 1e-3
    eps_a: float = 1e-3
    levels: int = 10


def arctan_ratio(v21: np.ndarray, v31: np.ndarray) -> np.ndarray:
    """v33 = (2 / pi) arctan(v31 / v21) (section 3.2.3), +-1 where v21 = 0 (sign of v31)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        v32 = np.where(v21 != 0.0, np.arctan(v31 / np.where(v21 != 0.0, v21, 1.0)), np.sign(v31) * np.pi / 2)
    return 2.0 / np.pi * v32


class Preprocessor:
    """Section 3.2 for one joint: ``fit(Q, Qd, Qdd, e)`` on the training samples (1-D arrays,
    concatenated over trajectories), then ``transform(Q, Qd, Qdd)`` -> dict with v11, v21, v31, v22,
    v33 and ``viable`` (bool) per sample. Learned: ``scale_`` (max|Q|, max|Qd|, max|Qdd|),
    ``beta0_`` = max|e|, ``level_max_`` (levels,) max|v21| per v33 level (NaN: no data)."""

    def __init__(self, config: PreprocessConfig | None = None):
        self.config = config

    @property
    def config_(self) -> PreprocessConfig:
        return self.config or PreprocessConfig()

    def fit(self, Q: np.ndarray, Qd: np.ndarray, Qdd: np.ndarray, e: np.ndarray) -> Preprocessor:
        scale = np.array([np.max(np.abs(Q)), np.max(np.abs(Qd)), np.max(np.abs(Qdd))], dtype=float)
        if not np.all(scale > 0) or not np.all(np.isfinite(scale)):
            raise ValueError(f"Preprocessor.fit: the motion influence does not move (max |Q|, |Qd|, |Qdd| = {scale})")
        self.scale_ = scale
        self.beta0_ = float(np.max(np.abs(e)))
        if not self.beta0_ > 0 or not np.isfinite(self.beta0_):
            raise ValueError(f"Preprocessor.fit: the error to learn is zero or not finite (max |e| = {self.beta0_})")
        v = self._normalized(Q, Qd, Qdd)
        level = self._level(v["v33"])
        self.level_max_ = np.full(self.config_.levels, np.nan)
        for lv in range(self.config_.levels):
            sel = v["viable"] & (level == lv)
            if sel.any():
                self.level_max_[lv] = np.max(np.abs(v["v21"][sel]))
        return self

    def transform(self, Q: np.ndarray, Qd: np.ndarray, Qdd: np.ndarray) -> dict[str, np.ndarray]:
        v = self._normalized(Q, Qd, Qdd)
        m = self.level_max_[self._level(v["v33"])]
        with np.errstate(divide="ignore", invalid="ignore"):
            v["v22"] = np.where(v["viable"], v["v21"] / m, np.nan)  # eq. (29)
        return v

    def _normalized(self, Q, Qd, Qdd) -> dict[str, np.ndarray]:
        cfg = self.config_
        v11, v21, v31 = (np.asarray(x, dtype=float) / s for x, s in zip((Q, Qd, Qdd), self.scale_, strict=True))
        viable = (np.abs(v21) > cfg.eps_v) | (np.abs(v31) > cfg.eps_a)  # eq. (27)
        return {"v11": v11, "v21": v21, "v31": v31, "v33": arctan_ratio(v21, v31), "viable": viable}

    def _level(self, v33: np.ndarray) -> np.ndarray:
        """Level index l of eq. (30): equal levels [a_l, b_l) over [-1, 1], the last one closed."""
        n = self.config_.levels
        return np.clip(np.floor((v33 + 1.0) / 2.0 * n).astype(int), 0, n - 1)
