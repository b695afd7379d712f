"""Example robot descriptions shipped with lcgym (package data).

``two_link.urdf``: a planar two-link arm (joints ``shoulder`` and ``elbow`` about parallel
horizontal axes, links 0.45 m and 0.40 m, 4.2 kg and 2.6 kg) with a 0.35 kg gripper finger on a
prismatic joint ``finger`` that lcgym locks unless it is named as an axis.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def two_link_urdf() -> Path:
    """Path of the example two-link arm's URDF (``lcgym.systems.urdf.from_urdf`` reads it)."""
    return Path(str(resources.files(__name__).joinpath("two_link.urdf")))


__all__ = ["two_link_urdf"]
