"""The FlexArm's own effect: an unknown payload at the flange, seen through the arm's kinematics."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from ...physics.candidates import Candidate
from ...physics.effects import Effect
from ...physics.grids import Search


@dataclass(frozen=True)
class Payload(Effect):
    """FlexArm: an unknown rigid body fixed to the flange, seen in one joint's motor torque.

    Its 10 standard inertial parameters in frame 6 (``systems.flexarm.dynamics``: m [kg], m c
    [kg m], inertia about the frame's origin [kg m^2]) add to link 6's; the torque is linear in
    them: the joint's row of link 6's regressor columns (``systems.flexarm.motor.link_columns``,
    motor side). Fitted per joint, each joint sees the payload through its own row (the shared 10
    parameters are what the benchmark's physical model identifies with all inertial parameters free).
    """

    m: float = 0.0
    mx: float = 0.0
    my: float = 0.0
    mz: float = 0.0
    Ixx: float = 0.0
    Ixy: float = 0.0
    Ixz: float = 0.0
    Iyy: float = 0.0
    Iyz: float = 0.0
    Izz: float = 0.0
    name: ClassVar[str] = "payload"
    search: ClassVar[Search] = Search("inertia")
    linear: ClassVar[tuple[str, ...]] = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")
    positive: ClassVar[tuple[str, ...]] = ("m",)

    def _columns(self, q, qd, qdd, loads):
        from .motor import link_columns

        return tuple(link_columns(5, q, qd, qdd)[:, self._i(), :].T)


CANDIDATES = (Candidate.of(Payload),)
