"""The PGNN's settings on one machine: its table in ``System.settings["pgnn"]`` (a machine file's
``[benchmark.pgnn]``), read into ``PGNNProtocol``. Without torch: the benchmark's main process reads
them without training a network."""

from __future__ import annotations

from dataclasses import dataclass

from ... import systems
from ..protocol import machine_settings

COLLECTS = ("physical", "feedback")
COLLECT = "physical"
"""What the training data are recorded with where the machine does not say."""
CONSTRAINT_CONFIGS = 16
"""Configurations of a batch that enter R2's M(theta) term where the machine does not say (``PGNNConfig``)."""


@dataclass(frozen=True)
class PGNNProtocol:
    """The PGNN's settings on one machine. The benchmark protocol's: ``collect``, what the training
    data are recorded with ("physical": a run of the training references with the physical base's
    feedforward on; "feedback": the shared feedback-only trials); ``filter_hz``, the low-pass of u
    [Hz] (None: u as measured; ``methods.pgnn.method``). The network's on this machine
    (``PGNNConfig.for_system``): ``decimate``, every k-th sample trained on (the FlexArm's 1 kHz
    data); ``constraint_configs``, the configurations of a batch R2's M(theta) term takes (None:
    all; the IX's 2 x 2 mass matrix is cheap); and ``filter_hz`` where it is set."""

    collect: str = COLLECT
    filter_hz: float | None = None
    decimate: int = 1
    constraint_configs: int | None = CONSTRAINT_CONFIGS

    def __post_init__(self):
        if self.collect not in COLLECTS:
            raise ValueError(f"collect must be 'physical' or 'feedback', got {self.collect!r}")
        if int(self.decimate) != self.decimate or self.decimate < 1:
            raise ValueError(f"decimate must be a whole number >= 1, got {self.decimate}")

    @classmethod
    def of(cls, system: systems.System) -> PGNNProtocol:
        """The machine's settings; a key this method does not take is an error that names it."""
        return machine_settings(cls, system, "pgnn")
