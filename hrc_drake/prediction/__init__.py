"""Activity prediction (thesis Ch. 5): next-action models and waiting-time distributions.

Cores only (no pydrake); the Drake adapter is `hrc_drake.prediction.systems.ActivityPredictor`.
"""

from importlib import import_module

#: public name -> core module defining it; imported on first use (PEP 562), so importing
#: `hrc_drake.prediction.config` for the scenario schema does not load scipy
_EXPORTS = {
    "SequenceModel": "base",
    "make_sequence_model": "factory",
    "make_waiting_predictor": "factory",
    "ChingHigherOrderModel": "markov",
    "HigherOrderMarkovModel": "markov",
    "MarkovChainModel": "markov",
    "SuffixTreeModel": "suffix_tree",
    "VariableOrderMarkovModel": "vomm",
    "WaitingTimePredictor": "waiting",
    "percentiles_from_cdf": "waiting",
}


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(import_module(f"hrc_drake.prediction.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'hrc_drake.prediction' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))


__all__ = sorted(_EXPORTS)
