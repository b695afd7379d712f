"""The IX regressor (Lemma 1, eq. 17) compiled (numba) for many samples.

The least-squares fit evaluates the regressor of 1e6 samples many times (once per candidate set of
the nonlinear parameters), which numpy's temporaries make take half a minute. The kernel calls the
same ``joint_torques`` as the numpy and torch paths of ``dynamics.py`` (no second implementation).
"""

from __future__ import annotations

import math

import numpy as np

from ...physics.compiled import FASTMATH, Kernels, in_row_blocks
from . import dynamics as ix

njit = Kernels(__file__, ix.__file__)

_torques = ix.joint_torques


@njit(fastmath=FASTMATH, nogil=True)  # nogil: blocks of rows on threads
def _inverse_dynamics_sets(P, q, qd, qdd, out):
    for t in range(q.shape[0]):
        s2, c2, s3, c3 = math.sin(q[t, 0]), math.cos(q[t, 0]), math.sin(q[t, 1]), math.cos(q[t, 1])
        for k in range(P.shape[0]):
            out[t, 0, k], out[t, 1, k] = _torques(P[k], s2, c2, s3, c3, qd[t, 0], qd[t, 1], qdd[t, 0], qdd[t, 1])


def regressor(zeta_n, q, qd, qdd, columns=None) -> np.ndarray:
    """``dynamics.regressor`` (Lemma 1, eq. 17) for (T, 2) sample arrays, compiled: shape (T, 2, 11);
    ``columns``: only these linear parameters' columns, (T, 2, len(columns)), the same numbers."""
    columns = np.arange(ix.N_LINEAR) if columns is None else np.asarray(columns, dtype=int)
    basis = np.zeros((columns.size, len(ix.PARAM_NAMES)))
    basis[np.arange(columns.size), columns] = 1.0
    basis[:, ix.N_LINEAR :] = np.asarray(zeta_n, dtype=float)
    q, qd, qdd = (np.ascontiguousarray(a, dtype=float).reshape(-1, 2) for a in (q, qd, qdd))
    out = np.empty((q.shape[0], 2, columns.size))
    in_row_blocks(_inverse_dynamics_sets, (basis,), (q, qd, qdd, out))
    return out
