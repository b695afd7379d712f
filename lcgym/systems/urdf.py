"""Machines from URDF files: the rigid-body model of a robot description, via pinocchio.

``from_urdf(path, joints)`` reads a URDF, makes the named joints the machine's axes and locks
every other joint of the file (fingers, a gripper) at its neutral position: the locked bodies
join the inertia of the body they hang on (``pinocchio.buildReducedModel``). The machine is
linear in its parameters, per axis (in the order of ``joints``)

    p = [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz  (each moving body), d  (each axis)]

the ten standard inertial parameters of the body that moves with each axis (mass [kg], first
moment [kg m], inertia [kg m^2] about the origin of the joint's frame, in that frame; pinocchio's
``Inertia.toDynamicParameters`` order) and one viscous friction coefficient per axis [N m s/rad or
N s/m], nominal 0. The machine's input is the joint torque [N m] or force [N]:

    u = M(q) qdd + h(q, qd) + d * qd = regressor(q, qd, qdd) @ p

with M, h the URDF's rigid body under gravity (9.81 m/s^2 along the world's -z unless given).
The regressor is pinocchio's joint-torque regressor (``computeJointTorqueRegressor``), one call
per sample, with the viscous columns added. Not all standard parameters are identifiable from
joint torques (base parameters): ``base_parameters`` gives the structural rank, which the
System's description states; the least-squares fit elsewhere handles the deficiency.

Joint kinds: revolute and continuous joints are revolute axes (rad, N m; a continuous joint's
angle is unbounded, pinocchio stores it as (cos, sin)), prismatic joints are prismatic axes (m,
N). Floating and planar joints cannot be axes (they may be locked). Joints coupled by ``<mimic>``
cannot be axes either: pinocchio's regressor and forward dynamics do not model the coupling, so
such a pair is locked (the default leaves them out of the axes).
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..physics.memo import ArrayMemo
from ..physics.model import column_rank
from .system import REGRESSOR_MIN_ROWS, Axis, ParameterVector, System

try:
    import pinocchio as pin
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError("lcgym's URDF machines need pinocchio: pip install pin") from exc

MOVABLE = ("revolute", "continuous", "prismatic")
INERTIAL_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
POSITIVE_INERTIAL = (0, 4, 6, 9)  # m, Ixx, Iyy, Izz within a body's ten parameters
CACHE_SIZE = 3  # regressors kept inside ``caching()``
RANK_SAMPLES = 300  # random kinematics stacked for the structural rank
RANK_TOLERANCE = 1e-9  # singular values below this fraction of the largest count as zero (columns scaled to norm 1)
ZERO_COLUMN = 1e-10  # a regressor column this small against the largest is round-off


class URDFRobot:
    """A URDF robot reduced to its axes: the pinocchio model and the maps between the machine's
    axis order (``joints``) and pinocchio's joint order.

    model: the reduced ``pinocchio.Model`` (the axes are its joints, gravity set); names: the axis
    (joint) names; kinds: their URDF types (revolute, continuous, prismatic); locked: the joints
    locked; v_index / q_index: each axis's index in pinocchio's velocity / configuration vector;
    lower, upper [rad or m] (a continuous joint: -pi, pi), velocity [rad/s or m/s], effort [N m or
    N]: the URDF's limits per axis (inf where the URDF gives none).
    """

    def __init__(self, path: Path, name: str, model, joints: Sequence[str], kinds: Sequence[str], locked: Sequence[str]):
        self.path = path
        self.name = name
        self.model = model
        self.names = tuple(joints)
        self.kinds = tuple(kinds)
        self.locked = tuple(locked)
        ids = [model.getJointId(j) for j in self.names]
        self.joint_ids = np.array(ids, dtype=np.int64)
        self.v_index = np.array([model.joints[i].idx_v for i in ids], dtype=np.int64)
        self.q_index = np.array([model.joints[i].idx_q for i in ids], dtype=np.int64)
        self.continuous = np.array([k == "continuous" for k in self.kinds])
        self.lower, self.upper = self._position_limits()
        self.velocity = np.array([model.velocityLimit[i] for i in self.v_index], dtype=float)
        self.effort = np.array([model.effortLimit[i] for i in self.v_index], dtype=float)
        # regressor rows are pinocchio's velocity order; its columns come in blocks of ten per joint id
        self._rows = self.v_index
        self._cols = np.concatenate([np.arange(10 * (i - 1), 10 * i) for i in ids])
        self._in_order = bool(np.array_equal(self._rows, np.arange(self.n_axes))
                              and np.array_equal(self._cols, np.arange(10 * self.n_axes)))
        self._cache = ArrayMemo(CACHE_SIZE, min_rows=REGRESSOR_MIN_ROWS)

    # ------------------------------------------------------------------ sizes and names
    @property
    def n_axes(self) -> int:
        return len(self.names)

    @property
    def n_params(self) -> int:
        return 11 * self.n_axes

    @property
    def axes(self) -> tuple[Axis, ...]:
        kinds = ("prismatic" if k == "prismatic" else "revolute" for k in self.kinds)
        return tuple(Axis(n, k) for n, k in zip(self.names, kinds, strict=True))

    @property
    def param_names(self) -> tuple[str, ...]:
        inertial = [f"{p}_{j}" for j in self.names for p in INERTIAL_NAMES]
        return (*inertial, *(f"d_{j}" for j in self.names))

    @property
    def positive(self) -> tuple[int, ...]:
        """Indices of the masses, the diagonal inertias and the viscous coefficients."""
        A = self.n_axes
        return (*(10 * k + i for k in range(A) for i in POSITIVE_INERTIAL), *range(10 * A, 11 * A))

    def _position_limits(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.empty(self.n_axes)
        hi = np.empty(self.n_axes)
        for k, (iq, cont) in enumerate(zip(self.q_index, self.continuous, strict=True)):
            lo[k], hi[k] = (-math.pi, math.pi) if cont else (self.model.lowerPositionLimit[iq], self.model.upperPositionLimit[iq])
        return lo, hi

    # ------------------------------------------------------------------ parameters
    def nominal_vector(self) -> np.ndarray:
        """The URDF's parameters (module docstring), viscous friction 0."""
        inertial = [self.model.inertias[int(i)].toDynamicParameters() for i in self.joint_ids]
        return np.concatenate([*inertial, np.zeros(self.n_axes)])

    def parameters(self, p=None) -> ParameterVector:
        """Named parameters: the nominal ones (p None) or the vector p (n_params,)."""
        v = self.nominal_vector() if p is None else np.asarray(p, dtype=float).ravel()
        if v.size != self.n_params:
            raise ValueError(f"{self.name}: parameter vector must have {self.n_params} values, got {v.size}")
        return ParameterVector(self.param_names, tuple(float(x) for x in v))

    # ------------------------------------------------------------------ kinematics maps
    def configuration(self, q) -> np.ndarray:
        """Pinocchio configurations (T, nq) of axis positions q (T, n_axes) [rad or m]: a continuous
        joint's angle becomes (cos, sin)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        out = np.empty((q.shape[0], self.model.nq))
        plain = ~self.continuous
        out[:, self.q_index[plain]] = q[:, plain]
        if self.continuous.any():
            angle = q[:, self.continuous]
            out[:, self.q_index[self.continuous]] = np.cos(angle)
            out[:, self.q_index[self.continuous] + 1] = np.sin(angle)
        return out

    def tangent(self, x) -> np.ndarray:
        """Pinocchio velocity-order vectors (T, nv) of axis-order ones (T, n_axes)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        out = np.empty((x.shape[0], self.model.nv))
        out[:, self.v_index] = x
        return out

    # ------------------------------------------------------------------ regressor
    def regressor(self, zeta_n, q, qd, qdd) -> np.ndarray:
        """X (T, n_axes, n_params) with u = X p [N m or N] for kinematics (T, n_axes) [rad or m, per
        s, per s^2]; ``zeta_n`` is unused (the machine is linear in all its parameters).

        Inside ``with caching():`` the last ``CACHE_SIZE`` results are kept (``physics.memo.ArrayMemo``)."""
        q, qd, qdd = (np.ascontiguousarray(np.atleast_2d(np.asarray(x, dtype=float))) for x in (q, qd, qdd))
        shapes = {x.shape for x in (q, qd, qdd)}
        if len(shapes) != 1 or q.ndim != 2 or q.shape[1] != self.n_axes:
            raise ValueError(f"{self.name}: q, qd, qdd must share one shape (T, {self.n_axes}), got "
                             f"{[x.shape for x in (q, qd, qdd)]}")
        return self._cache.get(lambda: self._regressor(q, qd, qdd), q, qd, qdd)

    def _regressor(self, q, qd, qdd) -> np.ndarray:
        T, A = q.shape
        X = np.zeros((T, A, 11 * A))
        cfg, vel, acc = self.configuration(q), self.tangent(qd), self.tangent(qdd)
        Y = X[:, :, : 10 * A] if self._in_order else np.empty((T, A, 10 * A))
        data = self.model.createData()  # per call: the regressor may run in several threads at once
        model, rnea_regressor = self.model, pin.computeJointTorqueRegressor
        for k in range(T):
            Y[k] = rnea_regressor(model, data, cfg[k], vel[k], acc[k])
        if not self._in_order:
            X[:, :, : 10 * A] = np.take(np.take(Y, self._rows, axis=1), self._cols, axis=2)
        axes = np.arange(A)
        X[:, axes, 10 * A + axes] = qd
        return X

    def caching(self, size: int | None = None):
        """Keep the last ``CACHE_SIZE`` regressors (or ``size``) while the block runs (see ``regressor``)."""
        return self._cache.active(size)

    # ------------------------------------------------------------------ geometry
    def joint_axes(self) -> np.ndarray:
        """Unit axes (n_axes, 3) of the joints in the world frame at the neutral pose: the rotation
        axis of a revolute joint, the direction of travel of a prismatic one."""
        data = self.model.createData()
        pin.computeJointJacobians(self.model, data, pin.neutral(self.model))
        out = np.empty((self.n_axes, 3))
        for k, (jid, iv, kind) in enumerate(zip(self.joint_ids, self.v_index, self.kinds, strict=True)):
            jacobian = np.asarray(pin.getJointJacobian(self.model, data, int(jid), pin.LOCAL_WORLD_ALIGNED))
            column = jacobian.reshape(6, -1)[:, iv]  # pinocchio gives a model of one velocity a (6,) vector
            axis = column[:3] if kind == "prismatic" else column[3:]
            out[k] = axis / np.linalg.norm(axis)
        return out

    def sample_kinematics(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """n random (q, qd, qdd) (n, n_axes): q uniform within the joint limits (+-pi where a limit
        is missing), qd and qdd standard normal [per s, per s^2]."""
        lo = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, math.pi)
        return rng.uniform(lo, hi, (n, self.n_axes)), rng.standard_normal((n, self.n_axes)), rng.standard_normal((n, self.n_axes))

    def description(self, rank: int) -> str:
        text = (f"URDF {self.path.name}: {self.n_axes} axes ({', '.join(self.names)}), {self.n_params} standard parameters "
                f"({10 * self.n_axes} inertial + {self.n_axes} viscous), {rank} base parameters")
        return text + (f"; locked: {', '.join(self.locked)}" if self.locked else "")


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------


def load_urdf(path: str | Path, joints: Sequence[str] | None = None, gravity: Sequence[float] | None = None) -> URDFRobot:
    """The URDF at ``path`` reduced to the axes ``joints`` (module docstring; None: every revolute,
    continuous and prismatic joint not coupled by ``<mimic>``, in the file's tree order). The other
    joints are locked at their neutral position (0; clipped into the joint's limits where 0 lies
    outside). gravity: the gravity vector [m/s^2] in the world frame (default 9.81 along -z).
    Raises ValueError naming the file for a missing or unparsable file, unknown joint names and
    joints that cannot be axes."""
    path = Path(path)
    robot_name, table = _read_joint_table(path)
    full = _build_model(path)
    axes = _choose_axes(path, table, full, joints)
    kinds = [table[j][0] for j in axes]
    locked = [n for n in full.names[1:] if n not in axes]
    model = _reduce(full, locked)
    model.gravity = pin.Motion(np.concatenate([_gravity(path, gravity), np.zeros(3)]))
    return URDFRobot(path, robot_name or full.name or path.stem, model, axes, kinds, locked)


def from_urdf(path: str | Path, joints: Sequence[str] | None = None, gravity: Sequence[float] | None = None,
              name: str | None = None) -> System:
    """A machine from the URDF at ``path`` (``load_urdf`` for ``joints`` and ``gravity``): its axes
    are ``joints`` in that order, its parameters the standard inertial parameters of each moving body
    plus a viscous coefficient per axis (module docstring); ``name`` defaults to the URDF's robot
    name. The description states the number of base parameters (``base_parameters``)."""
    robot = load_urdf(path, joints, gravity)
    rank = structural_rank(robot.regressor(None, *robot.sample_kinematics(RANK_SAMPLES, np.random.default_rng(0))))
    return System(
        name=name or robot.name, axes=robot.axes, param_names=robot.param_names, regressor=robot.regressor,
        parameters=robot.parameters, positive=robot.positive, description=robot.description(rank),
        joint_axes=robot.joint_axes, caching=robot.caching,
    )


def urdf_robot(system: System) -> URDFRobot:
    """The ``URDFRobot`` behind a machine made by ``from_urdf``."""
    robot = getattr(system.regressor, "__self__", None)
    if not isinstance(robot, URDFRobot):
        raise ValueError(f"{system.name} is not a URDF machine (made by lcgym.systems.urdf.from_urdf)")
    return robot


def base_parameters(system: System, samples: int = RANK_SAMPLES, seed: int = 0) -> tuple[int, int]:
    """(rank, n): the number of base parameters (the structural rank of the regressor stacked over
    ``samples`` seeded random kinematics) and the number of parameters of ``system``. Positions are
    drawn within the joint limits of a URDF machine, else within +-pi [rad or m]; velocities and
    accelerations standard normal."""
    rng = np.random.default_rng(seed)
    try:
        kinematics = urdf_robot(system).sample_kinematics(samples, rng)
    except ValueError:
        shape = (samples, system.n_axes)
        kinematics = rng.uniform(-math.pi, math.pi, shape), rng.standard_normal(shape), rng.standard_normal(shape)
    return structural_rank(system.regressor(np.zeros(0), *kinematics)), len(system.param_names)


def structural_rank(X) -> int:
    """Rank of a regressor X (T, n_axes, n) stacked to (T n_axes, n) (``physics.model.column_rank``:
    round-off columns dropped, the others scaled to unit norm)."""
    return column_rank(X, RANK_TOLERANCE, ZERO_COLUMN)


def _read_joint_table(path: Path) -> tuple[str, dict[str, tuple[str, str | None]]]:
    """(robot name, {joint: (type, joint it mimics or None)}) from the XML of the URDF."""
    if not path.is_file():
        raise ValueError(f"URDF {path}: no such file")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"URDF {path} does not parse: XML error: {exc}") from None
    except OSError as exc:
        raise ValueError(f"URDF {path} cannot be read: {exc.strerror or exc}") from None
    if root.tag != "robot":
        raise ValueError(f"URDF {path} does not parse: its root element is <{root.tag}>, not <robot>")
    table = {}
    moved_by = {}  # link -> the joint whose child it is
    for joint in root.iter("joint"):
        name = joint.get("name")
        if name is None or joint.get("type") is None:
            continue  # <joint> elements inside <transmission> carry no type; urdfdom rejects broken ones below
        mimic = joint.find("mimic")
        table[name] = (joint.get("type"), mimic.get("joint") if mimic is not None else None)
        child = joint.find("child")
        if child is not None:
            moved_by[child.get("link")] = name
        _check_limits(path, name, joint.find("limit"))
    for link in root.findall("link"):
        _check_inertial(path, link.get("name", "?"), moved_by.get(link.get("name")), link.find("inertial"))
    return root.get("name", ""), table


def _check_limits(path: Path, joint: str, limit) -> None:
    """A joint's <limit>: lower <= upper, effort and velocity >= 0 (a ValueError naming the joint otherwise)."""
    if limit is None:
        return
    try:
        lower, upper = float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0))
    except ValueError:
        return  # urdfdom names a malformed number
    if lower > upper:
        raise ValueError(f"URDF {path}: joint {joint}: <limit lower={lower:g} upper={upper:g}>: lower must not exceed "
                         "upper")
    for key, unit in (("effort", "N m or N"), ("velocity", "rad/s or m/s")):
        try:
            value = float(limit.get(key, 0.0))
        except ValueError:
            continue
        if value < 0:
            raise ValueError(f"URDF {path}: joint {joint}: <limit {key}={value:g}>: a limit [{unit}] must be >= 0")


def _check_inertial(path: Path, link: str, joint: str | None, inertial) -> None:
    """A link's <inertial>: a mass >= 0 and an inertia tensor no body has refused, naming the link and
    the joint that moves it. A rigid body's inertia about its centre of mass is positive semidefinite,
    and each principal moment is at most the sum of the other two (the triangle inequality)."""
    if inertial is None:
        return
    where = f"URDF {path}: link {link}" + (f" (moved by joint {joint})" if joint else "")
    mass, tensor = inertial.find("mass"), inertial.find("inertia")
    try:
        m = float(mass.get("value")) if mass is not None else 0.0
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        i = {k: float(tensor.get(k, 0.0)) for k in keys} if tensor is not None else dict.fromkeys(keys, 0.0)
    except (TypeError, ValueError):
        return  # urdfdom names a malformed number
    if not (np.isfinite(m) and m >= 0):
        raise ValueError(f"{where}: mass {m:g} kg: a mass must be >= 0")
    inertia = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]])
    if not np.all(np.isfinite(inertia)):
        raise ValueError(f"{where}: its <inertia> holds a value that is not finite")
    moments = np.linalg.eigvalsh(inertia)
    tolerance = 1e-9 * max(float(np.abs(moments).max()), 1e-12)
    if moments[0] < -tolerance:
        raise ValueError(f"{where}: its <inertia> has a negative principal moment ({moments[0]:.3g} kg m^2): "
                         "no body has one")
    if moments[2] > moments[0] + moments[1] + tolerance:
        raise ValueError(f"{where}: its <inertia>'s principal moments {', '.join(f'{x:.3g}' for x in moments)} kg m^2 "
                         "break the triangle inequality (each at most the sum of the other two): no body has them")


def _build_model(path: Path):
    """pinocchio's model of the URDF; urdfdom's complaints (written to the C stderr) become the
    reason of the ValueError, or warnings when the model still builds."""
    with _captured_stderr() as lines:
        try:
            model = pin.buildModelFromUrdf(str(path))
        except Exception as exc:  # pinocchio raises ValueError or RuntimeError, depending on the failure
            failure = exc
        else:
            failure = None
    complaints = [ln.strip()[len("Error:"):].strip() if ln.strip().startswith("Error:") else ln.strip()
                  for ln in lines if ln.strip() and not ln.strip().startswith("at line")]
    if failure is not None:
        reason = "; ".join(complaints) or str(failure).strip() or type(failure).__name__
        raise ValueError(f"URDF {path} does not parse: {reason}")
    for text in complaints:
        warnings.warn(f"URDF {path}: {text}", stacklevel=3)
    return model


@contextmanager
def _captured_stderr():
    """Collect what C code writes to file descriptor 2 while the block runs (a list of lines)."""
    lines: list[str] = []
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield lines
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            lines.extend(tmp.read().decode(errors="replace").splitlines())


def _choose_axes(path: Path, table: dict, full, joints: Sequence[str] | None) -> list[str]:
    """The axis joints: checked against the URDF (names, types, mimic coupling)."""
    coupled = {j for j, (_, leader) in table.items() if leader is not None}
    coupled |= {leader for _, leader in table.values() if leader is not None}
    in_model = list(full.names[1:])
    movable = [j for j in in_model if table.get(j, ("",))[0] in MOVABLE]
    if joints is None:
        chosen = [j for j in movable if j not in coupled]
        if not chosen:
            raise ValueError(f"URDF {path} has no revolute, continuous or prismatic joint to make an axis "
                             f"(joints: {_listing(table)})")
        return chosen
    if isinstance(joints, str):
        joints = [joints]
    chosen = [str(j) for j in joints]
    if not chosen:
        raise ValueError(f"URDF {path}: no joints given; its movable joints are {', '.join(movable) or 'none'}")
    repeated = sorted({j for j in chosen if chosen.count(j) > 1})
    if repeated:
        raise ValueError(f"URDF {path}: joint(s) named twice: {', '.join(repeated)}")
    missing = [j for j in chosen if j not in table]
    if missing:
        raise ValueError(f"URDF {path} has no joint {', '.join(missing)}; its movable joints are {', '.join(movable) or 'none'}")
    for j in chosen:
        kind, leader = table[j]
        if kind not in MOVABLE:
            dof = f", {full.joints[full.getJointId(j)].nv} DOF" if j in in_model else ""
            raise ValueError(f"URDF {path}: joint {j} is {kind}{dof}; only 1-DOF revolute, continuous or prismatic "
                             f"joints can be axes (movable: {', '.join(movable) or 'none'})")
        if leader is not None:
            raise ValueError(f"URDF {path}: joint {j} mimics {leader} (<mimic>); a mimic joint cannot be an axis: "
                             "leave it out of the joints (it is then locked)")
        if j in coupled:
            followers = ", ".join(f for f, (_, lead) in table.items() if lead == j)
            raise ValueError(f"URDF {path}: joint {j} drives the mimic joint(s) {followers}; the URDF model does not "
                             f"couple them (pinocchio), so {j} cannot be an axis: leave it out of the joints (locked)")
    return chosen


def _listing(table: dict) -> str:
    return ", ".join(f"{j} ({kind})" for j, (kind, _) in table.items()) or "none"


def _reduce(full, locked: Sequence[str]):
    """The model with the ``locked`` joints fixed at their neutral position (clipped into limits)."""
    if not locked:
        return full.copy()
    q0 = pin.neutral(full)
    lo, hi = full.lowerPositionLimit, full.upperPositionLimit
    finite = np.isfinite(lo) & np.isfinite(hi) & (lo <= hi)
    q0[finite] = np.clip(q0[finite], lo[finite], hi[finite])
    q0 = pin.normalize(full, q0)  # keep quaternions and (cos, sin) pairs on their manifold after clipping
    return pin.buildReducedModel(full, [full.getJointId(j) for j in locked], q0)


def _gravity(path: Path, gravity) -> np.ndarray:
    if gravity is None:
        return np.array([0.0, 0.0, -9.81])
    g = np.asarray(gravity, dtype=float)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ValueError(f"URDF {path}: gravity must be 3 finite values [m/s^2], got {gravity!r}")
    return g


__all__ = ["URDFRobot", "base_parameters", "from_urdf", "load_urdf", "structural_rank", "urdf_robot"]
