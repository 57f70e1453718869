"""Build the cores of an activity predictor from its typed config (`prediction.config`)."""

from __future__ import annotations

from collections.abc import Hashable, Sequence

from hrc_drake.errors import ConfigError

from .base import SequenceModel
from .config import (
    ChingPredictor,
    HigherOrderMarkovPredictor,
    MarkovChainPredictor,
    NoPredictor,
    SuffixTreePredictor,
    VariableOrderMarkovPredictor,
)
from .markov import ChingHigherOrderModel, HigherOrderMarkovModel, MarkovChainModel
from .suffix_tree import SuffixTreeModel
from .vomm import VariableOrderMarkovModel
from .waiting import WaitingTimePredictor


def _buffer(size: int) -> int | None:
    return None if int(size) == 0 else int(size)


def make_sequence_model(config, actions: Sequence[Hashable], path: str = "predictor") -> SequenceModel:
    """The next-action model a predictor config describes, over `actions` (validated first;
    ConfigError naming `path.<field>` for a bad value)."""
    if isinstance(config, NoPredictor):
        raise ConfigError(path, "NoPredictor describes no sequence model")
    if not hasattr(config, "validate"):
        raise ConfigError(path, f"{type(config).__name__} is not a predictor config")
    config.validate(path)
    actions = list(actions)
    if isinstance(config, SuffixTreePredictor):
        for i, members in enumerate(config.affine_sets):
            unknown = [a for a in members if a not in actions]
            if unknown:
                raise ConfigError(f"{path}.affine_sets[{i}]", f"actions {unknown} are not in {actions}")
        return SuffixTreeModel(
            order=config.order,
            affine_sets=[list(s) for s in config.affine_sets],
            forgetting=config.forgetting,
            actions=actions,
            token_threshold=config.token_threshold,
            learning_window=config.learning_window,
            learning_iterations=config.learning_iterations,
            l2=config.l2,
        )
    if isinstance(config, ChingPredictor):
        return ChingHigherOrderModel(
            order=config.order,
            buffer_size=_buffer(config.buffer_size),
            actions=actions,
            refit_every=config.refit_every,
        )
    if isinstance(config, HigherOrderMarkovPredictor):
        return HigherOrderMarkovModel(
            order=config.order,
            buffer_size=_buffer(config.buffer_size),
            actions=actions,
            refit_every=config.refit_every,
        )
    if isinstance(config, MarkovChainPredictor):
        return MarkovChainModel(buffer_size=_buffer(config.buffer_size), actions=actions)
    if isinstance(config, VariableOrderMarkovPredictor):
        return VariableOrderMarkovModel(
            max_depth=config.max_depth, buffer_size=_buffer(config.buffer_size), actions=actions
        )
    raise ConfigError(path, f"{type(config).__name__} is not a predictor config")


def make_waiting_predictor(config, model: SequenceModel) -> WaitingTimePredictor:
    """The waiting-time predictor (thesis 5.3) of a predictor config around `model`."""
    return WaitingTimePredictor(
        model,
        resolution=config.resolution,
        epsilon=config.epsilon,
        max_samples=config.max_samples,
        default_duration=config.default_duration,
        max_nodes=config.max_nodes,
    )
