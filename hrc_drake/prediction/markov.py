"""Markov models of the action sequence (thesis 5.1).

Column convention of the thesis (eq. 5.2-5.4): Q[to, from], columns sum to 1, X_{k+1} = Q X_k.
The MTD higher-order model (eq. 5.7-5.8) mixes i-step matrices:
    X_hat_{k+1} = sum_{i=0..n} lambda_i Q_i X_{k-i},
Q_i being the (i+1)-step transition matrix counted over the FIFO buffer.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence

import numpy as np
from scipy.optimize import linprog, nnls

from .base import SequenceModel


def transition_matrices(sequence: Sequence[int], n_actions: int, order: int) -> np.ndarray:
    """Count-based step matrices Q_0..Q_n of eq. (5.8), shape (n+1, m, m) as Q[i, to, from].

    Q_i[to, from] = #(A_t = from, A_{t+i+1} = to) / #(A_t = from with t+i+1 in the sequence);
    a column never seen is uniform.
    """
    counts = transition_counts(sequence, n_actions, order)
    return counts_to_matrices(counts)


def transition_counts(sequence: Sequence[int], n_actions: int, order: int) -> np.ndarray:
    """Pair counts C[i, to, from] for lags i+1 = 1..order+1."""
    seq = np.asarray(sequence, dtype=int)
    counts = np.zeros((order + 1, n_actions, n_actions))
    for lag in range(order + 1):
        if seq.size > lag + 1:
            np.add.at(counts[lag], (seq[lag + 1 :], seq[: seq.size - lag - 1]), 1.0)
    return counts


def counts_to_matrices(counts: np.ndarray) -> np.ndarray:
    """Normalise the columns of C[i, to, from]; empty columns become uniform."""
    totals = counts.sum(axis=1, keepdims=True)
    m = counts.shape[1]
    with np.errstate(invalid="ignore", divide="ignore"):
        q = np.where(totals > 0, counts / np.where(totals > 0, totals, 1.0), 1.0 / m)
    return q


def mtd_regression(sequence: Sequence[int], matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stacked regression A lambda - b of eq. (5.9) over every step with a full history.

    Row block t holds [Q_0 X_{t-1}, Q_1 X_{t-2}, ..., Q_n X_{t-1-n}] against b block X_t.
    Returns A (T*m, n+1) and b (T*m,); T = 0 when the sequence is shorter than n+2.
    """
    seq = np.asarray(sequence, dtype=int)
    lags, m = matrices.shape[0], matrices.shape[1]
    targets = np.arange(lags, seq.size)
    if targets.size == 0:
        return np.zeros((0, lags)), np.zeros(0)
    past = seq[targets[:, None] - 1 - np.arange(lags)[None, :]]  # (T, n+1)
    # advanced indices around a slice put their broadcast axes first: (T, n+1, m)
    columns = matrices[np.arange(lags)[None, :], :, past]
    a_matrix = columns.transpose(0, 2, 1).reshape(-1, lags)
    b_vector = np.eye(m)[seq[targets]].reshape(-1)
    return a_matrix, b_vector


def simplex_least_squares(a_matrix: np.ndarray, b_vector: np.ndarray) -> np.ndarray:
    """min ||A lambda - b||^2 s.t. sum(lambda) = 1, lambda >= 0 (eq. 5.9).

    NNLS on the system augmented by a heavily weighted row `M * sum(lambda) = M`; the small
    residual of the equality is removed by renormalising.
    """
    lags = a_matrix.shape[1]
    if a_matrix.shape[0] == 0:
        return np.full(lags, 1.0 / lags)
    # the triangular factor keeps NNLS small whatever the buffer length
    q_factor, r_factor = np.linalg.qr(a_matrix)
    rhs = q_factor.T @ b_vector
    weight = 1e3 * max(1.0, float(np.abs(r_factor).max()))
    augmented = np.vstack([r_factor, np.full((1, lags), weight)])
    target = np.concatenate([rhs, [weight]])
    solution, _ = nnls(augmented, target, maxiter=50 * lags)
    total = solution.sum()
    if not np.isfinite(total) or total <= 0:
        return np.full(lags, 1.0 / lags)
    return solution / total


def ching_weights(matrices: np.ndarray, stationary: np.ndarray) -> np.ndarray:
    """Ching et al. weights: min ||sum_i lambda_i Q_i X_inf - X_inf||_inf on the simplex (LP)."""
    lags, m = matrices.shape[0], matrices.shape[1]
    columns = np.einsum("ijk,k->ji", matrices, stationary)  # (m, n+1): Q_i X_inf
    # variables: lambda_0..lambda_n, w; minimise w
    cost = np.zeros(lags + 1)
    cost[-1] = 1.0
    ones = np.ones((m, 1))
    a_ub = np.vstack([np.hstack([columns, -ones]), np.hstack([-columns, -ones])])
    b_ub = np.concatenate([stationary, -stationary])
    a_eq = np.concatenate([np.ones(lags), [0.0]])[None, :]
    result = linprog(cost, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=[1.0], bounds=[(0, None)] * (lags + 1))
    if not result.success:
        return np.full(lags, 1.0 / lags)
    weights = np.clip(result.x[:lags], 0.0, None)
    return weights / weights.sum()


class HigherOrderMarkovModel(SequenceModel):
    """Higher-order Markov model with the mixture transition distribution, eqs. (5.7)-(5.9).

    order: n, the model uses the n+1 most recent actions (n = 0 is a Markov chain).
    buffer_size: FIFO length the counts and weights are computed on (Fig. 5.1, 5.4).
    refit_every: recompute lambda every this many `partial_fit` calls (1: every action).

    Learned: matrices_ (n+1, m, m) Q_i[to, from]; weights_ (n+1,) lambda_i.
    Short histories use the available lags with their weights renormalised; an empty history
    gives the buffer marginal.
    """

    def __init__(
        self,
        order: int = 3,
        buffer_size: int | None = 200,
        actions: int | Sequence[Hashable] | None = None,
        refit_every: int = 1,
    ):
        super().__init__(actions=actions, buffer_size=buffer_size)
        self.order = order
        self.refit_every = refit_every

    @property
    def context_length_(self) -> int:
        return int(self.order) + 1

    def _params(self) -> dict:
        return {"order": self.order, "buffer_size": self.buffer_size, "refit_every": self.refit_every}

    def _state_to_dict(self) -> dict:
        # lambda may lag the buffer by up to refit_every - 1 actions: keep it as learned
        return {"weights": self.weights_.tolist(), "since_refit": int(self._since_refit)}

    def _restore(self, codes: tuple[int, ...], n_observed: int, state: dict) -> None:
        super()._restore(codes, n_observed, state)
        self.matrices_ = counts_to_matrices(self.counts_)
        self._matrices_stale = False
        if "weights" in state:
            weights = np.asarray(state["weights"], dtype=float)
            if weights.shape != self.weights_.shape or not np.all(np.isfinite(weights)):
                raise ValueError(
                    f"{type(self).__name__}.from_dict: weights must be {self.weights_.size} finite numbers"
                )
            self.weights_ = weights
        else:
            self.weights_ = self._fit_weights()
        self._since_refit = int(state.get("since_refit", 0))

    def _clone_state(self) -> None:
        self.counts_ = self.counts_.copy()  # += in place; matrices_ and weights_ are replaced

    def _reset_state(self) -> None:
        if int(self.order) < 0:
            raise ValueError(f"{type(self).__name__}: order={self.order} must be >= 0")
        if int(self.refit_every) < 1:
            raise ValueError(f"{type(self).__name__}: refit_every={self.refit_every} must be >= 1")
        lags = int(self.order) + 1
        m = self.n_actions_
        self.counts_ = np.zeros((lags, m, m))
        self.matrices_ = np.full((lags, m, m), 1.0 / m)
        self.weights_ = np.full(lags, 1.0 / lags)
        self._since_refit = 0
        self._matrices_stale = False

    def _learn_newest(self) -> None:
        newest = len(self.buffer_) - 1
        newest_code = self.buffer_[newest]
        for lag in range(min(int(self.order) + 1, newest)):
            self.counts_[lag, newest_code, self.buffer_[newest - 1 - lag]] += 1.0
        self._matrices_stale = True

    def _forget_oldest(self) -> None:
        oldest_code = self.buffer_[0]
        for lag in range(min(int(self.order) + 1, len(self.buffer_) - 1)):
            self.counts_[lag, self.buffer_[1 + lag], oldest_code] -= 1.0
        self._matrices_stale = True

    def _update_fit(self, final: bool) -> None:
        self._since_refit += 1
        if final or self._since_refit >= int(self.refit_every):
            self._since_refit = 0
            self.matrices_ = counts_to_matrices(self.counts_)
            self._matrices_stale = False
            self.weights_ = self._fit_weights()

    def _fit_weights(self) -> np.ndarray:
        if int(self.order) == 0:
            return np.ones(1)
        a_matrix, b_vector = mtd_regression(list(self.buffer_), self.matrices_)
        return simplex_least_squares(a_matrix, b_vector)

    def _predict_codes(self, context: tuple[int, ...]) -> np.ndarray:
        if self._matrices_stale:
            self.matrices_ = counts_to_matrices(self.counts_)
            self._matrices_stale = False
        if not context:
            return self.marginal_()
        lags = min(len(context), int(self.order) + 1)
        recent = np.asarray(context[::-1][:lags], dtype=int)  # A_k, A_{k-1}, ...
        weights = self.weights_[:lags]
        total = weights.sum()
        if total <= 0:
            weights, total = np.ones(lags), float(lags)
        probs = np.einsum("i,ij->j", weights, self.matrices_[np.arange(lags), :, recent]) / total
        return probs / probs.sum()

    def _predict_many(self, contexts: list[tuple[int, ...]]) -> np.ndarray:
        lags = int(self.order) + 1
        if any(len(ctx) < lags for ctx in contexts):
            return super()._predict_many(contexts)
        if self._matrices_stale:
            self.matrices_ = counts_to_matrices(self.counts_)
            self._matrices_stale = False
        recent = np.asarray(contexts, dtype=int)[:, ::-1]  # (N, n+1): A_k, A_{k-1}, ...
        columns = self.matrices_[np.arange(lags)[None, :], :, recent]  # (N, n+1, m)
        probs = np.einsum("i,nij->nj", self.weights_ / self.weights_.sum(), columns)
        return probs / probs.sum(axis=1, keepdims=True)


class MarkovChainModel(HigherOrderMarkovModel):
    """First-order Markov chain, X_{k+1} = Q X_k (eq. 5.4), counts over the FIFO buffer."""

    def __init__(self, buffer_size: int | None = 200, actions: int | Sequence[Hashable] | None = None):
        super().__init__(order=0, buffer_size=buffer_size, actions=actions)

    def _params(self) -> dict:
        return {"buffer_size": self.buffer_size}


class ChingHigherOrderModel(HigherOrderMarkovModel):
    """MTD model with the weights of Ching et al. [26]: fit to the stationary distribution.

    lambda minimises ||sum_i lambda_i Q_i X_inf - X_inf||_inf on the simplex, X_inf being the
    action frequencies in the buffer (baseline of Fig. 5.4).
    """

    def _fit_weights(self) -> np.ndarray:
        if int(self.order) == 0:
            return np.ones(1)
        return ching_weights(self.matrices_, self.marginal_())
