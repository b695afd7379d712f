"""Physical-model feedforward: the machine's physical model fitted by least squares (IX: the rigid
body of paper 000, eq. 9; FlexArm: the motor-side rigid-joint model of ``systems.flexarm.model``,
with its joint-torsion reference offset; any other machine: its ``System.physical_model``), plus
what the machine's loop needs to track exactly (``loop.loop_feedforward``: a velocity loop's
velocity feedforward, zero where the loop acts on the error alone)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .. import systems
from ..fitted import check_fitted
from ..physics.model import PhysicalModel
from .loop import loop_feedforward, machine_loop
from .protocol import Controller, Cost, given_system


class PhysicalFeedforward(Controller):
    """``fit`` identifies the physical model of the machine (``system``: a ``System`` or a spec for
    ``systems.get``, such as "ix"; or the ``model`` given) on training trials; ``feedforward``
    evaluates it on a reference, with the loop's own term (module docstring), ``reference_offset``
    gives the model's reference offset where it has one (the arm), else None. Learned: ``model_``,
    ``loop_`` (the machine's plant whose loop it feeds, ``loop.machine_loop``; None: none)."""

    name = "physical"
    relative_cost = 0.3  # seconds of a quick cell (protocol.Controller)

    def __init__(self, model: PhysicalModel | None = None, system: systems.System | str | None = None):
        self.model = model
        self.system = system

    def fit(self, trials: Sequence) -> PhysicalFeedforward:
        if self.model is not None:
            model = self.model
        else:
            self.system_ = given_system(self, alternative=", or the model, PhysicalFeedforward(model=...)")
            model = self.system_.physical_model(fs=trials[0].fs)
        self.model_ = model.fit(trials)
        self.loop_ = machine_loop(self.model_.system)
        self.cost_ = Cost()
        return self

    def feedforward(self, reference) -> np.ndarray:
        """Feedforward (T, n_axes) [V for the IX, N m for the arm] for a reference (array of
        positions, Trial or Reference): the model's input, plus the loop's term."""
        return self._model().predict(reference) + loop_feedforward(self.loop_, reference)

    def reference_offset(self, reference) -> np.ndarray | None:
        """Reference offset (T, n_axes) [rad] of the model (the arm's joint torsion), or None."""
        model = self._model()
        return model.reference_offset(reference) if hasattr(model, "reference_offset") else None

    def _model(self) -> PhysicalModel:
        check_fitted(self, "model_", hint="call fit(trials) before feedforward()")
        return self.model_
