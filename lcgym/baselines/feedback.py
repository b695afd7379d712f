"""Feedback only: no feedforward, the fixed feedback controller alone (the leaderboard's floor)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..physics.kinematics import reference_positions


class FeedbackOnly:
    """Feedforward identically zero; ``fit`` learns nothing."""

    name = "feedback"

    def fit(self, trials: Sequence) -> FeedbackOnly:
        return self

    def feedforward(self, reference) -> np.ndarray:
        """Zeros (T, n_axes) [V]."""
        return np.zeros_like(reference_positions(reference))
