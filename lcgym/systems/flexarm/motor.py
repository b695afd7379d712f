"""The FlexArm seen from its motors: the rigid-joint model that feedforward learners fit.

With stiff joints (q_m = N q_l) eqs. (1)-(2) of paper 002 add up, per joint i, to the motor
torque [N m]

    u_i = tau_l,i(q, qd, qdd) / N_i + Jm_i N_i qdd_i + b_i qd_i + c_i sgn(qd_i)

with tau_l = M_l(q) qdd + C(q, qd) qd + G(q) the load-side rigid body (``dynamics.rnea``),
b_i = Dm_i N_i + Dl_i / N_i the viscous friction of motor and load reflected to the motor [N m s/rad
per load rad/s], c_i = Fmc_i + Flc_i / N_i the Coulomb friction [N m]. q are load-side angles
(rad), the reference's or the motor encoders' divided by N. sgn is smoothed as tanh(qd / EPS).

The model is linear in theta = [pi (60 inertial parameters, ``systems.flexarm.dynamics``), Jm (6), b (6),
c (6)]: u = X(q, qd, qdd) theta with the regressor X (T, 6, 78) below, the arm's counterpart of
Lemma 1 of paper 000 (which the PGNN's projection and the least-squares fit use). There is no
nonlinear parameter (the IX's centres of mass are zeta_n; the arm's first moments m c are linear).

``FLEXARM`` (``systems/flexarm/__init__.py``) bundles these functions for the learners. The plant integrates the
flexible equations themselves (``dynamics.flexible_derivatives``); this module only rearranges
the same RNEA, so plant and model share one implementation of the rigid body.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...physics import linalg
from ...physics.compiled import Kernels
from ...physics.memo import ArrayMemo
from ...physics.workspace import WORKSPACE
from ..system import REGRESSOR_MIN_ROWS
from . import dynamics as arm

N = arm.N_JOINTS
N_PI = arm.N_PARAMS
N_THETA = N_PI + 3 * N  # pi, Jm, b, c
EPS = 1e-3  # rad/s: smoothing of sgn(qd) (load side; the motor turns N times faster)
PARAM_NAMES = tuple(
    [f"{name}_{k + 1}" for k in range(N) for name in arm.LINK_PARAM_NAMES]
    + [f"{name}_{a}" for name in ("Jm", "b", "c") for a in arm.AXES]
)
GEAR = np.asarray(arm.DriveParameters().N, dtype=float)  # the gear ratios are known exactly
DH_TABLE = arm.DH().table()  # the kinematics are known exactly (CAD); the inertial parameters are not
MASS_INDICES = tuple(k * arm.N_PARAMS_LINK for k in range(N))


@dataclass(frozen=True)
class ArmMotorParameters:
    """theta of the module docstring: inertial parameters ``pi`` (60, per ``systems.flexarm.dynamics``), motor
    inertias ``Jm`` [kg m^2], viscous ``b`` [N m s/rad] and Coulomb ``c`` [N m] friction at the motor.

    The default is the nominal arm and drives (``ArmParameters()``, ``DriveParameters()``)."""

    pi: tuple[float, ...] = field(default_factory=lambda: tuple(arm.ArmParameters().pi))
    Jm: tuple[float, ...] = field(default_factory=lambda: tuple(arm.DriveParameters().Jm))
    b: tuple[float, ...] = field(default_factory=lambda: _nominal_friction()[0])
    c: tuple[float, ...] = field(default_factory=lambda: _nominal_friction()[1])

    def __post_init__(self):
        if self.to_vector().shape != (N_THETA,) or not np.all(np.isfinite(self.to_vector())):
            raise ValueError(f"ArmMotorParameters need 60 + 6 + 6 + 6 finite values, got {self.to_vector().shape}")

    def to_vector(self) -> np.ndarray:
        return np.concatenate([np.asarray(x, dtype=float) for x in (self.pi, self.Jm, self.b, self.c)])

    @classmethod
    def from_vector(cls, p) -> ArmMotorParameters:
        p = np.asarray(p, dtype=float)
        parts = np.split(p, [N_PI, N_PI + N, N_PI + 2 * N])
        return cls(*(tuple(float(v) for v in x) for x in parts))

    def arm(self) -> arm.ArmParameters:
        return arm.ArmParameters(pi=tuple(self.pi))

    def drive(self, nominal: arm.DriveParameters | None = None) -> arm.DriveParameters:
        """Drive parameters with this Jm and with b, c put on the motor side (Dm, Fmc); the load-side
        Dl, Flc and the joint stiffness and damping stay ``nominal``'s (the motor torque alone cannot
        tell motor from load friction, nor see the joint spring)."""
        d = nominal or arm.DriveParameters()
        n = np.asarray(d.N)
        dm = np.maximum((np.asarray(self.b) - np.asarray(d.Dl) / n) / n, 0.0)
        fmc = np.maximum(np.asarray(self.c) - np.asarray(d.Flc) / n, 0.0)
        return arm.DriveParameters(N=d.N, Jm=tuple(self.Jm), Dm=tuple(dm), Fmc=tuple(fmc), KJ=d.KJ, DJ=d.DJ, Dl=d.Dl,
                                   Flc=d.Flc)


def _nominal_friction() -> tuple[tuple[float, ...], tuple[float, ...]]:
    d = arm.DriveParameters()
    n, dm, dl, fmc, flc = (np.asarray(getattr(d, k), dtype=float) for k in ("N", "Dm", "Dl", "Fmc", "Flc"))
    return tuple(dm * n + dl / n), tuple(fmc + flc / n)


def regressor(zeta_n, q, qd, qdd) -> np.ndarray:
    """X (T, 6, 78) with u = X theta for kinematics (T, 6) [rad, rad/s, rad/s^2]; ``zeta_n`` is
    unused (the arm has no nonlinear parameter; kept for the signature of ``System.regressor``).

    Inside ``with cached_regressors():`` the last ``CACHE_SIZE`` results are kept (``physics.memo.ArrayMemo``):
    one evaluation costs about 40 us per sample (60 RNEA passes)."""
    q, qd, qdd = (np.ascontiguousarray(np.atleast_2d(np.asarray(x, dtype=float))) for x in (q, qd, qdd))
    return _memo().get(lambda: _regressor(DH_TABLE, GEAR, q, qd, qdd, arm.GRAVITY, EPS), q, qd, qdd)


CACHE_SIZE = 3


def _memo() -> ArrayMemo:
    return WORKSPACE.slot("systems.flexarm.regressors", lambda: ArrayMemo(CACHE_SIZE, min_rows=REGRESSOR_MIN_ROWS))


def cached_regressors(size: int | None = None):
    """The FlexArm's ``System.caching``: a block inside which its last regressors are kept."""
    return _memo().active(size)


njit = Kernels(__file__, arm.__file__, linalg.__file__)


@njit
def _regressor(dh, gear, q, qd, qdd, gravity, eps):
    T = q.shape[0]
    X = np.zeros((T, N, N_THETA))
    for k in range(T):
        Y = arm.regressor(dh, q[k], qd[k], qdd[k], gravity)
        for i in range(N):
            X[k, i, :N_PI] = Y[i] / gear[i]
            X[k, i, N_PI + i] = gear[i] * qdd[k, i]
            X[k, i, N_PI + N + i] = qd[k, i]
            X[k, i, N_PI + 2 * N + i] = np.tanh(qd[k, i] / eps)
    return X


def link_columns(link: int, q, qd, qdd) -> np.ndarray:
    """The regressor columns of one link's 10 inertial parameters (T, 6, 10) [N m per unit]
    (0-based ``link``; 5 is the flange's link, where a payload adds)."""
    k = link * arm.N_PARAMS_LINK
    return regressor(None, q, qd, qdd)[:, :, k : k + arm.N_PARAMS_LINK]


def inverse_dynamics(p, q, qd, qdd):
    """Motor torques u (T, 6) [N m] of the module docstring; ``p`` (78,) numpy or torch (then the
    result is torch, differentiable in p), kinematics numpy or torch."""
    X = regressor(None, *(_numpy(x) for x in (q, qd, qdd)))
    return _contract(X, p)


def mass_matrix(p, q):
    """Rigid-joint inertia at the load side, M_l(q) + diag(Jm N^2) (..., 6, 6) [kg m^2]: symmetric
    positive definite for physical parameters. ``p`` numpy or torch (differentiable in p: M_l as
    the basis of its 60 inertial parameters times pi; for numpy p the composite-rigid-body
    algorithm, ``dynamics.mass_matrix``, the same matrix without the basis: 17 us against 3.2 ms
    for 16 configurations)."""
    qn = np.ascontiguousarray(np.atleast_2d(_numpy(q)), dtype=float)
    if not hasattr(p, "detach"):
        p = np.asarray(p, dtype=float)
        return _mass_matrices(DH_TABLE, np.ascontiguousarray(p[:N_PI]), qn) + np.diag(p[N_PI : N_PI + N] * GEAR**2)
    basis = _mass_basis(DH_TABLE, qn)  # (T, 6, 6, 60): M_l is linear in pi
    M = _contract(basis, p[:N_PI])
    motor = p[N_PI : N_PI + N] * _like(p, GEAR**2)
    return M + _diag(motor)


@njit
def _mass_matrices(dh, pi, q):
    out = np.empty((q.shape[0], N, N))
    for k in range(q.shape[0]):
        out[k] = arm.mass_matrix(dh, pi, q[k])
    return out


@njit
def _mass_basis(dh, q):
    out = np.zeros((q.shape[0], N, N, N_PI))
    zero = np.zeros(N)
    for k in range(q.shape[0]):
        for j in range(N):
            e = np.zeros(N)
            e[j] = 1.0
            out[k, :, j, :] = arm.regressor(dh, q[k], zero, e, 0.0)
    return out


def _numpy(x) -> np.ndarray:
    return x.detach().double().numpy() if hasattr(x, "detach") else np.asarray(x, dtype=float)


def _like(p, a):
    """``a`` as the array type of p (torch tensor of p's dtype, or numpy)."""
    if hasattr(p, "detach"):
        import torch

        return torch.tensor(a, dtype=p.dtype)  # a copy: the cached regressor is read-only
    return np.asarray(a, dtype=float)


def _contract(X, p):
    """X (..., k) @ p (k,) in p's array type."""
    return _like(p, X) @ p


def _diag(v):
    if hasattr(v, "detach"):
        import torch

        return torch.diag_embed(v)
    return np.diag(v)
