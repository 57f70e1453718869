"""Segmentation of the human actions by evolving factor graphs (thesis 4.1), pure numpy/scipy.

The thesis' units, in the order of this module:

* 4.1, Fig. 4.1 - the skeleton signal (T, 8, 3) is cut into windows of at most l_w samples; window i
  gives F_O^i: the mean and the variance of every inter-skeletal distance (all 28 pairs of the 8
  tracked points, "all the combinations", Fig. 4.10) and of the distance of each wrist to each
  goal/buffer centre C_1..C_m.
* Fig. 4.3 - each O_j becomes the categorical Ô_j through bins that hold equal shares of the
  empirical CDF of O_j over the training library.
* Fig. 4.2, 4.1.1-4.1.2 - a hypothesis rho (shares of the window, sum 1) gives the MRF: a hidden
  action Y_s per segment, Ô_j^l observed per window l, Psi_OjY = exp(w_Oj Phi_OjY), eq. (4.1), and
  Psi^i_YY(Y_k, Y_k-i) = exp(w_Y lambda_i Q_i(Y_k, Y_k-i)), eq. (4.2), with (lambda, Q) the
  higher-order Markov model of Ch. 5 (`hrc_drake.prediction.markov`).
* 4.1.3 - the fitness of eq. (4.5), E(Ô, Y_MAP | rho) / sup E times the Poisson prior of eq. (4.6),
  maximised by a genetic algorithm (roulette selection, one-point crossover of Fig. 4.4, mutation
  by value change or insertion, then re-normalisation).
* 4.1.4 - the sliding window: the last o hidden variables survive, the messages from the deleted
  part of the graph become unary simple potentials on them.
* 4.1.5 - w_O and w_Y learnt (FactorGraph.fit, App. C.0.3) on artificial sequences drawn from the
  precedence constraints with observations sampled from the library (Fig. 4.6).
* 4.2 - the segmentation error E_s.

Two graphs of a hypothesis: `build_segmentation_graph` is the MRF of Fig. 4.2 as the thesis draws
it (observation variables and all); the fitness and the sliding window use the same MRF with the
evidence already sliced into one unary factor per hidden action (eq. (C.21)) - the same energy and
MAP (a test checks it) on a graph of |rho| variables instead of F L + |rho|, which is what makes a
GA of hundreds of evaluations per window affordable. With order o = 1 the hidden chain is a tree
and MAP, marginals and the sliding-window messages are exact; o >= 2 closes cycles (loopy BP,
approximate), and the messages into several survivors are kept per variable (a unary simple
potential each, as 4.1.4 says), which drops their correlation.

Actions are any hashable labels; inside they are codes 0..m-1 (the order of `SegmentationModel.
actions`). A segment is (start_frame, end_frame, action), end exclusive. The choices the thesis
leaves open are stated where they are made; the main ones: the prior rate is 1 + L / (mean action
length in windows) (`window_prior_rate`), and a hypothesis is kept in the rounded form it is
evaluated in (`canonical_hypothesis`). Phi_OjY is the count of the thesis (4.1.1); the variant
"per_action_frequencies" of `observation_phi` divides it by the action's library windows.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.special import gammaln

from hrc_drake.intention import _kernels
from hrc_drake.intention.config import OBSERVATION_POTENTIALS  # how Phi_OjY is made, counts first
from hrc_drake.intention.factor_graph import FactorGraph, FitReport
from hrc_drake.messages import L_WRIST, R_WRIST, SKELETON_POINTS
from hrc_drake.prediction.markov import HigherOrderMarkovModel

N_POINTS = len(SKELETON_POINTS)
#: The inter-skeletal distances of F_O: every pair of tracked points (Fig. 4.10, "all the combinations").
SKELETON_PAIRS: tuple[tuple[int, int], ...] = tuple(itertools.combinations(range(N_POINTS), 2))
#: The wrists whose distances to the goal/buffer centres enter F_O (4.1, Fig. 4.10).
WRISTS: tuple[int, ...] = (L_WRIST, R_WRIST)
#: Name of the fixed unit weight of the evidence already sliced into unary factors (eq. (C.21)).
SLICED_EVIDENCE = "sliced_evidence"
SEQUENCE_WEIGHT = "w_Y"


def observation_weight_name(feature: int) -> str:
    """Name of w_Oj, the weight shared by the Psi_OjY of feature j in every segment, eq. (4.1)."""
    return f"w_O{feature}"


def _is_int(value) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def _check_int(value, name: str, minimum: int) -> int:
    if not _is_int(value) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _generator(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is not None and not _is_int(seed) and not isinstance(seed, np.random.SeedSequence):
        raise ValueError(f"seed must be an int, a SeedSequence or a numpy Generator, got {seed!r}")
    return np.random.default_rng(seed)


# ---------------------------------------------------------------------------------------------
# windows and features F_O (4.1, Fig. 4.1)


def check_frames(frames, where: str = "frames") -> np.ndarray:
    """Skeleton samples as a float (T, 8, 3) array, T >= 1, all finite; ValueError naming the first
    bad sample (the segmenter has no model of a lost point)."""
    try:
        array = np.asarray(frames, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: not a numeric array of skeleton samples") from None
    if array.ndim != 3 or array.shape[1:] != (N_POINTS, 3) or array.shape[0] < 1:
        raise ValueError(f"{where} must have shape (T >= 1, {N_POINTS}, 3), got {array.shape}")
    bad = ~np.isfinite(array).all(axis=2)
    if bad.any():
        sample, point = np.argwhere(bad)[0]
        raise ValueError(f"{where}: sample {sample}, point {SKELETON_POINTS[point]!r} is not finite")
    return array


def check_centres(centres) -> np.ndarray:
    """Goal/buffer centres C_1..C_m as a (m, 3) array (m = 0 when None)."""
    if centres is None:
        return np.zeros((0, 3))
    array = np.asarray(centres, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3 or not np.isfinite(array).all():
        raise ValueError(f"centres must be a finite (m, 3) array, got shape {array.shape}")
    return array


def window_bounds(n_samples: int, window_length: int, keep_partial: bool = True) -> np.ndarray:
    """(start, end) sample indices of the windows of at most l_w samples (Fig. 4.1), end exclusive;
    a last shorter window is kept when `keep_partial` (the thesis' "maximal length" l_w)."""
    n_samples = _check_int(n_samples, "n_samples", 0)
    window_length = _check_int(window_length, "window_length", 1)
    starts = np.arange(0, n_samples, window_length)
    ends = np.minimum(starts + window_length, n_samples)
    if not keep_partial:
        full = ends - starts == window_length
        starts, ends = starts[full], ends[full]
    return np.stack([starts, ends], axis=1).astype(np.int64).reshape(-1, 2)


def distance_names(n_centres: int) -> tuple[str, ...]:
    """Names of the distances of `distance_signals`, in column order."""
    names = [f"{SKELETON_POINTS[a]}-{SKELETON_POINTS[b]}" for a, b in SKELETON_PAIRS]
    names += [f"{SKELETON_POINTS[w]}-centre{c}" for w in WRISTS for c in range(n_centres)]
    return tuple(names)


def feature_names(n_centres: int) -> tuple[str, ...]:
    """Names of the components of F_O, in order: mean and variance of each distance in turn."""
    return tuple(f"{stat}({name})" for name in distance_names(n_centres) for stat in ("mean", "var"))


def distance_signals(frames, centres=None) -> np.ndarray:
    """Per-sample distances whose window statistics make F_O (4.1): the 28 inter-skeletal
    distances, then |wrist - C_c| for each wrist (left, right) and centre c. Shape (T, 28 + 2m)."""
    frames = check_frames(frames)
    centres = check_centres(centres)
    first, second = (np.array(p) for p in zip(*SKELETON_PAIRS, strict=True))
    skeletal = np.linalg.norm(frames[:, first] - frames[:, second], axis=-1)
    wrists = frames[:, list(WRISTS)]
    to_centres = np.linalg.norm(wrists[:, :, None, :] - centres[None, None], axis=-1)
    return np.hstack([skeletal, to_centres.reshape(len(frames), -1)])


def window_features(
    frames, window_length: int, centres=None, keep_partial: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """F_O of every window (4.1, Fig. 4.1): (features (n, F), bounds (n, 2)). F = 2 (28 + 2m):
    for each distance of `distance_signals` its mean and its (population) variance over the window."""
    signals = distance_signals(frames, centres)
    bounds = window_bounds(len(signals), window_length, keep_partial)
    if len(bounds) == 0:
        return np.zeros((0, 2 * signals.shape[1])), bounds
    signals = signals[: bounds[-1, 1]]
    sizes = (bounds[:, 1] - bounds[:, 0])[:, None]
    mean = np.add.reduceat(signals, bounds[:, 0], axis=0) / sizes
    # the variance from the deviations, not E[x^2] - E[x]^2, which cancels badly for long arms
    owner = np.repeat(np.arange(len(bounds)), sizes[:, 0])
    var = np.add.reduceat((signals - mean[owner]) ** 2, bounds[:, 0], axis=0) / sizes
    features = np.empty((len(bounds), 2 * signals.shape[1]))
    features[:, 0::2], features[:, 1::2] = mean, var
    return features, bounds


# ---------------------------------------------------------------------------------------------
# ECDF discretisation (4.1.1, Fig. 4.3)


def fit_ecdf_edges(values, n_bins: int) -> np.ndarray:
    """Inner edges (F, n_bins - 1) of non-equispaced bins on each O_j (Fig. 4.3): edge k is the
    k / n_bins quantile of the training values, so each bin takes an equal share of the image of the
    empirical CDF. values: (N, F) feature values of the library windows."""
    n_bins = _check_int(n_bins, "n_bins", 2)
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[0] < 1:
        raise ValueError(f"ECDF values must be a non-empty (N, F) array, got shape {values.shape}")
    if not np.isfinite(values).all():
        raise ValueError(f"ECDF values: row {np.argwhere(~np.isfinite(values))[0][0]} is not finite")
    levels = np.arange(1, n_bins) / n_bins
    return np.quantile(values, levels, axis=0).T.copy()


def discretise(values, edges) -> np.ndarray:
    """Ô_j of each value (N, F) -> ints (N, F) in 0..n_bins-1: the bin of the ECDF partition holding
    it (a value on an edge goes to the upper bin)."""
    edges = np.asarray(edges, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or edges.ndim != 2 or values.shape[1] != edges.shape[0]:
        raise ValueError(
            f"discretise: values {values.shape} do not match the edges of {edges.shape[0]} features"
        )
    if not np.isfinite(values).all():
        raise ValueError(f"discretise: row {np.argwhere(~np.isfinite(values))[0][0]} is not finite")
    codes = np.empty(values.shape, dtype=np.int64)
    for j in range(values.shape[1]):
        codes[:, j] = np.searchsorted(edges[j], values[:, j], side="right")
    return codes


# ---------------------------------------------------------------------------------------------
# the potentials (4.1.1, 4.1.2) and the learnt model


def observation_phi(codes, labels, n_bins: int, n_actions: int, kind: str = "counts") -> np.ndarray:
    """Phi_OjY of eq. (4.1) for every feature, (F, n_bins, m) as phi[j, ô, y]: "counts" (4.1.1) is
    the number of times the pair (Ô_j = ô, Y = y) occurs in the library windows.

    "per_action_frequencies" departs from the text: the counts divided by the library windows of
    action y (phi[j, :, y] is the empirical distribution of Ô_j under y), so an action recorded
    longer or more often does not get larger potentials; one w_Oj can rescale all actions alike,
    not each its own."""
    if kind not in OBSERVATION_POTENTIALS:
        raise ValueError(f"observation_phi: kind must be one of {OBSERVATION_POTENTIALS}, got {kind!r}")
    codes = np.asarray(codes)
    labels = np.asarray(labels)
    if codes.ndim != 2 or labels.shape != (codes.shape[0],):
        raise ValueError(f"observation_phi: codes {codes.shape} and labels {labels.shape} do not match")
    if codes.size and (codes.min() < 0 or codes.max() >= n_bins):
        raise ValueError(f"observation_phi: codes out of range 0..{n_bins - 1}")
    if not np.issubdtype(labels.dtype, np.integer) or (
        labels.size and not 0 <= labels.min() <= labels.max() < n_actions
    ):
        raise ValueError(f"observation_phi: labels must be action codes 0..{n_actions - 1}")
    per_action = np.bincount(labels, minlength=n_actions)
    if np.any(per_action == 0):
        raise ValueError(
            f"observation_phi: action codes {np.flatnonzero(per_action == 0).tolist()} have no windows"
        )
    n_features = codes.shape[1]
    counts = np.zeros((n_features, n_bins, n_actions))
    feature = np.broadcast_to(np.arange(n_features), codes.shape)
    np.add.at(counts, (feature, codes, np.broadcast_to(labels[:, None], codes.shape)), 1.0)
    return counts if kind == "counts" else counts / per_action[None, None, :]


def sequence_phi(sequence: Sequence[int], n_actions: int, order: int) -> np.ndarray:
    """Phi^i_YY = lambda_i Q_i of eq. (4.2), (o, m, m) as phi[i - 1, y_k, y_k-i], from the HOMM of
    Ch. 5 fitted on `sequence` (action codes): its step matrices Q[i - 1, to, from] (the
    (i)-step counts of eq. (5.8)) and MTD weights lambda (eq. (5.9)); a HOMM of prediction order
    o - 1 uses the o lags 1..o."""
    order = _check_int(order, "order", 1)
    codes = np.asarray(sequence)
    if codes.ndim != 1 or not np.issubdtype(codes.dtype, np.integer) or codes.size < 2:
        raise ValueError("sequence_phi: the sequence must be at least 2 integer action codes")
    if codes.min() < 0 or codes.max() >= n_actions:
        raise ValueError(f"sequence_phi: action codes out of range 0..{n_actions - 1}")
    model = HigherOrderMarkovModel(order=order - 1, buffer_size=None, actions=n_actions)
    model.fit([int(c) for c in codes])
    return model.weights_[:, None, None] * model.matrices_


def window_prior_rate(n_windows: int, mean_action_windows: float) -> float:
    """lambda of eq. (4.6) for a window of L observations: 1 + L / (mean action length in windows),
    the expected number of actions a window of L windows meets (one running at its start plus the
    ones that begin inside). The thesis only asks lambda to leave no mass beyond L; that is
    enforced by the truncation of `poisson_log_prior`."""
    return 1.0 + n_windows / mean_action_windows


@dataclass
class SegmentationModel:
    """What the segmenter learns (4.1.1, 4.1.2, 4.1.5).

    actions: the labels, in code order; edges (F, B - 1): ECDF bins (Fig. 4.3); phi_obs (F, B, m):
    Phi_OjY; phi_seq (o, m, m): lambda_i Q_i; w_obs (F,), w_seq: the weights of eq. (4.1)-(4.2);
    mean_action_windows: mean length of a library action in windows (for the prior rate)."""

    actions: tuple[Hashable, ...]
    edges: np.ndarray
    phi_obs: np.ndarray
    phi_seq: np.ndarray
    w_obs: np.ndarray
    w_seq: float
    mean_action_windows: float

    def __post_init__(self) -> None:
        self.actions = tuple(self.actions)
        self.edges = np.asarray(self.edges, dtype=float)
        self.phi_obs = np.asarray(self.phi_obs, dtype=float)
        self.phi_seq = np.asarray(self.phi_seq, dtype=float)
        self.w_obs = np.asarray(self.w_obs, dtype=float)
        self.w_seq = float(self.w_seq)
        m = len(self.actions)
        if m < 1 or len(set(self.actions)) != m:
            raise ValueError(f"SegmentationModel: actions must be distinct labels, got {self.actions!r}")
        if self.edges.ndim != 2:
            raise ValueError(
                f"SegmentationModel: edges must be (F, n_bins - 1), got shape {self.edges.shape}"
            )
        n_features, n_bins = self.edges.shape[0], self.edges.shape[1] + 1
        expected = {
            "phi_obs": (self.phi_obs.shape, (n_features, n_bins, m)),
            "phi_seq": (self.phi_seq.shape[1:], (m, m)),
            "w_obs": (self.w_obs.shape, (n_features,)),
        }
        for name, (got, want) in expected.items():
            if got != want:
                raise ValueError(f"SegmentationModel: {name} has shape {got}, expected {want}")
        if self.phi_seq.ndim != 3 or self.phi_seq.shape[0] < 1:
            raise ValueError(
                f"SegmentationModel: phi_seq must be (order >= 1, m, m), got {self.phi_seq.shape}"
            )
        arrays = (self.edges, self.phi_obs, self.phi_seq, self.w_obs, np.array([self.w_seq]))
        if not all(np.isfinite(a).all() for a in arrays):
            raise ValueError("SegmentationModel: non-finite entries in the edges, potentials or weights")
        if not self.mean_action_windows > 0:
            raise ValueError(
                f"SegmentationModel: mean_action_windows must be > 0, got {self.mean_action_windows}"
            )

    @property
    def n_actions(self) -> int:
        return len(self.actions)

    @property
    def n_features(self) -> int:
        return self.edges.shape[0]

    @property
    def n_bins(self) -> int:
        return self.edges.shape[1] + 1

    @property
    def order(self) -> int:
        return self.phi_seq.shape[0]

    def check_codes(self, codes) -> np.ndarray:
        codes = np.asarray(codes)
        if codes.ndim != 2 or codes.shape[1] != self.n_features or not np.issubdtype(codes.dtype, np.integer):
            raise ValueError(f"observations must be integer codes (L, {self.n_features}), got {codes.shape}")
        if codes.size and (codes.min() < 0 or codes.max() >= self.n_bins):
            raise ValueError(f"observations: codes out of range 0..{self.n_bins - 1}")
        return codes

    def window_log_potentials(self, codes) -> np.ndarray:
        """log of prod_j Psi_OjY(ô_j^l, y) for each window l and action y, (L, m): the observation
        factors of eq. (4.1) with the evidence sliced in (eq. (C.21))."""
        codes = self.check_codes(codes)
        phi = self.phi_obs[np.arange(self.n_features)[None, :], codes]  # (L, F, m)
        return np.einsum("j,ljy->ly", self.w_obs, phi)

    def window_log_sup(self) -> float:
        """log of the product of the maxima of the F observation potentials of one window (4.5)."""
        return float(np.sum(np.max(self.w_obs[:, None, None] * self.phi_obs, axis=(1, 2))))

    def sequence_log_sup(self) -> np.ndarray:
        """log of the maximum of Psi^i_YY for each lag i = 1..o (4.5)."""
        return np.max(self.w_seq * self.phi_seq, axis=(1, 2))


# ---------------------------------------------------------------------------------------------
# a hypothesis rho and its MRF (4.1, Fig. 4.2)


def check_hypothesis(rho) -> np.ndarray:
    """rho as a float vector of positive shares summing to 1 (4.1)."""
    try:
        values = np.asarray(rho, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"rho must be a vector of shares, got {rho!r}") from None
    if values.ndim != 1 or values.size < 1:
        raise ValueError(f"rho must be a non-empty vector, got shape {values.shape}")
    if not np.isfinite(values).all() or np.any(values <= 0):
        raise ValueError(f"rho must hold positive finite shares, got {values}")
    if abs(values.sum() - 1.0) > 1e-9:
        raise ValueError(f"rho must sum to 1, sums to {values.sum()!r}")
    return values


def segment_counts(rho, n_windows: int) -> np.ndarray:
    """Observations per segment (the rho_i L of 4.1, rounded: footnote 1). The cumulative shares are
    rounded, so the counts sum to L; a segment rounded to no observation is dropped."""
    values = check_hypothesis(rho)
    n_windows = _check_int(n_windows, "n_windows", 1)
    cut = np.rint(np.cumsum(values) * n_windows).astype(np.int64)
    cut[-1] = n_windows
    counts = np.diff(np.concatenate([[0], cut]))
    return counts[counts > 0]


def canonical_hypothesis(rho, n_windows: int) -> np.ndarray:
    """rho in the rounded form it is evaluated in: counts / L (so equal hypotheses compare equal)."""
    return segment_counts(rho, n_windows) / n_windows


def chain_pairs(n_variables: int, order: int) -> list[tuple[int, int, int]]:
    """(k, k - i, i) for the sequence potentials Psi^i_YY(Y_k, Y_k-i), i = 1..o (Fig. 4.2)."""
    return [(k, k - lag, lag) for k in range(n_variables) for lag in range(1, order + 1) if k - lag >= 0]


@dataclass
class SegmentationGraph:
    """The MRF of one hypothesis (Fig. 4.2): the FactorGraph, the evidence {("O", l, j): ô}, the
    hidden variables ("Y", s) in order and, for inspection, each factor's (variables, weight name)
    in insertion order."""

    graph: FactorGraph
    evidence: dict[tuple, int]
    hidden: list[tuple]
    factors: list[tuple[tuple, str]] = field(default_factory=list)


def build_segmentation_graph(model: SegmentationModel, codes, rho) -> SegmentationGraph:
    """The variable-structure MRF of hypothesis rho on the L windows `codes` (L, F) (Fig. 4.2):
    hidden ("Y", s), one per segment; observed ("O", l, j) with B values; Psi_OjY of eq. (4.1) with
    weight w_Oj shared by all segments; Psi^i_YY of eq. (4.2) with the shared w_Y."""
    codes = model.check_codes(codes)
    counts = segment_counts(rho, len(codes))
    graph, factors = FactorGraph(), []
    hidden = [("Y", s) for s in range(len(counts))]
    for name in hidden:
        graph.add_variable(name, model.n_actions)
    owner = np.repeat(np.arange(len(counts)), counts)
    evidence = {}
    for window in range(len(codes)):
        for j in range(model.n_features):
            name = ("O", window, j)
            graph.add_variable(name, model.n_bins)
            evidence[name] = int(codes[window, j])
            weight = observation_weight_name(j)
            graph.add_exponential_factor(
                [name, hidden[owner[window]]], model.phi_obs[j], weight, model.w_obs[j]
            )
            factors.append(((name, hidden[owner[window]]), weight))
    for k, past, lag in chain_pairs(len(hidden), model.order):
        variables = (hidden[k], hidden[past])
        graph.add_exponential_factor(variables, model.phi_seq[lag - 1], SEQUENCE_WEIGHT, model.w_seq)
        factors.append((variables, SEQUENCE_WEIGHT))
    return SegmentationGraph(graph, evidence, hidden, factors)


# ---------------------------------------------------------------------------------------------
# fitness (4.1.3, eq. (4.5)-(4.6))


def poisson_log_prior(n_segments: int, rate: float, max_segments: int) -> float:
    """log P(rho) of eq. (4.6): exp(-lambda) lambda^|rho| / |rho|!, and 0 (-inf) for |rho| > L."""
    n_segments = _check_int(n_segments, "n_segments (|rho|)", 1)
    max_segments = _check_int(max_segments, "max_segments (L)", 1)
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"Poisson rate lambda must be finite and > 0, got {rate!r}")
    if n_segments > max_segments:
        return -np.inf
    return float(-rate + n_segments * np.log(rate) - gammaln(n_segments + 1))


def poisson_prior(n_segments: int, rate: float, max_segments: int) -> float:
    """P(rho) of eq. (4.6) (see `poisson_log_prior`)."""
    return float(np.exp(poisson_log_prior(n_segments, rate, max_segments)))


@dataclass
class ChainLink:
    """A hidden action variable of the chain: the log of its unary factors split into the sliced
    evidence of its windows (eq. (4.1)) and the messages from deleted parts of the graph (4.1.4),
    the log of the product of those factors' maxima (for sup E, eq. (4.5)), its frames and its last
    marginal X (eq. (4.7))."""

    log_evidence: np.ndarray
    log_message: np.ndarray
    log_sup: float
    start: int
    end: int
    marginal: np.ndarray | None = None

    @property
    def log_unary(self) -> np.ndarray:
        return self.log_evidence + self.log_message


def chain_graph(model: SegmentationModel, unaries: Sequence[np.ndarray | None], pairs) -> FactorGraph:
    """The graph on the hidden chain ("Y", k) once the evidence is sliced in (eq. (C.21)): a unary
    factor exp(u) per given unary (weight fixed at 1) and the Psi^i_YY of `pairs` (k, k - i, i)."""
    graph = FactorGraph()
    for k in range(len(unaries)):
        graph.add_variable(("Y", k), model.n_actions)
    for k, unary in enumerate(unaries):
        if unary is not None:
            graph.add_exponential_factor([("Y", k)], unary, SLICED_EVIDENCE, 1.0)
    for k, past, lag in pairs:
        graph.add_exponential_factor(
            [("Y", k), ("Y", past)], model.phi_seq[lag - 1], SEQUENCE_WEIGHT, model.w_seq
        )
    return graph


class WindowProblem:
    """The segmentation of one window of L observations (4.1.3), possibly after surviving links of
    the previous window (4.1.4: the first share of rho then belongs to the last survivor)."""

    def __init__(
        self, model: SegmentationModel, codes, bounds, survivors=(), prior_rate: float | None = None
    ):
        self.model = model
        self.codes = model.check_codes(codes)
        self.n_windows = len(self.codes)
        if self.n_windows < 1:
            raise ValueError("a window to segment needs at least one observation")
        self.bounds = np.asarray(bounds, dtype=np.int64).reshape(self.n_windows, 2)
        self.survivors = list(survivors)
        potentials = model.window_log_potentials(self.codes)
        self._cumulative = np.vstack([np.zeros(model.n_actions), np.cumsum(potentials, axis=0)])
        self._window_sup = model.window_log_sup()
        self._sequence_sup = model.sequence_log_sup()
        rate = (
            window_prior_rate(self.n_windows, model.mean_action_windows) if prior_rate is None else prior_rate
        )
        self.prior_rate = float(rate)
        self._cache: dict[tuple[int, ...], float] = {}
        # log Psi^1_YY (Y_k, Y_k-1) of the order-1 chain, shared by every hypothesis of the window
        self._pair_log = model.w_seq * model.phi_seq[0] if model.order == 1 else None

    def links(self, counts) -> list[ChainLink]:
        """The chain of hypothesis `counts`: copies of the survivors, the last one extended by the
        first segment when there are survivors, then a new link per segment."""
        chain = [
            ChainLink(s.log_evidence.copy(), s.log_message.copy(), s.log_sup, s.start, s.end, s.marginal)
            for s in self.survivors
        ]
        cut = np.concatenate([[0], np.cumsum(counts)])
        for s, (a, b) in enumerate(itertools.pairwise(cut)):
            evidence = self._cumulative[b] - self._cumulative[a]
            sup = (b - a) * self._window_sup
            if s == 0 and chain:
                last = chain[-1]
                last.log_evidence, last.log_sup = last.log_evidence + evidence, last.log_sup + sup
                last.end = int(self.bounds[b - 1, 1])
            else:
                zero = np.zeros(self.model.n_actions)
                chain.append(
                    ChainLink(evidence, zero, sup, int(self.bounds[a, 0]), int(self.bounds[b - 1, 1]))
                )
        return chain

    def graph(self, chain: list[ChainLink]) -> FactorGraph:
        return chain_graph(
            self.model, [c.log_unary for c in chain], chain_pairs(len(chain), self.model.order)
        )

    def map_log_energy(self, chain: list[ChainLink]) -> float:
        """log E(Ô, Y_MAP | rho) of eq. (4.5): with order 1 the chain is a tree and its exact
        max-product value is the compiled forward pass (`_kernels.chain_max_log_energy`, equal to
        the graph's within float rounding, tests/intention/test_segmentation_chain.py); otherwise,
        or when a potential is not finite, the energy of the graph's MAP (`graph_map_log_energy`)."""
        if self._pair_log is not None:
            unary = np.array([c.log_unary for c in chain])
            value = _kernels.chain_max_log_energy(unary, self._pair_log)
            if np.isfinite(value):
                return value
        return self.graph_map_log_energy(chain)

    def graph_map_log_energy(self, chain: list[ChainLink]) -> float:
        """log E of the MAP assignment of the chain's FactorGraph (App. C.0.1): the reference."""
        graph = self.graph(chain)
        return graph.log_energy(graph.map())

    def log_fitness(self, rho) -> float:
        """log of eq. (4.5): log E(Ô, Y_MAP | rho) - log sup E + log P(rho) (4.6); sup E is the product
        of the maxima of all potentials (the messages' too), Y_MAP by max-product on the graph."""
        counts = segment_counts(rho, self.n_windows)
        key = tuple(int(c) for c in counts)
        if key not in self._cache:
            chain = self.links(counts)
            log_energy = self.map_log_energy(chain)
            pairs = chain_pairs(len(chain), self.model.order)
            log_sup = sum(c.log_sup for c in chain) + sum(self._sequence_sup[lag - 1] for _, _, lag in pairs)
            prior = poisson_log_prior(len(counts), self.prior_rate, self.n_windows)
            self._cache[key] = float(log_energy - log_sup + prior)
        return self._cache[key]


def log_fitness(model: SegmentationModel, codes, rho, prior_rate: float | None = None) -> float:
    """log varrho(rho) of eq. (4.5) on a fixed window of observations `codes` (L, F) (4.1.3)."""
    codes = model.check_codes(codes)
    bounds = np.stack([np.arange(len(codes)), np.arange(1, len(codes) + 1)], axis=1)
    return WindowProblem(model, codes, bounds, prior_rate=prior_rate).log_fitness(rho)


# ---------------------------------------------------------------------------------------------
# the genetic algorithm (4.1.3, Fig. 4.4)


@dataclass(frozen=True)
class GeneticSettings:
    """population: G; generations: populations evaluated (Omega^1..Omega^K); mutation_rate: share of
    the children mutated; insertion_share: share of the mutations that insert a value (the others
    change one); elite: best individuals copied unchanged to the next generation (a choice: so the
    best of the final generation, the thesis' answer, is the best ever seen)."""

    population: int = 24
    generations: int = 20
    mutation_rate: float = 0.5
    insertion_share: float = 0.5
    elite: int = 1

    def __post_init__(self) -> None:
        _check_int(self.population, "GeneticSettings.population", 2)
        _check_int(self.generations, "GeneticSettings.generations", 1)
        _check_int(self.elite, "GeneticSettings.elite", 0)
        if self.elite >= self.population:
            raise ValueError(f"GeneticSettings.elite={self.elite} must be < population={self.population}")
        for name in ("mutation_rate", "insertion_share"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"GeneticSettings.{name} must be in [0, 1], got {getattr(self, name)!r}")


def random_hypothesis(n_windows: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """An initial individual (4.1.3, footnote 3): the number of values is sampled (from the prior of
    eq. (4.6), clipped to 1..L), the values uniformly, then normalised."""
    n_windows = _check_int(n_windows, "n_windows", 1)
    size = int(np.clip(rng.poisson(rate), 1, n_windows))
    values = rng.uniform(0.0, 1.0, size) + 1e-12  # never all zero
    return canonical_hypothesis(values / values.sum(), n_windows)


def crossover(rho_a, rho_b, n_windows: int, rng: np.random.Generator) -> np.ndarray:
    """The child of Fig. 4.4: both parents are broken at one random point of the window; the child
    has the segment boundaries of rho_a before it and those of rho_b after it."""
    inner_a = np.cumsum(check_hypothesis(rho_a))[:-1]
    inner_b = np.cumsum(check_hypothesis(rho_b))[:-1]
    cut = rng.uniform(0.0, 1.0)
    inner = np.concatenate([inner_a[inner_a < cut], inner_b[inner_b > cut]])
    return canonical_hypothesis(np.diff(np.concatenate([[0.0], inner, [1.0]])), n_windows)


def mutate(rho, n_windows: int, rng: np.random.Generator, insertion_share: float = 0.5) -> np.ndarray:
    """A mutation (4.1.3, step 3): insert a new value (uniform in (0, 2 / |rho|), the size of a
    typical share) at a random place, or scale one value by a factor uniform in (0, 2) (it may vanish:
    the rounding then drops it); then re-normalise (footnote 4: divide by the sum) and round."""
    values = check_hypothesis(rho).copy()
    if rng.uniform() < insertion_share and len(values) < n_windows:
        values = np.insert(values, rng.integers(len(values) + 1), rng.uniform(0.0, 2.0 / len(values)))
    else:
        values[rng.integers(len(values))] *= rng.uniform(0.0, 2.0)
    if not values.sum() > 0:
        return canonical_hypothesis(rho, n_windows)
    return canonical_hypothesis(values / values.sum(), n_windows)


def roulette(log_fitness: np.ndarray, size, rng: np.random.Generator) -> np.ndarray:
    """Indices drawn with probability proportional to the fitness (4.1.3, step 2), from its log."""
    log_fitness = np.asarray(log_fitness, dtype=float)
    if not np.isfinite(log_fitness).any():
        return rng.integers(len(log_fitness), size=size)
    weights = np.exp(log_fitness - np.max(log_fitness))
    return rng.choice(len(log_fitness), size=size, p=weights / weights.sum())


@dataclass
class GeneticResult:
    rho: np.ndarray
    log_fitness: float
    best_per_generation: list[float]


def evolve(
    fitness: Callable[[np.ndarray], float],
    n_windows: int,
    rate: float,
    settings: GeneticSettings,
    rng: np.random.Generator,
) -> GeneticResult:
    """The genetic algorithm of 4.1.3: Omega^1 random; then fitness, roulette selection of two parents
    per child, crossover, mutation; the best of the final generation is the answer."""
    population = [random_hypothesis(n_windows, rate, rng) for _ in range(settings.population)]
    best_per_generation = []
    for generation in range(settings.generations):
        scores = np.array([fitness(rho) for rho in population])
        best_per_generation.append(float(np.max(scores)))
        if generation == settings.generations - 1:
            break
        order = np.argsort(-scores, kind="stable")
        children = [population[i] for i in order[: settings.elite]]
        parents = roulette(scores, (settings.population - settings.elite, 2), rng)
        for a, b in parents:
            child = crossover(population[a], population[b], n_windows, rng)
            if rng.uniform() < settings.mutation_rate:
                child = mutate(child, n_windows, rng, settings.insertion_share)
            children.append(child)
        population = children
    best = int(np.argmax(scores))
    return GeneticResult(population[best], float(scores[best]), best_per_generation)


# ---------------------------------------------------------------------------------------------
# the sliding window (4.1.4, Fig. 4.5)


class Segment(NamedTuple):
    """A segmented action: frames start..end - 1."""

    start: int
    end: int
    action: Hashable


def incoming_messages(
    model: SegmentationModel, chain: list[ChainLink], n_deleted: int
) -> list[np.ndarray | None]:
    """log of the messages from the deleted links chain[:n_deleted] (and their factors) into each
    survivor (4.1.4): the survivor's marginal in the graph of the deleted links' unaries and of the
    sequence factors touching a deleted link - on a chain (order 1) exactly the message of the one
    factor joining it to the deleted part. None for a survivor no deleted factor touches."""
    pairs = [p for p in chain_pairs(len(chain), model.order) if p[1] < n_deleted]
    unaries = [c.log_unary if k < n_deleted else None for k, c in enumerate(chain)]
    touched = {k for k, _, _ in pairs if k >= n_deleted}
    if not touched:
        return [None] * (len(chain) - n_deleted)
    marginals = chain_graph(model, unaries, pairs).marginals()
    # floored at the smallest normal float: a potential must stay finite, and a value the message
    # makes 1e-308 times less likely than another is out of the MAP either way
    tiny = np.finfo(float).tiny
    return [
        np.log(np.maximum(marginals[("Y", k)], tiny)) if k in touched else None
        for k in range(n_deleted, len(chain))
    ]


class SlidingWindowSegmenter:
    """Segmentation on evolving windows (4.1.4) of already discretised observations: `push` one
    window's codes and frame bounds; every `batch_windows` windows the GA runs on the batch, the links
    before the last o are closed (their action: the argmax of the marginal, eq. (4.7)) and the last o
    survive with the incoming messages as unary potentials."""

    def __init__(
        self,
        model: SegmentationModel,
        batch_windows: int = 30,
        genetic: GeneticSettings | None = None,
        seed=0,
        prior_rate: float | None = None,
    ):
        self.model = model
        self.batch_windows = _check_int(batch_windows, "batch_windows", 1)
        self.genetic = genetic or GeneticSettings()
        self.prior_rate = prior_rate
        self._seed = seed
        self.reset()

    def clone(self) -> SlidingWindowSegmenter:
        """A copy that shares the (read-only) model: the state a Drake system keeps per Context."""
        twin = object.__new__(SlidingWindowSegmenter)
        twin.__dict__.update(self.__dict__)
        twin.rng = copy.deepcopy(self.rng)
        twin.survivors = [dataclasses.replace(link) for link in self.survivors]  # _process changes links
        twin._codes, twin._bounds = list(self._codes), list(self._bounds)
        return twin

    def reset(self) -> None:
        self.rng = _generator(self._seed)
        self.survivors: list[ChainLink] = []
        self._codes: list[np.ndarray] = []
        self._bounds: list[tuple[int, int]] = []
        self.last_result: GeneticResult | None = None

    def push(self, codes, bounds) -> list[Segment]:
        """One window's codes (F,) and its frames (start, end); returns the segments closed."""
        self._codes.append(self.model.check_codes(np.asarray(codes).reshape(1, -1))[0])
        self._bounds.append((int(bounds[0]), int(bounds[1])))
        return self._process() if len(self._codes) >= self.batch_windows else []

    def flush(self) -> list[Segment]:
        """Segment the pending windows (a shorter batch) and close every link; then start afresh."""
        closed = self._process() if self._codes else []
        closed += [self._close(link) for link in self.survivors]
        self.survivors = []
        return closed

    def _close(self, link: ChainLink) -> Segment:
        marginal = (
            link.marginal if link.marginal is not None else np.exp(link.log_unary - link.log_unary.max())
        )
        return Segment(link.start, link.end, self.model.actions[int(np.argmax(marginal))])

    def _process(self) -> list[Segment]:
        problem = WindowProblem(
            self.model, np.array(self._codes), self._bounds, self.survivors, self.prior_rate
        )
        self._codes, self._bounds = [], []
        result = evolve(problem.log_fitness, problem.n_windows, problem.prior_rate, self.genetic, self.rng)
        self.last_result = result
        chain = problem.links(segment_counts(result.rho, problem.n_windows))
        marginals = problem.graph(chain).marginals()  # X_i of eq. (4.7)
        for k, link in enumerate(chain):
            link.marginal = marginals[("Y", k)]
        n_deleted = len(chain) - min(self.model.order, len(chain))
        for link, message in zip(
            chain[n_deleted:], incoming_messages(self.model, chain, n_deleted), strict=True
        ):
            if message is not None:
                link.log_message = link.log_message + message
                link.log_sup += float(np.max(message))
        self.survivors = chain[n_deleted:]
        return [self._close(link) for link in chain[:n_deleted]]


# ---------------------------------------------------------------------------------------------
# training (4.1.5, Fig. 4.6)


def precedence_pairs(precedence, actions: Sequence[Hashable]) -> list[tuple[int, int]]:
    """(before, after) code pairs from a list of (before, after) label pairs or a successor map
    {label: labels that must come after it}; ValueError on unknown actions or a cycle."""
    code = {a: i for i, a in enumerate(actions)}
    if isinstance(precedence, Mapping):
        items = [(before, after) for before, afters in precedence.items() for after in afters]
    else:
        items = list(precedence)
    pairs = []
    for position, item in enumerate(items):
        if not isinstance(item, Sequence) or isinstance(item, str) or len(item) != 2:
            raise ValueError(f"precedence[{position}] must be a (before, after) pair, got {item!r}")
        for label in item:
            if label not in code:
                raise ValueError(
                    f"precedence[{position}]: unknown action {label!r}; known: {list(actions)!r}"
                )
        if item[0] == item[1]:
            raise ValueError(f"precedence[{position}]: action {item[0]!r} cannot precede itself")
        pairs.append((code[item[0]], code[item[1]]))
    _topological_order(len(actions), pairs, None, actions)
    return pairs


def _topological_order(n_actions: int, pairs, rng: np.random.Generator | None, actions=None) -> list[int]:
    """A valid order of all actions (Kahn's algorithm), the next one drawn uniformly among those whose
    predecessors are done (lowest first without rng)."""
    blockers = [set() for _ in range(n_actions)]
    for before, after in pairs:
        blockers[after].add(before)
    done: list[int] = []
    while len(done) < n_actions:
        ready = [a for a in range(n_actions) if a not in done and not blockers[a] - set(done)]
        if not ready:
            left = [actions[a] if actions is not None else a for a in range(n_actions) if a not in done]
            raise ValueError(f"precedence constraints have a cycle among actions {left!r}")
        done.append(ready[int(rng.integers(len(ready)))] if rng is not None else ready[0])
    return done


def artificial_sequence(n_actions: int, pairs, n_cycles: int, seed) -> np.ndarray:
    """Action codes of `n_cycles` assembly cycles one after the other, each a random order consistent
    with the precedence pairs (as the artificial series of 5.2.2, used in 4.1.5)."""
    n_cycles = _check_int(n_cycles, "n_cycles", 1)
    rng = _generator(seed)
    return np.array(
        [a for _ in range(n_cycles) for a in _topological_order(n_actions, pairs, rng)], dtype=np.int64
    )


def sequence_slices(series: np.ndarray, length: int, n_sequences: int, seed) -> np.ndarray:
    """`n_sequences` random contiguous slices of `length` actions of an artificial series, (N, K):
    the action sequences of the training set (Fig. 4.6)."""
    length = _check_int(length, "sequence_length", 1)
    n_sequences = _check_int(n_sequences, "n_sequences", 1)
    if length > len(series):
        raise ValueError(
            f"sequence_length={length} exceeds the {len(series)} actions of the artificial series"
        )
    starts = _generator(seed).integers(0, len(series) - length + 1, size=n_sequences)
    return series[starts[:, None] + np.arange(length)[None, :]]


@dataclass
class TrainingResult:
    w_obs: np.ndarray
    w_seq: float
    report: FitReport


def training_graph(
    phi_obs: np.ndarray, phi_seq: np.ndarray, length: int, windows_per_action: int
) -> FactorGraph:
    """The graph of Fig. 4.6: a chain of `length` actions ("Y", k) with the Psi^i_YY of eq. (4.2) and,
    on each, `windows_per_action` windows of F observations ("O", k, r, j) with Psi_OjY, eq. (4.1)."""
    n_features, n_bins, n_actions = phi_obs.shape
    graph = FactorGraph()
    for k in range(length):
        graph.add_variable(("Y", k), n_actions)
    for k in range(length):
        for r in range(windows_per_action):
            for j in range(n_features):
                graph.add_variable(("O", k, r, j), n_bins)
                graph.add_exponential_factor(
                    [("O", k, r, j), ("Y", k)], phi_obs[j], observation_weight_name(j)
                )
    for k, past, lag in chain_pairs(length, phi_seq.shape[0]):
        graph.add_exponential_factor([("Y", k), ("Y", past)], phi_seq[lag - 1], SEQUENCE_WEIGHT)
    return graph


def training_samples(
    codes, labels, sequences, windows_per_action: int, rng: np.random.Generator
) -> np.ndarray:
    """Rows of `training_graph` (Fig. 4.6): the action sequence, then for each action in it
    `windows_per_action` library windows of that action drawn at random (their codes)."""
    sequences = np.asarray(sequences, dtype=np.int64)
    picks = np.empty(sequences.shape + (windows_per_action,), dtype=np.int64)
    for action in np.unique(sequences):
        pool = np.flatnonzero(np.asarray(labels) == action)
        if pool.size == 0:
            raise ValueError(f"training: action code {action} of the sequences has no library window")
        where = sequences == action
        picks[where] = pool[rng.integers(pool.size, size=(int(where.sum()), windows_per_action))]
    observations = np.asarray(codes)[picks].reshape(len(sequences), -1)
    return np.hstack([sequences, observations])


def learn_weights(
    phi_obs,
    phi_seq,
    codes,
    labels,
    sequences,
    *,
    windows_per_action: int = 2,
    seed=0,
    l2: float = 1e-2,
    max_iter: int = 100,
) -> TrainingResult:
    """w_O1..w_OF and w_Y (4.1.5) by maximum likelihood (FactorGraph.fit, App. C.0.2-C.0.3) on the
    artificial action sequences (N, K) with observations sampled from the library windows `codes`
    (n, F) labelled `labels` (n,). A small L2 penalty keeps the weights finite when the data are
    deterministic (e.g. a single valid order makes w_Y grow without bound). Each w_Oj is fitted as
    u_j = w_Oj max Phi_Oj on Phi_Oj / max Phi_Oj (the same model), so the penalty and the optimiser
    see one scale whether Phi_OjY is a count of hundreds (4.1.1) or a frequency; the report's
    weights are the w, its gradient norm that of the u."""
    phi_obs, phi_seq = np.asarray(phi_obs, dtype=float), np.asarray(phi_seq, dtype=float)
    sequences = np.asarray(sequences)
    if sequences.ndim != 2 or sequences.shape[1] < 1 or not np.issubdtype(sequences.dtype, np.integer):
        raise ValueError(f"training sequences must be an integer (N, K) array, got shape {sequences.shape}")
    windows_per_action = _check_int(windows_per_action, "windows_per_action", 1)
    peak = np.max(np.abs(phi_obs), axis=(1, 2))
    scale = np.where(peak > 0, peak, 1.0)
    graph = training_graph(phi_obs / scale[:, None, None], phi_seq, sequences.shape[1], windows_per_action)
    samples = training_samples(codes, labels, sequences, windows_per_action, _generator(seed))
    report = graph.fit(samples, l2=l2, max_iter=max_iter)
    weights = dict(report.weights)
    w_obs = np.array([weights[observation_weight_name(j)] for j in range(phi_obs.shape[0])]) / scale
    weights.update({observation_weight_name(j): float(w) for j, w in enumerate(w_obs)})
    report = dataclasses.replace(report, weights=weights)
    return TrainingResult(w_obs, float(weights[SEQUENCE_WEIGHT]), report)


# ---------------------------------------------------------------------------------------------
# the segmenter


def library_windows(library, window_length: int, centres) -> tuple[list, list[np.ndarray], list[int]]:
    """Labels, F_O windows and lengths (in windows) of the recordings of a library [(action, frames)]."""
    if isinstance(library, str | bytes) or not isinstance(library, Sequence) or len(library) == 0:
        raise ValueError("library must be a non-empty sequence of (action, frames) recordings")
    labels, features, lengths = [], [], []
    for index, entry in enumerate(library):
        if not isinstance(entry, Sequence) or len(entry) != 2:
            raise ValueError(f"library[{index}] must be an (action, frames) pair")
        action, frames = entry
        values, _ = window_features(check_frames(frames, f"library[{index}] frames"), window_length, centres)
        labels.append(action)
        features.append(values)
        lengths.append(len(values))
    return labels, features, lengths


def _action_set(labels: list, actions: Sequence[Hashable] | None) -> tuple[Hashable, ...]:
    """The actions (given, or the sorted labels of the library), each with a recording."""
    if actions is None:
        try:
            actions = sorted(set(labels))
        except TypeError:
            raise ValueError("action labels are not sortable: pass actions=") from None
    actions = tuple(actions)
    unknown = [a for a in labels if a not in actions]
    if unknown:
        raise ValueError(f"library action {unknown[0]!r} is not in actions {list(actions)!r}")
    unrecorded = [a for a in actions if a not in set(labels)]
    if unrecorded:
        raise ValueError(f"actions {unrecorded!r} have no recording in the library")
    return actions


class Segmenter:
    """The action segmenter of thesis 4.1 on skeleton frames (T, 8, 3).

    window_length: l_w samples per observation window; batch_windows: L, observations per GA run;
    order: o of the sequence potentials (1: exact MAP on the chain; higher orders make the graph
    loopy and the MAP approximate); n_bins: values of each Ô_j; centres: goal/buffer centres (m, 3)
    or None; prior_rate: lambda of eq. (4.6) (None: `window_prior_rate`); observation_potential: how
    `fit` makes Phi_OjY (`observation_phi`: "counts" as 4.1.1, or "per_action_frequencies"); seed:
    an int (each `reset` restarts the same draws) or a Generator (shared, consumed); model: a learnt
    SegmentationModel (else call `fit`)."""

    def __init__(
        self,
        window_length: int,
        *,
        batch_windows: int = 30,
        order: int = 1,
        n_bins: int = 5,
        centres=None,
        prior_rate: float | None = None,
        genetic: GeneticSettings | None = None,
        seed=0,
        model: SegmentationModel | None = None,
        observation_potential: str = "counts",
    ):
        self.window_length = _check_int(window_length, "window_length", 1)
        self.batch_windows = _check_int(batch_windows, "batch_windows", 1)
        self.order = _check_int(order, "order", 1)
        self.n_bins = _check_int(n_bins, "n_bins", 2)
        self.centres = check_centres(centres)
        if prior_rate is not None and not (np.isfinite(prior_rate) and prior_rate > 0):
            raise ValueError(f"prior_rate must be finite and > 0, got {prior_rate!r}")
        self.prior_rate = prior_rate
        if observation_potential not in OBSERVATION_POTENTIALS:
            raise ValueError(
                f"observation_potential must be one of {OBSERVATION_POTENTIALS}, "
                f"got {observation_potential!r}"
            )
        self.observation_potential = observation_potential
        self.genetic = genetic or GeneticSettings()
        self.seed = seed
        self.fit_report_: FitReport | None = None
        self.model_ = model
        if model is not None:
            self._check_model(model)
        self.reset()

    def clone(self) -> Segmenter:
        """A copy that shares the learnt model and copies the stream (frames, windows, links)."""
        twin = object.__new__(Segmenter)
        twin.__dict__.update(self.__dict__)
        twin._frames = list(self._frames)
        twin._sliding = None if self._sliding is None else self._sliding.clone()
        return twin

    def _check_model(self, model: SegmentationModel) -> None:
        n_features = len(feature_names(len(self.centres)))
        if model.n_features != n_features:
            raise ValueError(
                f"model has {model.n_features} features; the segmenter's {len(self.centres)} centres "
                f"give {n_features}"
            )

    def fit(
        self,
        library,
        precedence,
        *,
        actions: Sequence[Hashable] | None = None,
        n_cycles: int = 20,
        n_sequences: int = 100,
        sequence_length: int | None = None,
        windows_per_action: int = 2,
        l2: float = 1e-2,
        max_iter: int = 100,
        seed=None,
    ) -> Segmenter:
        """Learn the model (4.1.1, 4.1.2, 4.1.5) from `library` [(action, frames (T, 8, 3))], one
        recording per executed action, and the precedence constraints (pairs or successor map).

        ECDF bins and Phi_OjY from the library windows; an artificial series of `n_cycles` valid
        orders gives the HOMM (lambda_i Q_i); `n_sequences` slices of it of `sequence_length`
        actions (default max(m, o + 1)) with `windows_per_action` library windows each train w_O, w_Y.
        """
        rng = _generator(self.seed if seed is None else seed)
        labels, features, lengths = library_windows(library, self.window_length, self.centres)
        actions = _action_set(labels, actions)
        code = {a: i for i, a in enumerate(actions)}
        window_labels = np.concatenate(
            [np.full(len(f), code[a]) for a, f in zip(labels, features, strict=True)]
        )
        values = np.vstack(features)
        edges = fit_ecdf_edges(values, self.n_bins)
        codes = discretise(values, edges)
        phi_obs = observation_phi(codes, window_labels, self.n_bins, len(actions), self.observation_potential)
        series = artificial_sequence(len(actions), precedence_pairs(precedence, actions), n_cycles, rng)
        phi_seq = sequence_phi(series, len(actions), self.order)
        length = max(len(actions), self.order + 1) if sequence_length is None else sequence_length
        sequences = sequence_slices(series, length, n_sequences, rng)
        trained = learn_weights(
            phi_obs, phi_seq, codes, window_labels, sequences,
            windows_per_action=windows_per_action, seed=rng, l2=l2, max_iter=max_iter,
        )  # fmt: skip
        self.model_ = SegmentationModel(
            actions, edges, phi_obs, phi_seq, trained.w_obs, trained.w_seq, float(np.mean(lengths))
        )
        self.fit_report_ = trained.report
        self.reset()
        return self

    # --- online -------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the stream (frames, windows, surviving links); an int seed restarts its draws."""
        self._frames: list[np.ndarray] = []
        self._n_frames = 0
        self._sliding = None
        if self.model_ is not None:
            self._sliding = SlidingWindowSegmenter(
                self.model_, self.batch_windows, self.genetic, self.seed, self.prior_rate
            )

    def _require_model(self, what: str) -> SlidingWindowSegmenter:
        if self._sliding is None:
            raise ValueError(f"Segmenter.{what}: no model; call fit(library, precedence) first")
        return self._sliding

    def _push_window(self, frames: np.ndarray) -> list[Segment]:
        values, _ = window_features(frames, len(frames), self.centres)
        codes = discretise(values, self.model_.edges)[0]
        start = self._n_frames - len(frames)
        return self._sliding.push(codes, (start, self._n_frames))

    def update(self, frame) -> list[Segment]:
        """One skeleton sample (8, 3); returns the segments closed by it (when it completes a batch of
        L windows, 4.1.4)."""
        self._require_model("update")
        sample = check_frames(np.asarray(frame, dtype=float)[None], f"frame {self._n_frames}")[0]
        self._frames.append(sample)
        self._n_frames += 1
        if len(self._frames) < self.window_length:
            return []
        frames, self._frames = np.array(self._frames), []
        return self._push_window(frames)

    def flush(self) -> list[Segment]:
        """End of the stream: the frames left make a last shorter window, the pending windows a last
        batch; every remaining link is closed. The segmenter is then reset."""
        sliding = self._require_model("flush")
        closed = self._push_window(np.array(self._frames)) if self._frames else []
        closed += sliding.flush()
        self.reset()
        return closed

    # --- offline ------------------------------------------------------------------------------

    def segment(self, frames, *, merge: bool = True) -> list[Segment]:
        """Segment a whole recording (T, 8, 3) with the sliding window of 4.1.4 (from a reset state,
        so the same seed gives the same answer); `merge` joins adjacent segments of the same action."""
        self._require_model("segment")
        frames = check_frames(frames)
        self.reset()  # a fresh SlidingWindowSegmenter, its generator restarted from the seed
        sliding = self._sliding
        values, bounds = window_features(frames, self.window_length, self.centres)
        closed: list[Segment] = []
        for row, (start, end) in zip(discretise(values, self.model_.edges), bounds, strict=True):
            closed += sliding.push(row, (start, end))
        closed += sliding.flush()
        self.reset()
        return merge_segments(closed) if merge else closed


def merge_segments(segments: Sequence[Segment]) -> list[Segment]:
    """Adjacent segments (one ends where the next starts) of the same action joined."""
    merged: list[Segment] = []
    for seg in map(Segment._make, segments):
        if merged and merged[-1].action == seg.action and merged[-1].end == seg.start:
            merged[-1] = Segment(merged[-1].start, seg.end, seg.action)
        else:
            merged.append(seg)
    return merged


# ---------------------------------------------------------------------------------------------
# segmentation error (4.2.1)


def _frame_labels(segments, what: str, n_frames: int | None = None) -> list:
    """Per-frame labels of a list of (start, end, action) segments (None where none), or a 1-d
    sequence of per-frame labels as is."""
    segments = list(segments)
    if segments and not all(isinstance(s, tuple) and len(s) == 3 for s in segments):
        return segments if n_frames is None else (segments + [None] * n_frames)[:n_frames]
    size = max((int(s[1]) for s in segments), default=0) if n_frames is None else n_frames
    labels: list = [None] * size
    for index, (start, end, action) in enumerate(segments):
        if not (_is_int(start) and _is_int(end)) or not 0 <= start < end:
            raise ValueError(
                f"{what}[{index}]: need integer frames 0 <= start < end, got ({start!r}, {end!r})"
            )
        if any(labels[f] is not None for f in range(start, min(end, size))):
            raise ValueError(f"{what}[{index}] ({start}, {end}) overlaps an earlier segment")
        labels[start : min(end, size)] = [action] * (min(end, size) - start)
    return labels


def segmentation_error(predicted, truth) -> float:
    """E_s of 4.2.1: the share of the camera samples (frames covered by `truth`) whose predicted action
    (the argmax of X_i, eq. (4.7)) differs from the true one; frames with no prediction count as
    errors. Both are lists of (start, end, action) segments or per-frame label sequences."""
    true_labels = _frame_labels(truth, "truth")
    guessed = _frame_labels(predicted, "predicted", len(true_labels))
    covered = [f for f, label in enumerate(true_labels) if label is not None]
    if not covered:
        raise ValueError("segmentation_error: the truth covers no frame")
    wrong = sum(1 for f in covered if guessed[f] is None or guessed[f] != true_labels[f])
    return wrong / len(covered)
