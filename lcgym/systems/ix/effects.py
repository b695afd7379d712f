"""The IX's own effect: friction of a guidance whose normal force follows the C-arm's pose.

Its formula reads both axes' angles (the propeller's q2 and the roll's q3), so it belongs to the
IX's geometry, not to the library of ``physics.effects``; the plant's kernel
(``systems/ix/kernel.py``) and the model evaluate the same ``normal_force_basis``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba.extending import register_jitable

from ...physics.candidates import Candidate
from ...physics.effects import Effect, smooth_sign
from ...physics.grids import Search

DEG = math.pi / 180.0


@register_jitable
def normal_force_basis(s2, c2, c3):
    """Configuration dependence of a guidance's normal force: (|cos q2|, |cos q2| cos q3, |sin q2|).

    Takes s2 = sin q2, c2 = cos q2, c3 = cos q3 (propeller and roll angles). The gravity load on
    rollers scales with the magnitude of the gravity components through the guidance; the roll
    body's offset CoM modulates it with the roll angle.
    """
    a2 = np.abs(c2)
    return a2, a2 * c3, np.abs(s2)


@dataclass(frozen=True)
class PositionDependentFriction(Effect):
    """Friction whose level follows the guidance's normal force:

        (c_cos |cos q2| + c_cos_roll |cos q2| cos q3 + c_sin |sin q2|) tanh(qd / eps)

    c_* [V] linear, eps [rad/s] nonlinear; q2, q3 are the propeller and roll angles.
    """

    c_cos: float = 0.0
    c_cos_roll: float = 0.0
    c_sin: float = 0.0
    eps: float = 1e-3
    name: ClassVar[str] = "position_dependent_friction"
    search: ClassVar[Search] = Search("friction", {"eps": tuple(np.array([0.05, 0.5, 2.0]) * DEG)})
    linear: ClassVar[tuple[str, ...]] = ("c_cos", "c_cos_roll", "c_sin")
    nonlinear: ClassVar[tuple[str, ...]] = ("eps",)

    def _columns(self, q, qd, qdd, loads):
        sgn = smooth_sign(self._v(qd), self.eps)
        basis = normal_force_basis(np.sin(q[..., 0]), np.cos(q[..., 0]), np.cos(q[..., 1]))
        return tuple(b * sgn for b in basis)


CANDIDATES = (Candidate.of(PositionDependentFriction),)
