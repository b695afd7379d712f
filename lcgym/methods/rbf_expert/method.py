"""Method ``rbf-expert``: paper 002's NN prediction feedforward with expert logic (section 2.3).

Training, once (the paper's factory stage; the plant runs counted in ``cost_``): each training
reference is run with the starting feedforward and its error recorded; the predictor
(``rbf_expert.predictor``) learns that error as a function of the reference. Operation, for any new
reference, with no run and no sensor: the predicted error e_hat replaces the measured one in one
update of the machine's learning law (``LearningLoop.predicted``, the plant's ``learning_law``):

* on the FlexArm's Basic (``rbf-expert@basic``), eq. (17): tau_nl,1 = Q_u [tau_nl,0 + P_lu^-1
  e_hat], e_hat the predicted model-following error [rad/s^2] learned from the accelerometer
  estimate e_pl of Basic runs; Q_u zero phase at 20 Hz (``ILCConfig.arm_q_hz``);
* on the FlexArm's physical model, eq. (17) around that base's feedforward (``ArmLaw``);
* on the IX or a URDF machine: f_1 = f_0 + Q (P S)^-1 e_hat, e_hat the predicted tracking error
  [rad or m] learned from runs with the fitted physical model's feedforward; L, Q (5 Hz) and the
  fade-in are those of the tracking-error ILC (``TrackingLaw``).

Base (``bases``): the machine's fitted physical model by default; the FlexArm's Basic for eq. (17)
as the paper writes it. A training-reference safeguard (``safeguard``, as RL's) keeps the predicted
correction only on the axes where it lowers the tracking error on every training reference;
``note_`` says what it dropped. ``paper002-nnp`` is the paper's protocol: on Basic, no safeguard.

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

from ... import systems
from ...fitted import check_fitted, is_fitted
from ...systems.learning import Signals
from ..bases import ReferenceMemo, base_controller
from ..ilc.method import ILCConfig
from ..protocol import DEFAULT_BASE, Controller, Cost, given_system
from ..safeguard import Safeguard, dropped_note, mixed
from .influence import task_influence
from .predictor import RBFExpertConfig, RBFExpertPredictor

MOVING_TOL = 1e-6  # rad/s: a joint whose reference velocity never exceeds this gets no networks


class RBFExpertFeedforward(Controller):
    """``fit(trials)`` keeps the training references and fits the base (``base``: "physical", the
    default, or "basic" on the FlexArm); ``learn(plant, reference)`` trains the predictor on the
    first call (and runs the safeguard); ``feedforward(reference)`` applies the predicted update.
    Learned: ``predictor_``, ``law_`` (the learning law of the plant trained on: its loop defines L), ``outside_``,
    ``kept_`` (per axis: the correction acts there), ``note_``, ``cost_``. ``system``: the machine (a
    ``System`` or a spec for ``systems.get``, such as "flexarm")."""

    name = "rbf-expert"
    relative_cost = 1.3  # seconds of a quick cell (protocol.Controller)
    uses_plant = True
    safeguard = True

    def __init__(self, config: RBFExpertConfig | None = None, learning: ILCConfig | None = None,
                 system: systems.System | str | None = None, base: str = DEFAULT_BASE):
        self.config = config
        self.learning = learning
        self.system = system
        self.base = base

    def fit(self, trials) -> RBFExpertFeedforward:
        from ...references import references_of

        self.system_ = given_system(self)
        self.base_ = base_controller(self.system_, self.base).fit(trials)
        self.memo_ = ReferenceMemo()
        self.training_ = references_of(trials)
        self.cost_ = Cost()
        self.outside_ = {}
        self.note_ = ""
        return self

    def learn(self, plant, reference) -> RBFExpertFeedforward:
        check_fitted(self, "training_", hint="call fit(trials) before learn()")
        if not is_fitted(self, "predictor_"):
            self.law_ = plant.learning_law(self.base, self.learning or ILCConfig())
            self._train(plant)
            self.kept_ = np.ones(reference.positions.shape[1], dtype=bool)
            if self.safeguard:
                guard = Safeguard(self.system_)
                self.kept_ = guard.choose(plant, self.training_, self._start, self._predicted)
                self.cost_.plant_trials += guard.trials_
                self.note_ = dropped_note(self.name, self.kept_, self.training_[0].axes, guard.references_worse_,
                                          len(self.training_), diverged=guard.diverged_)
        return self

    def _start(self, reference) -> tuple[np.ndarray, np.ndarray | None]:
        """The base's (feedforward, load-side reference offset or None)."""
        return self.memo_.get("base", reference, lambda: (np.asarray(self.base_.feedforward(reference), dtype=float),
                                                          self.base_.reference_offset(reference)))

    def _train(self, plant) -> None:
        refs = self.training_
        errors = self.law_.base_errors(refs, [Signals(*self._start(r)) for r in refs])
        phi = task_influence(refs, None if self.system_.joint_axes is None else self.system_.joint_axes())
        v = np.concatenate([r.velocities for r in refs])
        joints = tuple(int(j) for j in np.flatnonzero(np.abs(v).max(axis=0) > MOVING_TOL))
        self.predictor_ = RBFExpertPredictor(phi, joints, self.config).fit(refs, errors)
        self.cost_.plant_trials += len(refs)

    def predict(self, reference) -> np.ndarray:
        """e_hat (T, n): the predicted error of ``reference`` (arm: e_pl [rad/s^2]; IX: tracking [rad])."""
        check_fitted(self, "predictor_", hint="call learn(plant, reference) first (it trains the predictor)")
        e_hat = self.predictor_.predict(reference)
        self.outside_[reference.name] = dict(self.predictor_.outside_share_)
        return e_hat

    def _predicted(self, reference) -> tuple[np.ndarray, np.ndarray | None]:
        """(feedforward, offset) of the base updated once with the predicted error (the machine's
        learning law: ``LearningLoop.predicted``)."""
        e_hat = self.predict(reference)
        return tuple(self.law_.loop(reference, Signals(*self._start(reference))).predicted(e_hat))

    def _signals(self, reference) -> tuple[np.ndarray, np.ndarray | None]:
        check_fitted(self, "kept_", hint="call learn(plant, reference) first (it trains the predictor)")
        if self.kept_.all():
            return self.memo_.get("signals", reference, lambda: self._predicted(reference))
        return self.memo_.get("signals", reference,
                              lambda: mixed(self._start(reference), self._predicted(reference), self.kept_))

    def feedforward(self, reference) -> np.ndarray:
        return self._signals(reference)[0]

    def reference_offset(self, reference) -> np.ndarray | None:
        return self._signals(reference)[1]


class PaperNNP(RBFExpertFeedforward):
    """Method ``paper002-nnp``: paper 002's NN prediction with expert logic as the paper ran it: on
    Basic, eq. (17) applied as predicted, no safeguard."""

    name = "paper002-nnp"
    base = "basic"  # fixed: the paper's (and Table 3's four experts, ``RBFExpertConfig.cruise_and_rest`` off)
    systems = ("flexarm",)
    safeguard = False

    def __init__(self, config: RBFExpertConfig | None = None, learning: ILCConfig | None = None,
                 system: systems.System | str | None = None):
        super().__init__(config or RBFExpertConfig(cruise_and_rest=False), learning, system, base="basic")
