"""Example robot descriptions shipped with lcgym (package data).

``two_link.urdf`` (in ``systems/two_link/``: the benchmark machine TwoLink-v0 is built on it): a
planar two-link arm (joints ``shoulder`` and ``elbow`` about parallel horizontal axes, links 0.45 m
and 0.40 m, 4.2 kg and 2.6 kg) with a 0.35 kg gripper finger on a prismatic joint ``finger`` that
lcgym locks unless it is named as an axis.

``cobot6.urdf``: a six-joint collaborative arm with the UR5's joint layout, link lengths and masses
(joints ``shoulder_pan_joint``, ``shoulder_lift_joint``, ``elbow_joint``, ``wrist_1_joint`` to
``wrist_3_joint``) and a 0.8 kg tool; 42 of its 66 parameters are identifiable from joint torques.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def two_link_urdf() -> Path:
    """Path of the example two-link arm's URDF (``lcgym.systems.urdf.from_urdf`` reads it)."""
    return Path(str(resources.files("lcgym.systems.two_link").joinpath("two_link.urdf")))


def cobot6_urdf() -> Path:
    """Path of the example six-joint arm's URDF."""
    return Path(str(resources.files(__name__).joinpath("cobot6.urdf")))


# The cobot's joint friction as the studies and benchmarks hide it (a UR5's Coulomb levels are 5-10
# N m on the big joints, 1-2 on the wrists): Coulomb level [N m] and smoothing eps [rad/s] per joint.
# The URDF holds no rotor inertia, so the last wrist's link alone (7e-4 kg m^2) would make a 5 mrad/s
# step need 272 RK4 steps per 1 ms sample; these smoothings keep URDFPlant at 17.
COBOT6_FRICTION = ((6.0, 0.005), (6.0, 0.005), (4.0, 0.005), (1.5, 0.01), (1.5, 0.01), (1.0, 0.08))

__all__ = ["COBOT6_FRICTION", "cobot6_urdf", "two_link_urdf"]
