"""Motion influence (paper 002, section 3.1, eqs. 22-25 and Table 1).

The model-following error of joint i depends on the motion of the other joints too (the coupling
d(q) of the arm). The predictor of joint i therefore sees the *motion influence*

    Q(j) = Phi q_lr(j),   Qd(j) = Phi qd_lr(j),   Qdd(j) = Phi qdd_lr(j)        (22)-(24)

a linear combination of all joints' references, with Phi's diagonal 1 and its off-diagonal entries
from Table 1:

* phi_ij = 0 when the axes of joints i and j are perpendicular (or, here, not aligned within
  ``ALIGNED_DEG``);
* for aligned axes, phi_ij = +1 when the axes point the same way and inverse kinematics turns the
  two joints the same way for the task motion, -1 when exactly one of the two differs, +1 when both
  do. ("The same way" is read from the references: the sign of the correlation of the two joints'
  velocities. A joint that does not move in the references is taken as turning the same way.)
* beyond the paper: two moving joints whose velocities do not move together in the references
  (correlation coefficient below ``TOGETHER`` in magnitude) are not one task's motion, and phi_ij = 0
  whatever their axes. The paper's task (TCP lines) turns its joints in proportion (|r| = 0.99-1 on
  the FlexArm's moving joints); the two-link arm's random moves turn its parallel shoulder and elbow
  independently (|r| = 0.01), and mixing them put the shoulder's motion into the elbow's friction
  and the elbow's into the shoulder's spring (docs/methods/rbf-expert.md).

The axes are those of the machine at its reference pose (``System.joint_axes``; the paper uses the
arm's home pose, Fig. 4). For paper 002's robot and task (tool fixed, TCP along X) these rules give
eq. (25), ``PAPER_PHI``; the FlexArm's lines give the same entries among the moving joints 2, 3, 5
(``tests/test_rbf_expert.py``). For the IX the two axes (propeller, roll) are perpendicular: Phi is
the 2x2 identity.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

ALIGNED_DEG = 20.0  # axes within this angle (or of its opposite) count as aligned
TOGETHER = 0.5  # two moving joints move together (one task) where their velocities correlate at least this much

PAPER_PHI = np.array([  # eq. (25)
    [1, 0, 0, 1, 0, 1],
    [0, 1, -1, 0, 1, 0],
    [0, -1, 1, 0, -1, 0],
    [1, 0, 0, 1, 0, 1],
    [0, 1, -1, 0, 1, 0],
    [1, 0, 0, 1, 0, 1],
], dtype=float)


def rotation_directions(velocities: Sequence[np.ndarray], moving_tol: float = 1e-6) -> np.ndarray:
    """(n, n) +-1: whether joints i and j turn the same way in the given motions (sign of the
    correlation of their velocities, (T, n) [rad/s] each); +1 where either joint does not move; 0
    where both move but not together (|correlation coefficient| below ``TOGETHER``)."""
    v = np.concatenate([np.asarray(x, dtype=float) for x in velocities])
    moving = np.abs(v).max(axis=0) > moving_tol
    gram = v.T @ v
    s = np.sign(gram)
    norm = np.sqrt(np.maximum(np.diag(gram), 1e-300))
    independent = np.abs(gram / np.outer(norm, norm)) < TOGETHER  # about zero: their velocities are mean-free
    s[independent & np.outer(moving, moving)] = 0.0
    s[~moving, :] = 1.0
    s[:, ~moving] = 1.0
    np.fill_diagonal(s, 1.0)
    return s


def influence_matrix(axes: np.ndarray, directions: np.ndarray, aligned_deg: float = ALIGNED_DEG) -> np.ndarray:
    """Phi (n, n) by Table 1 from the joint axes (n, 3) and the rotation directions (n, n) +-1."""
    axes = np.asarray(axes, dtype=float)
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    cos = axes @ axes.T
    aligned = np.abs(cos) >= math.cos(math.radians(aligned_deg))
    phi = np.where(aligned, np.sign(cos) * np.asarray(directions, dtype=float), 0.0)
    np.fill_diagonal(phi, 1.0)
    return phi


def task_influence(references: Sequence, axes: np.ndarray | None) -> np.ndarray:
    """Phi for the task the references describe: the joint ``axes`` (n, 3) of the machine at its
    reference pose (None: mutually perpendicular, Phi = I), directions from the references' velocities."""
    if axes is None:
        return np.eye(references[0].positions.shape[1])
    return influence_matrix(axes, rotation_directions([r.velocities for r in references]))


def motion_influence(phi: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray):
    """Q, Qd, Qdd (T, n) of eqs. (22)-(24) from the references q, qd, qdd (T, n)."""
    return q @ phi.T, qd @ phi.T, qdd @ phi.T
