"""Expert activation logic of paper 002, section 3.3 (Table 3): which of four networks predicts a
sample, from the signs of velocity and acceleration and a few Boolean functions of v33.

Per viable sample j (``preprocess``), with the pseudo-gradient d1 = v33(j) - v33(j-1) and the
pseudo-hessian d2 = v33(j) - 2 v33(j-1) + v33(j-2) over consecutive viable samples:

* AZ, acceleration near zero and steady:  |v33| <= eps_33 and |d1| <= eps_grad;
* VC, velocity constant for a long period: AZ for at least ``long_period`` s, found as in the paper
  with morphology on the AZ sequence: a closing (dilate, erode) over ``gap`` s bridges short breaks,
  an opening (erode, dilate) over ``long_period`` s keeps only the long runs;
* AS, acceleration changes sign (near zero briefly): AZ and not VC;
* Vp, Vn: v22 > 0, v22 < 0;
* A, initial acceleration or concave acceleration at near-constant velocity:
  v33 >> 0 (read as v33 > eps_strong) or (d2 < 0 and AZ);
* D, final deceleration or convex acceleration at near-constant velocity:
  v33 << 0 (v33 < -eps_strong) or (d2 > 0 and AZ).

Network t of Table 3 is active where chi_NN^t holds:

    t = 1 (v > 0, accelerating): (AS or A) and not VC and Vp
    t = 2 (v > 0, decelerating): (not AS and D) and not VC and Vp
    t = 3 (v < 0, decelerating): (not AS and D) and not VC and Vn
    t = 4 (v < 0, accelerating): (AS or A) and not VC and Vn

The four sets are disjoint. Where no network is active (not viable, long constant velocity, or a
fast zero crossing of v33 that is neither AZ, A nor D) the prediction is zero.

Beyond the paper (``network_types(..., cruise_and_rest=True)``, the ``rbf-expert`` method's
default): two more experts take the samples Table 3 leaves out,

    t = 5 (cruise): VC, a long run at constant velocity;
    t = 6 (rest): not viable, the reference at rest.

Paper 002 predicts the model-following error, an acceleration, which is about zero there. A
tracking error is not: a friction at constant speed and a spring or gravity at rest leave one as
long as they last (on the IX, the EMPS and the two-link arm 50-77 % of the base's tracking-error
energy lies where Table 3 activates no network; docs/methods/rbf-expert.md). Their inputs are the
joint's position and velocity (cruise), and its position and the direction of its last motion
(rest: a friction holds the error the last move left, ``CRUISE_REST_RANGES``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Table 5: neuron ranges per network type, dimensions (v11, v22, v33)
TABLE5_RANGES = {
    1: ((-1.0, 1.0), (0.0, 1.0), (-0.1, 1.0)),
    2: ((-1.0, 1.0), (0.0, 1.0), (-1.0, 0.1)),
    3: ((-1.0, 1.0), (-1.0, 0.0), (-1.0, 0.1)),
    4: ((-1.0, 1.0), (-1.0, 0.0), (-0.1, 1.0)),
}
NETWORK_TYPES = (1, 2, 3, 4)
CRUISE, REST = 5, 6
CRUISE_REST_RANGES = {CRUISE: ((-1.0, 1.0), (-1.0, 1.0)), REST: ((-1.0, 1.0), (-1.0, 1.0))}
"""Neuron ranges of the two experts beyond Table 3: (v11, v21) at cruise, (v11, last direction) at rest."""


@dataclass(frozen=True)
class ExpertConfig:
    """Thresholds of section 3.3: eps_33 (|v33| near zero), eps_grad (|d1| near zero), eps_strong
    (v33 >> 0), gap and long_period [s] for VC (closing, then opening of AZ)."""

    eps_33: float = 0.02
    eps_grad: float = 2e-3
    eps_strong: float = 0.02
    gap: float = 0.01
    long_period: float = 0.5


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive) indices of the runs of True in a 1-D bool array."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def keep_long_runs(mask: np.ndarray, n: int) -> np.ndarray:
    """Morphological opening (erode, then dilate) of a 1-D mask with a length-n element: the runs of
    True at least n long stay, shorter ones go."""
    out = np.zeros_like(mask, dtype=bool)
    for a, b in zip(*_runs(mask), strict=True):
        if b - a >= n:
            out[a:b] = True
    return out


def fill_short_gaps(mask: np.ndarray, n: int) -> np.ndarray:
    """Morphological closing (dilate, then erode) of a 1-D mask with a length-n element (the outside
    counted False): gaps of False shorter than n between two runs of True are filled."""
    out = mask.astype(bool).copy()
    starts, ends = _runs(~out)
    for a, b in zip(starts, ends, strict=True):
        if a > 0 and b < out.size and b - a < n:
            out[a:b] = True
    return out


def boolean_functions(v22: np.ndarray, v33: np.ndarray, viable: np.ndarray, fs: float,
                      config: ExpertConfig | None = None) -> dict[str, np.ndarray]:
    """The chi_p functions AZ, VC, AS, Vp, Vn, A, D (bool, (T,)); False where not viable."""
    cfg = config or ExpertConfig()
    T = v33.shape[0]
    idx = np.flatnonzero(viable)
    z = v33[idx]
    d1 = np.diff(z, prepend=z[:1]) if z.size else z
    d2 = np.diff(z, n=2, prepend=z[:1].repeat(2)) if z.size else z
    az = (np.abs(z) <= cfg.eps_33) & (np.abs(d1) <= cfg.eps_grad)
    gap = max(1, int(round(cfg.gap * fs)))
    long = max(1, int(round(cfg.long_period * fs)))
    vc = keep_long_runs(fill_short_gaps(az, gap), long)
    out = {"AZ": az, "VC": vc, "AS": az & ~vc, "Vp": v22[idx] > 0, "Vn": v22[idx] < 0,
           "A": (z > cfg.eps_strong) | ((d2 < 0) & az), "D": (z < -cfg.eps_strong) | ((d2 > 0) & az)}
    full = {}
    for k, b in out.items():
        full[k] = np.zeros(T, dtype=bool)
        full[k][idx] = b
    return full


def network_types(v22: np.ndarray, v33: np.ndarray, viable: np.ndarray, fs: float,
                  config: ExpertConfig | None = None, cruise_and_rest: bool = False) -> np.ndarray:
    """Active network type per sample (T,) int: 1-4 (Table 3), with ``cruise_and_rest`` also
    ``CRUISE`` and ``REST`` (module docstring), 0 where none is."""
    c = boolean_functions(v22, v33, viable, fs, config)
    rise = (c["AS"] | c["A"]) & ~c["VC"]
    fall = (~c["AS"] & c["D"]) & ~c["VC"]
    t = np.zeros(v33.shape[0], dtype=int)
    t[rise & c["Vp"]] = 1
    t[fall & c["Vp"]] = 2
    t[fall & c["Vn"]] = 3
    t[rise & c["Vn"]] = 4
    if cruise_and_rest:
        t[c["VC"] & (t == 0)] = CRUISE
        t[~viable] = REST
    return t
