"""Factor graphs over categorical variables: belief propagation, MAP and weight learning.

The undirected graphical models of the thesis, Appendix C: P(V) = E(V) / Z with the energy
E = prod_i Phi_i(D^i), eq. (C.3)-(C.5); factors are simple (an explicit non-negative table) or
exponential, Psi = exp(w Phi), eq. (C.7), as the potentials of the action segmentation, eq. (4.1)
(observation-action, weight w_Oj) and eq. (4.2) (action-action, one weight w_Y shared by all).

Public API (names of variables are any hashable; values are 0 .. cardinality - 1)::

    g = FactorGraph()
    g.add_variable(name, cardinality)
    g.add_factor(variables, table)                         # simple potential, eq. (C.2)
    g.add_exponential_factor(variables, phi, weight_name, weight=None)   # exp(w phi), (C.7)/(4.1)
    g.add_correlation_factor(a, b, weight=None, weight_name=None)        # exp(w [a == b])
    g.marginals(evidence, max_iter=, damping=, tol=)  -> {name: probabilities}   sum-product
    g.map(evidence, max_iter=, damping=, tol=)        -> {name: value}           max-product
    g.log_partition(evidence)  -> log Z(o), eq. (C.11)      g.log_energy(assignment) -> log E
    g.weights() / g.set_weights({name: w})                 g.variables -> {name: cardinality}
    g.fit(samples, method="lbfgs" | "gradient", ...) -> FitReport       App. C.0.2-C.0.3
    g.last_report  -> BPReport(mode, exact, converged, iterations, max_change, feasible) of the last query

Inference. Evidence is conditioned on by slicing the factors (eq. (C.21), Fig. C.4); factors left
over the same set of hidden variables are merged. If the remaining factor graph is a forest, the
message passing of App. C.0.1 is exact: leaves-to-root then root-to-leaves on each connected
component (rooted at its centre, so the sweeps are short), messages of eq. (C.20) for the
marginals and of eq. (C.22) for the MAP, which is decoded by backtracking from the root (an exact
argmax; ties go to the lowest value, in row-major order within a factor). If it has cycles,
loopy belief propagation (flooding schedule, messages damped in probability space) is run and
reported; the marginals are then approximate, and the MAP is the argmax of each max-marginal,
eq. (C.23), which is approximate too (a strong local optimum, not always the global one).
Messages are kept in log space, normalised, so long chains do not underflow.

Zeros. A query whose evidence leaves Z(o) = 0 raises ValueError ("zero probability"), on trees
(a variable with no possible value, exact there) and on loopy graphs too, where BP alone cannot
see it (a triangle of "not equal" factors on two values keeps uniform, converged messages):
when a loopy graph has zero entries, a depth-first search with arc consistency over the zeros
(`_possible_assignment`) looks for an assignment of non-zero energy. Its verdict is
`last_report.feasible`; the loopy MAP is that search's answer, values tried in max-marginal
order, so it is the argmax of eq. (C.23) whenever that is possible and a possible one otherwise.

Learning (App. C.0.2-C.0.3). The average log-likelihood J(W) of fully observed samples,
eq. (C.29), has the gradient of eq. (C.38): for a weight shared by several factors the sum over
them of (empirical mean of Phi - mean of Phi under the model), eq. (C.40)-(C.42); the model means
come from the factor beliefs of belief propagation, and log Z from the Bethe free energy of those
beliefs (both exact on trees, approximate on loopy graphs).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, sparse

SUM = "sum"
MAX = "max"
_NEG_INF = -np.inf
#: Compiled graphs kept, one per set of observed variables.
_CACHED_STRUCTURES = 32
#: Values the search for a possible assignment of a loopy graph with zeros tries before giving up.
SEARCH_BUDGET = 20000


@dataclass(frozen=True)
class BPReport:
    """How the last inference went: `exact` when the graph left by the evidence is a forest (then
    `converged` is True, `iterations` 1 and `max_change` 0); otherwise loopy BP's iterations and
    the largest change of a message (probabilities) in the last one. `feasible`: an assignment of
    non-zero energy exists (True), none does (False: Z = 0, the query raised ValueError), or the
    search of a loopy graph with zeros gave up after `SEARCH_BUDGET` nodes (None: unknown)."""

    mode: str
    exact: bool
    converged: bool
    iterations: int
    max_change: float
    feasible: bool | None = True


@dataclass(frozen=True)
class FitReport:
    """Result of `FactorGraph.fit`: the average log-likelihood J of eq. (C.29) at the returned
    weights (without the L2 penalty) and the largest component of the gradient of the penalised
    objective; `weights` are the fitted weights (also set on the graph)."""

    iterations: int
    log_likelihood: float
    gradient_norm: float
    converged: bool
    message: str
    weights: dict[str, float] = field(default_factory=dict)


@dataclass
class _Factor:
    variables: tuple[int, ...]
    log_base: np.ndarray  # the fixed part of log Phi
    phi: np.ndarray | None = None  # feature table of an exponential factor, eq. (C.7)
    weight_name: str | None = None


@dataclass(frozen=True)
class _Role:
    """Where an original factor goes once the evidence is sliced out: a constant, a unary prior
    of hidden variable `target`, or merged factor `target` (its axes permuted by `perm`)."""

    kind: str
    target: int = -1
    perm: tuple[int, ...] = ()


@dataclass
class _Group:
    """Merged factors of one shape, stacked so their messages are computed together."""

    shape: tuple[int, ...]
    members: list[int]
    edges: np.ndarray  # (n_members, arity) edge ids


@dataclass
class _Structure:
    """The factor graph left on the hidden variables by a set of observed ones."""

    hidden: list[int]
    local: dict[int, int]  # variable index -> hidden index
    card: np.ndarray
    kmax: int
    roles: list[_Role]
    merged_vars: list[tuple[int, ...]]
    merged_slot: list[tuple[int, int]]  # merged factor -> (group, row)
    groups: list[_Group]
    edge_var: np.ndarray
    incidence: sparse.csr_matrix  # (hidden variables, edges)
    degree: np.ndarray
    forest: bool
    up: list = field(default_factory=list)
    down: list = field(default_factory=list)
    backtrack: list = field(default_factory=list)
    roots: list[int] = field(default_factory=list)
    feasible: dict = field(default_factory=dict)  # evidence items -> verdict of the search


# ---------------------------------------------------------------------------------------------
# log-space helpers (the callers silence numpy's log(0) and -inf - -inf warnings: see _quiet)


def _quiet(method):
    """Run `method` with numpy's divide/invalid warnings off: log(0) = -inf is meant here."""

    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        with np.errstate(divide="ignore", invalid="ignore"):
            return method(*args, **kwargs)

    return wrapper


def _logsumexp(x: np.ndarray, axis) -> np.ndarray:
    peak = np.max(x, axis=axis, keepdims=True)
    peak[~np.isfinite(peak)] = 0.0  # an all -inf slice stays -inf, never nan
    return np.squeeze(np.log(np.sum(np.exp(x - peak), axis=axis, keepdims=True)) + peak, axis=axis)


def _normalize(x: np.ndarray) -> np.ndarray:
    """Shift the last axis of a log array to peak at 0 (a message's scale is arbitrary; the peak
    is cheaper than the sum and keeps every entry <= 0)."""
    shift = np.max(x, axis=-1, keepdims=True)
    shift[~np.isfinite(shift)] = 0.0
    return x - shift


def _log_normalize(x: np.ndarray) -> np.ndarray:
    """Shift the last axis of a log array to log-probabilities (sum 1)."""
    shift = _logsumexp(x, -1)[..., None]
    shift[~np.isfinite(shift)] = 0.0
    return x - shift


def _split(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A log array as (finite part, count of zeros): sums of messages can then leave one out
    exactly, where -inf - -inf would be nan."""
    zero = x == _NEG_INF
    return np.where(zero, 0.0, x), zero.astype(np.int64)


def _join(finite: np.ndarray, zeros: np.ndarray) -> np.ndarray:
    return np.where(zeros > 0, _NEG_INF, finite)


def _is_index(value) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


# ---------------------------------------------------------------------------------------------
# message passing on a compiled structure


class _Propagation:
    """The messages of one query: q (variable -> factor) and r (factor -> variable) per edge, in
    log space, normalised, padded with -inf beyond each variable's cardinality. The sums of the
    r messages into each variable are kept (finite part and count of zeros) so that a message
    leaving a variable is its prior plus that sum minus the edge's own message."""

    def __init__(self, st: _Structure, prior: np.ndarray, tables: list[np.ndarray], mode: str):
        self.st, self.prior, self.tables, self.mode = st, prior, tables, mode
        pad = np.where(np.arange(st.kmax)[None, :] < st.card[st.edge_var][:, None], 0.0, _NEG_INF)
        self.q = pad.copy()
        self.r = pad
        self.prior_fin, self.prior_zero = _split(prior)
        self.possible: np.ndarray | None = None  # a possible assignment found by `_possible_assignment`
        self._totals()

    def _totals(self) -> None:
        self.r_fin, self.r_zero = _split(self.r)
        self.tot_fin = self.st.incidence @ self.r_fin
        self.tot_zero = self.st.incidence @ self.r_zero

    def update_q(self, edges: np.ndarray) -> None:
        """Eq. (C.20), the product part: prior times all incoming messages but the edge's own."""
        v = self.st.edge_var[edges]
        fin = self.prior_fin[v] + self.tot_fin[v] - self.r_fin[edges]
        zero = self.prior_zero[v] + self.tot_zero[v] - self.r_zero[edges]
        self.q[edges] = _normalize(_join(fin, zero))

    def _with_incoming(self, g: int, rows: np.ndarray, skip: int) -> np.ndarray:
        """Log tables of factors `rows` of group g plus the q messages of all but position `skip`."""
        grp = self.st.groups[g]
        arity = len(grp.shape)
        t = self.tables[g][rows]
        for i in range(arity):
            if i != skip:
                shape = [len(rows)] + [1] * arity
                shape[i + 1] = grp.shape[i]
                t = t + self.q[grp.edges[rows, i], : grp.shape[i]].reshape(shape)
        return t

    def factor_messages(self, g: int, j: int, rows: np.ndarray) -> np.ndarray:
        """Eq. (C.20) (sum) or (C.22) (max) from the factors `rows` of group g to their j-th variable."""
        t = self._with_incoming(g, rows, j)
        axes = tuple(k for k in range(1, t.ndim) if k != j + 1)
        # the peak is taken per value of the receiving variable: a shared one would underflow the
        # far-off values to exact zeros
        m = _logsumexp(t, axes) if self.mode == SUM else np.max(t, axis=axes)
        out = np.full((len(rows), self.st.kmax), _NEG_INF)
        out[:, : m.shape[1]] = m
        return _normalize(out)

    def update_r(self, items) -> None:
        for g, j, rows, edges in items:
            new = self.factor_messages(g, j, rows)
            new_fin, new_zero = _split(new)
            v = self.st.edge_var[edges]
            np.add.at(self.tot_fin, v, new_fin - self.r_fin[edges])
            np.add.at(self.tot_zero, v, new_zero - self.r_zero[edges])
            self.r[edges], self.r_fin[edges], self.r_zero[edges] = new, new_fin, new_zero

    @_quiet
    def tree_passes(self, downward: bool = True) -> None:
        """Leaves-to-root, then root-to-leaves (App. C.0.1, Fig. C.5): each message once."""
        for kind, payload in self.st.up + (self.st.down if downward else []):
            if kind == "q":
                self.update_q(payload)
            else:
                self.update_r(payload)

    @_quiet
    def loopy(self, max_iter: int, damping: float, tol: float) -> tuple[bool, int, float]:
        """Loopy BP (flooding): all messages from uniform ones, recomputed until they settle."""
        st = self.st
        all_edges = np.arange(len(st.edge_var))
        items = [
            (g, j, np.arange(len(grp.members)), grp.edges[:, j])
            for g, grp in enumerate(st.groups)
            for j in range(len(grp.shape))
        ]
        change, iterations = np.inf, 0
        while iterations < max_iter:
            iterations += 1
            self.update_q(all_edges)
            new = self.r.copy()
            for g, j, rows, edges in items:
                new[edges] = self.factor_messages(g, j, rows)
            if damping > 0.0:
                # damped in probability space, where a mixture of zeros stays a zero
                new = _normalize(np.logaddexp(np.log1p(-damping) + new, np.log(damping) + self.r))
            change = float(np.max(np.abs(np.exp(new) - np.exp(self.r)), initial=0.0))
            self.r = new
            self._totals()
            if change < tol:
                break
        self.update_q(all_edges)
        return change < tol, iterations, change

    @_quiet
    def variable_beliefs(self) -> np.ndarray:
        """Eq. (C.19)/(C.23): prior times all incoming messages, (hidden, kmax) log; normalised to
        log-probabilities (sum-product) or to peak at 0 (max-marginals, max-product)."""
        b = _join(self.prior_fin + self.tot_fin, self.prior_zero + self.tot_zero)
        return _log_normalize(b) if self.mode == SUM else _normalize(b)

    @_quiet
    def factor_beliefs(self) -> list[np.ndarray]:
        """Log joint beliefs of the merged factors, one stacked array per group (sum-product)."""
        out = []
        for g, grp in enumerate(self.st.groups):
            t = self._with_incoming(g, np.arange(len(grp.members)), -1)
            axes = tuple(range(1, t.ndim))
            out.append(t - np.expand_dims(_logsumexp(t, axes), axes))
        return out

    @_quiet
    def bethe_log_partition(self, const: float) -> float:
        """log Z from the beliefs: sum_f E_bf[log Phi_f - log b_f] + sum_v (d_v - 1) E_bv[log b_v]
        + sum_v E_bv[log prior_v] (minus the Bethe free energy), exact on trees."""
        total = const
        for t, lb in zip(self.tables, self.factor_beliefs(), strict=True):
            total += float(np.sum(np.where(np.isfinite(lb), np.exp(lb) * (t - lb), 0.0)))
        lb = self.variable_beliefs()
        live = np.isfinite(lb)
        terms = np.where(live, self.prior, 0.0) + (self.st.degree[:, None] - 1) * np.where(live, lb, 0.0)
        return total + float(np.sum(np.where(live, np.exp(lb) * terms, 0.0)))

    @_quiet
    def backtrack(self) -> np.ndarray:
        """MAP values by backtracking after the max-product upward pass (exact on forests)."""
        st = self.st
        values = np.zeros(len(st.hidden), dtype=np.int64)
        beliefs = self.variable_beliefs()
        for root in st.roots:
            values[root] = int(np.argmax(beliefs[root]))
        for g, p, rows, parents, children in st.backtrack:
            t = self._with_incoming(g, rows, p)
            t = np.moveaxis(t, p + 1, 1)[np.arange(len(rows)), values[parents]]
            best = np.unravel_index(np.argmax(t.reshape(len(rows), -1), axis=1), t.shape[1:])
            for k, child_values in enumerate(best):
                values[children[:, k]] = child_values
        return values


# ---------------------------------------------------------------------------------------------
# compiling the hidden graph and its schedule


def _merge_factors(factors: list[tuple[int, ...]], local: dict[int, int]):
    """The role of each factor once the observed variables are sliced out; factors left on the
    same set of hidden variables become one merged factor (over them in increasing order), so
    that a repeated pair does not make a cycle."""
    roles: list[_Role] = []
    merged: dict[tuple[int, ...], int] = {}
    for variables in factors:
        on = [local[v] for v in variables if v in local]
        if len(on) < 2:
            roles.append(_Role("prior", on[0]) if on else _Role("const"))
            continue
        m = merged.setdefault(tuple(sorted(on)), len(merged))
        roles.append(_Role("merged", m, tuple(int(a) for a in np.argsort(on))))
    return roles, list(merged)


def _edge_layout(merged_vars: list[tuple[int, ...]], card: np.ndarray):
    """Edge ids (one per merged factor and position) and the groups of factors of equal shape."""
    edge_of, edge_var = [], []
    for key in merged_vars:
        edge_of.append(list(range(len(edge_var), len(edge_var) + len(key))))
        edge_var.extend(key)
    by_shape: dict[tuple[int, ...], list[int]] = {}
    for m, key in enumerate(merged_vars):
        by_shape.setdefault(tuple(int(card[v]) for v in key), []).append(m)
    groups, slot = [], [(0, 0)] * len(merged_vars)
    for g, (shape, members) in enumerate(by_shape.items()):
        groups.append(_Group(shape, members, np.array([edge_of[m] for m in members], dtype=np.int64)))
        for row, m in enumerate(members):
            slot[m] = (g, row)
    return groups, slot, edge_of, np.array(edge_var, dtype=np.int64)


def _bfs(start: int, adj: list[list[int]]) -> tuple[list[int], dict[int, int], dict[int, int]]:
    order, parent, depth = [start], {start: -1}, {start: 0}
    for node in order:  # the list grows while it is walked: a queue
        for nxt in adj[node]:
            if nxt not in depth:
                parent[nxt], depth[nxt] = node, depth[node] + 1
                order.append(nxt)
    return order, parent, depth


def _centre(start: int, adj: list[list[int]], n_vars: int) -> int:
    """A variable node at the centre of a tree (double BFS), so that both sweeps are short."""
    order, _, _ = _bfs(start, adj)
    order, parent, _ = _bfs(order[-1], adj)
    path = [order[-1]]
    while parent[path[-1]] != -1:
        path.append(parent[path[-1]])
    mid = len(path) // 2
    return path[mid] if path[mid] < n_vars else path[mid - 1]


def _grouped(entries: list[tuple[int, int, int, int]]) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """(group, position, row, edge) entries as arrays per (group, position)."""
    buckets: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for g, j, row, edge in entries:
        buckets.setdefault((g, j), []).append((row, edge))
    return [
        (g, j, np.array([a for a, _ in pairs]), np.array([b for _, b in pairs]))
        for (g, j), pairs in sorted(buckets.items())
    ]


def _levels(st: _Structure, adj: list[list[int]]) -> list[list[tuple[int, int]]]:
    """Nodes (variables, then n_vars + factor) by depth from each component's root, with parents."""
    n_vars = len(st.hidden)
    levels: list[list[tuple[int, int]]] = []
    seen = np.zeros(n_vars, dtype=bool)
    for start in range(n_vars):
        if seen[start]:
            continue
        root = _centre(start, adj, n_vars) if adj[start] else start
        st.roots.append(root)
        order, parent, depth = _bfs(root, adj)
        for node in order:
            if node < n_vars:
                seen[node] = True
            while len(levels) <= depth[node]:
                levels.append([])
            levels[depth[node]].append((node, parent[node]))
    return levels


def _schedule(st: _Structure, edge_of: list[list[int]]) -> None:
    """Fill the two sweeps and the backtracking steps of a forest, level by level: variables sit
    at even depths, factors at odd ones."""
    n_vars = len(st.hidden)
    adj: list[list[int]] = [[] for _ in range(n_vars + len(st.merged_vars))]
    for m, key in enumerate(st.merged_vars):
        for v in key:
            adj[v].append(n_vars + m)
            adj[n_vars + m].append(v)
    levels = _levels(st, adj)

    def edge(m: int, v: int) -> tuple[int, int, int, int]:
        j = st.merged_vars[m].index(v)
        g, row = st.merged_slot[m]
        return g, j, row, edge_of[m][j]

    for d in range(len(levels) - 1, 0, -1):
        if d % 2 == 0:  # variables send to their parent factor
            st.up.append(("q", np.array([edge(p - n_vars, v)[3] for v, p in levels[d]])))
        else:
            st.up.append(("r", _grouped([edge(m - n_vars, p) for m, p in levels[d]])))
    for d in range(len(levels) - 1):
        if d % 2 == 0:
            kids = [edge(m - n_vars, v)[3] for v, p in levels[d] for m in adj[v] if m != p]
            if kids:
                st.down.append(("q", np.array(kids)))
        else:
            entries = [
                edge(m - n_vars, v) for m, p in levels[d] for v in st.merged_vars[m - n_vars] if v != p
            ]
            st.down.append(("r", _grouped(entries)))
            st.backtrack.extend(_backtrack_steps(st, [(m - n_vars, p) for m, p in levels[d]]))


def _backtrack_steps(st: _Structure, factors: list[tuple[int, int]]) -> list:
    buckets: dict[tuple[int, int], list[tuple[int, int, list[int]]]] = {}
    for m, parent in factors:
        key = st.merged_vars[m]
        p = key.index(parent)
        g, row = st.merged_slot[m]
        buckets.setdefault((g, p), []).append((row, parent, [v for v in key if v != parent]))
    return [
        (g, p, np.array([a for a, _, _ in e]), np.array([b for _, b, _ in e]), np.array([c for _, _, c in e]))
        for (g, p), e in sorted(buckets.items())
    ]


# ---------------------------------------------------------------------------------------------
# zeros on loopy graphs: is any assignment possible?


def _zero_factors(st: _Structure, tables: list[np.ndarray]) -> list[tuple[tuple[int, ...], np.ndarray]]:
    """(hidden variables, mask of the possible entries) of every merged factor with a zero."""
    out = []
    for g, grp in enumerate(st.groups):
        for row, m in enumerate(grp.members):
            possible = np.isfinite(tables[g][row])
            if not possible.all():
                out.append((st.merged_vars[m], possible))
    return out


def _arc_consistent(domains: list[np.ndarray], factors, watching, queue) -> bool:
    """Generalised arc consistency over the zeros: each domain shrunk to the values some possible
    entry of each of its factors supports (domains are replaced, never changed in place); False
    when a domain empties."""
    pending = set(queue)
    queue = list(queue)
    while queue:
        f = queue.pop()
        pending.discard(f)
        variables, possible = factors[f]
        arity = len(variables)
        t = possible
        for i, v in enumerate(variables):
            shape = [1] * arity
            shape[i] = len(domains[v])
            t = t & domains[v].reshape(shape)
        for i, v in enumerate(variables):
            support = t.any(axis=tuple(a for a in range(arity) if a != i))
            if np.array_equal(support, domains[v]):
                continue
            if not support.any():
                return False
            domains[v] = support
            for h in watching[v]:
                if h != f and h not in pending:
                    pending.add(h)
                    queue.append(h)
    return True


def _possible_assignment(
    st: _Structure, prior: np.ndarray, tables: list[np.ndarray], preference: np.ndarray, budget: int
) -> tuple[bool | None, np.ndarray | None]:
    """(True, values) of non-zero energy, (False, None) when none exists (Z = 0), (None, None) when
    `budget` values were tried in vain. Depth-first over the variables of the zero factors (fewest
    values left first) with arc consistency after each choice; values in decreasing `preference`
    (hidden, kmax), so the first assignment tried is its argmax. Variables outside the zero
    factors take their preferred possible value."""
    n = len(st.hidden)
    domains = [np.isfinite(prior[v, : st.card[v]]) for v in range(n)]
    if not all(d.any() for d in domains):
        return False, None
    factors = _zero_factors(st, tables)
    watching: list[list[int]] = [[] for _ in range(n)]
    for f, (variables, _) in enumerate(factors):
        for v in variables:
            watching[v].append(f)
    constrained = [v for v in range(n) if watching[v]]
    if not _arc_consistent(domains, factors, watching, range(len(factors))):
        return False, None

    def candidates(v: int, doms: list[np.ndarray]):
        order = np.argsort(-preference[v, : st.card[v]], kind="stable")
        return iter([int(x) for x in order if doms[v][x]])

    def pick(doms: list[np.ndarray]) -> int | None:
        open_ = [v for v in constrained if doms[v].sum() > 1]
        return min(open_, key=lambda v: int(doms[v].sum())) if open_ else None

    def finish(doms: list[np.ndarray]) -> np.ndarray:
        masked = np.where(np.stack([np.pad(d, (0, st.kmax - len(d))) for d in doms]), preference, -np.inf)
        return np.argmax(masked, axis=1).astype(np.int64)

    first = pick(domains)
    if first is None:
        return True, finish(domains)
    stack = [(domains, first, candidates(first, domains))]
    tried = 0
    while stack:
        doms, v, values = stack[-1]
        x = next(values, None)
        if x is None:
            stack.pop()
            continue
        tried += 1
        if tried > budget:
            return None, None
        trial = list(doms)
        trial[v] = np.arange(st.card[v]) == x
        if not _arc_consistent(trial, factors, watching, watching[v]):
            continue
        nxt = pick(trial)
        if nxt is None:
            return True, finish(trial)
        stack.append((trial, nxt, candidates(nxt, trial)))
    return False, None


# ---------------------------------------------------------------------------------------------
# the graph


class FactorGraph:
    """A factor graph over categorical variables (App. C); see the module docstring."""

    def __init__(self) -> None:
        self._names: list[Hashable] = []
        self._index: dict[Hashable, int] = {}
        self._cards: list[int] = []
        self._factors: list[_Factor] = []
        self._weights: dict[str, float] = {}
        self._structures: dict[frozenset[int], _Structure] = {}
        self.last_report: BPReport | None = None

    # --- building ---------------------------------------------------------------------------

    @property
    def variables(self) -> dict[Hashable, int]:
        """Variable names (insertion order) and their cardinalities."""
        return dict(zip(self._names, self._cards, strict=True))

    def add_variable(self, name: Hashable, cardinality: int) -> None:
        if name in self._index:
            raise ValueError(f"duplicate variable {name!r}")
        if not _is_index(cardinality) or cardinality < 1:
            raise ValueError(f"cardinality of variable {name!r} must be an integer >= 1, got {cardinality!r}")
        self._index[name] = len(self._names)
        self._names.append(name)
        self._cards.append(int(cardinality))
        self._structures.clear()

    def add_factor(self, variables: Sequence[Hashable], table) -> None:
        """A simple potential, eq. (C.2): a non-negative table with one axis per variable."""
        idx = self._factor_variables(variables)
        values = self._table(idx, table, "table")
        if np.any(values < 0):
            raise ValueError(f"table of factor over {self._label(idx)} has negative entries")
        if not np.any(values > 0):
            raise ValueError(f"table of factor over {self._label(idx)} is all zero")
        with np.errstate(divide="ignore"):
            self._append(_Factor(idx, np.log(values)))

    def add_exponential_factor(
        self, variables: Sequence[Hashable], phi, weight_name: str, weight: float | None = None
    ) -> None:
        """Psi = exp(w phi), eq. (C.7), (4.1)-(4.2); factors with the same `weight_name` share w.
        A new weight starts at `weight` (1.0 if None); for an existing one `weight` must match."""
        idx = self._factor_variables(variables)
        features = self._table(idx, phi, "phi")
        self._declare_weight(weight_name, weight)
        self._append(_Factor(idx, np.zeros(features.shape), features, weight_name))

    def add_correlation_factor(
        self, a: Hashable, b: Hashable, weight: float | None = None, weight_name: str | None = None
    ) -> None:
        """exp(w) where a == b, 1 elsewhere: fixed (w = `weight`, 1.0 if None) unless `weight_name`
        makes w a shared learnable weight (then as in `add_exponential_factor`)."""
        idx = self._factor_variables([a, b])
        ka, kb = (self._cards[i] for i in idx)
        if ka != kb:
            raise ValueError(f"correlation factor between {a!r} ({ka} values) and {b!r} ({kb} values)")
        eye = np.eye(ka)
        if weight_name is not None:
            self._declare_weight(weight_name, weight)
            self._append(_Factor(idx, np.zeros((ka, ka)), eye, weight_name))
            return
        w = 1.0 if weight is None else self._finite_weight("correlation weight", weight)
        self._append(_Factor(idx, w * eye))

    def weights(self) -> dict[str, float]:
        return dict(self._weights)

    def set_weights(self, weights: Mapping[str, float]) -> None:
        for name in weights:
            if name not in self._weights:
                raise ValueError(f"unknown weight name {name!r}; known: {sorted(self._weights)}")
        for name, value in weights.items():
            self._weights[name] = self._finite_weight(name, value)

    # --- queries ----------------------------------------------------------------------------

    def marginals(
        self,
        evidence: Mapping[Hashable, int] | None = None,
        *,
        max_iter: int = 1000,
        damping: float = 0.5,
        tol: float = 1e-10,
    ) -> dict[Hashable, np.ndarray]:
        """P(V_i | O = o) for every variable, eq. (C.12)/(C.19), by sum-product. max_iter, damping
        (weight of the old message, in [0, 1)) and tol only matter on loopy graphs."""
        obs, st, bp, _ = self._propagate(evidence, SUM, max_iter, damping, tol, downward=True)
        beliefs = np.exp(bp.variable_beliefs())
        out: dict[Hashable, np.ndarray] = {}
        for i, name in enumerate(self._names):
            p = np.zeros(self._cards[i])
            if i in obs:
                p[obs[i]] = 1.0
            else:
                p = beliefs[st.local[i], : self._cards[i]].copy()
                p /= p.sum()
            out[name] = p
        return out

    def map(
        self,
        evidence: Mapping[Hashable, int] | None = None,
        *,
        max_iter: int = 1000,
        damping: float = 0.5,
        tol: float = 1e-10,
    ) -> dict[Hashable, int]:
        """The most probable joint assignment given the evidence (App. C.0.1, eq. (C.22)-(C.23)):
        exact by backtracking on forests, the max-marginals' argmax (approximate) on loopy graphs;
        with zero entries there, the first possible assignment in max-marginal order (see Zeros in
        the module docstring). ValueError when none is possible."""
        obs, st, bp, _ = self._propagate(evidence, MAX, max_iter, damping, tol, downward=False)
        if st.forest:
            values = bp.backtrack()
        elif bp.possible is not None:  # zeros: the possible assignment nearest the argmax
            values = bp.possible
        else:
            values = np.argmax(bp.variable_beliefs(), axis=1)
        return {
            name: int(obs[i]) if i in obs else int(values[st.local[i]]) for i, name in enumerate(self._names)
        }

    def log_partition(
        self,
        evidence: Mapping[Hashable, int] | None = None,
        *,
        max_iter: int = 1000,
        damping: float = 0.5,
        tol: float = 1e-10,
    ) -> float:
        """log Z(o) = log sum_h E(h, o), eq. (C.5)/(C.11); Bethe approximation on loopy graphs."""
        _, _, bp, const = self._propagate(evidence, SUM, max_iter, damping, tol, downward=True)
        return bp.bethe_log_partition(const)

    def log_energy(self, assignment: Mapping[Hashable, int]) -> float:
        """log E(v) = sum_i log Phi_i(d^i) of a full assignment, eq. (C.3) (-inf if impossible)."""
        values = self._evidence(assignment)
        missing = [self._names[i] for i in range(len(self._names)) if i not in values]
        if missing:
            raise ValueError(f"assignment is missing variables {missing!r}")
        return float(sum(self._log_table(f)[tuple(values[v] for v in f.variables)] for f in self._factors))

    # --- learning ---------------------------------------------------------------------------

    def fit(
        self,
        samples,
        *,
        method: str = "lbfgs",
        learning_rate: float = 0.5,
        max_iter: int = 200,
        tol: float = 1e-6,
        l2: float = 0.0,
        bp_max_iter: int = 1000,
        damping: float = 0.5,
    ) -> FitReport:
        """Maximum likelihood of the learnable weights from fully observed samples (App. C.0.2-
        C.0.3), from the current weights: maximises J(W) - l2/2 |W|^2, J the average
        log-likelihood of eq. (C.29), by L-BFGS ("lbfgs") or plain gradient ascent with step
        `learning_rate` ("gradient"), until every component of the gradient is <= `tol` (then
        `converged`; `gradient_norm` is the largest component). `samples`: a list of {variable:
        value} dicts, or a 2-d integer array with the variables in insertion order. On loopy
        graphs the gradient and log Z come from loopy BP (Bethe), so the optimum is approximate."""
        names = sorted(self._weights)
        if not names:
            raise ValueError("the graph has no learnable weights (add_exponential_factor)")
        if method not in ("lbfgs", "gradient"):
            raise ValueError(f"unknown fit method {method!r}; use 'lbfgs' or 'gradient'")
        if l2 < 0 or not np.isfinite(l2):
            raise ValueError(f"l2 must be a finite number >= 0, got {l2!r}")
        data = self._samples(samples)
        base, empirical = self._sufficient_statistics(data, names)
        options = {"max_iter": bp_max_iter, "damping": damping, "tol": 1e-10}

        def objective(w: np.ndarray) -> tuple[float, np.ndarray]:
            self._weights.update(zip(names, (float(x) for x in w), strict=True))
            log_z, expected = self._expected_features(names, options)
            value = base + float(w @ empirical) - log_z
            return value - 0.5 * l2 * float(w @ w), empirical - expected - l2 * w

        w0 = np.array([self._weights[n] for n in names])
        if method == "lbfgs":
            res = optimize.minimize(
                lambda w: tuple(-x for x in objective(w)),
                w0,
                jac=True,
                method="L-BFGS-B",
                # ftol off: stop on the gradient (tol), which the weights' accuracy is judged by
                options={"maxiter": max_iter, "gtol": tol, "ftol": 1e-15},
            )
            w, iterations, message = res.x, int(res.nit), str(res.message)
        else:
            w, iterations, message = self._gradient_ascent(objective, w0, learning_rate, max_iter, tol)
        value, grad = objective(w)
        return FitReport(
            iterations=iterations,
            log_likelihood=value + 0.5 * l2 * float(w @ w),
            gradient_norm=float(np.max(np.abs(grad))),
            converged=bool(np.max(np.abs(grad)) <= tol),
            message=message,
            weights=self.weights(),
        )

    @staticmethod
    def _gradient_ascent(objective, w0: np.ndarray, rate: float, max_iter: int, tol: float):
        if not rate > 0:
            raise ValueError(f"learning_rate must be > 0, got {rate!r}")
        w = w0.copy()
        for it in range(max_iter):
            _, grad = objective(w)
            if np.max(np.abs(grad)) <= tol:
                return w, it, "gradient below tol"
            w = w + rate * grad
        return w, max_iter, "max_iter reached"

    def _sufficient_statistics(self, data: np.ndarray, names: list[str]) -> tuple[float, np.ndarray]:
        """Mean of the fixed log-potentials and, per weight, the empirical mean of the sum of its
        factors' Phi over the samples, eq. (C.40)."""
        base = np.zeros(len(data))
        empirical = dict.fromkeys(names, 0.0)
        for f in self._factors:
            cells = tuple(data[:, v] for v in f.variables)
            base += f.log_base[cells]
            if f.phi is not None:
                empirical[f.weight_name] += float(np.mean(f.phi[cells]))
        if np.any(np.isneginf(base)):
            bad = int(np.flatnonzero(np.isneginf(base))[0])
            raise ValueError(f"sample {bad} has zero probability under the fixed factors")
        return float(np.mean(base)), np.array([empirical[n] for n in names])

    def _expected_features(self, names: list[str], options: dict) -> tuple[float, np.ndarray]:
        """log Z and, per weight, the model mean of its factors' Phi from the factor beliefs,
        eq. (C.36)-(C.37) and (C.41)-(C.42)."""
        _, st, bp, const = self._propagate(None, SUM, downward=True, **options)
        var_beliefs = np.exp(bp.variable_beliefs())
        factor_beliefs = bp.factor_beliefs()
        expected = dict.fromkeys(names, 0.0)
        for f, role in zip(self._factors, st.roles, strict=True):
            if f.phi is None:
                continue
            if role.kind == "prior":
                b = var_beliefs[role.target, : f.phi.shape[0]]
            else:
                g, row = st.merged_slot[role.target]
                b = np.exp(factor_beliefs[g][row]).transpose(np.argsort(role.perm))
            expected[f.weight_name] += float(np.sum(b * f.phi))
        return bp.bethe_log_partition(const), np.array([expected[n] for n in names])

    # --- internals --------------------------------------------------------------------------

    def _propagate(self, evidence, mode: str, max_iter: int, damping: float, tol: float, downward: bool):
        if not _is_index(max_iter) or max_iter < 1:
            raise ValueError(f"max_iter must be an integer >= 1, got {max_iter!r}")
        if not 0.0 <= damping < 1.0:
            raise ValueError(f"damping must be in [0, 1), got {damping!r}")
        if not tol > 0:
            raise ValueError(f"tol must be > 0, got {tol!r}")
        obs = self._evidence(evidence or {})
        st = self._structure(frozenset(obs))
        prior, tables, const = self._reduced_tables(st, obs)
        bp = _Propagation(st, prior, tables, mode)
        if st.forest:
            bp.tree_passes(downward=downward)
            self.last_report = BPReport(mode, True, True, 1, 0.0)
        else:
            converged, iterations, change = bp.loopy(max_iter, damping, tol)
            self.last_report = BPReport(mode, False, converged, iterations, change)
        beliefs = bp.variable_beliefs()
        dead = np.all(np.isneginf(beliefs), axis=1)
        if np.any(dead):
            self.last_report = dataclasses.replace(self.last_report, feasible=False)
            name = self._names[st.hidden[int(np.flatnonzero(dead)[0])]]
            raise ValueError(f"evidence has zero probability (no value of {name!r} is possible)")
        if not st.forest:
            self._check_zeros(st, obs, prior, tables, beliefs, bp)
        return obs, st, bp, const

    def _check_zeros(self, st: _Structure, obs: dict[int, int], prior, tables, beliefs, bp) -> None:
        """On a loopy graph with zero entries, whether Z(o) > 0 (`_possible_assignment`): the verdict
        goes to `last_report.feasible`, ValueError when Z(o) = 0. The verdict of a sum-product query
        is kept per evidence (the zeros do not depend on the weights); a max-product query keeps
        the assignment found, its MAP."""
        live = np.arange(st.kmax)[None, :] < st.card[:, None]
        if not (np.any(np.isneginf(prior) & live) or any(np.isneginf(t).any() for t in tables)):
            return
        key = tuple(sorted(obs.items()))
        if len(st.feasible) >= _CACHED_STRUCTURES:  # many evidence patterns: drop the oldest
            st.feasible.pop(next(iter(st.feasible)))
        if self.last_report.mode == MAX or key not in st.feasible:
            verdict, values = _possible_assignment(st, prior, tables, beliefs, SEARCH_BUDGET)
            st.feasible[key] = verdict
            bp.possible = values
        verdict = st.feasible[key]
        self.last_report = dataclasses.replace(self.last_report, feasible=verdict)
        if verdict is False:
            what = "evidence has" if obs else "every assignment has"
            raise ValueError(
                f"{what} zero probability: no assignment of the hidden variables is possible (Z = 0; "
                "loopy BP cannot tell, a search over the zero entries proved it)"
            )

    def _reduced_tables(self, st: _Structure, obs: dict[int, int]):
        """Slice the evidence out of every factor, eq. (C.21), into priors, merged tables and a
        constant."""
        prior = np.where(np.arange(st.kmax)[None, :] < st.card[:, None], 0.0, _NEG_INF)
        merged = [np.zeros(tuple(int(st.card[v]) for v in key)) for key in st.merged_vars]
        const = 0.0
        for n, (f, role) in enumerate(zip(self._factors, st.roles, strict=True)):
            reduced = self._log_table(f)[tuple(obs.get(v, slice(None)) for v in f.variables)]
            if role.kind == "const":
                const += float(reduced)
                if np.isneginf(const):
                    raise ValueError(
                        f"evidence has zero probability (factor {n} over {self._label(f.variables)})"
                    )
            elif role.kind == "prior":
                prior[role.target, : reduced.shape[0]] += reduced
            else:
                merged[role.target] += reduced.transpose(role.perm)
        tables = [np.stack([merged[m] for m in grp.members]) for grp in st.groups]
        return prior, tables, const

    def _structure(self, observed: frozenset[int]) -> _Structure:
        if observed not in self._structures:
            if len(self._structures) >= _CACHED_STRUCTURES:  # many evidence patterns: drop the oldest
                self._structures.pop(next(iter(self._structures)))
            self._structures[observed] = self._compile(observed)
        return self._structures[observed]

    def _compile(self, observed: frozenset[int]) -> _Structure:
        hidden = [i for i in range(len(self._names)) if i not in observed]
        local = {gv: k for k, gv in enumerate(hidden)}
        card = np.array([self._cards[i] for i in hidden], dtype=np.int64)
        roles, merged_vars = _merge_factors([f.variables for f in self._factors], local)
        groups, slot, edge_of, edge_var = _edge_layout(merged_vars, card)
        ones = np.ones(len(edge_var))
        incidence = sparse.csr_matrix(
            (ones, (edge_var, np.arange(len(edge_var)))), shape=(len(hidden), len(ones))
        )
        degree = np.bincount(edge_var, minlength=len(hidden))
        st = _Structure(
            hidden, local, card, int(card.max(initial=1)), roles, merged_vars, slot, groups,
            edge_var, incidence, degree, forest=self._is_forest(len(hidden), merged_vars),
        )  # fmt: skip
        if st.forest:
            _schedule(st, edge_of)
        return st

    @staticmethod
    def _is_forest(n_vars: int, merged_vars: list[tuple[int, ...]]) -> bool:
        """A bipartite graph is a forest iff it has no edge closing a cycle (union-find)."""
        parent = list(range(n_vars + len(merged_vars)))

        def find(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for m, key in enumerate(merged_vars):
            for v in key:
                a, b = find(v), find(n_vars + m)
                if a == b:
                    return False
                parent[a] = b
        return True

    def _append(self, factor: _Factor) -> None:
        self._factors.append(factor)
        self._structures.clear()

    def _log_table(self, f: _Factor) -> np.ndarray:
        if f.phi is None:
            return f.log_base
        return f.log_base + self._weights[f.weight_name] * f.phi

    def _label(self, idx: Sequence[int]) -> str:
        return repr(tuple(self._names[i] for i in idx))

    def _factor_variables(self, variables) -> tuple[int, ...]:
        if isinstance(variables, str | bytes):
            variables = [variables]
        variables = list(variables)
        if not variables:
            raise ValueError("a factor needs at least one variable")
        for name in variables:
            if name not in self._index:
                raise ValueError(f"unknown variable {name!r}")
        if len(set(variables)) != len(variables):
            raise ValueError(f"repeated variable in factor over {tuple(variables)!r}")
        return tuple(self._index[name] for name in variables)

    def _table(self, idx: tuple[int, ...], table, what: str) -> np.ndarray:
        try:
            values = np.array(table, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{what} of factor over {self._label(idx)} is not numeric: {exc}") from None
        expected = tuple(self._cards[i] for i in idx)
        if values.shape != expected:
            raise ValueError(
                f"{what} of factor over {self._label(idx)} has shape {values.shape}, expected {expected}"
            )
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{what} of factor over {self._label(idx)} has non-finite entries")
        return values

    def _declare_weight(self, name: str, weight: float | None) -> None:
        if not isinstance(name, str) or not name:
            raise ValueError(f"weight_name must be a non-empty string, got {name!r}")
        if name not in self._weights:
            self._weights[name] = 1.0 if weight is None else self._finite_weight(name, weight)
        elif weight is not None and self._finite_weight(name, weight) != self._weights[name]:
            raise ValueError(f"weight {name!r} already has value {self._weights[name]}, got {weight!r}")

    @staticmethod
    def _finite_weight(name: str, value) -> float:
        try:
            w = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"weight {name!r} must be a number, got {value!r}") from None
        if not np.isfinite(w):
            raise ValueError(f"weight {name!r} must be finite, got {value!r}")
        return w

    def _evidence(self, evidence: Mapping[Hashable, int]) -> dict[int, int]:
        if not isinstance(evidence, Mapping):
            raise ValueError(f"evidence must be a mapping variable -> value, got {type(evidence).__name__}")
        out = {}
        for name, value in evidence.items():
            if name not in self._index:
                raise ValueError(f"evidence for unknown variable {name!r}")
            i = self._index[name]
            if not _is_index(value) or not 0 <= value < self._cards[i]:
                raise ValueError(f"evidence for {name!r} is {value!r}, out of range 0..{self._cards[i] - 1}")
            out[i] = int(value)
        return out

    def _samples(self, samples) -> np.ndarray:
        if isinstance(samples, Sequence) and len(samples) and all(isinstance(s, Mapping) for s in samples):
            rows = []
            for k, s in enumerate(samples):
                unknown = [n for n in s if n not in self._index]
                missing = [n for n in self._names if n not in s]
                if unknown or missing:
                    raise ValueError(
                        f"sample {k}: unknown variables {unknown!r}, missing variables {missing!r}"
                    )
                rows.append([s[n] for n in self._names])
            samples = rows
        data = np.asarray(samples)
        if data.ndim != 2 or data.shape[0] == 0 or data.shape[1] != len(self._names):
            raise ValueError(
                f"samples must be a non-empty (N, {len(self._names)}) array, one column per variable "
                f"in insertion order, got shape {data.shape}"
            )
        if not np.issubdtype(data.dtype, np.integer):
            raise ValueError(f"samples must hold integer values, got dtype {data.dtype}")
        for i, name in enumerate(self._names):
            bad = (data[:, i] < 0) | (data[:, i] >= self._cards[i])
            if np.any(bad):
                raise ValueError(
                    f"samples: value {data[np.argmax(bad), i]} of variable {name!r} out of range "
                    f"0..{self._cards[i] - 1}"
                )
        return data.astype(np.int64)
