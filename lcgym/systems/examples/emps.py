"""The EMPS (Electro-Mechanical Positioning System) of Janot, Gautier and Brunot (2019) as an lcgym
machine: one prismatic axis ``x`` [m], a carriage driven by a ball screw, input the motor force
[N]. Its inverse dynamic model, eq. (1) of the benchmark's description, without the Coulomb
friction and offset that the diagnosis is to find:

    u = M qdd + Fv qd

M [kg] the moving mass (carriage, screw and motor rotor seen on the axis), Fv [N s/m] the viscous
friction. The nominal values (100 kg, 200 N s/m) are round guesses of the kind a datasheet gives;
the least-squares fit of the diagnosis replaces them. Data: ``lcgym.datasets.emps`` reads the
benchmark's files (``lcgym import emps`` writes them as measurement files).
"""

from __future__ import annotations

import numpy as np

from ..system import Axis, System

NOMINAL = {"M": 100.0, "Fv": 200.0}  # kg, N s/m


def emps_regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Columns of u = M qdd + Fv qd: (T, 1, 2) for kinematics (T, 1) [m, m/s, m/s^2]."""
    return np.stack([qdd, qd], axis=-1)


EMPS = System.from_regressor(
    "emps", [Axis("x", "prismatic")], NOMINAL, emps_regressor, positive=("M", "Fv"), fs=1000.0,
    description="EMPS benchmark axis (Janot, Gautier and Brunot 2019): M qdd + Fv qd, prismatic, N",
)

__all__ = ["EMPS", "NOMINAL", "emps_regressor"]
