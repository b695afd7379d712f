"""Example robot descriptions shipped with lcgym (package data).

``two_link.urdf``: a planar two-link arm (joints ``shoulder`` and ``elbow`` about parallel
horizontal axes, links 0.45 m and 0.40 m, 4.2 kg and 2.6 kg) with a 0.35 kg gripper finger on a
prismatic joint ``finger`` that lcgym locks unless it is named as an axis.

``cobot6.urdf``: a six-joint collaborative arm with the UR5's joint layout, link lengths and masses
(joints ``shoulder_pan_joint``, ``shoulder_lift_joint``, ``elbow_joint``, ``wrist_1_joint`` to
``wrist_3_joint``) and a 0.8 kg tool; 42 of its 66 parameters are identifiable from joint torques.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def two_link_urdf() -> Path:
    """Path of the example two-link arm's URDF (``lcgym.systems.urdf.from_urdf`` reads it)."""
    return Path(str(resources.files(__name__).joinpath("two_link.urdf")))


def cobot6_urdf() -> Path:
    """Path of the example six-joint arm's URDF."""
    return Path(str(resources.files(__name__).joinpath("cobot6.urdf")))


__all__ = ["cobot6_urdf", "two_link_urdf"]
