"""Iterative learning control: learn the feedforward of one repeated reference by running it again.

ILC runs the reference on the plant, measures its error, updates the feedforward, and runs it
again (``iterate``); it keeps the trial its sensors measured best, never one measured worse than
its base (``systems.learning.best_trial``). What the error is and how a feedforward changes it
belong to the machine: ILC asks the plant for its learning law (``plant.learning_law(base,
config)``, ``systems.learning``) and iterates that law's loop, the same code on every machine:

* the IX and a URDF machine (``TrackingLaw``): plant-inversion ILC on the measured tracking error,
  f_{j+1} = f_0 + Q (f_j - f_0 + L e_j), L = (P S)^-1 the inverse of each axis's nominal process
  sensitivity (the IX: the rigid axis P(s) = 1 / (J s^2 + D s) [rad/V] at the reference's mean
  pose, the plant's one-sample delay and its PD + low-pass C(z)), computed on the whole trial in
  the frequency domain (zero-padded to twice its length so that the circular wrap of the
  non-causal filters falls in the padding). With Q = 1 and an exact model e_{j+1} = e_j - P S L
  e_j = 0; Q < 1 restricts the learning to the frequencies where the model holds;
* the FlexArm on its physical model (``ArmLaw``): the torque learned from the motor encoders'
  error through the loop model P_m S with the fitted arm's load inertia, each trial judged by the
  load error estimated from encoders and accelerometer and the end-effector acceleration error;
* the FlexArm on Basic (``ModelFollowingLaw``, paper 002's eq. 16, the "LCS" of section 5.3):
  tau_nl updated with e_pl, the model-following error from the accelerometer, L = P_lu^-1.

Q is zero phase: |B(w)|^2 of a Butterworth low-pass of order ``q_order`` with corner ``q_hz`` (B
applied twice, as ``filtfilt`` does). ``q_hz`` trades the bandwidth of what is learned against the
model error at high frequency: the IX's drivetrain modes (15-34 Hz) are not in its nominal model;
the paper sets 20 Hz for the arm (``arm_q_hz``). Every trial's error norm is recorded
(``history_``); a trial that leaves the plant's safe range, or an error that grows three trials in a
row and stands 1.5x above the best trial, ends the learning at its best trial so far, and the row's
note says so. Measurements behind these choices: docs/methods/ilc.md, "Design choices and what they
measured".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ... import systems
from ...fitted import check_fitted, is_fitted
from ...systems import SimulationDiverged
from ...systems.learning import ILCDiverged, Measured, Signals, best_trial, check_divergence
from ..bases import ReferenceMemo, base_controller
from ..protocol import DEFAULT_BASE, Controller, Cost, given_system
from ..safeguard import Safeguard, dropped_note, mixed, scored_axes


@dataclass(frozen=True)
class ILCConfig:
    """trials: learning trials per reference on a machine without a nominal structure (the IX, a
    URDF machine); arm_trials: on the FlexArm (paper 002's LCS is one, ``PaperLCS``); q_hz [Hz],
    q_order: the zero-phase Q filter (the arm: ``arm_q_hz``, the paper's 20 Hz); gain: scales L
    (1: full inversion, as eq. 16). The IX's 5 Hz, order 4, is a
    measured choice (``studies/ilc_ix.py``): at 12 Hz the learning diverges on some references
    (the drivetrain modes at 15-34 Hz are not in L's model), and a gain below 1 leaves a larger
    error where Q < 1."""

    trials: int = 10
    arm_trials: int = 8
    q_hz: float = 5.0
    arm_q_hz: float = 20.0
    q_order: int = 4
    gain: float = 1.0
    arm_gain: float = 1.0


MIN_JUDGED = 2
"""ILC transfer keeps its correction only where it lowers the error of at least this many training
references it did not learn on: with the quick bench's one other, a correction that lowered it
there ended 1.10-1.57x worse than the base on the FlexArm's validation references."""


def short(exc: Exception, limit: int = 160) -> str:
    """An exception's message on one line of at most ``limit`` characters."""
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass
class Learned:
    """What ``iterate`` learned on one reference: the kept trial's ``signals``; per trial the
    measured ``history`` and the ``true_history`` (``LearningLoop.measure``'s rows, trial 0 the
    base); the plant runs ``used``; the index ``best`` of the trial kept; ``failed``: why the
    learning stopped early ("" where it did not); ``tried``: every trial's state."""

    signals: Signals
    history: list
    true_history: list
    used: int
    best: int
    failed: str = ""
    tried: list = field(default_factory=list)


def iterate(loop, reference, trials: int, scored) -> Learned:
    """ILC on one reference through a machine's learning loop (``systems.learning.LearningLoop``):
    trial 0 runs the base, each later one the update of the one before, every one measured
    (``trials`` updates; the last trial measures the last update). Where the machine's axes
    separate and no trial is best on every axis, one more run of each axis's best (``loop.mix``).
    A trial that leaves the plant's safe range, or a diverging history (``check_divergence`` on
    the axes' columns), ends the learning at the best trial so far; the base's own run failing
    is raised as it is. The trial kept: ``best_trial`` on ``loop.columns(scored)``."""
    state, n_axes = loop.start, reference.positions.shape[1]
    tried, history, true_history = [], [], []
    used, failed = 0, ""

    def measured_run(state, label) -> Measured | None:
        """The trial of ``state`` measured and recorded; None where it left the safe range."""
        nonlocal failed
        try:
            trial = loop.run(state)
        except SimulationDiverged as exc:
            if label == 0:
                raise
            failed = f"trial {label} left the plant's safe range ({short(exc)})"
            return None
        measured = loop.measure(trial, state)
        tried.append(state)
        history.append(measured.row)
        true_history.append(measured.true_row)
        return measured

    for j in range(trials + 1):
        used += 1
        measured = measured_run(state, j)
        if measured is None:
            break
        try:
            check_divergence([h[:n_axes] for h in history], reference.name)
        except ILCDiverged:
            failed = f"the error grew three trials in a row (to trial {j})"
            break
        if j < trials:
            state = loop.update(state, measured)
    mix = loop.mix(tried, history)
    if mix is not None:  # each axis's column from the trial it did best in, measured once more
        used += 1
        measured_run(mix, "mixing each axis's best")
    best = best_trial(history, loop.columns(scored))
    return Learned(loop.signals(tried[best]), history, true_history, used, best, failed, tried)


class IterativeLearningControl(Controller):
    """Method ``ilc``: learns on each evaluation reference itself (``learn``), starting from its base
    (``base``, ``bases``: the machine's physical model fitted on the training trials, the default;
    or the FlexArm's nominal structure "basic", where it updates tau_nl as eq. 16 does), and keeps
    its best trial as measured by the machine's sensors (``best_trial``: never one measured worse
    than the base on a scored axis). ``history_[name]``: (trials, n_axes) error RMS per trial and
    axis as measured, trial 0 the base (tracking error [rad]; the arm: e_pl from the accelerometer
    [rad/s^2]); ``true_history_[name]``: the same for the simulation's true error where the trials
    carry it (IX: ``load_<axis>``; arm: ``e_pl_true_<joint>``), for reports only; ``best_[name]``:
    the trial kept. ``system``: the machine (a ``System`` or a spec for ``systems.get``)."""

    name = "ilc"
    relative_cost = 10.0  # seconds of a quick cell (protocol.Controller)
    uses_plant = True
    learns_on_scored_references = True

    def __init__(self, config: ILCConfig | None = None, system: systems.System | str | None = None,
                 budget: float = 1.0, base: str = DEFAULT_BASE):
        self.config = config
        self.system = system
        self.budget = budget
        self.base = base

    @property
    def config_(self) -> ILCConfig:
        """The configuration it learns with: the one given, its trials scaled by ``budget`` (at least
        one; ``protocol.build_method``)."""
        cfg = self.config or ILCConfig()
        if self.budget == 1.0:
            return cfg
        return replace(cfg, trials=max(1, math.ceil(cfg.trials * self.budget)),
                       arm_trials=max(1, math.ceil(cfg.arm_trials * self.budget)))

    def fit(self, trials) -> IterativeLearningControl:
        self.system_ = given_system(self)
        self.base_ = base_controller(self.system_, self.base).fit(trials)
        self.memo_ = ReferenceMemo()
        self.learned_, self.history_, self.true_history_, self.best_ = {}, {}, {}, {}
        self.failed_: dict[str, str] = {}  # reference -> why its learning stopped early (``_run_trial``)
        self.cost_ = Cost()
        return self

    def learn(self, plant, reference) -> IterativeLearningControl:
        check_fitted(self, "learned_", hint="call fit(trials) before learn()")
        law = plant.learning_law(self.base, self.config_)
        loop = law.loop(reference, Signals(*self._start(reference)), self.base_.model_)
        out = self._iterate(loop, reference, law.trials)
        name = reference.name
        self.learned_[name], self.best_[name] = out.signals, out.best
        self.history_[name], self.true_history_[name] = np.array(out.history), np.array(out.true_history)
        if out.failed:
            self.failed_[name] = out.failed
        self.cost_.plant_trials += out.used
        self.note_ = self._base_kept_note()
        return self

    def _iterate(self, loop, reference, trials: int) -> Learned:
        return iterate(loop, reference, trials, self._scored(reference.positions.shape[1]))

    def _base_kept_note(self) -> str:
        """The row's note where no learning trial beat the base on some references (trial 0 kept:
        the base acts there, whatever the trials cost), and where a learning trial failed, else ""."""
        kept = [name for name, best in self.best_.items() if best == 0]
        notes = []
        if kept:
            notes.append(f"{self.name}: on {len(kept)} of {len(self.best_)} references no learning trial measured better "
                         f"than its base on every scored axis; the base acts there")
        if self.failed_:
            first = next(iter(self.failed_.items()))
            notes.append(f"{self.name}: on {len(self.failed_)} of {len(self.best_)} references the learning stopped early "
                         f"and its best safe trial acts ({first[0]}: {first[1]})")
        return "; ".join(notes)

    def _scored(self, n_axes: int) -> list[int]:
        return scored_axes(self.system_, n_axes)

    def _start(self, reference) -> tuple[np.ndarray, np.ndarray | None]:
        """The base's (feedforward, load-side reference offset or None) of ``reference``."""
        return self.memo_.get("base", reference, lambda: (np.asarray(self.base_.feedforward(reference), dtype=float),
                                                          self.base_.reference_offset(reference)))

    def _learned(self, reference) -> Signals:
        check_fitted(self, "learned_", hint="call fit(trials) before learn()")
        if reference.name not in self.learned_:
            raise RuntimeError(f"ILC: no feedforward learned for {reference.name}; call learn(plant, reference) first")
        return self.learned_[reference.name]

    def feedforward(self, reference) -> np.ndarray:
        return self._learned(reference).feedforward

    def reference_offset(self, reference) -> np.ndarray | None:
        return self._learned(reference).offset


class PaperLCS(IterativeLearningControl):
    """Method ``paper002-lcs``: paper 002's LCS as the paper ran it (section 5.3): one ILC iteration
    of eq. (16) on Basic, the updated feedforward returned unmeasured (no trial is kept or
    compared). What ``lcgym leaderboard --share-of paper002-lcs --base basic`` measures Table 6's
    shares against."""

    name = "paper002-lcs"
    base = "basic"  # fixed: the paper's
    relative_cost = 3.0  # seconds of a quick cell (protocol.Controller)
    systems = ("flexarm",)

    def __init__(self, config: ILCConfig | None = None, system: systems.System | str | None = None):
        super().__init__(config, system, base="basic")

    @property
    def config_(self) -> ILCConfig:
        """The configuration given, with one iteration (the paper's)."""
        return replace(self.config or ILCConfig(), arm_trials=1)

    def _iterate(self, loop, reference, trials: int) -> Learned:
        """Eq. (16) once on trial 0's measurement, the update returned unmeasured (the paper's): ``best``
        is 1, the update, a trial never run, so ``history_`` holds trial 0 alone."""
        trial = loop.run(loop.start)
        measured = loop.measure(trial, loop.start)
        update = loop.update(loop.start, measured)
        return Learned(loop.signals(update), [measured.row], [measured.true_row], 1, best=1, tried=[loop.start, update])


class ILCTransfer(IterativeLearningControl):
    """Method ``ilc-transfer``: ILC learns once, on the first training reference, and its learned
    correction (the learned feedforward and reference offset minus the base's) is then added, as
    the time signal it is, to the base's of any other reference (cut, or held at its last value, to
    that reference's length). What ILC learns belongs to one trajectory; this shows how little of it
    carries over (paper 002, section 1). It cannot measure a reference before it is scored on it:
    the training-reference safeguard (``safeguard``) keeps the correction only on the axes where it
    lowers the error of every other training reference, and only where there are ``MIN_JUDGED`` of
    them (its plant runs counted); ``note_`` says what it dropped."""

    name = "ilc-transfer"
    relative_cost = 3.0  # seconds of a quick cell (protocol.Controller)
    learns_on_scored_references = False  # it learns on a training reference only

    def fit(self, trials) -> ILCTransfer:
        super().fit(trials)
        from ...references import references_of

        self.training_ = references_of(trials)
        self.source_ = self.training_[0]
        self.note_ = ""
        return self

    def learn(self, plant, reference) -> ILCTransfer:
        if not is_fitted(self, "kept_"):
            super().learn(plant, self.source_)
            f0, o0 = self._start(self.source_)
            learned = self._learned(self.source_)
            self.correction_ = learned.feedforward - f0
            offset = learned.offset
            self.offset_correction_ = None if offset is None else offset - (0.0 if o0 is None else o0)
            # judged on the training references it did not learn on (the source alone where there is no other)
            others = self.training_[1:] or self.training_
            guard = Safeguard(self.system_)
            self.kept_ = guard.choose(plant, others, self._start, self._transferred)
            self.cost_.plant_trials += guard.trials_
            self.note_ = dropped_note(self.name, self.kept_, self.source_.axes, guard.references_worse_, len(others),
                                      diverged=guard.diverged_)
            if len(self.training_) - 1 < MIN_JUDGED and self.kept_.any():
                # one other reference cannot tell a correction that carries over from a coincidence
                self.kept_ = np.zeros_like(self.kept_)
                self.note_ = (f"{self.name}: correction dropped (judged on {len(self.training_) - 1} training reference(s) "
                              f"it did not learn on; it needs {MIN_JUDGED}); the base acts alone")
        return self

    def _transferred(self, reference) -> tuple[np.ndarray, np.ndarray | None]:
        """The base's (feedforward, offset) plus the correction, fitted to ``reference``'s length."""
        f0, o0 = self._start(reference)
        f = f0 + _fitted(self.correction_, reference.n_samples)
        if self.offset_correction_ is None:
            return f, o0
        return f, (0.0 if o0 is None else o0) + _fitted(self.offset_correction_, reference.n_samples)

    def _signals(self, reference) -> tuple[np.ndarray, np.ndarray | None]:
        check_fitted(self, "kept_", hint="call learn(plant, reference) first")
        return self.memo_.get("signals", reference,
                              lambda: mixed(self._start(reference), self._transferred(reference), self.kept_))

    def feedforward(self, reference) -> np.ndarray:
        return self._signals(reference)[0]

    def reference_offset(self, reference) -> np.ndarray | None:
        return self._signals(reference)[1]


def _fitted(c: np.ndarray, T: int) -> np.ndarray:
    """A (T0, n) signal cut to T samples, or held at its last value to T."""
    return c[:T] if c.shape[0] >= T else np.vstack([c, np.repeat(c[-1:], T - c.shape[0], axis=0)])
