"""What a learning method may ask of a machine's loop: the learning-law contract, and the law every
machine without one of its own offers.

A learning method (``methods.ilc``, ``methods.rbf_expert``) learns on a plant through the law the
plant offers, ``plant.learning_law(base, config)`` (``systems.plant.Plant``), and imports no machine's
module. A law is the machine's answer to three questions a learner asks of its closed loop:

* what the learner's error is (``LearningLoop.measure``: the error as the machine's sensors measure
  it, its RMS per history column, and the simulation's true error for reports),
* how a feedforward changes that error (``LearningLoop.update``: the inverse of the machine's loop
  model, behind a robustness filter Q), and
* what an error predictor learns and how a predicted error enters the feedforward
  (``model_error``, ``predicted``: paper 002's eq. 17).

``LearningLaw`` is the machine's, immutable: one per plant, base and configuration.
``LearningLoop`` is its scratch workspace for one reference (the filters of that reference's
length, its start), in the manner of pinocchio's model and data. A loop's *state* is what it
iterates on (a feedforward, a feedforward with an offset, paper 002's update of tau_nl);
``signals(state)`` is what the plant then runs: the feedforward and the load-side reference offset.

Laws: ``TrackingLaw`` here (plant-inversion ILC on the measured tracking error, for every plant
with a process sensitivity and an encoder: the IX, a URDF machine); the FlexArm's two in
``systems/flexarm/learning.py`` (on a base with its accelerometer, and paper 002's eq. 16 on Basic).

Shared by every law: the zero-phase Q filter, the frequency-domain update, the error RMS per column,
divergence detection, and the one rule that picks the trial to keep (``best_trial``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np


class Signals(NamedTuple):
    """What a plant runs beside its reference: the feedforward (T, n_axes) [V, N m or N] and the
    load-side reference offset (T, n_axes) [rad] where the machine has that channel (None: none)."""

    feedforward: np.ndarray
    offset: np.ndarray | None


class Measured(NamedTuple):
    """One trial as a learner sees it: ``row``, the RMS of each history column (the axes' measured
    errors, then any column the machine adds: the FlexArm's end-effector acceleration error);
    ``true_row``, the same of the simulation's true error (reports only; NaN where it is not had);
    ``error``: what the law's ``update`` takes."""

    row: np.ndarray
    true_row: np.ndarray
    error: Any


class ILCDiverged(RuntimeError):
    """The ILC error grew three trials in a row; the message holds the error history."""


class LearningLoop(ABC):
    """One reference on one plant under a ``LearningLaw`` (module docstring). ``start``: the state
    of the base (trial 0)."""

    start: Any

    @abstractmethod
    def run(self, state):
        """The closed-loop trial of the reference with ``state``'s signals (``SimulationDiverged``
        where the plant leaves its safe range)."""

    @abstractmethod
    def measure(self, trial, state) -> Measured:
        """What the machine measures of ``trial``, run with ``state``."""

    @abstractmethod
    def update(self, state, measured: Measured):
        """The next state from this one and its trial's measurement."""

    @abstractmethod
    def signals(self, state) -> Signals:
        """The feedforward and offset the plant runs with ``state``."""

    @abstractmethod
    def model_error(self, trial, state) -> np.ndarray:
        """The error (T, n_axes) an error predictor learns from a trial run with ``state``."""

    @abstractmethod
    def predicted(self, error: np.ndarray) -> Signals:
        """The start's signals after one update with a predicted ``model_error`` (T, n_axes)."""

    def columns(self, scored: Sequence[int]) -> list[int]:
        """The history columns ``best_trial`` judges, given the scored axes."""
        return list(scored)

    def mix(self, tried: list, history: list[np.ndarray]):
        """A state that takes each axis from the trial it was measured best in, or None (nothing to
        mix, or a machine whose axes do not separate)."""
        return None


class LearningLaw(ABC):
    """A machine's learning law on one plant (module docstring). ``trials``: the learning updates
    a learner makes on this machine by default (ILC: trials + 1 plant runs)."""

    plant: Any
    trials: int

    @abstractmethod
    def loop(self, reference, start: Signals, model=None) -> LearningLoop:
        """The workspace of ``reference`` from the base's ``start`` signals; ``model``: the base's
        fitted physical model where it has one (a law may take its loop model from it)."""

    def base_errors(self, references: Sequence, starts: Sequence[Signals]) -> list[np.ndarray]:
        """``model_error`` of each reference run once with its start's signals."""
        out = []
        for reference, start in zip(references, starts, strict=True):
            loop = self.loop(reference, start)
            out.append(loop.model_error(loop.run(loop.start), loop.start))
        return out


# ----------------------------------------------------------------------------- shared pieces

def q_filter(n: int, fs: float, q_hz: float, order: int) -> np.ndarray:
    """Zero-phase Q on the rfft grid of n samples: |Butterworth(order, q_hz)|^2."""
    w = np.fft.rfftfreq(n, 1.0 / fs)
    return 1.0 / (1.0 + (w / q_hz) ** (2 * order))


def rms(e: np.ndarray) -> np.ndarray:
    """RMS per column (T, A) -> (A,)."""
    return np.sqrt(np.mean(np.square(e), axis=0))


GROWTH = 1.01  # a trial counts as worse when its error RMS exceeds the previous one's by 1 %
NOISE_BAND = 1.5  # ... and the run diverges only once it is also this far above its best trial


def check_divergence(history: list[np.ndarray], name: str) -> None:
    """Raise ``ILCDiverged`` when the error (RMS over all columns) grew three trials in a row and now
    exceeds the best trial by ``NOISE_BAND``: three small rises in a row near the noise floor are not
    a divergence."""
    total = [float(np.sqrt(np.mean(np.square(h)))) for h in history]
    if (len(total) >= 4 and all(total[-k] > GROWTH * total[-k - 1] for k in (1, 2, 3))
            and total[-1] > NOISE_BAND * min(total)):
        raise ILCDiverged(f"ILC on {name} diverges: the error grew three trials in a row; "
                          f"RMS per trial {[f'{h:.3g}' for h in total]}")


def best_trial(history: Sequence[np.ndarray], columns: Sequence[int], tolerance: float = 0.0) -> int:
    """The trial to keep, by what the sensors measured (``history``: per trial, the RMS of each
    column, trial 0 the base). Eligible: trial 0, and every trial no ``columns`` entry of which
    exceeds trial 0's by more than ``tolerance`` (a fraction); of those, the lowest sum of ratios to
    trial 0 over ``columns``: unit-free, so a rail's metres, a joint's radians and an end-effector's
    m/s^2 weigh alike. The result is never measured worse than the base."""
    h = np.asarray(history, dtype=float)[:, list(columns)]
    ratio = h / np.maximum(h[0], 1e-300)
    eligible = np.all(ratio <= 1.0 + tolerance, axis=1)
    eligible[0] = True
    return int(np.argmin(np.where(eligible, ratio.sum(axis=1), np.inf)))


def held_edges(x: np.ndarray) -> np.ndarray:
    """x (T, A) padded to 2 T with its edge values (the last one for the first half of the padding,
    the first for the second, where the circular wrap lands; ``frequency_update``)."""
    T = x.shape[0]
    return np.concatenate([x, np.repeat(x[-1:], T // 2, axis=0), np.repeat(x[:1], T - T // 2, axis=0)])


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
    after the trial. e stays zero-padded: outside the trial there is no error to learn."""
    T = f.shape[0]
    if hold_edges:
        f = held_edges(f)
    F = np.fft.rfft(f, n=2 * T, axis=0)
    E = np.fft.rfft(e, n=2 * T, axis=0)
    return np.fft.irfft(q[:, None] * (F + gain * inverse * E), n=2 * T, axis=0)[:T]


def deadzone(e: np.ndarray, width) -> np.ndarray:
    """e with ``width`` taken off its magnitude (zero inside +-width), per column: an encoder reads
    the error only to within half a count, and learning the quantization as if it were error
    makes the feedforward wander from trial to trial (the IX propeller: 0.0669 deg counts)."""
    return np.sign(e) * np.maximum(np.abs(e) - width, 0.0)


def true_error(trial) -> np.ndarray:
    """Reference minus the simulation's true positions (``extra["load_<axis>"]``), (T, n_axes)."""
    return trial.ref - np.column_stack([trial.extra[f"load_{a}"] for a in trial.axes])


# ----------------------------------------------------------------------------- the tracking-error law

FADE_IN = 0.25  # s: the tracking-error update's fade-in at the start of a trial


class TrackingLaw(LearningLaw):
    """Plant-inversion learning on the measured tracking error, for a plant with a nominal
    ``process_sensitivity(n, positions)`` (P S per axis on the rfft grid of n samples) and an
    ``encoder_resolution`` per axis (the IX, a URDF machine). Per axis, from the base's f_0,

        f_{j+1} = f_0 + w Q (f_j - f_0 + L deadzone(e_j)),   L = (P S)^-1,

    with e = reference - encoder [rad or m]: with Q = 1 and an exact model e_{j+1} = 0; Q < 1
    keeps the learning to the frequencies where the model holds. The deadzone is half an encoder
    count; w fades the update in over ``FADE_IN`` s (the plant holds the first sample's feedforward
    through its pre-roll: a learned change there moves the initial state, which L's linear model
    does not describe, and the error at the start then alternates from trial to trial). Q acts on
    what is learned: the base's content above Q's corner stays. ``config``: ``trials``, ``q_hz``,
    ``q_order``, ``gain`` (``methods.ilc.ILCConfig``)."""

    def __init__(self, plant, config):
        self.plant = plant
        self.config = config
        self.trials = config.trials

    def loop(self, reference, start: Signals, model=None) -> TrackingLoop:
        return TrackingLoop(self, reference, start)

    def base_errors(self, references, starts) -> list[np.ndarray]:
        return [t.error for t in self.plant.run(list(references), [s.feedforward for s in starts])]


class TrackingLoop(LearningLoop):
    """``TrackingLaw``'s workspace of one reference; its state is the feedforward (T, n_axes)."""

    def __init__(self, law: TrackingLaw, reference, start: Signals):
        self.law, self.reference = law, reference
        self.start, self.offset = np.asarray(start.feedforward, dtype=float), start.offset
        plant, cfg, T = law.plant, law.config, reference.n_samples
        self.inverse = 1.0 / plant.process_sensitivity(2 * T, reference.positions)
        self.q = q_filter(2 * T, plant.fs, cfg.q_hz, cfg.q_order)
        self.fade = np.clip(np.arange(T) / (FADE_IN * plant.fs), 0.0, 1.0)[:, None]

    def run(self, state):
        return self.law.plant.run(self.reference, state)

    def measure(self, trial, state) -> Measured:
        return Measured(rms(trial.error), rms(true_error(trial)), trial.error)

    def update(self, state, measured: Measured):
        e = deadzone(measured.error, 0.5 * np.asarray(self.law.plant.encoder_resolution))
        return self.start + self.fade * frequency_update(state - self.start, e, self.inverse, self.q, self.law.config.gain)

    def signals(self, state) -> Signals:
        return Signals(state, self.offset)

    def model_error(self, trial, state) -> np.ndarray:
        return trial.error

    def predicted(self, error: np.ndarray) -> Signals:
        f0 = self.start
        return Signals(f0 + self.fade * frequency_update(np.zeros_like(f0), error, self.inverse, self.q,
                                                         self.law.config.gain), self.offset)

    def mix(self, tried: list, history: list[np.ndarray]):
        """The feedforward whose column of each axis is that of the trial the axis was measured best
        in; None where one trial is best on every axis. On a coupled machine the learning may lower
        some axes and raise another (the rail arm: the elbow 10x down, the rail at its encoder's
        floor 2x up): the mix keeps each axis's best, and ``best_trial`` keeps it only where its
        own run, measured, is no worse than the base on any axis."""
        best = np.argmin(np.asarray(history), axis=0)
        if np.all(best == best[0]):
            return None
        return np.column_stack([tried[k][:, a] for a, k in enumerate(best)])
