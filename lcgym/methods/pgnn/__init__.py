"""Method ``pgnn``: the physics-guided neural network feedforward of paper 000 (sections III-IV),
the physical model in parallel with one MLP per axis, trained with the orthogonal-projection
regularizer R1 and the physics penalty R2 (Algorithm 1).

``method`` (the leaderboard methods ``pgnn`` and ``pgnn-ls`` and their protocol) -> ``estimator``
(``PGNN``: fit on measured trials, predict feedforward) -> ``training`` (``PGNNConfig``, Algorithm
1) -> ``objective`` and ``network`` (J, R1, R2 and the MLPs) -> ``fused`` (the compiled kernels).

``PGNN`` and ``PGNNConfig`` need torch. They are imported on first use, so that the registry of
methods, and a benchmark's main process, run without it.
"""

from .method import PGNNFeedforward, PGNNLSFeedforward
from .settings import PGNNProtocol

__all__ = ["PGNN", "PGNNConfig", "PGNNFeedforward", "PGNNLSFeedforward", "PGNNProtocol"]


def __getattr__(name: str):
    if name == "PGNN":
        from .estimator import PGNN
        return PGNN
    if name == "PGNNConfig":
        from .training import PGNNConfig
        return PGNNConfig
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
