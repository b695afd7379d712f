"""Compiled (numba) evaluation of the physics over many samples, and the cache folder of all
lcgym kernels.

The functions compiled here call the same ``register_jitable`` equations as the numpy and
torch paths of ``physics/`` (no second implementation); they exist because the least-squares
fit evaluates the regressor of 1e6 samples many times (once per candidate set of the
nonlinear parameters), which numpy's temporaries make take half a minute. ``regressor`` is
written for the IX (2 axes, 11 linear parameters); another system compiles its own.
"""

from __future__ import annotations

import hashlib
import math
import os
from pathlib import Path

import numba
import numpy as np

from . import ix

# LLVM fast-math flags for the kernels: fused multiply-add, reciprocals, reassociation. Not
# 'nnan'/'ninf': the plant's divergence check must still see NaN and inf. Results stay
# deterministic on one machine; they may differ in the last bits between CPUs.
FASTMATH = {"contract", "arcp", "reassoc", "nsz", "afn"}


def cache_dir(*files: str) -> str:
    """Where numba caches compiled kernels: a folder named by a hash of the given source files.
    Numba itself only watches the file of each jitted function, so a changed equation in a file
    it calls would otherwise run stale machine code."""
    h = hashlib.sha256()
    for path in files:
        h.update(Path(path).read_bytes())
    root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "lcgym" / "numba"
    return str(root / h.hexdigest()[:16])


# numba reads CACHE_DIR when a function is decorated: set it for this module's kernels only
_previous_cache_dir = numba.config.CACHE_DIR
numba.config.CACHE_DIR = cache_dir(__file__, ix.__file__)

_torques = ix.joint_torques


@numba.njit(cache=True, fastmath=FASTMATH)
def _inverse_dynamics_sets(P, q, qd, qdd, out):
    for t in range(q.shape[0]):
        s2, c2, s3, c3 = math.sin(q[t, 0]), math.cos(q[t, 0]), math.sin(q[t, 1]), math.cos(q[t, 1])
        for k in range(P.shape[0]):
            out[t, 0, k], out[t, 1, k] = _torques(P[k], s2, c2, s3, c3, qd[t, 0], qd[t, 1], qdd[t, 0], qdd[t, 1])


numba.config.CACHE_DIR = _previous_cache_dir


def regressor(zeta_n, q, qd, qdd) -> np.ndarray:
    """``ix.regressor`` (Lemma 1, eq. 17) for (T, 2) sample arrays, compiled: shape (T, 2, 11)."""
    basis = np.zeros((ix.N_LINEAR, len(ix.PARAM_NAMES)))
    basis[:, : ix.N_LINEAR] = np.eye(ix.N_LINEAR)
    basis[:, ix.N_LINEAR :] = np.asarray(zeta_n, dtype=float)
    q, qd, qdd = (np.ascontiguousarray(a, dtype=float).reshape(-1, 2) for a in (q, qd, qdd))
    out = np.empty((q.shape[0], 2, ix.N_LINEAR))
    _inverse_dynamics_sets(basis, q, qd, qdd, out)
    return out
