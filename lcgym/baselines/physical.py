"""Physical-model feedforward: the rigid-body model (eq. 9 of paper 000) fitted by least squares."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..physics.model import PhysicalModel
from .protocol import Controller, Cost


class PhysicalFeedforward(Controller):
    """``fit`` identifies a ``PhysicalModel`` (nominal rigid body, optionally with effects) on
    training trials; ``feedforward`` evaluates it on a reference."""

    name = "physical"

    def __init__(self, model: PhysicalModel | None = None):
        self.model = model

    def fit(self, trials: Sequence) -> PhysicalFeedforward:
        model = self.model if self.model is not None else PhysicalModel(fs=trials[0].fs)
        self.model_ = model.fit(trials)
        self.cost_ = Cost()
        return self

    def feedforward(self, reference) -> np.ndarray:
        """Feedforward (T, 2) [V] for a reference (array of positions, Trial or Reference)."""
        if not hasattr(self, "model_"):
            raise RuntimeError("PhysicalFeedforward: call fit(trials) before feedforward()")
        return self.model_.predict(reference)
