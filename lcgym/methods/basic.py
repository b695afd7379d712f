"""Paper 002's "Basic": a machine's nominal feedforward structure with the nominal parameters, no
fit (the FlexArm's ``systems.flexarm.nominal.BasicFeedforward``: F1 and r_q,0 as the motor reference
offset, tau_ff,0 = tau_ln + tau_nl,0 as the motor torque). The reference that the paper's
learning methods improve on; it runs on the machines that have such a structure (``systems``)."""

from __future__ import annotations

import numpy as np

from .. import systems as machines
from ..fitted import check_fitted
from .loop import loop_feedforward, machine_loop
from .protocol import Controller, Cost, given_system


class BasicArmFeedforward(Controller):
    """Method ``basic``: nothing to fit; feedforward and reference offset of the nominal structure
    (``nominal``, default the ``System.nominal`` of the machine ``system``: a ``System`` or a spec
    for ``systems.get``, such as "flexarm")."""

    name = "basic"
    relative_cost = 0.0  # seconds of a quick cell (protocol.Controller)
    systems = ("flexarm",)  # the machines with a nominal structure

    def __init__(self, nominal=None, system: machines.System | str | None = None):
        self.nominal = nominal
        self.system = system

    def fit(self, trials) -> BasicArmFeedforward:
        self.loop_ = None
        self.model_ = None  # a learner's base model (``methods.bases``): none, the nominal structure is fixed
        if self.nominal is not None:
            self.nominal_ = self.nominal
        else:
            self.system_ = given_system(self, alternative=", or the structure, BasicArmFeedforward(nominal=...)")
            self.nominal_ = self.system_.nominal
            self.loop_ = machine_loop(self.system_)
        if self.nominal_ is None:
            raise ValueError("basic: the machine has no nominal feedforward structure (System.nominal)")
        self.cost_ = Cost()
        return self

    def _parts(self, reference) -> dict:
        check_fitted(self, "nominal_", hint="call fit(trials) before feedforward()")
        return self.nominal_.compute(reference.positions, reference.fs)

    def feedforward(self, reference) -> np.ndarray:
        """tau_ff,0 (T, 6) [N m, motor side], plus the loop's term (``loop.loop_feedforward``; zero on
        the FlexArm, whose PIDs act on the error alone), the same rule as the physical base's."""
        return self._parts(reference)["tau_ff"] + loop_feedforward(self.loop_, reference)

    def reference_offset(self, reference) -> np.ndarray:
        """The motor reference offset of F1 and r_q,0, as load-side angle (T, 6) [rad]."""
        return self._parts(reference)["reference_offset"]
