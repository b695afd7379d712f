"""What a learning method may ask of a machine beyond its plant's runs, and what every learning law
shares.

A machine with a learning law of its own (the FlexArm: its loop model, its load-error estimate from
the encoders and the accelerometer, its best-trial rule; ``systems/flexarm/learning.py``) offers it
as ``System.learning`` (a ``LearningLaw``); the learning methods (``methods.ilc``,
``methods.rbf_expert``) call it there and import no machine's module. A machine without one
(``learning is None``: the IX, a URDF machine) is learned by the methods' plant-inversion law, from
the plant's ``process_sensitivity`` and ``encoder_resolution``.

Shared by every law (``methods.ilc``: the IX's, a URDF machine's and paper 002's LCS; the FlexArm's):
the zero-phase Q filter, the error RMS per axis, divergence detection and the choice of the trial
to keep."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LearningLaw:
    """A machine's own learning law (``System.learning``), as functions of its module:
    ``learn_on_base(plant, reference, base_feedforward, base_offset, nominal, trials=, inertia=)`` (ILC
    from a base: the kept trial's feedforward and offset, the measured and true histories, the
    plant trials used), ``load_inertia(fitted_arm_params, positions)`` (the loop model's load
    inertia at a reference's mean pose), ``model_following_error(plant, trial, reference, nominal,
    feedforward, offset)`` (what an error predictor learns) and ``predicted_update(nominal,
    base_feedforward, base_offset, predicted_error, fs, gains)`` (the update a predicted error
    enters)."""

    learn_on_base: Callable
    load_inertia: Callable
    model_following_error: Callable
    predicted_update: Callable


class ILCDiverged(RuntimeError):
    """The ILC error grew three trials in a row; the message holds the error history."""


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
    """Raise ``ILCDiverged`` when the error (RMS over all axes) grew three trials in a row and now
    exceeds the best trial by ``NOISE_BAND``: three small rises in a row near the noise floor are not
    a divergence."""
    total = [float(np.sqrt(np.mean(np.square(h)))) for h in history]
    if (len(total) >= 4 and all(total[-k] > GROWTH * total[-k - 1] for k in (1, 2, 3))
            and total[-1] > NOISE_BAND * min(total)):
        raise ILCDiverged(f"ILC on {name} diverges: the error grew three trials in a row; "
                          f"RMS per trial {[f'{h:.3g}' for h in total]}")


def best_trial(history: Sequence[np.ndarray], scored: Sequence[int]) -> int:
    """The trial to keep: among those measured no worse than trial 0 (the base) on any ``scored`` axis,
    the one of the lowest RMS over those axes; trial 0 where none is better. ``history``: per trial,
    the measured error RMS per axis."""
    h = np.asarray(history)[:, list(scored)]
    eligible = np.flatnonzero((h <= h[0]).all(axis=1))
    return int(eligible[np.argmin(np.sqrt(np.mean(np.square(h[eligible]), axis=1)))])


def held_edges(x: np.ndarray) -> np.ndarray:
    """x (T, A) padded to 2 T with its edge values (the last one for the first half of the padding,
    the first for the second, where the circular wrap lands; ``ilc.frequency_update``)."""
    T = x.shape[0]
    return np.concatenate([x, np.repeat(x[-1:], T // 2, axis=0), np.repeat(x[:1], T - T // 2, axis=0)])
