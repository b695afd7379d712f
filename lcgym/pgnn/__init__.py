"""Physics-guided neural network feedforward of paper 000 (sections III-IV): the physical model in
parallel with one MLP per axis, trained with the orthogonal-projection regularizer R1 and the
physics penalty R2 (Algorithm 1)."""

from .estimator import PGNN
from .training import PGNNConfig

__all__ = ["PGNN", "PGNNConfig"]
