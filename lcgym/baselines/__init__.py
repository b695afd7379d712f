"""Baseline feedforward controllers.

Each has ``name``, ``fit(trials)`` (learn offline from measured trials; may do nothing) and
``feedforward(reference) -> (T, n_axes)`` (the signal to apply). The full controller protocol,
with ``learn(plant, reference)`` and cost accounting, comes with the benchmark runner.
"""

from .feedback import FeedbackOnly
from .physical import PhysicalFeedforward

CONTROLLERS = {c.name: c for c in (FeedbackOnly, PhysicalFeedforward)}

__all__ = ["CONTROLLERS", "FeedbackOnly", "PhysicalFeedforward"]
