"""Activity prediction (thesis Ch. 5): next-action models and waiting-time distributions.

Cores only (no pydrake); the Drake adapter is `hrc_drake.prediction.systems.ActivityPredictor`.
"""

from .base import SequenceModel
from .factory import make_sequence_model, make_waiting_predictor
from .markov import ChingHigherOrderModel, HigherOrderMarkovModel, MarkovChainModel
from .suffix_tree import SuffixTreeModel
from .vomm import VariableOrderMarkovModel
from .waiting import WaitingTimePredictor, percentiles_from_cdf

__all__ = [
    "ChingHigherOrderModel",
    "HigherOrderMarkovModel",
    "MarkovChainModel",
    "SequenceModel",
    "SuffixTreeModel",
    "VariableOrderMarkovModel",
    "WaitingTimePredictor",
    "make_sequence_model",
    "make_waiting_predictor",
    "percentiles_from_cdf",
]
