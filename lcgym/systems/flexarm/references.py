"""FlexArm references (paper 002, section 5.2 and Fig. 6): straight lines of the tool centre point
(TCP) along the base X axis with fixed orientation, 60-100 cm long, at various velocities and
accelerations. Joints 1, 4 and 6 stay at 0; the line lies in the arm's vertical plane, so only
joints 2, 3 and 5 move, as in the paper.

The TCP is the flange centre (origin of DH frame 6, ``systems.flexarm.dynamics``), the tool points straight
down (frame 6's z axis along -Z of the base). Each reference: rest, a third-order (jerk-limited)
move of the TCP along +X by the line's length, rest, the move back, rest. Cartesian profiles come
from ``references.AxisProfile`` (the same third-order setpoints as the IX), joint angles from
inverse kinematics solved by Newton's method on the forward kinematics of ``systems.flexarm.dynamics``
(compiled, warm-started from the previous sample, to 1e-12 m), joint velocities and accelerations
by central differences of the sampled angles.
"""

from __future__ import annotations

import math

import numpy as np

from ...physics import linalg
from ...physics.compiled import Kernels
from ...references import AxisProfile, Reference, stream
from . import dynamics as arm

TCP_HEIGHT = 0.50  # m above the base frame's origin: the height of the lines
X_RANGE = (0.55, 1.55)  # m: where the lines lie (the TCP's reach at that height)
LENGTHS = (0.60, 1.00)  # m: line lengths (paper: 60-100 cm)
LIMITS = {"v": (0.3, 1.0), "a": (1.0, 4.0), "j": (10.0, 40.0)}  # m/s, m/s^2, m/s^3: TCP setpoint limits
MOVING = (1, 2, 4)  # joints 2, 3, 5 (0-based)
START_GUESS = arm.HOME  # the IK starts from the home pose (elbow up, tool down)


njit = Kernels(__file__, arm.__file__, linalg.__file__)


_fk = njit(arm.forward_kinematics)


@njit
def _tool_error(dh, q, x, z):
    """(TCP x - x, TCP z - z, tilt of the tool from straight down) for joint angles q."""
    Rw, pw = _fk(dh, q)
    return np.array([pw[5, 0] - x, pw[5, 2] - z, math.atan2(Rw[5, 0, 2], -Rw[5, 2, 2])])


@njit
def inverse_kinematics_line(dh, xs, z, q0):
    """Joint angles (T, 6) that put the TCP at (xs[k], 0, z) with the tool down, moving joints 2,
    3, 5 only, starting from q0. Raises if a sample does not converge (out of reach)."""
    out = np.empty((xs.shape[0], 6))
    q = q0.copy()
    idx = np.array([1, 2, 4])
    for k in range(xs.shape[0]):
        for _ in range(50):
            r = _tool_error(dh, q, xs[k], z)
            if np.max(np.abs(r)) < 1e-12:
                break
            J = np.empty((3, 3))
            for c in range(3):
                dq = q.copy()
                dq[idx[c]] += 1e-7
                J[:, c] = (_tool_error(dh, dq, xs[k], z) - r) / 1e-7
            step = np.linalg.solve(J, r)
            for c in range(3):
                q[idx[c]] -= step[c]
        if np.max(np.abs(_tool_error(dh, q, xs[k], z))) > 1e-9:
            raise ValueError("inverse kinematics did not converge: the line leaves the arm's reach")
        out[k] = q
    return out


@njit
def _tcp_batch(dh, q):
    out = np.empty((q.shape[0], 3))
    for k in range(q.shape[0]):
        out[k] = _fk(dh, q[k])[1][5]
    return out


def tcp_positions(q: np.ndarray, dh: arm.DH | None = None) -> np.ndarray:
    """TCP (flange centre) positions (T, 3) [m] in the base frame for joint angles q (T, 6) [rad]."""
    return _tcp_batch((dh or arm.DH()).table(), np.ascontiguousarray(np.atleast_2d(q), dtype=float))


def tcp_line(name: str, rng: np.random.Generator, fs: float = 1000.0, dh: arm.DH | None = None) -> Reference:
    """One reference: the TCP goes out along +X by a random length and back, at random fractions of
    the setpoint limits, with rests; joint angles (T, 6) [rad] sampled at ``fs`` [Hz]."""
    dh = dh or arm.DH()
    length = rng.uniform(*LENGTHS)
    x0 = rng.uniform(X_RANGE[0], X_RANGE[1] - length)
    v, a, j = (rng.uniform(*LIMITS[k]) for k in ("v", "a", "j"))
    profile = AxisProfile(x0).dwell(0.5).move(x0 + length, v, a, j).dwell(rng.uniform(0.5, 1.5))
    profile.move(x0, v, a, j).dwell(1.0)
    t = np.arange(int(math.ceil(profile.end_time * fs)) + 1) / fs
    xs = profile.evaluate(t)[0]
    q = inverse_kinematics_line(dh.table(), xs, TCP_HEIGHT, _start(dh.table(), xs[0]))
    qd = np.gradient(q, 1.0 / fs, axis=0, edge_order=2)
    qdd = np.gradient(qd, 1.0 / fs, axis=0, edge_order=2)
    return Reference(name, fs, q, qd, qdd, axes=arm.AXES)


def _start(dh_table: np.ndarray, x: float) -> np.ndarray:
    """IK of the first sample from the elbow-up, tool-down guess, approached in small steps."""
    q = START_GUESS.copy()
    pw = _fk(dh_table, q)[1][5]
    for s in np.linspace(0.0, 1.0, 21)[1:]:  # walk from the guess's TCP to the line's start
        q = inverse_kinematics_line(dh_table, np.array([pw[0] + s * (x - pw[0])]), pw[2] + s * (TCP_HEIGHT - pw[2]), q)[0]
    return q


def arm_reference_set(name: str, seed: int = 0, n_references: int | None = None, fs: float = 1000.0) -> list[Reference]:
    """Seeded set "train" (default 8 lines), "validation" (2) or "test" (2) of TCP lines."""
    rng = stream(name, seed)
    n = n_references if n_references is not None else {"train": 8, "validation": 2, "test": 2}.get(name, 0)
    if n < 1:
        raise ValueError(f"n_references must be >= 1 (set {name!r}), got {n}")
    return [tcp_line(f"arm-{name}-{seed}-{i}", rng, fs) for i in range(n)]
