"""Method ``ilc`` and its protocols: iterative learning control of one repeated reference.

``method`` (the leaderboard methods ``ilc``, ``ilc-transfer``, ``paper002-lcs`` and the
plant-inversion update laws). A machine's own law (the FlexArm's update from its encoders and
accelerometer, any base) lives with the machine and is reached as ``System.learning``; what every
update loop shares (the Q filter, held edges, the divergence check, the choice of the best trial)
is ``systems.learning``.
"""

from .method import ILCConfig, ILCTransfer, IterativeLearningControl, PaperLCS

__all__ = ["ILCConfig", "ILCTransfer", "IterativeLearningControl", "PaperLCS"]
