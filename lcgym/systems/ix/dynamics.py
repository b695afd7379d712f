"""Rigid-body model of the IX C-arm: propeller (theta2) and roll (theta3), paper 000 eqs. (2)-(9).

    tau = M(theta) thetadd + H(theta, thetad) + D(thetad)                      (2)

Units: angles in rad, torques in V at the joint (1 V = 100 N m, the amplifier input), so the
"masses" and "inertias" below are in V s^2/rad-compatible units.

The 16 parameters of Table I are held in one flat vector ``p`` ordered as ``PARAM_NAMES``:
first the parameters the model is linear in (zeta_l of Lemma 1), then the centre-of-mass
coordinates it is nonlinear in (zeta_n).

One implementation, three back-ends. ``rigid_terms`` (``register_jitable``: a plain Python
function that compiled code may also call) is pure arithmetic on the sines and
cosines of the joint angles, so the very same function runs on floats inside the compiled
plant (numba), on numpy arrays (simulation, least squares) and on torch tensors (learning,
autograd in ``p``). Only the trigonometric values are computed by the caller, with the
back-end's own ``sin``/``cos``.

Frame convention (the one that reproduces the paper's M exactly): world z up, gravity
(0, 0, -g); propeller R02 = Ry(theta2), roll R03 = Ry(theta2) Rx(theta3); CoM of the propeller
(x2, y2, z2) in its frame (y2 drops out), of the roll body (x3, y3, z3) in the roll frame;
inertias about each body's own CoM, products J_ab = +int(a b dm).

Paper erratum: eq. (7) prints the gravity term of h2 as ``+g(m2 z2 + m3 z3 cos + m3 y3 sin) sin th2``.
The correct sign is minus: as printed the gravity field has non-zero curl, so no potential
exists and energy is not conserved (tests/test_physics_ix.py shows both).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np
from numba.extending import register_jitable

G = 9.81  # m/s^2

ZETA_L = ("m2", "m3", "J2yy", "J3xx", "J3yy", "J3zz", "J3xy", "J3xz", "J3yz", "d2", "d3")
ZETA_N = ("x2", "z2", "x3", "y3", "z3")
PARAM_NAMES = ZETA_L + ZETA_N
AXES = ("propeller", "roll")

# index of each parameter in p (module constants, so that numba freezes them)
M2, M3, J2YY, J3XX, J3YY, J3ZZ, J3XY, J3XZ, J3YZ, D2, D3, X2, Z2, X3, Y3, Z3 = range(16)
N_LINEAR = len(ZETA_L)


@dataclass(frozen=True)
class IXParameters:
    """The 16 physical parameters of Table I (paper 000).

    Masses m* are in V s^2/m^2-consistent units (1 V = 100 N m), inertias J* in V s^2/rad,
    CoM coordinates x*, y*, z* in m, viscous coefficients d* in V s/rad.
    The default values are an invented but plausible set (the paper does not publish Table I's values).
    """

    m2: float = 1.5
    m3: float = 3.0
    J2yy: float = 0.55
    J3xx: float = 0.80
    J3yy: float = 0.50
    J3zz: float = 0.40
    J3xy: float = 0.02
    J3xz: float = -0.03
    J3yz: float = 0.015
    d2: float = 1.2
    d3: float = 1.0
    x2: float = 0.03
    z2: float = 0.06
    x3: float = 0.02
    y3: float = 0.04
    z3: float = -0.05

    def to_vector(self) -> np.ndarray:
        """Parameters as the flat vector p, ordered as PARAM_NAMES."""
        return np.array([getattr(self, n) for n in PARAM_NAMES], dtype=float)

    @classmethod
    def from_vector(cls, p) -> IXParameters:
        p = np.asarray(p, dtype=float)
        if p.shape != (len(PARAM_NAMES),):
            raise ValueError(f"IX parameter vector must have shape (16,), got {p.shape}")
        return cls(**{n: float(v) for n, v in zip(PARAM_NAMES, p, strict=True)})

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


assert tuple(f.name for f in fields(IXParameters)) == PARAM_NAMES


@register_jitable
def rigid_terms(p, s2, c2, s3, c3, qd2, qd3):
    """Entries of M(theta) (eqs. 4-5) and H(theta, thetad) (eqs. 6-7, h2 sign corrected).

    Pure arithmetic on s2 = sin th2, c2 = cos th2, s3 = sin th3, c3 = cos th3 and the joint
    velocities qd2, qd3 [rad/s]; works on floats, numpy arrays and torch tensors alike.
    Returns (m22, m23, m33, h2, h3) in V s^2/rad and V.
    """
    m2, m3 = p[M2], p[M3]
    x2, z2, x3, y3, z3 = p[X2], p[Z2], p[X3], p[Y3], p[Z3]
    sin2 = 2.0 * s3 * c3  # sin(2 th3)
    cos2 = c3 * c3 - s3 * s3  # cos(2 th3)
    pxy = p[J3XY] + m3 * x3 * y3
    pxz = p[J3XZ] + m3 * x3 * z3
    pyz = p[J3YZ] + m3 * y3 * z3
    m22 = (
        p[J2YY]
        + p[J3ZZ]
        + m3 * (x3 * x3 + y3 * y3)
        + m2 * (x2 * x2 + z2 * z2)
        + (p[J3YY] - p[J3ZZ] + m3 * (z3 * z3 - y3 * y3)) * c3 * c3
        + pyz * sin2
    )
    m23 = pxz * s3 - pxy * c3
    m33 = p[J3XX] + m3 * (y3 * y3 + z3 * z3)
    # partial derivatives of m22 and m23 with respect to th3 (Christoffel symbols)
    dm22 = (m3 * (y3 * y3 - z3 * z3) - p[J3YY] + p[J3ZZ]) * sin2 + 2.0 * pyz * cos2
    dm23 = pxy * s3 + pxz * c3
    a = m2 * z2 + m3 * (z3 * c3 + y3 * s3)
    b = m2 * x2 + m3 * x3
    h2 = dm22 * qd2 * qd3 + dm23 * qd3 * qd3 - G * a * s2 - G * b * c2
    h3 = -0.5 * dm22 * qd2 * qd2 + m3 * G * (y3 * c3 - z3 * s3) * c2
    return m22, m23, m33, h2, h3


@register_jitable
def joint_torques(p, s2, c2, s3, c3, qd2, qd3, qdd2, qdd3):
    """(tau2, tau3) = M qdd + H + D qd (eqs. 2, 3, 9) [V] from the trigonometric values; any back-end."""
    m22, m23, m33, h2, h3 = rigid_terms(p, s2, c2, s3, c3, qd2, qd3)
    return m22 * qdd2 + m23 * qdd3 + h2 + p[D2] * qd2, m23 * qdd2 + m33 * qdd3 + h3 + p[D3] * qd3


def potential_terms(p, s2, c2, s3, c3):
    """Potential energy V(theta) [V rad] whose gradient is the gravity part of H."""
    a = p[M2] * p[Z2] + p[M3] * (p[Z3] * c3 + p[Y3] * s3)
    b = p[M2] * p[X2] + p[M3] * p[X3]
    return G * (a * c2 - b * s2)


def _trig(q):
    """sin and cos of both joint angles with the back-end of ``q`` (numpy or torch); q[..., 0:2]."""
    if _is_torch(q):
        import torch

        s, c = torch.sin(q), torch.cos(q)
    else:
        q = np.asarray(q, dtype=float)
        s, c = np.sin(q), np.cos(q)
    return s[..., 0], c[..., 0], s[..., 1], c[..., 1]


def _is_torch(x) -> bool:
    return type(x).__module__.startswith("torch")


def _stack(parts, like):
    if _is_torch(like):
        import torch

        return torch.stack(torch.broadcast_tensors(*parts), dim=-1)
    return np.stack(np.broadcast_arrays(*parts), axis=-1)


def mass_matrix(p, q):
    """M(theta) of eq. (4), shape (..., 2, 2)."""
    s2, c2, s3, c3 = _trig(q)
    m22, m23, m33, _, _ = rigid_terms(p, s2, c2, s3, c3, 0.0 * s2, 0.0 * s2)
    row2 = _stack([m22, m23], q)
    row3 = _stack([m23, m33], q)
    if _is_torch(q):
        import torch

        return torch.stack([row2, row3], dim=-2)
    return np.stack([row2, row3], axis=-2)


def bias_torque(p, q, qd):
    """H(theta, thetad) of eq. (6): gravity, Coriolis and centrifugal torques [V], shape (..., 2)."""
    s2, c2, s3, c3 = _trig(q)
    _, _, _, h2, h3 = rigid_terms(p, s2, c2, s3, c3, qd[..., 0], qd[..., 1])
    return _stack([h2, h3], q)


def inverse_dynamics(p, q, qd, qdd):
    """tau = M qdd + H + D qd (eqs. 2, 3, 9) [V] for arrays q, qd, qdd of shape (..., 2).

    ``p`` may be a numpy vector or a torch tensor (gradients flow to it), or a (16, K) array to
    evaluate K parameter sets at once (the result then has shape (..., K, 2)).
    """
    if not _is_torch(q):
        q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    extra = () if np.ndim(p) == 1 else (None,)  # broadcast several parameter sets
    qx, qdx, qddx = (a[(..., *extra, slice(None))] for a in (q, qd, qdd))
    s2, c2, s3, c3 = _trig(qx)
    tau2, tau3 = joint_torques(p, s2, c2, s3, c3, qdx[..., 0], qdx[..., 1], qddx[..., 0], qddx[..., 1])
    return _stack([tau2, tau3], qx)


def energy(p, q, qd):
    """Total mechanical energy 1/2 qd^T M qd + V [V rad], shape (...)."""
    s2, c2, s3, c3 = _trig(q)
    m22, m23, m33, _, _ = rigid_terms(p, s2, c2, s3, c3, 0.0 * s2, 0.0 * s2)
    kinetic = 0.5 * (m22 * qd[..., 0] ** 2 + 2.0 * m23 * qd[..., 0] * qd[..., 1] + m33 * qd[..., 1] ** 2)
    return kinetic + potential_terms(p, s2, c2, s3, c3)


def regressor(zeta_n, q, qd, qdd) -> np.ndarray:
    """Basis-function matrix X_{zeta_n}(theta) of Lemma 1, eqs. (16)-(17).

    tau = X zeta_l for the linear parameters zeta_l (ZETA_L order) at fixed nonlinear
    parameters zeta_n (ZETA_N order). Because tau is linear and homogeneous in zeta_l, column j
    is the inverse dynamics evaluated with zeta_l = e_j (eq. 17): no second implementation.
    Returns shape (..., 2, 11): axis (propeller, roll) by linear parameter.
    """
    basis = np.zeros((len(PARAM_NAMES), N_LINEAR))
    basis[:N_LINEAR] = np.eye(N_LINEAR)
    basis[N_LINEAR:] = np.asarray(zeta_n, dtype=float)[:, None]
    tau = inverse_dynamics(basis, q, qd, qdd)  # (..., 11, 2)
    return np.swapaxes(tau, -1, -2)


def forward_dynamics(p, q, qd, tau):
    """thetadd = M^-1 (tau - H - D qd) [rad/s^2], numpy, shape (..., 2)."""
    q, qd, tau = (np.asarray(a, dtype=float) for a in (q, qd, tau))
    s2, c2, s3, c3 = _trig(q)
    m22, m23, m33, h2, h3 = rigid_terms(p, s2, c2, s3, c3, qd[..., 0], qd[..., 1])
    r2 = tau[..., 0] - h2 - p[D2] * qd[..., 0]
    r3 = tau[..., 1] - h3 - p[D3] * qd[..., 1]
    det = m22 * m33 - m23 * m23
    return np.stack([(m33 * r2 - m23 * r3) / det, (m22 * r3 - m23 * r2) / det], axis=-1)
