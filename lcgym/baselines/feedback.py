"""Feedback only: no feedforward, the fixed feedback controller alone (the leaderboard's floor)."""

from __future__ import annotations

import numpy as np

from ..physics.kinematics import reference_positions
from .protocol import Controller


class FeedbackOnly(Controller):
    """Feedforward identically zero; ``fit`` learns nothing."""

    name = "feedback"

    def feedforward(self, reference) -> np.ndarray:
        """Zeros (T, n_axes) [V]."""
        return np.zeros_like(reference_positions(reference))
