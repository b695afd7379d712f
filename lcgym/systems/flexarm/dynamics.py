"""Rigid-body physics of the FlexArm: a 6-joint industrial arm of the FANUC M-16iB/20 class
(paper 002, section 2.1, the load side of eq. 1).

Kinematics: standard (distal) Denavit-Hartenberg, frame i fixed to link i at the far end of
joint i, T_{i-1,i} = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i), theta_i = q_i + offset_i. Lengths
in m, angles in rad; base frame z up; gravity g = 9.81 m/s^2 along -z.

Inertial parameters, per link i, in frame i, the 10 "standard" ones in which the dynamics are
linear (Atkinson, An and Hollerbach 1986):

    pi_i = [m, m cx, m cy, m cz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz]

m [kg], m c [kg m] (first moment; c the centre of mass), I [kg m^2] the inertia tensor about the
frame's origin (not about the centre of mass). The 60 of the arm are ``ArmParameters``.

Inverse dynamics by the recursive Newton-Euler algorithm in link frames (Luh, Walker and Paul
1980), written with (m, m c, I_origin) so that the torque is linear in pi:

    tau = M(q) qdd + C(q, qd) qd + G(q)        [N m, load side]      (eq. 1 without friction)

and the regressor Y(q, qd, qdd) (tau = Y pi) is RNEA evaluated with unit parameter vectors.
The mass matrix comes from the composite-rigid-body algorithm (tested against RNEA columns: qd = 0,
no gravity, qdd = e_j), forward dynamics from qdd = M^-1 (tau - C qd - G) by a written-out Cholesky
solve. The functions here are ``register_jitable``: plain numpy on one
sample from Python, compiled inside numba kernels; ``*_batch`` versions loop over samples.
Verified in tests/test_physics_flexarm.py against an independent Euler-Lagrange derivation (torch
autograd of the kinetic and potential energy from the DH chain), M symmetric positive definite,
and energy conservation of the unforced arm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba.extending import register_jitable

from ...physics import effects as fx
from ...physics import linalg, plant_effects
from ...physics.compiled import Kernels
from ...physics.linalg import solve_spd_in_place

N_JOINTS = 6
N_PARAMS_LINK = 10
N_PARAMS = N_JOINTS * N_PARAMS_LINK
GRAVITY = 9.81  # m/s^2, along -z of the base
AXES = ("j1", "j2", "j3", "j4", "j5", "j6")
HOME = np.array([0.0, 0.3, -0.3, 0.0, math.pi / 2, 0.0])  # rad: elbow up, tool pointing down
LINK_PARAM_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


@dataclass(frozen=True)
class DH:
    """Standard DH table of the arm: d, a [m], alpha, offset [rad] per joint (6 each).

    Defaults: a 20 kg-payload arm of the M-16iB/20 class: base height 0.525 m, shoulder offset
    0.15 m, upper arm 0.77 m, elbow offset 0.10 m, forearm 0.74 m, wrist to flange 0.10 m. At
    q = 0 the upper arm points up and the forearm forward (+x), the flange faces down.
    """

    d: tuple[float, ...] = (0.525, 0.0, 0.0, 0.74, 0.0, 0.10)
    a: tuple[float, ...] = (0.15, 0.77, 0.10, 0.0, 0.0, 0.0)
    alpha: tuple[float, ...] = (-math.pi / 2, 0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, 0.0)
    offset: tuple[float, ...] = (0.0, -math.pi / 2, 0.0, 0.0, 0.0, math.pi)

    def table(self) -> np.ndarray:
        """(6, 4) array of [d, a, alpha, offset]."""
        return np.array([self.d, self.a, self.alpha, self.offset], dtype=float).T


def link_parameters(m: float, com, inertia_com) -> np.ndarray:
    """The 10 standard parameters of a link from its mass [kg], centre of mass [m] in its frame and
    inertia tensor about the centre of mass [kg m^2] (3x3), by the parallel-axis theorem."""
    c = np.asarray(com, dtype=float)
    Ic = np.asarray(inertia_com, dtype=float)
    Io = Ic + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    return np.array([m, m * c[0], m * c[1], m * c[2], Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2]])


def _box(m, lx, ly, lz):
    """Inertia about the centre of a solid box [kg m^2]."""
    return np.diag([m * (ly**2 + lz**2), m * (lx**2 + lz**2), m * (lx**2 + ly**2)]) / 12.0


def _default_links() -> np.ndarray:
    """Plausible masses and inertias (boxes) of a 20 kg-payload arm, 220 kg in all, in DH frames."""
    links = [
        # turret: frame 1 at the shoulder, the mass below it (toward -y1 in frame 1 = down)
        link_parameters(80.0, (-0.05, 0.20, 0.0), _box(80.0, 0.45, 0.40, 0.45)),
        # upper arm: frame 2 at the elbow, the arm lies along -x2
        link_parameters(45.0, (-0.38, 0.0, 0.12), _box(45.0, 0.90, 0.20, 0.25)),
        # elbow housing with the wrist motors: frame 3 at the elbow offset
        link_parameters(35.0, (-0.05, 0.0, 0.05), _box(35.0, 0.30, 0.30, 0.35)),
        # forearm: frame 4 at the wrist centre, the forearm along +y4
        link_parameters(18.0, (0.0, 0.30, 0.0), _box(18.0, 0.15, 0.60, 0.15)),
        # wrist
        link_parameters(5.0, (0.0, 0.0, 0.02), _box(5.0, 0.12, 0.12, 0.12)),
        # flange and tool
        link_parameters(2.0, (0.0, 0.0, -0.03), _box(2.0, 0.10, 0.10, 0.06)),
    ]
    return np.concatenate(links)


@dataclass(frozen=True)
class ArmParameters:
    """The arm's kinematics (``dh``) and its 60 inertial parameters ``pi`` (6 links x
    ``LINK_PARAM_NAMES``, in each link's DH frame; see the module docstring)."""

    dh: DH = field(default_factory=DH)
    pi: tuple[float, ...] = field(default_factory=lambda: tuple(_default_links()))

    def __post_init__(self):
        p = np.asarray(self.pi, dtype=float)
        if p.shape != (N_PARAMS,) or not np.all(np.isfinite(p)):
            raise ValueError(f"ArmParameters.pi must hold {N_PARAMS} finite values, got shape {p.shape}")

    def vector(self) -> np.ndarray:
        return np.asarray(self.pi, dtype=float)

    def with_payload(self, mass: float, com=(0.0, 0.0, 0.0), inertia_com=None) -> ArmParameters:
        """The same arm with a payload [kg] rigidly fixed to the flange (link 6), centre of mass
        ``com`` [m] in frame 6 and inertia ``inertia_com`` [kg m^2] about it (default a point)."""
        extra = link_parameters(mass, com, np.zeros((3, 3)) if inertia_com is None else inertia_com)
        p = self.vector().copy()
        p[5 * N_PARAMS_LINK :] += extra
        return ArmParameters(self.dh, tuple(p))


DRIVE_FIELDS = ("N", "Jm", "Dm", "Fmc", "KJ", "DJ", "Dl", "Flc")
DRIVE_ROWS = len(DRIVE_FIELDS)  # rows of ``DriveParameters.table()``; a plant's hidden effects follow


@dataclass(frozen=True)
class DriveParameters:
    """Drive train per joint (paper 002, eqs. 1-2), 6 values each: gear ratio N [-], motor
    inertia Jm [kg m^2] (M_m), motor viscous Dm [N m s/rad] and Coulomb friction Fmc [N m]
    (motor side), joint stiffness KJ [N m/rad] and damping DJ [N m s/rad] (gear compliance,
    load side), load viscous Dl [N m s/rad] and Coulomb friction Flc [N m].

    Defaults: plausible for a 20 kg-payload arm; the first resonances of joints 1-3 fall near
    10-15 Hz as on such arms (the reason paper 002 learns the residual vibration)."""

    N: tuple[float, ...] = (150.0, 160.0, 120.0, 100.0, 100.0, 60.0)
    Jm: tuple[float, ...] = (2.0e-3, 2.5e-3, 1.2e-3, 2.5e-4, 2.5e-4, 1.0e-4)
    Dm: tuple[float, ...] = (5e-3, 6e-3, 3e-3, 5e-4, 5e-4, 2e-4)
    Fmc: tuple[float, ...] = (0.3, 0.35, 0.2, 0.05, 0.05, 0.02)
    KJ: tuple[float, ...] = (3.0e5, 2.5e5, 1.5e5, 6.0e3, 5.0e3, 1.5e3)
    DJ: tuple[float, ...] = (300.0, 250.0, 150.0, 6.0, 5.0, 1.5)
    Dl: tuple[float, ...] = (20.0, 20.0, 10.0, 1.0, 1.0, 0.5)
    Flc: tuple[float, ...] = (15.0, 15.0, 10.0, 1.0, 1.0, 0.5)

    def __post_init__(self):
        for name in DRIVE_FIELDS:
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != (N_JOINTS,) or not np.all(np.isfinite(v)) or np.any(v < 0):
                raise ValueError(f"DriveParameters.{name} must be {N_JOINTS} finite values >= 0, got {getattr(self, name)}")
        for name in ("N", "Jm", "KJ"):
            if np.any(np.asarray(getattr(self, name)) <= 0):
                raise ValueError(f"DriveParameters.{name} must be positive")

    def table(self) -> np.ndarray:
        """(8, 6) array in the order of ``DRIVE_FIELDS``."""
        return np.array([getattr(self, n) for n in DRIVE_FIELDS], dtype=float)


# ---------------------------------------------------------------------------------------------
# Equations: one sample, numpy on small arrays (plain Python or compiled by numba)
# ---------------------------------------------------------------------------------------------


def joint_axes(q: np.ndarray, dh: DH | None = None) -> np.ndarray:
    """Unit rotation axis of each joint in the base frame (6, 3) at pose q (6,) [rad]: joint i
    turns about z of DH frame i - 1 (the base's z for joint 1)."""
    R, _ = forward_kinematics((dh or DH()).table(), np.asarray(q, dtype=float))
    return np.vstack([[0.0, 0.0, 1.0], R[:-1, :, 2]])


@register_jitable
def joint_transforms(dh, q):
    """Rotation R_i (3x3, frame i in frame i-1) and origin p_i of frame i in frame i-1 (3,),
    for each joint: R (6, 3, 3), p (6, 3). ``dh`` is the (6, 4) table [d, a, alpha, offset]."""
    R = np.zeros((N_JOINTS, 3, 3))
    p = np.zeros((N_JOINTS, 3))
    for i in range(N_JOINTS):
        th = q[i] + dh[i, 3]
        ct, st = math.cos(th), math.sin(th)
        ca, sa = math.cos(dh[i, 2]), math.sin(dh[i, 2])
        R[i, 0, 0], R[i, 0, 1], R[i, 0, 2] = ct, -st * ca, st * sa
        R[i, 1, 0], R[i, 1, 1], R[i, 1, 2] = st, ct * ca, -ct * sa
        R[i, 2, 0], R[i, 2, 1], R[i, 2, 2] = 0.0, sa, ca
        p[i, 0], p[i, 1], p[i, 2] = dh[i, 1] * ct, dh[i, 1] * st, dh[i, 0]
    return R, p


@register_jitable
def forward_kinematics(dh, q):
    """Pose of every link frame in the base: rotations (6, 3, 3) and origins (6, 3) [m]."""
    R, p = joint_transforms(dh, q)
    Rw = np.zeros((N_JOINTS, 3, 3))
    pw = np.zeros((N_JOINTS, 3))
    # the 3x3 products written out: numba's @ calls BLAS, which serializes across threads
    for i in range(N_JOINTS):
        for r in range(3):
            if i == 0:
                pw[0, r] = p[0, r]
                for c in range(3):
                    Rw[0, r, c] = R[0, r, c]
            else:
                pw[i, r] = pw[i - 1, r] + (Rw[i - 1, r, 0] * p[i, 0] + Rw[i - 1, r, 1] * p[i, 1]
                                           + Rw[i - 1, r, 2] * p[i, 2])
                for c in range(3):
                    Rw[i, r, c] = Rw[i - 1, r, 0] * R[i, 0, c] + Rw[i - 1, r, 1] * R[i, 1, c] + Rw[i - 1, r, 2] * R[i, 2, c]
    return Rw, pw


# 3-vectors as tuples inside the recursions: compiled, they live in registers (no allocation),
# which makes one Newton-Euler pass about a microsecond instead of tens
@register_jitable
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@register_jitable
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@register_jitable
def _scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@register_jitable
def _rot(R, i, v):
    """R[i] @ v."""
    return (R[i, 0, 0] * v[0] + R[i, 0, 1] * v[1] + R[i, 0, 2] * v[2],
            R[i, 1, 0] * v[0] + R[i, 1, 1] * v[1] + R[i, 1, 2] * v[2],
            R[i, 2, 0] * v[0] + R[i, 2, 1] * v[1] + R[i, 2, 2] * v[2])


@register_jitable
def _rot_t(R, i, v):
    """R[i].T @ v."""
    return (R[i, 0, 0] * v[0] + R[i, 1, 0] * v[1] + R[i, 2, 0] * v[2],
            R[i, 0, 1] * v[0] + R[i, 1, 1] * v[1] + R[i, 2, 1] * v[2],
            R[i, 0, 2] * v[0] + R[i, 1, 2] * v[1] + R[i, 2, 2] * v[2])


@register_jitable
def _inertia(pi, k, v):
    """I v for the inertia tensor about the link origin stored at pi[k + 4 : k + 10]."""
    return (pi[k + 4] * v[0] + pi[k + 5] * v[1] + pi[k + 6] * v[2],
            pi[k + 5] * v[0] + pi[k + 7] * v[1] + pi[k + 8] * v[2],
            pi[k + 6] * v[0] + pi[k + 8] * v[1] + pi[k + 9] * v[2])


@register_jitable
def _row(X, i):
    return (X[i, 0], X[i, 1], X[i, 2])


@register_jitable
def _slot(work, k, i):
    return (work[k, i, 0], work[k, i, 1], work[k, i, 2])


@register_jitable
def forward_pass(R, p, qd, qdd, gravity):
    """Outward recursion of Newton-Euler for the joint transforms (R, p) of ``joint_transforms``:
    per link i, in frame i, the angular velocity W[i] and acceleration WD[i] [rad/s, rad/s^2], the
    acceleration of the frame's origin *minus gravity* A[i] [m/s^2] (the base is given an upward
    acceleration g; with ``gravity`` = g, A[i] is the specific force an accelerometer at that
    origin reads), and PS[i], origin i seen from origin i-1 in frame i [m]. Each (6, 3)."""
    work = np.empty((4, N_JOINTS, 3))
    forward_pass_into(R, p, qd, qdd, gravity, work)
    return work[0], work[1], work[2], work[3]


@register_jitable
def forward_pass_into(R, p, qd, qdd, gravity, work):
    """``forward_pass`` into one work array (4, 6, 3): W, WD, A, PS (one allocation instead of four)."""
    w = (0.0, 0.0, 0.0)
    wd = (0.0, 0.0, 0.0)
    a = (0.0, 0.0, gravity)
    for i in range(N_JOINTS):
        ps = _rot_t(R, i, _row(p, i))
        # joint i turns about z of frame i-1: w + z qd, wd + z qdd + w x z qd
        wd = _rot_t(R, i, (wd[0] + w[1] * qd[i], wd[1] - w[0] * qd[i], wd[2] + qdd[i]))
        w = _rot_t(R, i, (w[0], w[1], w[2] + qd[i]))
        a = _add(_add(_rot_t(R, i, a), _cross(wd, ps)), _cross(w, _cross(w, ps)))
        for c in range(3):
            work[0, i, c], work[1, i, c], work[2, i, c], work[3, i, c] = w[c], wd[c], a[c], ps[c]


@register_jitable
def rnea_transforms(R, p, pi, qd, qdd, gravity):
    """``rnea`` for precomputed joint transforms (R, p)."""
    work = np.empty((4, N_JOINTS, 3))  # indexed, not sliced: a slice is an object numba counts references of
    forward_pass_into(R, p, qd, qdd, gravity, work)
    return backward_pass(R, p, pi, work, N_JOINTS - 1)


@register_jitable
def backward_pass(R, p, pi, work, top):
    """Inward recursion of Newton-Euler: joint torques [N m] (6,) from the forward pass's ``work``
    (``forward_pass_into``) and the inertial parameters pi (60,), starting at link ``top``: the
    links beyond it must carry no parameters (their wrench is zero; ``regressor`` skips them)."""
    f_next = (0.0, 0.0, 0.0)
    n_next = (0.0, 0.0, 0.0)
    tau = np.zeros(N_JOINTS)
    for i in range(top, -1, -1):
        k = i * N_PARAMS_LINK
        m = pi[k]
        h = (pi[k + 1], pi[k + 2], pi[k + 3])
        w, wd, a = _slot(work, 0, i), _slot(work, 1, i), _slot(work, 2, i)
        f = _add(_add(_scale(m, a), _cross(wd, h)), _cross(w, _cross(w, h)))
        n = _add(_add(_inertia(pi, k, wd), _cross(w, _inertia(pi, k, w))), _cross(h, a))
        if i < N_JOINTS - 1:
            f_child = _rot(R, i + 1, f_next)
            n = _add(_add(n, _rot(R, i + 1, n_next)), _cross(_row(p, i + 1), f_child))
            f = _add(f, f_child)
        # f, n: wrench link i-1 exerts on the subtree from link i, n about origin i (the far end);
        # joint i turns about z_{i-1} through origin i-1 (R[i].T z = row 2 of R[i]): move the moment there
        nt = _add(n, _cross(_slot(work, 3, i), f))
        tau[i] = nt[0] * R[i, 2, 0] + nt[1] * R[i, 2, 1] + nt[2] * R[i, 2, 2]
        f_next, n_next = f, n
    return tau


@register_jitable
def rnea(dh, pi, q, qd, qdd, gravity):
    """Joint torques [N m] (6,) for motion q, qd, qdd (rad, rad/s, rad/s^2) with inertial
    parameters pi (60,) and gravity [m/s^2] (0 to leave it out). Linear in pi."""
    R, p = joint_transforms(dh, q)
    return rnea_transforms(R, p, pi, qd, qdd, gravity)


@register_jitable
def mass_matrix(dh, pi, q):
    """M(q) (6, 6) [kg m^2] by the composite-rigid-body algorithm (tested against RNEA with qd = 0,
    qdd = e_j, no gravity, column by column)."""
    R, p = joint_transforms(dh, q)
    return mass_matrix_transforms(R, p, pi)


@register_jitable
def _to_parent(B, R, p, i):
    """The 10 inertial parameters B (m, first moment h, inertia about the origin: xx xy xz yy yz zz;
    a tuple) of a body given in frame i about origin i, expressed in frame i-1 about origin i-1
    (R[i], p[i]): m stays, h' = m r + E h, I' = E I E^T + m (|r|^2 1 - r r^T) + 2 (r . Eh) 1
    - r (Eh)^T - Eh r^T."""
    m = B[0]
    r = _row(p, i)
    hb = _rot(R, i, (B[1], B[2], B[3]))
    # E I E^T, I symmetric: the columns of I E^T are I times the rows of E
    c0 = _inertia_of(B, (R[i, 0, 0], R[i, 0, 1], R[i, 0, 2]))
    c1 = _inertia_of(B, (R[i, 1, 0], R[i, 1, 1], R[i, 1, 2]))
    c2 = _inertia_of(B, (R[i, 2, 0], R[i, 2, 1], R[i, 2, 2]))
    rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    rh = r[0] * hb[0] + r[1] * hb[1] + r[2] * hb[2]
    d = m * rr + 2.0 * rh

    def entry(a, c, col):  # (E I E^T)[a, c] = row a of E . column c of I E^T, plus the shift
        rot = R[i, a, 0] * col[0] + R[i, a, 1] * col[1] + R[i, a, 2] * col[2]
        return rot - m * r[a] * r[c] - r[a] * hb[c] - hb[a] * r[c]

    return (m, m * r[0] + hb[0], m * r[1] + hb[1], m * r[2] + hb[2],
            entry(0, 0, c0) + d, entry(0, 1, c1), entry(0, 2, c2), entry(1, 1, c1) + d, entry(1, 2, c2),
            entry(2, 2, c2) + d)


@register_jitable
def _inertia_of(B, v):
    """I v for the inertia (xx xy xz yy yz zz) at B[4:10]."""
    return (B[4] * v[0] + B[5] * v[1] + B[6] * v[2],
            B[5] * v[0] + B[7] * v[1] + B[8] * v[2],
            B[6] * v[0] + B[8] * v[1] + B[9] * v[2])


@register_jitable
def mass_matrix_transforms(R, p, pi):
    """``mass_matrix`` for precomputed joint transforms (R, p). Link i turns with joint i about z of
    frame i-1 through origin i-1: for i from the tip down, the composite of links i..5 in frame i-1
    about origin i-1 gives M[i, i] (its zz inertia) and the wrench of a unit acceleration of joint i
    (moment I z, force z x h); carried down the chain, that wrench's z moment in frame j-1 is M[j, i]."""
    M = np.empty((N_JOINTS, N_JOINTS))
    C = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # composite of links i+1..5, frame i, origin i
    for i in range(N_JOINTS - 1, -1, -1):
        k = i * N_PARAMS_LINK
        B = (pi[k] + C[0], pi[k + 1] + C[1], pi[k + 2] + C[2], pi[k + 3] + C[3], pi[k + 4] + C[4],
             pi[k + 5] + C[5], pi[k + 6] + C[6], pi[k + 7] + C[7], pi[k + 8] + C[8], pi[k + 9] + C[9])
        C = _to_parent(B, R, p, i)
        M[i, i] = C[9]
        n = (C[6], C[8], C[9])
        f = (-C[2], C[1], 0.0)
        for j in range(i - 1, -1, -1):  # from frame j about origin j to frame j-1 about origin j-1
            f = _rot(R, j, f)
            n = _add(_rot(R, j, n), _cross(_row(p, j), f))
            M[j, i] = n[2]
            M[i, j] = n[2]
    return M


@register_jitable
def bias_torques(dh, pi, q, qd, gravity):
    """C(q, qd) qd + G(q) [N m]: RNEA with qdd = 0."""
    return rnea(dh, pi, q, qd, np.zeros(N_JOINTS), gravity)


@register_jitable
def solve_spd(M, b):
    """x = M^-1 b (``solve_spd_in_place`` on copies)."""
    x = b.copy()
    solve_spd_in_place(M.copy(), x)
    return x


@register_jitable
def forward_dynamics(dh, pi, q, qd, tau, gravity):
    """qdd = M^-1 (tau - C qd - G) [rad/s^2] for load-side torques tau [N m] (M and the bias
    torques from one set of joint transforms)."""
    R, p = joint_transforms(dh, q)
    rhs = rnea_transforms(R, p, pi, qd, np.zeros(N_JOINTS), gravity)
    for i in range(N_JOINTS):
        rhs[i] = tau[i] - rhs[i]
    solve_spd_in_place(mass_matrix_transforms(R, p, pi), rhs)
    return rhs


@register_jitable
def regressor(dh, q, qd, qdd, gravity):
    """Y (6, 60) with tau = Y pi: RNEA with unit parameter vectors (the dynamics are linear in pi).
    The transforms and the forward pass do not depend on pi: computed once; a parameter of link L
    moves no link beyond it, so its inward pass starts at L (the same values as the whole pass)."""
    Y = np.zeros((N_JOINTS, N_PARAMS))
    R, p = joint_transforms(dh, q)
    work = np.empty((4, N_JOINTS, 3))
    forward_pass_into(R, p, qd, qdd, gravity, work)
    e = np.zeros(N_PARAMS)
    for j in range(N_PARAMS):
        e[j] = 1.0
        Y[:, j] = backward_pass(R, p, e, work, j // N_PARAMS_LINK)
        e[j] = 0.0
    return Y


@register_jitable
def energy(dh, pi, q, qd, gravity):
    """Kinetic + potential energy [J] of the arm (reference: base height, potential m g z)."""
    Rw, pw = forward_kinematics(dh, q)
    ekin = 0.5 * qd @ (mass_matrix(dh, pi, q) @ qd)
    epot = 0.0
    for i in range(N_JOINTS):
        k = i * N_PARAMS_LINK
        h = np.array([pi[k + 1], pi[k + 2], pi[k + 3]])
        epot += gravity * (pi[k] * pw[i, 2] + (Rw[i] @ h)[2])
    return ekin + epot


# ---------------------------------------------------------------------------------------------
# Many samples at once (compiled loops)
# ---------------------------------------------------------------------------------------------


njit = Kernels(__file__, fx.__file__, plant_effects.__file__, linalg.__file__)


@njit
def _rnea_batch(dh, pi, q, qd, qdd, gravity):
    out = np.empty(q.shape)
    for k in range(q.shape[0]):
        out[k] = rnea(dh, pi, q[k], qd[k], qdd[k], gravity)
    return out


@njit
def _regressor_batch(dh, q, qd, qdd, gravity):
    out = np.empty((q.shape[0], N_JOINTS, N_PARAMS))
    for k in range(q.shape[0]):
        out[k] = regressor(dh, q[k], qd[k], qdd[k], gravity)
    return out


def inverse_dynamics(params: ArmParameters, q, qd, qdd, gravity: float = GRAVITY) -> np.ndarray:
    """Load-side joint torques (T, 6) [N m] for kinematics (T, 6) (rad, rad/s, rad/s^2)."""
    args = [np.ascontiguousarray(np.atleast_2d(x), dtype=float) for x in (q, qd, qdd)]
    return _rnea_batch(params.dh.table(), params.vector(), *args, float(gravity))


def load_torque(params: ArmParameters, drive: DriveParameters, q, qd, qdd, eps: float) -> np.ndarray:
    """The joint torque the load needs (T, 6) [N m]: rigid body + load viscous and Coulomb friction,
    D_l qd + F_lc sgn(qd) with sgn smoothed as tanh(qd / eps) (paper 002, eq. 14)."""
    qd = np.atleast_2d(np.asarray(qd, dtype=float))
    return inverse_dynamics(params, q, qd, qdd) + np.asarray(drive.Dl) * qd + np.asarray(drive.Flc) * np.tanh(qd / eps)


def regressor_batch(params: ArmParameters, q, qd, qdd, gravity: float = GRAVITY) -> np.ndarray:
    """Y (T, 6, 60) with tau = Y @ pi, for kinematics (T, 6)."""
    args = [np.ascontiguousarray(np.atleast_2d(x), dtype=float) for x in (q, qd, qdd)]
    return _regressor_batch(params.dh.table(), *args, float(gravity))


@register_jitable
def specific_force(dh, q, qd, qdd, offset, gravity):
    """What a 3-axis accelerometer fixed to link 6 at ``offset`` [m] (in frame 6, axes parallel
    to frame 6) reads: the sensor point's acceleration minus gravity, in frame 6 [m/s^2]."""
    R, p = joint_transforms(dh, q)
    W, WD, A, PS = forward_pass(R, p, qd, qdd, gravity)
    last = N_JOINTS - 1
    w, wd, a = _row(W, last), _row(WD, last), _row(A, last)
    o = (offset[0], offset[1], offset[2])
    return np.array(_add(_add(a, _cross(wd, o)), _cross(w, _cross(w, o))))


@register_jitable
def flexible_derivatives(dh, pi, drive, x, u, gravity, eps):
    """d/dt of the flexible-joint state x = [q_l, qd_l, q_m, qd_m] (24,) for motor torques u (6,)
    [N m] (paper 002, eqs. 1-2, no external force):

        M_l(q_l) qdd_l + C qd_l + G + D_l qd_l + F_lc sgn(qd_l) = tau_J
        J_m qdd_m + D_m qd_m + F_mc sgn(qd_m) = u - tau_J / N
        tau_J = K_J (q_m / N - q_l) + D_J (qd_m / N - qd_l)

    sgn smoothed as tanh(v / eps) [rad/s]. ``drive`` is ``DriveParameters.table()``; rows beyond its
    ``DRIVE_ROWS`` hold, per joint (column), hidden effects of the library in the records of
    ``physics.plant_effects`` (``FlexArmPlant.drive_table``): torques of q_l and qd_l in motor N m
    (the model's input unit), which act on the load as N times that."""
    n = N_JOINTS
    out = np.empty(4 * n)
    load = np.empty(n)
    for i in range(n):  # per joint, scalars (no temporary arrays)
        N, Jm, Dm, Fmc, KJ, DJ, Dl, Flc = (drive[0, i], drive[1, i], drive[2, i], drive[3, i], drive[4, i],
                                           drive[5, i], drive[6, i], drive[7, i])
        ql, qdl, qm, qdm = x[i], x[n + i], x[2 * n + i], x[3 * n + i]
        tau_j = KJ * (qm / N - ql) + DJ * (qdm / N - qdl)
        load[i] = tau_j - Dl * qdl - Flc * math.tanh(qdl / eps)
        if drive.shape[0] > DRIVE_ROWS:
            load[i] -= N * plant_effects.axis_torque(drive[DRIVE_ROWS:, i], ql, qdl, 0.0, 0.0)
        out[i] = qdl
        out[2 * n + i] = qdm
        out[3 * n + i] = (u[i] - Dm * qdm - Fmc * math.tanh(qdm / eps) - tau_j / N) / Jm
    out[n : 2 * n] = forward_dynamics(dh, pi, x[:n], x[n : 2 * n], load, gravity)
    return out


@register_jitable
def flexible_energy(dh, pi, drive, x, gravity):
    """Energy [J] of the flexible arm: load (kinetic + potential), motors (kinetic), joint springs."""
    n = N_JOINTS
    ql, qdl, qm, qdm = x[:n], x[n : 2 * n], x[2 * n : 3 * n], x[3 * n :]
    N, Jm, KJ = drive[0], drive[1], drive[4]
    spring = qm / N - ql
    return energy(dh, pi, ql, qdl, gravity) + 0.5 * np.sum(Jm * qdm * qdm) + 0.5 * np.sum(KJ * spring * spring)


# compiled single-sample versions, for loops in Python (tests, small studies)
forward_dynamics_compiled = njit(forward_dynamics)
solve_spd_compiled = njit(solve_spd)
energy_compiled = njit(energy)
flexible_derivatives_compiled = njit(flexible_derivatives)
flexible_energy_compiled = njit(flexible_energy)
specific_force_compiled = njit(specific_force)
