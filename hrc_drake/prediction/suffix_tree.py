"""Suffix-tree model of the action sequence with affine-set priors (thesis 5.2).

P(A_k = a | A_k^sigma) = Psi(A_k^sigma, a) / Z,  Psi = exp(w_0 Phi_v + sum_i w_i Phi_Ci)  (5.10)-(5.13)

The tree holds every observed branch A_k^sigma |> A_k of length sigma+1 with its token set
Gamma (the steps it was seen at, 5.2.1). Phi_v depends on the domain of (A_k^sigma, a):
D1 the branch exists (5.27), D2 a branch with the same actions in another order exists
(5.28)-(5.30), D3 otherwise (5.31)-(5.32). Phi_Ci are the affine-set priors (5.33); the
weights w maximise the log-likelihood (5.34) by gradient ascent (5.35)-(5.36).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Hashable, Iterable, Sequence

import numpy as np

from .base import SequenceModel


def occurrence_counts(sequences: np.ndarray, n_actions: int) -> np.ndarray:
    """Operator I of eq. (5.16): I[Y]_a = number of times a occurs in Y.

    sequences: (N, L) action indices; returns (N, m).
    """
    seqs = np.atleast_2d(np.asarray(sequences, dtype=int))
    return np.eye(n_actions, dtype=int)[seqs].sum(axis=1)


def occurrence_positions(sequences: np.ndarray, n_actions: int) -> np.ndarray:
    """Operator O of eq. (5.18): O[Y]_a^K = 1-based position of the K-th occurrence of a, or 0.

    sequences: (N, L) action indices; returns (N, m, L) with axis 2 holding K = 1..L.
    """
    seqs = np.atleast_2d(np.asarray(sequences, dtype=int))
    n_seqs, length = seqs.shape
    ranks = np.cumsum(np.eye(n_actions, dtype=int)[seqs], axis=1)  # (N, L, m)
    rank_of_position = np.take_along_axis(ranks, seqs[:, :, None], axis=2)[:, :, 0]
    out = np.zeros((n_seqs, n_actions, length), dtype=int)
    rows = np.repeat(np.arange(n_seqs), length)
    out[rows, seqs.ravel(), rank_of_position.ravel() - 1] = np.tile(np.arange(1, length + 1), n_seqs)
    return out


def distance_i(x: Sequence[int], y: Sequence[int], n_actions: int) -> int:
    """d_I of eq. (5.19): L1 distance between the action counts of two sequences."""
    return int(np.abs(occurrence_counts([x], n_actions) - occurrence_counts([y], n_actions)).sum())


def distance_o(x: Sequence[int], y: Sequence[int], n_actions: int) -> int:
    """d_O of eq. (5.20): L1 distance between the occurrence positions of two sequences."""
    length = max(len(x), len(y))
    ox = np.zeros((n_actions, length), dtype=int)
    oy = np.zeros((n_actions, length), dtype=int)
    ox[:, : len(x)] = occurrence_positions([x], n_actions)[0]
    oy[:, : len(y)] = occurrence_positions([y], n_actions)[0]
    return int(np.abs(ox - oy).sum())


def activation(tokens: Iterable[float], step: float, forgetting: float) -> float:
    """f_act^Gamma(n) = sum_{gamma in Gamma} exp(-alpha (n - gamma)), eq. (5.26)."""
    tokens = np.fromiter(tokens, dtype=float)
    return float(np.exp(-forgetting * (step - tokens)).sum())


def affine_prior(context: Sequence[int], members: np.ndarray, forgetting: float) -> np.ndarray:
    """Phi_Ci(A_k^sigma, a) of eq. (5.33) for every set i and candidate a, shape (N_C, m).

    Phi_Ci = sum_{j=1..sigma} L_Ci(A_{k-j}, a) exp(-alpha j) with L_Ci = 1 when A_{k-j} and a
    are distinct members of C_i, -1/(|C_i|-1) when A_{k-j} = a is a member, 0 otherwise.
    The text's first case omits "a in C_i"; without it the prior would not favour the set,
    so we read it as requiring both actions in the set.
    members: (N_C, m) bool, row i the indicator of C_i.
    """
    n_sets, m = members.shape
    if n_sets == 0 or len(context) == 0:
        return np.zeros((n_sets, m))
    recent = np.asarray(context, dtype=int)[::-1]  # A_{k-1}, A_{k-2}, ...
    decay = np.exp(-forgetting * np.arange(1, recent.size + 1))
    sizes = members.sum(axis=1)
    same = recent[None, :] == np.arange(m)[:, None]  # (m, sigma)
    past_in_set = members[:, recent]  # (N_C, sigma)
    penalty = -1.0 / (sizes - 1.0)
    lag_terms = np.where(same[None, :, :], penalty[:, None, None], past_in_set[:, None, :].astype(float))
    lag_terms = lag_terms * members[:, :, None]
    return lag_terms @ decay


def affine_prior_many(contexts: np.ndarray, members: np.ndarray, forgetting: float) -> np.ndarray:
    """`affine_prior` (eq. 5.33) of N contexts (N, sigma) at once, shape (N_C, N, m)."""
    contexts = np.atleast_2d(np.asarray(contexts, dtype=int))
    n_sets, m = members.shape
    n_ctx, sigma = contexts.shape
    if n_sets == 0 or sigma == 0:
        return np.zeros((n_sets, n_ctx, m))
    recent = contexts[:, ::-1]  # A_{k-1}, A_{k-2}, ...
    decay = np.exp(-forgetting * np.arange(1, sigma + 1))
    penalty = -1.0 / (members.sum(axis=1) - 1.0)
    same = recent[:, None, :] == np.arange(m)[None, :, None]  # (N, m, sigma)
    past_in_set = members[:, recent].astype(float)  # (N_C, N, sigma)
    lag_terms = np.where(same[None], penalty[:, None, None, None], past_in_set[:, :, None, :])
    return (lag_terms * members[:, None, :, None]) @ decay


class SuffixTreeModel(SequenceModel):
    """Suffix-tree next-action model with affine-set priors, thesis 5.2 (eqs. 5.10-5.36).

    order: sigma, the number of past actions in a context (branches have sigma+1 actions).
    affine_sets: sets C_i of actions (labels) likely done in sequence, each with >= 2 actions.
    forgetting: alpha of the activation (5.26); a token weighs exp(-alpha * age), and the
        text's forgetting time is N = 5 / alpha steps. A branch's activation only rests on
        the tokens of about 1 / alpha recent steps: for a stationary process alpha must be
        small enough that every branch collects several tokens (Fig. 5.7 uses 0.002).
    token_threshold: tokens whose weight exp(-alpha * age) fell below it are dropped, and
        branches left without tokens are removed: memory stays bounded.
    learning_window: number of recent steps whose features enter the likelihood (5.34).
    learning_iterations: gradient-ascent steps per `partial_fit` (a full `fit` runs 10x more).
    l2: ridge on w, keeps w finite when the data separate perfectly (not in the thesis).

    The likelihood uses, for each step j, the features computed with the tree as it was
    before A_j was inserted (the predictive likelihood): with the tree after insertion the
    true branch would always be in D1.
    Learned: weights_ (1 + N_C,) = [w_0, w_C1, ...]; branches_ (B, sigma+1); token_sets_.
    Many contexts are scored in one vectorised call (`predict_proba_many`, used by the
    waiting-time tree); `to_dict` / `SequenceModel.from_dict` save and restore the tree,
    tokens, training window and weights exactly.
    """

    def __init__(
        self,
        order: int = 3,
        affine_sets: Sequence[Iterable[Hashable]] = (),
        forgetting: float = 0.02,
        actions: int | Sequence[Hashable] | None = None,
        token_threshold: float = 1e-3,
        learning_window: int = 300,
        learning_iterations: int = 3,
        l2: float = 1e-3,
    ):
        super().__init__(actions=actions, buffer_size=None)
        self.order = order
        self.affine_sets = affine_sets
        self.forgetting = forgetting
        self.token_threshold = token_threshold
        self.learning_window = learning_window
        self.learning_iterations = learning_iterations
        self.l2 = l2

    @property
    def context_length_(self) -> int:
        return int(self.order)

    def _params(self) -> dict:
        return {
            "order": self.order,
            "affine_sets": [list(s) for s in self.affine_sets],
            "forgetting": self.forgetting,
            "token_threshold": self.token_threshold,
            "learning_window": self.learning_window,
            "learning_iterations": self.learning_iterations,
            "l2": self.l2,
        }

    # ---------------------------------------------------------------- persistence
    def _state_to_dict(self) -> dict:
        count = self._train_count
        return {
            "branches": self._branches.tolist(),
            "activation": self._activation.tolist(),
            "n_tokens": self._n_tokens.tolist(),
            "tokens": [[int(step), int(index)] for step, index in self._tokens],
            "weights": self.weights_.tolist(),
            "step_size": float(self._step_size),
            # the ring buffer of training steps as stored (the sums then add up identically)
            "train_features": self._train_features[:count].tolist(),
            "train_targets": self._train_targets[:count].tolist(),
            "train_next": int(self._train_next),
        }

    def _restore(self, codes: tuple[int, ...], n_observed: int, state: dict) -> None:
        """The tree, tokens and training window as saved (a replay of the bounded buffer
        would renumber the tokens and relearn w differently)."""
        if not state:  # a bare buffer: rebuild by replaying it
            super()._restore(codes, n_observed, state)
            self._update_fit(final=True)
            return
        m, sigma = self.n_actions_, int(self.order)
        branches = np.asarray(state["branches"], dtype=int).reshape(-1, sigma + 1)
        activation = np.asarray(state["activation"], dtype=float)
        n_tokens = np.asarray(state["n_tokens"], dtype=int)
        tokens = [(int(step), int(index)) for step, index in state["tokens"]]
        weights = np.asarray(state["weights"], dtype=float)
        features = np.asarray(state["train_features"], dtype=float).reshape(-1, m, weights.size)
        targets = np.asarray(state["train_targets"], dtype=int)
        n_branches = branches.shape[0]
        problems = []
        if branches.size and (branches.min() < 0 or branches.max() >= m):
            problems.append("branch actions outside 0..m-1")
        if activation.shape != (n_branches,) or n_tokens.shape != (n_branches,):
            problems.append("activation/n_tokens do not match the branches")
        if any(not 0 <= index < n_branches for _, index in tokens):
            problems.append("a token names a missing branch")
        if weights.shape != self.weights_.shape:
            problems.append(f"weights need {self.weights_.size} values")
        if targets.shape != (features.shape[0],) or features.shape[0] > int(self.learning_window):
            problems.append("training window does not match learning_window")
        if not all(np.all(np.isfinite(values)) for values in (weights, activation, features)):
            problems.append("non-finite numbers")
        if problems:
            raise ValueError(f"SuffixTreeModel.from_dict: {'; '.join(problems)}")
        self.buffer_ = deque(codes)
        self.n_observed_ = max(n_observed, len(codes))
        self._branches = branches
        self._counts = occurrence_counts(branches, m) if n_branches else np.zeros((0, m), dtype=int)
        self._positions = (
            occurrence_positions(branches, m).reshape(n_branches, -1)
            if n_branches
            else np.zeros((0, m * (sigma + 1)), dtype=int)
        )
        self._branch_index = {tuple(int(v) for v in row): i for i, row in enumerate(branches)}
        self._activation = activation
        self._n_tokens = n_tokens
        self._tokens = deque(tokens)
        self.weights_ = weights
        self._step_size = float(state.get("step_size", 1.0))
        count = features.shape[0]
        self._train_features[:count] = features
        self._train_targets[:count] = targets
        self._train_count = count
        self._train_next = int(state.get("train_next", count)) % int(self.learning_window)

    # ---------------------------------------------------------------- state
    def _clone_state(self) -> None:
        """What `_learn_newest` writes in place: activation, token counts and list, the branch
        index and the training ring buffer. Branch rows, counts and positions are only ever
        replaced (vstack, masks), so they stay shared."""
        self._branch_index = dict(self._branch_index)
        self._activation = self._activation.copy()
        self._n_tokens = self._n_tokens.copy()
        self._tokens = deque(self._tokens)
        self._train_features = self._train_features.copy()
        self._train_targets = self._train_targets.copy()

    def _reset_state(self) -> None:
        sigma = int(self.order)
        if sigma < 1:
            raise ValueError(f"SuffixTreeModel: order={self.order} must be >= 1")
        alpha = float(self.forgetting)
        if not (np.isfinite(alpha) and alpha > 0):
            raise ValueError(f"SuffixTreeModel: forgetting={self.forgetting} must be a positive number")
        if not 0 < float(self.token_threshold) < 1:
            raise ValueError(f"SuffixTreeModel: token_threshold={self.token_threshold} must be in (0, 1)")
        if int(self.learning_window) < 1:
            raise ValueError(f"SuffixTreeModel: learning_window={self.learning_window} must be >= 1")
        m = self.n_actions_
        members = []
        for index, labels in enumerate(self.affine_sets):
            row = np.zeros(m, dtype=bool)
            try:
                row[list(self.encode(labels))] = True
            except ValueError as err:
                raise ValueError(f"SuffixTreeModel: affine_sets[{index}]: {err}") from None
            if row.sum() < 2:
                raise ValueError(f"SuffixTreeModel: affine_sets[{index}] needs at least 2 distinct actions")
            members.append(row)
        self._members = np.array(members, dtype=bool).reshape(len(members), m)
        # a token older than this many steps weighs less than token_threshold
        self._token_life = int(math.ceil(math.log(1.0 / float(self.token_threshold)) / alpha))
        self._decay = math.exp(-alpha)
        self._branch_index: dict[tuple[int, ...], int] = {}
        self._branches = np.zeros((0, sigma + 1), dtype=int)
        self._counts = np.zeros((0, m), dtype=int)
        self._positions = np.zeros((0, m * (sigma + 1)), dtype=int)
        self._activation = np.zeros(0)  # f_act at the newest step
        self._n_tokens = np.zeros(0, dtype=int)
        self._tokens: deque[tuple[int, int]] = deque()  # (step, branch), oldest first
        n_features = 1 + len(members)
        self.weights_ = np.ones(n_features)
        self._train_features = np.zeros((int(self.learning_window), m, n_features))
        self._train_targets = np.zeros(int(self.learning_window), dtype=int)
        self._train_count = 0
        self._train_next = 0
        self._step_size = 1.0
        self._last_features: tuple | None = None
        self._tables: tuple | None = None

    def _learn_newest(self) -> None:
        sigma = int(self.order)
        step = self.n_observed_  # k: 1-based index of the newest action
        newest = self.buffer_[-1]
        if len(self.buffer_) > sigma:
            end = len(self.buffer_) - 1
            context = tuple(self.buffer_[i] for i in range(end - sigma, end))
            # the features of the prediction just made for this step, if any (same tree)
            self._store_training(self._features_cached(context), newest)
            self._activation *= self._decay
            self._add_token(context + (newest,), step)
        else:
            self._activation *= self._decay
        self._drop_old_tokens(step)

    def _buffer_limit(self) -> int:
        # the buffer keeps what rebuilds the tree (persistence) and the current context
        return self._token_life + int(self.order) + 1

    def _forget_oldest(self) -> None:
        """The tree keeps its own memory (tokens); the buffer only serves persistence."""

    def _add_token(self, branch: tuple[int, ...], step: int) -> None:
        index = self._branch_index.get(branch)
        if index is None:  # case b): a new branch
            index = len(self._branch_index)
            self._branch_index[branch] = index
            row = np.asarray(branch, dtype=int)[None, :]
            self._branches = np.vstack([self._branches, row])
            self._counts = np.vstack([self._counts, occurrence_counts(row, self.n_actions_)])
            self._positions = np.vstack(
                [self._positions, occurrence_positions(row, self.n_actions_).reshape(1, -1)]
            )
            self._activation = np.append(self._activation, 0.0)
            self._n_tokens = np.append(self._n_tokens, 0)
        self._activation[index] += 1.0
        self._n_tokens[index] += 1
        self._tokens.append((step, index))

    def _drop_old_tokens(self, step: int) -> None:
        dropped = False
        while self._tokens and step - self._tokens[0][0] > self._token_life:
            token_step, index = self._tokens.popleft()
            self._activation[index] = max(0.0, self._activation[index] - self._decay ** (step - token_step))
            self._n_tokens[index] -= 1
            if self._n_tokens[index] == 0:
                self._activation[index] = 0.0
                dropped = True
        if dropped:
            dead = int(np.count_nonzero(self._n_tokens == 0))
            if dead > max(16, len(self._n_tokens) // 4):
                self._remove_dead_branches()

    def _remove_dead_branches(self) -> None:
        keep = self._n_tokens > 0
        new_index = np.cumsum(keep) - 1
        self._branches = self._branches[keep]
        self._counts = self._counts[keep]
        self._positions = self._positions[keep]
        self._activation = self._activation[keep]
        self._n_tokens = self._n_tokens[keep]
        self._tokens = deque((s, int(new_index[i])) for s, i in self._tokens)
        self._branch_index = {tuple(int(v) for v in row): i for i, row in enumerate(self._branches)}

    # ---------------------------------------------------------------- inspection
    @property
    def branches_(self) -> list[tuple]:
        """Branches (labels, oldest first) that hold at least one token."""
        rows = self._branches[self._n_tokens > 0]
        return [tuple(self.classes_[c] for c in row) for row in rows]

    @property
    def token_sets_(self) -> dict[tuple, list[int]]:
        """Gamma of each branch: the steps (1-based) at which the branch was observed."""
        out: dict[tuple, list[int]] = {}
        for step, index in self._tokens:
            key = tuple(self.classes_[c] for c in self._branches[index])
            out.setdefault(key, []).append(step)
        return out

    @property
    def n_tokens_(self) -> int:
        return len(self._tokens)

    def domains(self, context: Sequence[Hashable]) -> np.ndarray:
        """Domain (1, 2 or 3) of (context, a) for every candidate a, eqs. (5.22)-(5.25)."""
        codes = self._context_codes(context)
        return self._domains_and_phi_many(np.array([codes]))[0][0]

    def phi_v(self, context: Sequence[Hashable]) -> np.ndarray:
        """Phi_v(context, a | ST) for every candidate a at the next step, eq. (5.21)."""
        codes = self._context_codes(context)
        return self._domains_and_phi_many(np.array([codes]))[1][0]

    def _context_codes(self, context: Sequence[Hashable]) -> tuple[int, ...]:
        codes = self.encode(context)
        if len(codes) != int(self.order):
            raise ValueError(f"SuffixTreeModel: a context has order={self.order} actions, got {len(codes)}")
        return codes

    # ---------------------------------------------------------------- features
    def _domains_and_phi(self, context: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Reference form of `_domains_and_phi_many` for one context: the candidate sequences
        and the distances of eqs. (5.19)-(5.20) to every branch, as written in the text."""
        m = self.n_actions_
        n_branches = self._branches.shape[0]
        if n_branches == 0:
            return np.full(m, 3), np.zeros(m)
        # activation at the step being predicted, one step after the newest token
        act = self._activation * self._decay
        alive = self._n_tokens > 0
        candidates = np.empty((m, len(context) + 1), dtype=int)
        candidates[:, :-1] = context
        candidates[:, -1] = np.arange(m)
        d_i = np.abs(occurrence_counts(candidates, m)[:, None, :] - self._counts[None, :, :]).sum(axis=2)
        positions = occurrence_positions(candidates, m).reshape(m, -1)
        d_o = np.abs(positions[:, None, :] - self._positions[None, :, :]).sum(axis=2)
        d_i = np.where(alive[None, :], d_i, -1)  # dead branches match nothing
        exact = (d_i == 0) & (d_o == 0)
        permuted = (d_i == 0) & ~exact
        in_d1 = exact.any(axis=1)
        in_d2 = ~in_d1 & permuted.any(axis=1)
        phi1 = (exact * act[None, :]).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            n_perm = permuted.sum(axis=1)
            phi2 = np.where(permuted, act[None, :] / np.where(permuted, d_o, 1), 0.0).sum(axis=1)
            phi2 = np.where(n_perm > 0, phi2 / np.maximum(n_perm, 1), 0.0)
            delta = np.where(alive[None, :], d_i + d_o, 1)
            n_alive = max(int(alive.sum()), 1)
            phi3 = np.where(alive[None, :], act[None, :] / delta, 0.0).sum(axis=1) / n_alive
        domain = np.where(in_d1, 1, np.where(in_d2, 2, 3))
        phi = np.where(in_d1, phi1, np.where(in_d2, phi2, phi3))
        return domain, phi

    def _branch_tables(self) -> tuple | None:
        """Arrays of the live branches for `_domains_and_phi_many`, cached while the tree is
        unchanged (state_id_): activation at the next step (B,), counts I[B] (m, B),
        positions O[B]_a^K as (m, K, B), and q + [q > 0] as (m, K, B). None without branches."""
        if self._tables is not None and self._tables[0] == self.state_id_:
            return self._tables[1]
        alive = self._n_tokens > 0
        tables = None
        if alive.any():
            m, sigma = self.n_actions_, int(self.order)
            positions = self._positions[alive].reshape(-1, m, sigma + 1)
            positions = np.ascontiguousarray(positions.transpose(1, 2, 0))
            tables = (
                self._activation[alive] * self._decay,  # at the step being predicted
                np.ascontiguousarray(self._counts[alive].T),
                positions,
                np.where(positions > 0, positions + 1, 0).astype(np.int16),
            )
        self._tables = (self.state_id_, tables)
        return tables

    def _domains_and_phi_many(self, contexts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Domains and Phi_v (N, m) of N full contexts (N, sigma) at once, eqs. (5.21)-(5.32).

        Same values as `_domains_and_phi`, without building the N*m candidate sequences.
        For Y = context |> a and a branch B, let q = O[B]_a^K be the position in B of the
        occurrence K = I[context]_a + 1 of a (0 if B has none). Appending a only adds the
        entry O[Y]_a^K = sigma+1 and one count of a, so
            d_I(Y, B) = d_I(context, B) - 1 if q > 0 else + 1,
            d_O(Y, B) = d_O(context, B) + sigma + 1 - 2 q.
        Context-to-branch distances need only the sigma entries the context holds, as
        sum |x - y| = sum x + sum y - 2 sum min(x, y) for non-negative entries. d_I(Y, B) = 0
        (D1, D2) needs d_I(context, B) = 1, a sparse set of (context, branch) pairs.
        """
        m = self.n_actions_
        contexts = np.asarray(contexts, dtype=np.int64).reshape(-1, int(self.order))
        n_ctx, sigma = contexts.shape
        tables = self._branch_tables()
        if tables is None:
            return np.full((n_ctx, m), 3), np.zeros((n_ctx, m))
        act, counts_b, positions_b, shift = tables
        n_branches = act.size
        one_hot = contexts[:, :, None] == np.arange(m)[None, None, :]  # (N, sigma, m)
        rank = np.take_along_axis(np.cumsum(one_hot, axis=1), contexts[:, :, None], axis=2)[:, :, 0]
        counts_ctx = one_hot.sum(axis=1)  # (N, m)
        # sum_i min(I[ctx]_i, I[B]_i) = #slots whose occurrence rank is <= I[B] of their action
        shared_counts = (rank[:, :, None] <= counts_b[contexts]).sum(axis=1)  # (N, B)
        d_i_ctx = 2 * sigma + 1 - 2 * shared_counts
        slot_position = np.arange(1, sigma + 1)[None, :, None]
        shared_positions = np.minimum(slot_position, positions_b[contexts, rank - 1]).sum(axis=1)
        d_o_ctx = sigma * (sigma + 1) // 2 + (sigma + 1) * (sigma + 2) // 2 - 2 * shared_positions

        # D3, eqs. (5.31)-(5.32): delta = d_I(ctx) + d_O(ctx) + sigma + 2 - 2 (q + [q > 0])
        base = (d_i_ctx + d_o_ctx + sigma + 2).astype(np.int16)  # (N, B)
        delta = base[:, None, :] - 2 * shift[np.arange(m)[None, :], counts_ctx]  # (N, m, B)
        reciprocal = 1.0 / np.maximum(np.arange(int(base.max()) + 1), 1)  # delta >= 1 wherever D3 applies
        phi3 = reciprocal[delta] @ act / n_branches

        # D1 and D2, eqs. (5.22)-(5.30): the pairs with d_I(ctx, B) = 1, one candidate each
        pair_ctx, pair_branch = np.nonzero(d_i_ctx == 1)
        pair_action = np.argmax(counts_b.T[pair_branch] - counts_ctx[pair_ctx], axis=1)
        q = positions_b[pair_action, counts_ctx[pair_ctx, pair_action], pair_branch]
        d_o = d_o_ctx[pair_ctx, pair_branch] + sigma + 1 - 2 * q
        cell = pair_ctx * m + pair_action
        pair_act = act[pair_branch]
        exact = d_o == 0
        size = n_ctx * m
        phi1 = np.bincount(cell, weights=np.where(exact, pair_act, 0.0), minlength=size).reshape(n_ctx, m)
        in_d1 = np.bincount(cell, weights=exact, minlength=size).reshape(n_ctx, m) > 0
        n_perm = np.bincount(cell, weights=~exact, minlength=size).reshape(n_ctx, m)
        phi2 = np.bincount(cell, weights=np.where(exact, 0.0, pair_act / np.maximum(d_o, 1)), minlength=size)
        phi2 = phi2.reshape(n_ctx, m) / np.maximum(n_perm, 1)
        in_d2 = ~in_d1 & (n_perm > 0)
        domain = np.where(in_d1, 1, np.where(in_d2, 2, 3))
        phi = np.where(in_d1, phi1, np.where(in_d2, phi2, phi3))
        return domain, phi

    def _features_many(self, contexts: np.ndarray) -> np.ndarray:
        """Features [Phi_v, Phi_C1, ...] of N full contexts, shape (N, m, 1 + N_C)."""
        contexts = np.asarray(contexts, dtype=np.int64).reshape(-1, int(self.order))
        _, phi = self._domains_and_phi_many(contexts)
        prior = affine_prior_many(contexts, self._members, float(self.forgetting))  # (N_C, N, m)
        return np.concatenate([phi[:, :, None], prior.transpose(1, 2, 0)], axis=2)

    def _predict_many(self, contexts: list[tuple[int, ...]]) -> np.ndarray:
        sigma = int(self.order)
        out = np.empty((len(contexts), self.n_actions_))
        full = [i for i, ctx in enumerate(contexts) if len(ctx) >= sigma]
        for i in range(len(contexts)):
            if len(contexts[i]) < sigma:
                out[i] = self._short_context_fallback(contexts[i])
        if full:
            rows = np.array([contexts[i][len(contexts[i]) - sigma :] for i in full], dtype=np.int64)
            scores = self._features_many(rows) @ self.weights_
            scores -= scores.max(axis=1, keepdims=True)
            probs = np.exp(scores)
            out[full] = probs / probs.sum(axis=1, keepdims=True)
        return out

    def _features_cached(self, context: tuple[int, ...]) -> np.ndarray:
        """`_features`, reused while the tree is unchanged (state_id_) and asked again."""
        key = (self.state_id_, context)
        if self._last_features is None or self._last_features[0] != key:
            self._last_features = (key, self._features(context))
        return self._last_features[1]

    def _features(self, context: tuple[int, ...]) -> np.ndarray:
        """Features [Phi_v, Phi_C1, ...] of every candidate, shape (m, 1 + N_C)."""
        return self._features_many(np.array([context]))[0]

    # ---------------------------------------------------------------- weights
    def _store_training(self, features: np.ndarray, target: int) -> None:
        self._train_features[self._train_next] = features
        self._train_targets[self._train_next] = target
        self._train_next = (self._train_next + 1) % int(self.learning_window)
        self._train_count = min(self._train_count + 1, int(self.learning_window))

    def log_likelihood(self, weights: np.ndarray | None = None) -> float:
        """Mean of eq. (5.34) over the learning window, minus the ridge term."""
        return self._objective(self.weights_ if weights is None else np.asarray(weights, dtype=float))[0]

    def _objective(self, weights: np.ndarray) -> tuple[float, np.ndarray]:
        count = self._train_count
        features = self._train_features[:count]
        targets = self._train_targets[:count]
        scores = features @ weights  # (T, m)
        top = scores.max(axis=1, keepdims=True)
        exp_scores = np.exp(scores - top)
        norm = exp_scores.sum(axis=1, keepdims=True)
        log_z = top[:, 0] + np.log(norm[:, 0])
        probs = exp_scores / norm
        chosen_sum = features[np.arange(count), targets].sum(axis=0)  # (d,)
        ridge = 0.5 * float(self.l2) * weights @ weights
        value = float(chosen_sum @ weights - log_z.sum()) / count - ridge
        # gradient of eqs. (5.35)-(5.36), averaged over steps
        expected = probs.reshape(1, -1) @ features.reshape(-1, features.shape[2])  # sum_t sum_a P Phi
        gradient = (chosen_sum - expected[0]) / count - float(self.l2) * weights
        return value, gradient

    def _update_fit(self, final: bool) -> None:
        if self._train_count == 0:
            return
        iterations = int(self.learning_iterations) * (10 if final else 1)
        weights = self.weights_
        value, gradient = self._objective(weights)
        for _ in range(iterations):
            step = self._step_size
            # Armijo backtracking keeps the ascent monotone without a tuned learning rate
            for _ in range(20):
                trial = weights + step * gradient
                trial_value, trial_gradient = self._objective(trial)
                if trial_value >= value + 1e-4 * step * gradient @ gradient:
                    break
                step *= 0.5
            else:
                break
            weights, value, gradient = trial, trial_value, trial_gradient
            self._step_size = min(step * 2.0, 1e3)
        self.weights_ = weights

    # ---------------------------------------------------------------- prediction
    def _predict_codes(self, context: tuple[int, ...]) -> np.ndarray:
        sigma = int(self.order)
        if len(context) >= sigma:
            scores = self._features_cached(tuple(context[len(context) - sigma :])) @ self.weights_
            scores -= scores.max()
            probs = np.exp(scores)
            return probs / probs.sum()
        return self._short_context_fallback(context)

    def _short_context_fallback(self, context: tuple[int, ...]) -> np.ndarray:
        """Fewer than sigma past actions: activation-weighted next actions of the branches whose
        context ends with them (all branches for an empty context); uniform without branches."""
        m = self.n_actions_
        act = self._activation * (self._n_tokens > 0)
        if act.size == 0 or act.sum() <= 0:
            return np.full(m, 1.0 / m)
        sigma = int(self.order)
        if context:
            tail = self._branches[:, sigma - len(context) : sigma]
            match = (tail == np.asarray(context)[None, :]).all(axis=1)
            if (act * match).sum() > 0:
                act = act * match
        probs = np.bincount(self._branches[:, -1], weights=act, minlength=m)
        return probs / probs.sum()
