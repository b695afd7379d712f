"""A URDF machine's rigid body in flat arrays, and its forward dynamics compiled with numba.

What the URDF plant integrates at every RK4 stage (``urdf_plant``), in one compiled loop with its
feedback and its effects, so that a sample costs what its physics costs rather than a dozen calls
from Python:

    (M(q) + diag(armature)) qdd = tau - h(q, qd),    h = C(q, qd) qd + g(q)

``RigidBody.from_model`` copies a pinocchio model of 1-DOF revolute and prismatic joints (what
``urdf.URDFRobot`` reduces a URDF to) into arrays: each joint's parent, kind, axis, placement in
its parent's frame, and body inertia. ``accelerations`` computes qdd from those arrays:

* h(q, qd) and g(q) by the recursive Newton-Euler algorithm (Featherstone, *Rigid Body Dynamics
  Algorithms*, 2008, Table 5.1), gravity as an acceleration of the base;
* M(q) by the composite-rigid-body algorithm (ibid., Table 6.2), the composite inertias kept as
  (mass, centre of mass, inertia about it);
* qdd by a Cholesky solve (``physics.linalg``; M + diag(armature) is symmetric positive definite).

Spatial vectors are pairs of 3-vectors in each body's frame: a motion (angular w, linear v of the
frame's origin), a force (moment n about the origin, force f). Pinocchio's ``aba`` (the
articulated-body algorithm: another algorithm for the same equation) is the reference it is tested
against (``tests/test_rigid_body.py``: revolute, continuous and prismatic joints, unaligned axes,
armature, a 7-joint arm), as are the model's inverse dynamics and regressor, which stay pinocchio's.

Joint angles are plain numbers here, also for a continuous joint (pinocchio stores its cos and sin).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..physics import linalg
from ..physics.compiled import FASTMATH, NO_REFCOUNTS, Kernels
from ..physics.linalg import solve_spd_in_place

REVOLUTE, PRISMATIC = 0, 1

@dataclass(frozen=True)
class RigidBody:
    """A tree of n 1-DOF joints in arrays (joint i moves body i; joints in pinocchio's order, a
    parent before its children).

    parent (n,): the parent joint's index, -1 for the base; kind (n,): ``REVOLUTE`` or
    ``PRISMATIC``; axis (n, 3): the joint's unit axis in its own frame; rotation (n, 3, 3) and
    translation (n, 3) [m]: the joint frame's placement in the parent's frame at q = 0 (a point x
    in the joint frame is R x + p in the parent's); mass (n,) [kg], com (n, 3) [m] and inertia
    (n, 3, 3) [kg m^2, about the centre of mass]: the body's, in the joint frame; armature (n,)
    [kg m^2 or kg]: a rotor inertia added to M's diagonal; gravity (3,) [m/s^2]: in the base frame.
    """

    parent: np.ndarray
    kind: np.ndarray
    axis: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    armature: np.ndarray
    gravity: np.ndarray

    @property
    def n(self) -> int:
        return int(self.parent.size)

    @classmethod
    def from_model(cls, model) -> RigidBody:
        """The arrays of a pinocchio ``Model`` whose joints (but the universe) are 1-DOF revolute
        (also unbounded, a continuous joint) or prismatic, with one velocity each, in order."""
        n = model.njoints - 1
        arrays = {k: np.zeros(s) for k, s in (("axis", (n, 3)), ("rotation", (n, 3, 3)), ("translation", (n, 3)),
                                                ("mass", n), ("com", (n, 3)), ("inertia", (n, 3, 3)))}
        parent, kind = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        for i in range(n):
            joint = model.joints[i + 1]
            kind[i], arrays["axis"][i] = _joint_kind(model, i + 1)
            if joint.idx_v != i:
                raise ValueError(f"joint {model.names[i + 1]}: velocity index {joint.idx_v}, expected {i} (1-DOF joints)")
            parent[i] = model.parents[i + 1] - 1
            placement, body = model.jointPlacements[i + 1], model.inertias[i + 1]
            arrays["rotation"][i], arrays["translation"][i] = placement.rotation, placement.translation
            arrays["mass"][i], arrays["com"][i], arrays["inertia"][i] = body.mass, body.lever, body.inertia
        return cls(parent=parent, kind=kind, armature=np.array(model.armature, dtype=float).copy(),
                   gravity=np.array(model.gravity.linear, dtype=float).copy(), **arrays)

    def packed(self) -> tuple:
        """The arrays in the order the compiled functions take them (``accelerations``)."""
        return (self.parent, self.kind, self.axis, self.rotation, self.translation, self.mass, self.com, self.inertia,
                self.armature, self.gravity)


def _joint_kind(model, i: int) -> tuple[int, np.ndarray]:
    """(kind, unit axis) of pinocchio joint i, from its motion subspace S (pinocchio's order: linear,
    then angular): a revolute joint (also unbounded, a continuous one) turns about S's angular part, a
    prismatic one slides along its linear part; any other joint is refused."""
    joint = model.joints[i]
    if joint.nv != 1:
        raise ValueError(f"joint {model.names[i]} ({joint.shortname()}): the compiled rigid body takes 1-DOF joints, "
                         f"this one has {joint.nv} velocities")
    data = joint.createData()
    joint.calc(data, pin.neutral(model)[joint.idx_q : joint.idx_q + joint.nq])
    S = np.asarray(data.S, dtype=float).ravel()
    linear, angular = np.linalg.norm(S[:3]), np.linalg.norm(S[3:])
    if angular > 0 and linear == 0:
        return REVOLUTE, S[3:] / angular
    if linear > 0 and angular == 0:
        return PRISMATIC, S[:3] / linear
    raise ValueError(f"joint {model.names[i]} ({joint.shortname()}): the compiled rigid body takes revolute, "
                     "continuous and prismatic joints only")


njit = Kernels(__file__, linalg.__file__)


def scratch(n: int) -> tuple:
    """Work arrays for ``accelerations`` and ``gravity_torque`` on n joints (made once per run; the
    compiled functions allocate nothing): the joint frames R (n, 3, 3) and p (n, 3); per body a
    motion, an acceleration and a force (n, 6); composite inertias: mass (n,), centre (n, 3),
    inertia (n, 3, 3); M (n, n); h (n,); and rows for temporaries (8, 6)."""
    return (np.zeros((n, 3, 3)), np.zeros((n, 3)), np.zeros((n, 6)), np.zeros((n, 6)), np.zeros((n, 6)),
            np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3)), np.zeros((n, n)), np.zeros(n), np.zeros((8, 6)))


# Spatial vectors are rows of (k, 6) arrays: a motion (w, v), a force (n, f). The helpers take an
# array and a row rather than a view of the row: a view costs numba a reference count.
BASE_V, BASE_A, JOINT, MOMENTUM, MOVED = range(5)  # rows of the temporaries


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def _motion_to_child(R, p, i, src, j, dst):
    """dst[i] = the motion src[j] of joint i's parent, expressed in joint i's frame (placed at R[i],
    p[i] in the parent's): (R^T w, R^T (v + w x p))."""
    w0, w1, w2 = src[j, 0], src[j, 1], src[j, 2]
    t0 = src[j, 3] + w1 * p[i, 2] - w2 * p[i, 1]
    t1 = src[j, 4] + w2 * p[i, 0] - w0 * p[i, 2]
    t2 = src[j, 5] + w0 * p[i, 1] - w1 * p[i, 0]
    for r in range(3):
        dst[i, r] = R[i, 0, r] * w0 + R[i, 1, r] * w1 + R[i, 2, r] * w2
        dst[i, 3 + r] = R[i, 0, r] * t0 + R[i, 1, r] * t1 + R[i, 2, r] * t2


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def _add_force_to_parent(R, p, i, src, k, dst, j):
    """dst[j] += the force src[k] of joint i's frame expressed in its parent's: (R n + p x R f, R f)."""
    f0 = R[i, 0, 0] * src[k, 3] + R[i, 0, 1] * src[k, 4] + R[i, 0, 2] * src[k, 5]
    f1 = R[i, 1, 0] * src[k, 3] + R[i, 1, 1] * src[k, 4] + R[i, 1, 2] * src[k, 5]
    f2 = R[i, 2, 0] * src[k, 3] + R[i, 2, 1] * src[k, 4] + R[i, 2, 2] * src[k, 5]
    for r in range(3):
        dst[j, r] += R[i, r, 0] * src[k, 0] + R[i, r, 1] * src[k, 1] + R[i, r, 2] * src[k, 2]
    dst[j, 0] += p[i, 1] * f2 - p[i, 2] * f1
    dst[j, 1] += p[i, 2] * f0 - p[i, 0] * f2
    dst[j, 2] += p[i, 0] * f1 - p[i, 1] * f0
    dst[j, 3] += f0
    dst[j, 4] += f1
    dst[j, 5] += f2


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def _add_inertia_times(m, c, I, i, x, j, out, k):
    """out[k] += the force of the rigid inertia i (mass m[i], centre c[i], inertia I[i] about the
    centre) moving with x[j] = (w, v): f = m (v + w x c), n = I w + c x f."""
    w0, w1, w2 = x[j, 0], x[j, 1], x[j, 2]
    c0, c1, c2 = c[i, 0], c[i, 1], c[i, 2]
    f0 = m[i] * (x[j, 3] + w1 * c2 - w2 * c1)
    f1 = m[i] * (x[j, 4] + w2 * c0 - w0 * c2)
    f2 = m[i] * (x[j, 5] + w0 * c1 - w1 * c0)
    for r in range(3):
        out[k, r] += I[i, r, 0] * w0 + I[i, r, 1] * w1 + I[i, r, 2] * w2
    out[k, 0] += c1 * f2 - c2 * f1
    out[k, 1] += c2 * f0 - c0 * f2
    out[k, 2] += c0 * f1 - c1 * f0
    out[k, 3] += f0
    out[k, 4] += f1
    out[k, 5] += f2


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def _joint_motion(kind, axis, i, rate, out, k):
    """out[k] = S_i rate: joint i's motion at unit ``rate``, angular (revolute) or linear (prismatic)."""
    off = 0 if kind[i] == REVOLUTE else 3
    for r in range(6):
        out[k, r] = 0.0
    for r in range(3):
        out[k, off + r] = axis[i, r] * rate


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def _joint_force(kind, axis, i, F, k):
    """S_i^T F[k]: the force's component the joint transmits (its moment or force along the axis)."""
    off = 0 if kind[i] == REVOLUTE else 3
    return axis[i, 0] * F[k, off] + axis[i, 1] * F[k, off + 1] + axis[i, 2] * F[k, off + 2]


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def _joint_frames(q, kind, axis, rotation, translation, R, p):
    """R[i], p[i]: joint i's frame in its parent's at position q[i] (placement times joint motion)."""
    for i in range(q.size):
        a0, a1, a2 = axis[i, 0], axis[i, 1], axis[i, 2]
        if kind[i] == REVOLUTE:  # Rodrigues: E = I + sin(q) [a]x + (1 - cos(q)) [a]x^2; R = rotation E
            s, c = math.sin(q[i]), math.cos(q[i])
            t = 1.0 - c
            e00, e01, e02 = c + t * a0 * a0, t * a0 * a1 - s * a2, t * a0 * a2 + s * a1
            e10, e11, e12 = t * a0 * a1 + s * a2, c + t * a1 * a1, t * a1 * a2 - s * a0
            e20, e21, e22 = t * a0 * a2 - s * a1, t * a1 * a2 + s * a0, c + t * a2 * a2
            for r in range(3):
                x0, x1, x2 = rotation[i, r, 0], rotation[i, r, 1], rotation[i, r, 2]
                R[i, r, 0] = x0 * e00 + x1 * e10 + x2 * e20
                R[i, r, 1] = x0 * e01 + x1 * e11 + x2 * e21
                R[i, r, 2] = x0 * e02 + x1 * e12 + x2 * e22
                p[i, r] = translation[i, r]
        else:  # a translation by q along the axis
            for r in range(3):
                R[i, r, 0], R[i, r, 1], R[i, r, 2] = rotation[i, r, 0], rotation[i, r, 1], rotation[i, r, 2]
                p[i, r] = translation[i, r] + q[i] * (rotation[i, r, 0] * a0 + rotation[i, r, 1] * a1
                                                      + rotation[i, r, 2] * a2)


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def _bias_forces(qd, parent, kind, axis, mass, com, inertia, gravity, R, p, V, A, F, T, out):
    """out = h(q, qd) = C(q, qd) qd + g(q) [N m or N] by the recursive Newton-Euler algorithm with
    qdd = 0, the base accelerating at -gravity (qd = 0: g(q)). R, p: the joint frames
    (``_joint_frames``); V, A, F (n, 6): scratch for each body's velocity, acceleration and force;
    T: the temporaries (``scratch``)."""
    for r in range(6):
        T[BASE_V, r] = 0.0
        T[BASE_A, r] = 0.0 if r < 3 else -gravity[r - 3]
    for i in range(qd.size):
        j = parent[i]
        if j < 0:
            _motion_to_child(R, p, i, T, BASE_V, V)
            _motion_to_child(R, p, i, T, BASE_A, A)
        else:
            _motion_to_child(R, p, i, V, j, V)
            _motion_to_child(R, p, i, A, j, A)
        _joint_motion(kind, axis, i, qd[i], T, JOINT)
        s0, s1, s2, s3, s4, s5 = T[JOINT, 0], T[JOINT, 1], T[JOINT, 2], T[JOINT, 3], T[JOINT, 4], T[JOINT, 5]
        for r in range(6):
            V[i, r] += T[JOINT, r]
        w0, w1, w2, v0, v1, v2 = V[i, 0], V[i, 1], V[i, 2], V[i, 3], V[i, 4], V[i, 5]
        # A[i] += V[i] x S qd = (w x s_w, w x s_v + v x s_w)
        A[i, 0] += w1 * s2 - w2 * s1
        A[i, 1] += w2 * s0 - w0 * s2
        A[i, 2] += w0 * s1 - w1 * s0
        A[i, 3] += w1 * s5 - w2 * s4 + v1 * s2 - v2 * s1
        A[i, 4] += w2 * s3 - w0 * s5 + v2 * s0 - v0 * s2
        A[i, 5] += w0 * s4 - w1 * s3 + v0 * s1 - v1 * s0
        # F[i] = I A[i] + V[i] x* (I V[i]), with (w, v) x* (n, f) = (w x n + v x f, w x f)
        for r in range(6):
            F[i, r] = 0.0
            T[MOMENTUM, r] = 0.0
        _add_inertia_times(mass, com, inertia, i, A, i, F, i)
        _add_inertia_times(mass, com, inertia, i, V, i, T, MOMENTUM)
        n0, n1, n2, f0, f1, f2 = T[MOMENTUM, 0], T[MOMENTUM, 1], T[MOMENTUM, 2], T[MOMENTUM, 3], T[MOMENTUM, 4], T[MOMENTUM, 5]
        F[i, 0] += w1 * n2 - w2 * n1 + v1 * f2 - v2 * f1
        F[i, 1] += w2 * n0 - w0 * n2 + v2 * f0 - v0 * f2
        F[i, 2] += w0 * n1 - w1 * n0 + v0 * f1 - v1 * f0
        F[i, 3] += w1 * f2 - w2 * f1
        F[i, 4] += w2 * f0 - w0 * f2
        F[i, 5] += w0 * f1 - w1 * f0
    for i in range(qd.size - 1, -1, -1):  # F[i] holds its subtree's force: project on the joint, pass it on
        out[i] = _joint_force(kind, axis, i, F, i)
        if parent[i] >= 0:
            _add_force_to_parent(R, p, i, F, i, F, parent[i])


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def _mass_matrix(parent, kind, axis, mass, com, inertia, armature, R, p, cm, cc, cI, T, M):
    """M = M(q) + diag(armature) by the composite-rigid-body algorithm; the composite inertia of
    each subtree (cm, cc, cI: scratch) as (mass, centre, inertia about the centre) in its joint's
    frame. R, p: the joint frames (``_joint_frames``); T: the temporaries (``scratch``)."""
    n = mass.size
    for i in range(n):
        cm[i] = mass[i]
        for r in range(3):
            cc[i, r] = com[i, r]
            for s in range(3):
                cI[i, r, s] = inertia[i, r, s]
    for i in range(n - 1, -1, -1):  # children before parents: composite i is complete here
        # the subtree's momentum for a unit joint velocity, carried from joint i down to the base
        _joint_motion(kind, axis, i, 1.0, T, JOINT)
        for r in range(6):
            T[MOMENTUM, r] = 0.0
        _add_inertia_times(cm, cc, cI, i, T, JOINT, T, MOMENTUM)
        j = i
        while True:
            M[i, j] = M[j, i] = _joint_force(kind, axis, j, T, MOMENTUM)
            if parent[j] < 0:
                break
            for r in range(6):
                T[MOVED, r] = 0.0
            _add_force_to_parent(R, p, j, T, MOMENTUM, T, MOVED)
            for r in range(6):
                T[MOMENTUM, r] = T[MOVED, r]
            j = parent[j]
        M[i, i] += armature[i]
        if parent[i] >= 0:
            _add_composite(cm, cc, cI, parent[i], i, R, p)


@njit(fastmath=FASTMATH, **NO_REFCOUNTS)
def _add_composite(cm, cc, cI, k, i, R, p):
    """Composite k += composite i, whose frame is placed at R[i], p[i] in k's: the centres combined,
    the inertias moved to the new centre by the parallel-axis theorem."""
    c0 = R[i, 0, 0] * cc[i, 0] + R[i, 0, 1] * cc[i, 1] + R[i, 0, 2] * cc[i, 2] + p[i, 0]
    c1 = R[i, 1, 0] * cc[i, 0] + R[i, 1, 1] * cc[i, 1] + R[i, 1, 2] * cc[i, 2] + p[i, 1]
    c2 = R[i, 2, 0] * cc[i, 0] + R[i, 2, 1] * cc[i, 1] + R[i, 2, 2] * cc[i, 2] + p[i, 2]
    mk, mi = cm[k], cm[i]
    total = mk + mi
    if total > 0.0:
        x0, x1, x2 = (mk * cc[k, 0] + mi * c0) / total, (mk * cc[k, 1] + mi * c1) / total, (mk * cc[k, 2] + mi * c2) / total
    else:
        x0 = x1 = x2 = 0.0
    d = ((cc[k, 0] - x0, cc[k, 1] - x1, cc[k, 2] - x2), (c0 - x0, c1 - x1, c2 - x2))
    for r in range(3):
        for s in range(3):
            rotated = 0.0  # (R I_i R^T)[r, s]
            for a in range(3):
                rotated += R[i, r, a] * (cI[i, a, 0] * R[i, s, 0] + cI[i, a, 1] * R[i, s, 1] + cI[i, a, 2] * R[i, s, 2])
            cI[k, r, s] += rotated
            for mass_, e in ((mk, d[0]), (mi, d[1])):  # parallel axis: m (|d|^2 1 - d d^T)
                cI[k, r, s] += mass_ * ((e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) * (r == s) - e[r] * e[s])
    cm[k] = total
    cc[k, 0], cc[k, 1], cc[k, 2] = x0, x1, x2


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def accelerations(q, qd, tau, parent, kind, axis, rotation, translation, mass, com, inertia, armature, gravity,
                  R, p, V, A, F, cm, cc, cI, M, h, T, qdd):
    """qdd = (M(q) + diag(armature))^-1 (tau - h(q, qd)) [rad/s^2 or m/s^2], joint order; tau
    [N m or N]. The arrays from parent to gravity: ``RigidBody.packed()``; from R to T: ``scratch(n)``."""
    _joint_frames(q, kind, axis, rotation, translation, R, p)
    _bias_forces(qd, parent, kind, axis, mass, com, inertia, gravity, R, p, V, A, F, T, h)
    _mass_matrix(parent, kind, axis, mass, com, inertia, armature, R, p, cm, cc, cI, T, M)
    for i in range(h.size):
        qdd[i] = tau[i] - h[i]
    solve_spd_in_place(M, qdd)


@njit(fastmath=FASTMATH, inline="always", **NO_REFCOUNTS)
def gravity_torque(q, parent, kind, axis, rotation, translation, mass, com, inertia, armature, gravity,
                   R, p, V, A, F, cm, cc, cI, M, h, T, g):
    """g = g(q) [N m or N], joint order: the torques that hold the machine still at q (the
    arguments as ``accelerations``')."""
    _joint_frames(q, kind, axis, rotation, translation, R, p)
    h[:] = 0.0  # at rest
    _bias_forces(h, parent, kind, axis, mass, com, inertia, gravity, R, p, V, A, F, T, g)
