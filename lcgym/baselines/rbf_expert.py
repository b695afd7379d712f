"""Method ``rbf-expert``: paper 002's NN prediction feedforward with expert logic (section 2.3).

Training, once (the paper's factory stage; the plant runs counted in ``cost_``): each training
reference is run with the starting feedforward and its error recorded; the predictor
(``rbf_expert.predictor``) learns that error as a function of the reference. Operation, for any new
reference, with no run and no sensor: the predicted error e_hat replaces the measured one in one
plant-inversion update,

* a machine with a nominal feedforward structure (``System.nominal``: the FlexArm, its home), eq.
  (17): tau_nl,1 = Q_u [tau_nl,0 + P_lu^-1 e_hat], starting from Basic (tau_nl,0, r_q of eq. 12),
  e_hat the predicted model-following error [rad/s^2] learned from the accelerometer estimate e_pl
  of Basic runs; Q_u zero phase at 20 Hz (``ILCConfig.arm_q_hz``);
* a machine without one (the IX): f_1 = Q [f_0 + (P S)^-1 e_hat], starting from the fitted
  physical model's feedforward, e_hat the predicted tracking error [rad] learned from runs with
  that feedforward; L, Q (5 Hz) and the fade-in are those of the tracking-error ILC
  (``ilc.learning_filters``).

The motion influence Phi comes from the machine's joint axes at its reference pose
(``System.joint_axes``, ``influence.task_influence``): on the arm the entries of eq. (25), on the IX
the 2 x 2 identity (the two axes are perpendicular).

The same update with the measured instead of the predicted error is one iteration of ILC (the LCS
of paper 002); ``studies/rbf_expert_arm.py`` compares the two (Table 6).
``outside_[reference]``: per predicted joint, the share of the reference's active samples outside
the training data (the safety rule of ``rbf_expert.network``).
"""

from __future__ import annotations

import numpy as np

from .. import systems
from ..rbf_expert.influence import task_influence
from ..rbf_expert.predictor import RBFExpertConfig, RBFExpertPredictor
from .ilc import ILCConfig, frequency_update, learning_filters, nominal_update
from .protocol import Controller, Cost, given_system

MOVING_TOL = 1e-6  # rad/s: a joint whose reference velocity never exceeds this gets no networks


class RBFExpertFeedforward(Controller):
    """``fit(trials)`` keeps the training references (and fits the physical model where the machine
    has no nominal structure);
    ``learn(plant, reference)`` trains the predictor on the first call; ``feedforward(reference)``
    applies the predicted update. Learned: ``predictor_``, ``plant_`` (the one trained on: its
    loop defines L), ``outside_``, ``cost_``. ``system``: the machine (a ``System`` or a spec for
    ``systems.get``, such as "flexarm")."""

    name = "rbf-expert"
    relative_cost = 1.3  # seconds of a quick cell (protocol.Controller)
    uses_plant = True

    def __init__(self, config: RBFExpertConfig | None = None, learning: ILCConfig | None = None,
                 system: systems.System | str | None = None):
        self.config = config
        self.learning = learning
        self.system = system

    def fit(self, trials) -> RBFExpertFeedforward:
        from ..references import references_of
        from .physical import PhysicalFeedforward

        self.system_ = given_system(self)
        self.nominal_ = self.system_.nominal
        self.start_ = PhysicalFeedforward(system=self.system_).fit(trials) if self.nominal_ is None else None
        self.training_ = references_of(trials)
        self.cost_ = Cost()
        self.outside_ = {}
        return self

    def learn(self, plant, reference) -> RBFExpertFeedforward:
        if not hasattr(self, "training_"):
            raise RuntimeError("rbf-expert: call fit(trials) before learn()")
        if not hasattr(self, "predictor_"):
            self.plant_ = plant
            self._train(plant)
        return self

    def _train(self, plant) -> None:
        refs = self.training_
        if self.nominal_ is not None:
            errors = []
            for r in refs:
                tr = self.nominal_.run(plant, r)
                errors.append(np.column_stack([tr.extra[f"e_pl_{a}"] for a in tr.axes]))
        else:
            errors = [t.error for t in plant.run(refs, [self.start_.feedforward(r) for r in refs])]
        phi = task_influence(refs, None if self.system_.joint_axes is None else self.system_.joint_axes())
        v = np.concatenate([r.velocities for r in refs])
        joints = tuple(int(j) for j in np.flatnonzero(np.abs(v).max(axis=0) > MOVING_TOL))
        self.predictor_ = RBFExpertPredictor(phi, joints, self.config).fit(refs, errors)
        self.cost_.plant_trials += len(refs)

    def predict(self, reference) -> np.ndarray:
        """e_hat (T, n): the predicted error of ``reference`` (arm: e_pl [rad/s^2]; IX: tracking [rad])."""
        if not hasattr(self, "predictor_"):
            raise RuntimeError("rbf-expert: call learn(plant, reference) first (it trains the predictor)")
        e_hat = self.predictor_.predict(reference)
        self.outside_[reference.name] = dict(self.predictor_.outside_share_)
        return e_hat

    def feedforward(self, reference) -> np.ndarray:
        e_hat = self.predict(reference)
        learning = self.learning or ILCConfig()
        if self.nominal_ is not None:
            basic = self.nominal_.compute(reference.positions, reference.fs)
            return basic["tau_ff"] - basic["tau_nl"] + nominal_update(self.nominal_, basic["tau_nl"], e_hat, reference.fs,
                                                                      learning)
        f0 = np.asarray(self.start_.feedforward(reference), dtype=float)
        inverse, q, fade = learning_filters(self.plant_, reference, learning)
        return f0 + fade * (frequency_update(f0, e_hat, inverse, q, learning.gain) - f0)

    def reference_offset(self, reference) -> np.ndarray | None:
        return None if self.nominal_ is None else self.nominal_.reference_offset(reference)
