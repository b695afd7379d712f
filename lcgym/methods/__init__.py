"""The feedforward methods of the leaderboard and their registry.

Each method is one module (``feedback``, ``physical``, ``basic``, ``rl``) or one folder (``ilc/``,
``pgnn/``, ``rbf_expert/``: the leaderboard adapter in ``method.py`` beside the learner it runs).
Every method is a ``protocol.Controller``. ``CONTROLLERS`` maps method ids to classes;
``load_method`` also accepts a user's ``module:Class``, and either with ``@BASE``: the learning
methods' base (``bases``). A class with a ``systems`` tuple runs only on those systems (``basic``:
the FlexArm's nominal structure; ``paper002-lcs`` and ``paper002-nnp``: paper 002's protocols on
it; ``paper000-pgnn``: paper 000's on the IX). ``safeguard`` keeps a learner's correction only where
it beats its base on the training references.
"""

from .basic import BasicArmFeedforward
from .feedback import FeedbackOnly
from .ilc.method import ILCTransfer, IterativeLearningControl, PaperLCS
from .pgnn.method import PaperPGNN, PGNNFeedforward, PGNNLSFeedforward
from .physical import PhysicalFeedforward
from .protocol import Controller, Cost, load_method
from .rbf_expert.method import PaperNNP, RBFExpertFeedforward
from .rl import RLConfig, RLFeedforward

CONTROLLERS = {c.name: c for c in (FeedbackOnly, PhysicalFeedforward, PGNNFeedforward, PGNNLSFeedforward,
                                    BasicArmFeedforward, IterativeLearningControl, ILCTransfer,
                                    RBFExpertFeedforward, RLFeedforward, PaperLCS, PaperNNP, PaperPGNN)}

__all__ = ["BasicArmFeedforward", "CONTROLLERS", "Controller", "Cost", "FeedbackOnly", "ILCTransfer",
           "IterativeLearningControl", "PaperLCS", "PaperNNP", "PaperPGNN",
           "PGNNFeedforward", "PGNNLSFeedforward",
           "PhysicalFeedforward", "RBFExpertFeedforward", "RLConfig", "RLFeedforward", "load_method"]
