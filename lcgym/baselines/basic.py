"""FlexArm only: paper 002's "Basic", the nominal feedforward structure of its Fig. 1 with the
nominal parameters, no fit (``physics.arm_nominal.BasicFeedforward``: F1 and r_q,0 as the motor
reference offset, tau_ff,0 = tau_ln + tau_nl,0 as the motor torque). The reference that the
paper's learning methods improve on."""

from __future__ import annotations

import numpy as np

from ..physics.arm_nominal import BasicFeedforward
from .protocol import Controller, Cost


class BasicArmFeedforward(Controller):
    """Method ``basic``: nothing to fit; feedforward and reference offset of the nominal structure."""

    name = "basic"
    systems = ("flexarm",)

    def __init__(self, nominal: BasicFeedforward | None = None):
        self.nominal = nominal

    def fit(self, trials) -> BasicArmFeedforward:
        self.cost_ = Cost()
        return self

    def _parts(self, reference) -> dict:
        return (self.nominal or BasicFeedforward()).compute(reference.positions, reference.fs)

    def feedforward(self, reference) -> np.ndarray:
        """tau_ff,0 (T, 6) [N m, motor side]."""
        return self._parts(reference)["tau_ff"]

    def reference_offset(self, reference) -> np.ndarray:
        """The motor reference offset of F1 and r_q,0, as load-side angle (T, 6) [rad]."""
        return self._parts(reference)["reference_offset"]
