"""The plant contract: what a learning method's ``learn(plant, reference)`` may use.

A plant is a machine's closed loop as a learner meets it (the bench holds it: ``Bench.plant``).
Every plant offers its sample rate, its axes, its input limit, closed-loop runs (with a load-side
reference offset where it has that channel), and the learning
law of its machine (``systems.learning``): the error its sensors measure, the inverse of its loop
model, what an error predictor learns. A learning method written against this contract runs on
every machine; it never reads a machine's own attributes (its gains, its accelerometer's offset):
those stay behind the law. Plants: ``ix/plant.py``, ``flexarm/plant.py``, ``urdf_plant.py``
(``docs/layout.md``, "What a learning method may ask of a machine").
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ..data import Trial
from .learning import LearningLaw, TrackingLaw


@runtime_checkable
class Plant(Protocol):
    """fs [Hz]; axes: the axis names, in the order of every (T, n_axes) signal; u_max: the input
    limit [V, N m or N] (one value, or one per axis)."""

    fs: float
    axes: tuple[str, ...]

    @property
    def u_max(self) -> float | np.ndarray: ...

    def run(self, reference, feedforward=None) -> Trial:
        """The closed-loop trial of ``reference`` (a ``references.Reference``) with ``feedforward``
        (T, n_axes) (None: feedback only); ``SimulationDiverged`` where the plant leaves its safe
        range."""

    def run_with_offset(self, reference, feedforward, offset) -> Trial:
        """``run`` with a load-side reference offset (T, n_axes) [rad] moving the reference (a base's
        or a learner's: the FlexArm's joint torsion); a plant without that channel says so
        (ValueError)."""

    def learning_law(self, base: str, config) -> LearningLaw:
        """The machine's learning law for a learner on ``base`` (``methods.bases``: "physical",
        "basic") with ``config`` (``methods.ilc.ILCConfig``: its trials and Q filters)."""


class EncoderLoop:
    """What a plant whose loop closes on its encoder's position offers a learner (the IX's, a URDF
    plant's): no reference-offset channel, and ``TrackingLaw``, learning on the measured tracking
    error through its ``process_sensitivity`` and ``encoder_resolution``, on any base."""

    def run_with_offset(self, reference, feedforward, offset) -> Trial:
        raise ValueError(f"{type(self).__name__} has no reference-offset channel (its loop closes on the encoder); "
                         "give the feedforward alone, plant.run(reference, feedforward)")

    def learning_law(self, base: str, config) -> TrackingLaw:
        return TrackingLaw(self, config)
