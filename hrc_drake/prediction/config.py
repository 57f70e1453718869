"""Typed configs of the activity predictor, one dataclass per kind (thesis Ch. 5).

A scenario chooses one by its YAML tag, e.g. ``predictor: !HigherOrderMarkovPredictor {order: 2}``.
Every kind carries the waiting-time fields (thesis 5.3, Algorithm 1) and the update rate.
No pydrake here, and real annotations (pydrake's typed YAML loader reads them).
"""

import math
from dataclasses import dataclass, field
from typing import Union

from hrc_drake.errors import check


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


@dataclass
class NoPredictor:
    """No activity predictor in the cell (no forecast port)."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class _PredictorCommon:
    """Fields every predictor kind shares: update rate and the waiting-time predictor."""

    #: forecast updates per second (Hz); each costs a waiting-time tree. Today's cell default: 2 Hz.
    rate: float = 2.0
    #: time step of the waiting-time grid (s), the discretisation of tau^a (thesis 5.3)
    resolution: float = 0.2
    #: branch probability p_branch below which a tree node is not expanded (epsilon, Algorithm 1 l. 16)
    epsilon: float = 1e-3
    #: duration samples remembered per action (the most recent ones), for T^a
    max_samples: int = 50
    #: duration assumed for an action without samples (s)
    default_duration: float = 1.0
    #: safety cap on the number of reachability-tree nodes per prediction
    max_nodes: int = 20000
    #: how far ahead the waiting-time distributions reach (s); later starts count as inf
    horizon: float = 60.0
    #: levels in (0, 1) of the waiting-time percentiles on the forecast
    percentile_levels: list[float] = field(default_factory=lambda: [0.2, 0.5, 0.8])

    def _validate_common(self, path: str) -> None:
        rate_ok = _finite(self.rate) and 0 < self.rate <= 50
        check(rate_ok, f"{path}.rate", f"{self.rate} must be in (0, 50] Hz")
        check(
            _finite(self.resolution) and 1e-3 <= self.resolution <= 10,
            f"{path}.resolution",
            f"{self.resolution} must be in [0.001, 10] s",
        )
        check(_finite(self.epsilon) and 0 <= self.epsilon < 1, f"{path}.epsilon", "must be in [0, 1)")
        check(
            _integer(self.max_samples) and 1 <= self.max_samples <= 100_000,
            f"{path}.max_samples",
            f"{self.max_samples} must be an integer in 1..100000",
        )
        check(
            _finite(self.default_duration) and self.default_duration > 0,
            f"{path}.default_duration",
            f"{self.default_duration} must be a positive number of seconds",
        )
        check(
            _integer(self.max_nodes) and 1 <= self.max_nodes <= 10_000_000,
            f"{path}.max_nodes",
            f"{self.max_nodes} must be an integer in 1..10000000",
        )
        check(
            _finite(self.horizon) and 0 < self.horizon <= 3600,
            f"{path}.horizon",
            f"{self.horizon} must be in (0, 3600] s",
        )
        check(
            len(self.percentile_levels) >= 1
            and all(_finite(x) and 0 < x < 1 for x in self.percentile_levels),
            f"{path}.percentile_levels",
            f"{self.percentile_levels} must be one or more levels in (0, 1)",
        )
        n_bins = self.horizon / self.resolution if _finite(self.resolution) and self.resolution > 0 else 0
        check(n_bins <= 1_000_000, f"{path}.horizon", "horizon / resolution exceeds 1e6 grid steps")

    def validate(self, path: str) -> None:
        """Raise ConfigError naming `path.<field>` for a bad value."""
        self._validate_common(path)


def _check_order(value, path: str, low: int) -> None:
    check(_integer(value) and low <= value <= 10, path, f"{value} must be an integer in {low}..10")


def _check_buffer(value, path: str) -> None:
    check(
        _integer(value) and 0 <= value <= 1_000_000,
        path,
        f"{value} must be an integer in 0..1000000 (0: unbounded)",
    )


def _validate_mtd(config, path: str) -> None:
    """The fields of both MTD models (HOMM and Ching's): order, FIFO length, refit period."""
    config._validate_common(path)
    _check_order(config.order, f"{path}.order", 1)
    _check_buffer(config.buffer_size, f"{path}.buffer_size")
    check(
        _integer(config.refit_every) and 1 <= config.refit_every <= 10_000,
        f"{path}.refit_every",
        f"{config.refit_every} must be an integer in 1..10000",
    )


@dataclass
class HigherOrderMarkovPredictor(_PredictorCommon):
    """Higher-order Markov model with MTD weights, eqs. (5.7)-(5.9) (kind "homm")."""

    #: n, the model uses the n+1 most recent actions (eq. 5.7); 0 is a Markov chain
    order: int = 3
    #: FIFO length the counts and weights are computed on (Fig. 5.1); 0: unbounded
    buffer_size: int = 200
    #: recompute the weights lambda_i every this many actions (1: every action)
    refit_every: int = 1

    def validate(self, path: str) -> None:
        _validate_mtd(self, path)


@dataclass
class MarkovChainPredictor(_PredictorCommon):
    """First-order Markov chain X_{k+1} = Q X_k, eq. (5.4) (kind "markov")."""

    #: FIFO length the transition counts are computed on; 0: unbounded
    buffer_size: int = 200

    def validate(self, path: str) -> None:
        self._validate_common(path)
        _check_buffer(self.buffer_size, f"{path}.buffer_size")


@dataclass
class ChingPredictor(_PredictorCommon):
    """MTD model with the weights of Ching et al. (baseline of Fig. 5.4, kind "ching")."""

    #: n, the model uses the n+1 most recent actions
    order: int = 3
    #: FIFO length the counts are computed on; 0: unbounded
    buffer_size: int = 200
    #: recompute the weights every this many actions
    refit_every: int = 1

    def validate(self, path: str) -> None:
        _validate_mtd(self, path)


@dataclass
class VariableOrderMarkovPredictor(_PredictorCommon):
    """PPM-C variable-order Markov model (baseline of Fig. 5.4, kind "vomm")."""

    #: longest context (number of past actions) counted
    max_depth: int = 5
    #: FIFO length the context counts are computed on; 0: unbounded
    buffer_size: int = 200

    def validate(self, path: str) -> None:
        self._validate_common(path)
        check(
            _integer(self.max_depth) and 0 <= self.max_depth <= 10,
            f"{path}.max_depth",
            f"{self.max_depth} must be an integer in 0..10",
        )
        _check_buffer(self.buffer_size, f"{path}.buffer_size")


@dataclass
class SuffixTreePredictor(_PredictorCommon):
    """Suffix tree with affine-set priors, eqs. (5.10)-(5.36) (kind "suffix_tree")."""

    #: sigma, the number of past actions in a context (branches have sigma+1 actions)
    order: int = 3
    #: sets C_i of action names likely done in sequence (eq. 5.33), each with >= 2 actions
    affine_sets: list[list[str]] = field(default_factory=list)
    #: alpha of the activation, eq. (5.26) (1/step); forgetting time N = 5 / alpha steps
    forgetting: float = 0.02
    #: tokens whose weight exp(-alpha age) fell below it are dropped
    token_threshold: float = 1e-3
    #: recent steps whose features enter the likelihood, eq. (5.34)
    learning_window: int = 300
    #: gradient-ascent steps per observed action, eqs. (5.35)-(5.36)
    learning_iterations: int = 3
    #: ridge on the weights w (not in the thesis)
    l2: float = 1e-3

    def validate(self, path: str) -> None:
        self._validate_common(path)
        _check_order(self.order, f"{path}.order", 1)
        for i, members in enumerate(self.affine_sets):
            check(
                len(set(members)) >= 2 and all(isinstance(a, str) and a for a in members),
                f"{path}.affine_sets[{i}]",
                f"{members} needs at least 2 distinct action names",
            )
        check(
            _finite(self.forgetting) and 0 < self.forgetting <= 10,
            f"{path}.forgetting",
            f"{self.forgetting} must be in (0, 10]",
        )
        check(
            _finite(self.token_threshold) and 0 < self.token_threshold < 1,
            f"{path}.token_threshold",
            f"{self.token_threshold} must be in (0, 1)",
        )
        check(
            _integer(self.learning_window) and 1 <= self.learning_window <= 100_000,
            f"{path}.learning_window",
            f"{self.learning_window} must be an integer in 1..100000",
        )
        check(
            _integer(self.learning_iterations) and 0 <= self.learning_iterations <= 1000,
            f"{path}.learning_iterations",
            f"{self.learning_iterations} must be an integer in 0..1000",
        )
        check(_finite(self.l2) and 0 <= self.l2 <= 1e6, f"{path}.l2", f"{self.l2} must be in [0, 1e6]")


#: Every predictor kind, as a scenario field type (chosen in YAML by tag).
PredictorConfig = Union[  # noqa: UP007 - pydrake's typed YAML loader needs typing.Union
    NoPredictor,
    HigherOrderMarkovPredictor,
    MarkovChainPredictor,
    ChingPredictor,
    VariableOrderMarkovPredictor,
    SuffixTreePredictor,
]
