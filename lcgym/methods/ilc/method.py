"""Iterative learning control: learn the feedforward of one repeated reference by running it again.

The update of trial j to j + 1, per axis, is plant-inversion ILC with a robustness filter,
f_{j+1} = Q (f_j + L e_j), computed on the whole trial in the frequency domain (FFT over the trial,
zero-padded to twice its length so that the circular wrap of the non-causal filters falls in the
padding). On a base f_0, Q acts on what is learned, f_{j+1} = f_0 + Q (f_j - f_0 + L e_j), as the
FlexArm's update does (``systems/flexarm/learning.py``): the base's own content above Q's corner stays (a velocity
loop's velocity feedforward, ``methods.loop``, whose steps Q would round off):

* A machine without a nominal feedforward structure (``System.nominal`` is None: the IX, paper
  000's machine) starts from its physical model fitted on the training trials; e = reference -
  measured angle [rad]; L = (P S)^-1, the inverse of the process sensitivity of the nominal closed
  loop of each axis (``plant.process_sensitivity``; the IX: the rigid axis P(s) = 1 / (J s^2 + D s)
  [rad/V] with J the diagonal of the nominal mass matrix at the reference's mean pose and D the
  nominal viscous coefficient, discretized with a zero-order hold and the plant's one-sample
  computation delay, and the plant's own PD + low-pass feedback C(z)). The trial's error is e_j =
  S r - P S f_j (plus what the model lacks), so with Q = 1 and an exact model e_{j+1} = e_j - P S L
  e_j = 0; Q < 1 restricts the learning to the frequencies where the model holds.
* A machine with one (the FlexArm's Basic, paper 002, eq. 16, the "LCS" of section 5.3): the
  nonlinear torque tau_nl is updated with e = e_pl, the model-following error estimated from the
  accelerometer (``nominal.run``), and L = P_lu^-1, the inverse of the nominal linear model from
  motor torque to load acceleration (``nominal.load_response``). One iteration by default, as in
  the paper.

The edges: on Basic (eq. 16) Q filters the previous feedforward too, and zero padding would filter
it as if it dropped to zero before and after the trial; the arm's tau_nl holds gravity at rest,
which Q would bend at both ends (a start-up transient, ringing after the trial). ``nominal_update``
pads tau_nl with its edge values (``frequency_update(hold_edges=True)``); the tracking-error ILC
filters only its learned correction, zero-padded (its fade-in covers the start).

Q is zero phase: the magnitude |B(w)|^2 of a Butterworth low-pass of order ``q_order`` with corner
``q_hz`` (B applied twice, as ``filtfilt`` does). ``q_hz`` trades the bandwidth of what is learned
against the model error at high frequency: the IX's drivetrain modes (15-34 Hz) are not in its
nominal model; the paper sets 20 Hz for the arm. On the IX the learned error passes a deadzone of
half an encoder count (``deadzone``: else the propeller's quantization is learned as error and the
feedforward wanders), and the update fades in over the first 0.25 s (the plant holds the first
sample's feedforward through its pre-roll; a learned change there moves the initial state, which
L's linear model does not describe). Every trial's error norm is recorded (``history_``); when it
grows three trials in a row and stands 1.5x above the best trial, ``ILCDiverged`` is raised with
the history (as it is by a trial that drives the plant out of its safe range). Measurements behind
these choices: docs/methods/ilc.md, "Design choices and what they measured".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ... import systems
from ...fitted import check_fitted, is_fitted
from ...systems import SimulationDiverged
from ...systems.learning import ILCDiverged, best_trial, check_divergence, held_edges, q_filter, rms
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


def frequency_update(f: np.ndarray, e: np.ndarray, inverse: np.ndarray, q: np.ndarray, gain: float,
                     hold_edges: bool = False) -> np.ndarray:
    """Q (f + gain L e) per column of (T, A) signals; ``inverse`` (n_freq, A) the response of L and
    ``q`` (n_freq,) the one of Q on the rfft grid of 2 T samples (zero padding against wrap-around).

    ``hold_edges``: f is padded with its own edge values instead of zeros (the last sample for the
    first half of the padding, the first sample for the second half, where the wrap-around lands),
    i.e. f held before and after the trial. A feedforward that holds a torque at rest (the arm's
    tau_nl carries gravity, up to 5 N m) would otherwise be filtered as if it dropped to zero at both
    ends: Q then bends it by up to half its edge value over Q's settling time (about 50 ms at 20 Hz),
    and the plant answers that change of torque with a start-up transient and residual vibration
    after the trial (module docstring, "the edges"). e stays zero-padded: outside the trial there is
    no error to learn."""
    T = f.shape[0]
    if hold_edges:
        f = held_edges(f)
    F = np.fft.rfft(f, n=2 * T, axis=0)
    E = np.fft.rfft(e, n=2 * T, axis=0)
    return np.fft.irfft(q[:, None] * (F + gain * inverse * E), n=2 * T, axis=0)[:T]


def learning_filters(plant, reference, config: ILCConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """L = (P S)^-1 and Q on the rfft grid of 2 T samples, and the fade-in (T, 1) of the update, for
    tracking-error learning on ``reference`` (module docstring)."""
    T = reference.n_samples
    inverse = 1.0 / plant.process_sensitivity(2 * T, reference.positions)
    fade = np.clip(np.arange(T) / (FADE_IN * plant.fs), 0.0, 1.0)[:, None]
    return inverse, q_filter(2 * T, plant.fs, config.q_hz, config.q_order), fade


def nominal_update(nominal, tau_nl: np.ndarray, e_pl: np.ndarray, fs: float, config: ILCConfig) -> np.ndarray:
    """Eq. (16) (and eq. (17) with a predicted e_pl): Q_u [tau_nl + P_lu^-1 e_pl] (T, n_axes) [N m],
    P_lu the ``nominal`` structure's load response. Its zero-frequency bin is 0 (a constant torque
    leaves no load acceleration), so a constant e_pl asks for no torque there: the inverse's bin is 0.
    tau_nl is filtered with its edges held (module docstring, "The edges")."""
    T = tau_nl.shape[0]
    response = nominal.load_response(2 * T, fs)
    inverse = np.divide(1.0, response, out=np.zeros_like(response), where=np.abs(response) > 0.0)
    inverse[0] = 0.0
    return frequency_update(tau_nl, e_pl, inverse, q_filter(2 * T, fs, config.arm_q_hz, config.q_order), config.arm_gain,
                            hold_edges=True)


def deadzone(e: np.ndarray, width) -> np.ndarray:
    """e with ``width`` taken off its magnitude (zero inside +-width), per column: an encoder reads
    the error only to within half a count, and learning the quantization as if it were error
    makes the feedforward wander from trial to trial (the IX propeller: 0.0669 deg counts)."""
    return np.sign(e) * np.maximum(np.abs(e) - width, 0.0)


FADE_IN = 0.25  # s: the tracking-error update's fade-in at the start of a trial (``_learn_tracking``)
MIN_JUDGED = 2
"""ILC transfer keeps its correction only where it lowers the error of at least this many training
references it did not learn on: with the quick bench's one other, a correction that lowered it
there ended 1.10-1.57x worse than the base on the FlexArm's validation references."""


class _FailedTrial(Exception):
    """A learning trial left the plant's safe range (``IterativeLearningControl._run_trial``)."""


def short(exc: Exception, limit: int = 160) -> str:
    """An exception's message on one line of at most ``limit`` characters."""
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


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
        self.nominal_ = self.system_.nominal
        self.learned_, self.history_, self.true_history_, self.best_ = {}, {}, {}, {}
        self.failed_: dict[str, str] = {}  # reference -> why its learning stopped early (``_run_trial``)
        self.cost_ = Cost()
        return self

    def learn(self, plant, reference) -> IterativeLearningControl:
        check_fitted(self, "learned_", hint="call fit(trials) before learn()")
        if self.base == "basic":
            learn = self._learn_model_following
        elif self.system_.learning is not None:  # the machine's own law (the FlexArm's)
            learn = self._learn_arm
        else:
            learn = self._learn_tracking
        learned, history, true_history, used = learn(plant, reference)
        self.learned_[reference.name] = learned
        self.history_[reference.name], self.true_history_[reference.name] = np.array(history), np.array(true_history)
        self.cost_.plant_trials += used
        self.note_ = self._base_kept_note()
        return self

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

    def _learn_tracking(self, plant, reference):
        """Plant-inversion ILC on the measured tracking error, from the fitted physical model; where no
        trial is best on every axis, one more run of each axis's best (``_per_axis_best``)."""
        cfg = self.config_
        f0 = self._start(reference)[0]
        f = f0
        # the plant holds the first sample's feedforward through its pre-roll: a learned change there
        # would move the initial state, which L's linear model does not describe (the error at the
        # start then alternates from trial to trial); the update fades in over FADE_IN seconds
        inverse, q, fade = learning_filters(plant, reference, cfg)
        history, true_history, tried = [], [], []
        used = 0
        for j in range(cfg.trials + 1):  # the last trial measures the last update
            used += 1
            try:
                trial = self._run_trial(plant, reference, f, j)
            except _FailedTrial:
                break
            tried.append(f)
            history.append(rms(trial.error))
            true_history.append(rms(trial.ref - np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])))
            try:
                check_divergence(history, reference.name)
            except ILCDiverged:
                self.failed_[reference.name] = f"the error grew three trials in a row (to trial {j})"
                break
            if j < cfg.trials:
                e = deadzone(trial.error, 0.5 * np.asarray(plant.encoder_resolution))
                f = f0 + fade * frequency_update(f - f0, e, inverse, q, cfg.gain)
        scored = self._scored(f0.shape[1])
        mixed = _per_axis_best(tried, history)
        if mixed is not None:  # each axis's column from the trial it did best in, measured once more
            used += 1
            try:
                trial = self._run_trial(plant, reference, mixed, "mixing each axis's best")
            except _FailedTrial:
                pass
            else:
                tried.append(mixed)
                history.append(rms(trial.error))
                true_history.append(rms(trial.ref - np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])))
        best = self.best_[reference.name] = best_trial(history, scored)
        return {"feedforward": tried[best]}, history, true_history, used

    def _run_trial(self, plant, reference, f: np.ndarray, trial) -> object:
        """A learning trial's run. One that leaves the plant's safe range is the method's failed trial:
        recorded in ``failed_`` (the row's note says so) and raised as ``_FailedTrial``, so that the
        learning stops there and keeps its best safe trial. The base's own run (trial 0) failing is
        the cell's failure: raised as it is."""
        try:
            return plant.run(reference, f)
        except SimulationDiverged as exc:
            if trial == 0:
                raise
            self.failed_[reference.name] = f"trial {trial} left the plant's safe range ({short(exc)})"
            raise _FailedTrial from None

    def _learn_model_following(self, plant, reference):
        """Paper 002's LCS iterated on Basic: its tau_nl updated with the model-following error
        (eq. 16), ``arm_trials`` updates, each measured, the best kept."""
        cfg, nominal = self.config_, self.nominal_
        basic = nominal.compute(reference.positions, reference.fs)
        update = np.zeros(reference.positions.shape)
        history, true_history, tried = [], [], []
        for j in range(cfg.arm_trials + 1):
            trial = nominal.run(plant, reference, update)
            tried.append(update)
            e_pl = np.column_stack([trial.extra[f"e_pl_{a}"] for a in trial.axes])
            history.append(rms(e_pl))
            true_history.append(rms(np.column_stack([trial.extra[f"e_pl_true_{a}"] for a in trial.axes])))
            check_divergence(history, reference.name)
            if j < cfg.arm_trials:
                # eq. (16): tau_nl,k+1 = Q_u [tau_nl,k + P_lu^-1 e_pl,k]; tau_nl,0 is Basic's
                update = nominal_update(nominal, basic["tau_nl"] + update, e_pl, plant.fs, cfg) - basic["tau_nl"]
        best = self.best_[reference.name] = best_trial(history, self._scored(update.shape[1]))
        return ({"feedforward": basic["tau_ff"] + tried[best], "offset": basic["reference_offset"]}, history,
                true_history, cfg.arm_trials + 1)

    def _learn_arm(self, plant, reference):
        """The machine's own learning law (``System.learning``: the FlexArm on its physical model)."""
        law = self.system_.learning

        f0, o0 = self._start(reference)
        # each joint's loop model carries the load inertia of the fitted arm (payload included) at the
        # reference's mean pose: the nominal M_n lacks the payload, and the static EE error rose with it
        inertia = law.load_inertia(self.base_.model_.fitted_params.arm(), reference.positions)
        learned, history, true_history, used = law.learn_on_base(plant, reference, f0, o0, self.nominal_,
                                                             trials=self.config_.arm_trials, inertia=inertia)
        self.best_[reference.name] = learned.pop("trial")
        learned.pop("candidates")
        return learned, history, true_history, used

    def _learned(self, reference) -> dict:
        if reference.name not in getattr(self, "learned_", {}):
            raise RuntimeError(f"ILC: no feedforward learned for {reference.name}; call learn(plant, reference) first")
        return self.learned_[reference.name]

    def feedforward(self, reference) -> np.ndarray:
        return self._learned(reference)["feedforward"]

    def reference_offset(self, reference) -> np.ndarray | None:
        return self._learned(reference).get("offset")


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

    def _learn_model_following(self, plant, reference):
        cfg, nominal = self.config_, self.nominal_
        basic = nominal.compute(reference.positions, reference.fs)
        trial = nominal.run(plant, reference)
        e_pl = np.column_stack([trial.extra[f"e_pl_{a}"] for a in trial.axes])
        history = [rms(e_pl)]
        true_history = [rms(np.column_stack([trial.extra[f"e_pl_true_{a}"] for a in trial.axes]))]
        # eq. (16): tau_nl,1 = Q_u [tau_nl,0 + P_lu^-1 e_pl,0]
        update = nominal_update(nominal, basic["tau_nl"], e_pl, plant.fs, cfg) - basic["tau_nl"]
        return {"feedforward": basic["tau_ff"] + update, "offset": basic["reference_offset"]}, history, true_history, 1


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
            self.correction_ = learned["feedforward"] - f0
            offset = learned.get("offset")
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


def _per_axis_best(tried: list[np.ndarray], history: list[np.ndarray]) -> np.ndarray | None:
    """The feedforward whose column of each axis is that of the trial the axis was measured best in;
    None where one trial is best on every axis (nothing to mix). On a coupled machine the learning
    may lower some axes and raise another (the rail arm: the elbow 10x down, the rail at its
    encoder's floor 2x up): the mix keeps each axis's best, and ``best_trial`` keeps it only where
    its own run, measured, is no worse than the base on any axis."""
    best = np.argmin(np.asarray(history), axis=0)
    if np.all(best == best[0]):
        return None
    return np.column_stack([tried[k][:, a] for a, k in enumerate(best)])


def _fitted(c: np.ndarray, T: int) -> np.ndarray:
    """A (T0, n) signal cut to T samples, or held at its last value to T."""
    return c[:T] if c.shape[0] >= T else np.vstack([c, np.repeat(c[-1:], T - c.shape[0], axis=0)])
