"""Baseline feedforward controllers and the registry of leaderboard methods.

Every method follows the controller protocol of ``baselines/protocol.py``. ``CONTROLLERS`` maps
method ids to classes; ``load_method`` also accepts a user's ``module:Class``. A class with a
``systems`` tuple runs only on those systems (``basic``: the FlexArm's nominal structure).
"""

from .basic import BasicArmFeedforward
from .feedback import FeedbackOnly
from .ilc import ILCTransfer, IterativeLearningControl
from .pgnn import PGNNFeedforward, PGNNLSFeedforward
from .physical import PhysicalFeedforward
from .protocol import Controller, Cost, load_method
from .rbf_expert import RBFExpertFeedforward
from .rl import RLConfig, RLFeedforward

CONTROLLERS = {c.name: c for c in (FeedbackOnly, PhysicalFeedforward, PGNNFeedforward, PGNNLSFeedforward,
                                    BasicArmFeedforward, IterativeLearningControl, ILCTransfer,
                                    RBFExpertFeedforward, RLFeedforward)}

__all__ = ["BasicArmFeedforward", "CONTROLLERS", "Controller", "Cost", "FeedbackOnly", "ILCTransfer",
           "IterativeLearningControl",
           "PGNNFeedforward", "PGNNLSFeedforward",
           "PhysicalFeedforward", "RBFExpertFeedforward", "RLConfig", "RLFeedforward", "load_method"]
