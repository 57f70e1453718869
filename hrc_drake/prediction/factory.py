"""Build a next-action model from a scenario's `predictor: {kind, params}` option."""

from __future__ import annotations

from collections.abc import Hashable, Sequence

from .base import SequenceModel
from .markov import ChingHigherOrderModel, HigherOrderMarkovModel, MarkovChainModel
from .suffix_tree import SuffixTreeModel
from .vomm import VariableOrderMarkovModel

#: kind -> (class, integer parameters, float parameters)
_KINDS = {
    "homm": (HigherOrderMarkovModel, {"order", "buffer_size", "refit_every"}, set()),
    "markov": (MarkovChainModel, {"buffer_size"}, set()),
    "ching": (ChingHigherOrderModel, {"order", "buffer_size", "refit_every"}, set()),
    "vomm": (VariableOrderMarkovModel, {"max_depth", "buffer_size"}, set()),
    "suffix_tree": (
        SuffixTreeModel,
        {"order", "learning_window", "learning_iterations"},
        {"forgetting", "token_threshold", "l2"},
    ),
}

#: parameters of the waiting-time part, ignored by the sequence models
WAITING_PARAMS = {"resolution", "epsilon", "max_samples", "default_duration", "max_nodes"}


def make_sequence_model(
    kind: str,
    params: dict | None,
    actions: Sequence[Hashable],
    affine_sets: Sequence[Sequence[Hashable]] = (),
) -> SequenceModel:
    """A model of `kind` (homm | markov | ching | vomm | suffix_tree) over `actions`.

    params: numbers from the scenario (floats are cast to int where the model needs ints);
    keys of the waiting-time predictor (WAITING_PARAMS) are skipped. Unknown keys are errors.
    """
    if kind not in _KINDS:
        raise ValueError(f"predictor kind {kind!r} is unknown; choose one of {sorted(_KINDS)}")
    cls, int_keys, float_keys = _KINDS[kind]
    kwargs: dict = {}
    for key, value in (params or {}).items():
        if key in WAITING_PARAMS:
            continue
        if key in int_keys:
            if value is None and key == "buffer_size":
                kwargs[key] = None
                continue
            if float(value) != int(value):
                raise ValueError(f"predictor.params.{key}={value} must be an integer")
            kwargs[key] = int(value)
        elif key in float_keys:
            kwargs[key] = float(value)
        else:
            raise ValueError(
                f"predictor.params.{key} is not a parameter of kind {kind!r}; "
                f"known: {sorted(int_keys | float_keys | WAITING_PARAMS)}"
            )
    if kind == "suffix_tree":
        kwargs["affine_sets"] = [list(s) for s in affine_sets]
    return cls(actions=list(actions), **kwargs)
