"""Feedback only: no feedforward, the fixed feedback controller alone (the leaderboard's floor)."""

from __future__ import annotations

import numpy as np

from .. import systems
from ..physics.kinematics import reference_positions
from .protocol import Controller


class FeedbackOnly(Controller):
    """Feedforward identically zero; ``fit`` learns nothing. ``system`` is accepted like every
    method's (the protocol hands it) and not needed."""

    name = "feedback"
    relative_cost = 0.0  # seconds of a quick cell (protocol.Controller)

    def __init__(self, system: systems.System | str | None = None):
        self.system = system

    def feedforward(self, reference) -> np.ndarray:
        """Zeros (T, n_axes) [V]."""
        return np.zeros_like(reference_positions(reference))
