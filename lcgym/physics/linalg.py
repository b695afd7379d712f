"""Small dense linear algebra for the compiled kernels, written out so that it allocates nothing.

``solve_spd_in_place`` solves a mass matrix's equation M x = b: the FlexArm's dynamics and a URDF
machine's rigid body (``systems/rigid_body.py``) both call it, inlined into their kernels
(``register_jitable``).
"""

from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from .effects import SMOOTHING


@register_jitable
def solve_spd_in_place(M, b):
    """b <- M^-1 b for a symmetric positive definite M (n, n) and b (n,), by Cholesky M = L L^T on
    M's lower triangle, written out, L overwriting that triangle (no allocation): for n = 6 this
    takes a fifth of numba's ``np.linalg.solve`` (LAPACK, whose calls also serialize across
    threads). A matrix that is not positive definite gives NaN (which the plant's loop reports as
    leaving the safe range)."""
    n = b.shape[0]
    for j in range(n):
        s = M[j, j]
        for k in range(j):
            s -= M[j, k] * M[j, k]
        d = math.sqrt(s) if s > 0.0 else math.nan
        M[j, j] = d
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= M[i, k] * M[j, k]
            M[i, j] = s / d
    for i in range(n):  # L y = b
        s = b[i]
        for k in range(i):
            s -= M[i, k] * b[k]
        b[i] = s / M[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        s = b[i]
        for k in range(i + 1, n):
            s -= M[k, i] * b[k]
        b[i] = s / M[i, i]


def penalty_rows(A: np.ndarray, penalties) -> np.ndarray:
    """Rows to append to a design A (rows, p) for the roughness penalties (``Effect.roughness``):
    ``penalties`` [(column indices, D)], each weighted by ``SMOOTHING`` times the mean square of
    its columns, with target zero."""
    rows = []
    for idx, D in penalties:
        lam = SMOOTHING * float((A[:, idx] ** 2).sum()) / len(idx)
        block = np.zeros((D.shape[0], A.shape[1]))
        block[:, idx] = np.sqrt(lam) * D
        rows.append(block)
    return np.concatenate(rows) if rows else np.zeros((0, A.shape[1]))


def solve_min_norm(A, u, theta0, rcond: float = 1e-9, penalties=()):
    """Minimum-norm correction to theta0 (column-scaled) of the least-squares problem A theta = u;
    singular values below ``rcond`` times the largest count as zero (directions the data lacks);
    ``penalties``: roughness penalties of some columns (``penalty_rows``). Returns theta and the
    residual of the data rows."""
    A = A.reshape(-1, theta0.size)
    n = A.shape[0]
    if penalties:
        A = np.concatenate([A, penalty_rows(A, penalties)])
        u = np.concatenate([np.ravel(u), np.zeros(A.shape[0] - n)])
    y = u - A @ theta0
    scale = np.linalg.norm(A, axis=0)
    used = scale > 1e-12 * scale.max(initial=0.0)  # a column of round-off only is no direction
    scale[~used] = 1.0
    delta, *_ = np.linalg.lstsq(np.where(used, A / scale, 0.0), y, rcond=rcond)
    theta = theta0 + delta / scale
    return theta, (u - A @ theta)[:n]
