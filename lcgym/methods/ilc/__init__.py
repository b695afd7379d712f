"""Method ``ilc`` and its protocols: iterative learning control of one repeated reference.

``method`` (the leaderboard methods ``ilc``, ``ilc-transfer``, ``paper002-lcs`` and the
plant-inversion update laws), ``flexarm`` (the FlexArm's update from its encoders and
accelerometer, any base), ``iteration`` (what every update loop shares: the Q filter, held edges,
the divergence check and the choice of the best trial).
"""

from .method import ILCConfig, ILCTransfer, IterativeLearningControl, PaperLCS

__all__ = ["ILCConfig", "ILCTransfer", "IterativeLearningControl", "PaperLCS"]
