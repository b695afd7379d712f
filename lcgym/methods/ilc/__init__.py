"""Method ``ilc`` and its protocols: iterative learning control of one repeated reference.

``method`` (the leaderboard methods ``ilc``, ``ilc-transfer``, ``paper002-lcs``, and ``iterate``,
the learning iteration). What the error is and how a feedforward changes it is the machine's
learning law, which the plant offers (``plant.learning_law``, ``systems.learning``; the FlexArm's
in ``systems/flexarm/learning.py``).
"""

from .method import ILCConfig, ILCTransfer, IterativeLearningControl, PaperLCS

__all__ = ["ILCConfig", "ILCTransfer", "IterativeLearningControl", "PaperLCS"]
