"""Simulation of a linear time-invariant system on a sampled input (the FlexArm's nominal models).

    xdot = A x + B u,  y = C x + D u,  u linear between samples (first-order hold)

``lsim`` gives what ``scipy.signal.lsim`` gives (its default ``interp=True``) to round-off (bit for
bit where numpy's small vector-matrix products sum in the loop's order; tested). The same
discretization (the matrix exponential of the augmented system, ``discretize_foh``; for an input
that is zero throughout exp(A dt) alone, as scipy) and the same recursion
x[k+1] = x[k] Ad + u[k] Bd0 + u[k+1] Bd1 summed in the same order, but in a compiled loop. scipy
runs that recursion in Python: 22-25 ms for 5,000 samples here against about 0.1 ms, and the
FlexArm's Basic feedforward and its model-following error call it 18 and 6 times per reference.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

from .compiled import Kernels
from .workspace import WORKSPACE

njit = Kernels(__file__)


def discretize_foh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Ad, Bd0, Bd1) of the first-order-hold discretization, transposed for row-vector states:
    x[k+1] = x[k] Ad + u[k] Bd0 + u[k+1] Bd1. With u(t) = u0 + (u1 - u0) t / dt on the interval,

        [ x(dt) ]       [ A dt  B dt  0 ] [   x0    ]
        [ u(dt) ] = exp [  0     0    I ] [   u0    ]
        [ u1-u0 ]       [  0     0    0 ] [ u1 - u0 ]

    Memoized on (A, B, dt) (read-only arrays, in ``physics.workspace``): the FlexArm's nominal models are discretized again
    and again with the same matrices, and the matrix exponential was most of their cost."""
    key = (A.shape, B.shape, np.asarray(A, dtype=float).tobytes(), np.asarray(B, dtype=float).tobytes(), float(dt))
    kept = WORKSPACE.slot("physics.lti.foh", dict)
    if key not in kept:
        if len(kept) >= 256:
            kept.clear()
        kept[key] = tuple(_read_only(a) for a in _discretize_foh(A, B, dt))
    return kept[key]


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _discretize_foh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n, m = B.shape
    M = np.vstack([np.hstack([A * dt, B * dt, np.zeros((n, m))]),
                   np.hstack([np.zeros((m, n + m)), np.identity(m)]),
                   np.zeros((m, n + 2 * m))])
    E = linalg.expm(M.T)
    Ad = E[:n, :n]
    Bd1 = E[n + m :, :n]
    Bd0 = E[n : n + m, :n] - Bd1
    return np.ascontiguousarray(Ad), np.ascontiguousarray(Bd0), np.ascontiguousarray(Bd1)


@njit
def _states(Ad, Bd0, Bd1, u, x0):
    x = np.empty((u.shape[0], Ad.shape[0]))
    x[0] = x0
    for i in range(1, u.shape[0]):
        for k in range(Ad.shape[0]):
            free = 0.0
            for j in range(Ad.shape[0]):
                free += x[i - 1, j] * Ad[j, k]
            before = 0.0
            after = 0.0
            for j in range(u.shape[1]):
                before += u[i - 1, j] * Bd0[j, k]
            for j in range(u.shape[1]):
                after += u[i, j] * Bd1[j, k]
            x[i, k] = free + before + after
    return x


def lsim(A, B, C, D, u, fs: float, x0=None) -> tuple[np.ndarray, np.ndarray]:
    """Output y (T,) or (T, n_outputs) and states x (T, n_states) of the system (A, B, C, D) for
    the input u (T,) or (T, n_inputs) sampled at ``fs`` [Hz] from the state ``x0`` (default 0) at
    the first sample. Shapes as ``scipy.signal.lsim`` returns them (single dimensions squeezed)."""
    A, B, C, D = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (A, B, C, D))
    u = np.asarray(u, dtype=float)
    U = u[:, None] if u.ndim == 1 else u
    if U.shape[1] != B.shape[1] or A.shape[0] != A.shape[1] or B.shape[0] != A.shape[0]:
        raise ValueError(f"lsim: A {A.shape}, B {B.shape} and input {u.shape} do not fit together")
    if not np.all(np.isfinite(U)):
        raise ValueError(f"lsim: the input contains NaN or inf (first at sample {np.argwhere(~np.isfinite(U))[0, 0]})")
    x0 = np.zeros(A.shape[0]) if x0 is None else np.asarray(x0, dtype=float).reshape(A.shape[0])
    if np.any(U):
        Ad, Bd0, Bd1 = discretize_foh(A, B, 1.0 / fs)
    else:  # as scipy: the free response by exp(A dt) alone (the same up to round-off)
        Ad, Bd0 = np.ascontiguousarray(linalg.expm(A.T / fs)), np.zeros((B.shape[1], A.shape[0]))
        Bd1 = Bd0
    x = _states(Ad, Bd0, Bd1, np.ascontiguousarray(U), x0)
    y = np.squeeze(x @ C.T) + np.squeeze(U @ D.T)
    return y, np.squeeze(x)


def rigid_axis(J: float, D: float, fs: float, z: np.ndarray, delay: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(numerator, denominator) at the points z of the sampled rigid axis P(s) = 1 / (J s^2 + D s)
    [rad per input unit; J in input unit s^2/rad, D in input unit s/rad] behind a zero-order hold at
    ``fs`` [Hz], with ``delay`` samples of computation delay (z^-delay): P(z) = num / den. What
    plant-inversion ILC inverts on a machine seen as independent rigid axes (``methods.ilc.method``)."""
    from scipy import signal

    num, den, _ = signal.cont2discrete(([1.0], [J, D, 0.0]), 1.0 / fs, method="zoh")
    num = np.trim_zeros(np.ravel(num), "f")
    pn, pd = np.polyval(num, z), np.polyval(den, z)
    for _ in range(delay):
        pd = z * pd
    return pn, pd
