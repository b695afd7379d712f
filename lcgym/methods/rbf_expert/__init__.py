"""Method ``rbf-expert``: NN prediction feedforward with expert logic, paper 002 (sections 2.3-4):
predict a trajectory's error from its reference alone, after training once on measured
trajectories.

``influence`` (motion influence, eqs. 22-25, Table 1) -> ``preprocess`` (section 3.2) ->
``expert`` (activation logic, section 3.3, Table 3) -> ``network`` (RBF networks, eqs. 31-38,
and the prediction safety of section 4.1) -> ``predictor`` (all of it, plus the 50 Hz
postprocessing of section 3.5) -> ``method`` (the leaderboard methods ``rbf-expert`` and
``paper002-nnp``).
"""

from .method import PaperNNP, RBFExpertFeedforward
from .predictor import RBFExpertConfig, RBFExpertPredictor

__all__ = ["PaperNNP", "RBFExpertConfig", "RBFExpertFeedforward", "RBFExpertPredictor"]
