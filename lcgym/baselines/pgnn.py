"""Leaderboard methods ``pgnn`` (J = J_LS + mu1 R1 + mu2 R2) and ``pgnn-ls`` (J_LS only): the
PGNN of paper 000 (``lcgym.pgnn``) trained on the shared training trials.

The leaderboard trains with one torch thread (benchmark cells run in parallel workers) and the
paper's settings otherwise; ``nn_contribution`` gives f^C for the results' ``nn_rms`` column.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .. import systems
from ..pgnn import PGNN, PGNNConfig
from .protocol import Controller, Cost


class PGNNFeedforward(Controller):
    """Method ``pgnn``: physical model + per-axis MLPs, trained with R1 and R2."""

    name = "pgnn"
    regularize = True

    def __init__(self, config: PGNNConfig | None = None):
        self.config = config

    def fit(self, trials: Sequence) -> PGNNFeedforward:
        cfg = self.config or replace(PGNNConfig.for_system(systems.of_trials(trials)), threads=1)
        cfg = replace(cfg, regularize=self.regularize)
        self.pgnn_ = PGNN(cfg, fs=trials[0].fs).fit(trials)
        self.cost_ = Cost()
        return self

    def feedforward(self, reference) -> np.ndarray:
        return self.pgnn_.predict(reference)

    def nn_contribution(self, reference) -> np.ndarray:
        return self.pgnn_.nn_contribution(reference)

    def reference_offset(self, reference) -> np.ndarray | None:
        return self.pgnn_.reference_offset(reference)


class PGNNLSFeedforward(PGNNFeedforward):
    """Method ``pgnn-ls``: the same PGNN trained with J_LS only (no R1, no R2)."""

    name = "pgnn-ls"
    regularize = False
