"""Small dense linear algebra for the compiled kernels, written out so that it allocates nothing.

``solve_spd_in_place`` solves a mass matrix's equation M x = b: the FlexArm's dynamics and a URDF
machine's rigid body (``systems/rigid_body.py``) both call it, inlined into their kernels
(``register_jitable``).
"""

from __future__ import annotations

import math

from numba.extending import register_jitable


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
