"""Reachability tree of a pcTPN with farthest enabling ancestors and arrival times (thesis 6.2.1).

A node is S_i = <m_i, alpha_i> (eq. 6.3). Each node remembers, for every transition enabled in
it, the node where that transition became enabled; the farthest enabling ancestor of a child,
enab(S_i), is that node for the transition leading to S_i. Arrival times are characterised two
ways:

- supports (intervals, as Algorithm 3): the unconditioned arrival time of eq. (6.4),
  alpha_bar_i = alpha_E + d_i, has support [lo(alpha_E) + d_low, hi(alpha_E) + d_high]; in an
  uncontrollable conflict a child cannot be reached after the latest possible firing of any
  competitor, nor before its father, so its real support is
  [max(lo(alpha_bar_i), lo(alpha_f)), min_c hi(alpha_bar_c)]; a child whose interval is empty
  is impossible and left out (Algorithm 3's "impossible" tag).
- distributions on a time grid of step h (eq. 6.5-6.8): alpha_bar_i is the convolution of
  alpha_E with d_i; alpha_hat_i(a) = alpha_bar_i(a) (1 - G_f(a)) prod_{c != i} G_c(a), with the
  G_f factor only for transitions enabled before S_f (as in Fig. 6.8); P_fi is the mass of
  alpha_hat_i and alpha_i = alpha_hat_i / P_fi (eq. 6.7). The P_fi of one conflict are
  divided by their sum: eq. (6.5) leaves implicit that S_f was reached, i.e. that the
  transitions enabled before S_f had not fired yet, and the division is that conditioning.
  Ties on the grid (two masses in the same cell) are split half and half.

Controllable transitions fire at once or never (6.2.1): at a node where some are enabled the
children are exactly those (footnote 2 of 6.2.1) and keep the father's arrival time; the choice
is the scheduler's, so their P_fi is 1. A transition fired and enabled again restarts its clock
(its enabling node is the child).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hrc_drake.distributions import duration_cdf, duration_support
from hrc_drake.scheduling.petri import PcTPN


@dataclass
class ReachNode:
    """One state S_i of the reachability tree.

    marking: (P,) m_i. parent, transition: father node and the transition fired from it (-1 at
    the root). enab: index of enab(S_i) (-1 at the root). enabled_since: transition index ->
    node where it became enabled, for every transition enabled in m_i. support: (lo, hi) of the
    conditioned arrival time alpha_i; unconditioned: (lo, hi) of alpha_bar_i (eq. 6.4).
    probability: P_fi, the probability of reaching S_i from its father (1 for controllable
    firings). pmf: alpha_i on the tree's grid (None without a grid).
    conflict: "controllable", "uncontrollable" or "" (no child expanded) for the branching below.
    """

    marking: np.ndarray
    parent: int
    transition: int
    depth: int
    enab: int
    enabled_since: dict[int, int]
    support: tuple[float, float]
    unconditioned: tuple[float, float]
    probability: float = 1.0
    pmf: np.ndarray | None = None
    children: list[int] = field(default_factory=list)
    conflict: str = ""


class ReachabilityTree:
    """Reachability tree of `net` from `marking` (default m0), thesis 6.2.1.

    max_depth: firings along a branch; horizon: nodes whose earliest arrival exceeds it are not
    expanded (T_sch, 7.1); max_nodes: bound on the tree size (ValueError beyond it).
    grid_step, grid_end: time grid a_k = k h, k = 0..grid_end/h for the arrival-time
    distributions of eq. (6.5)-(6.8); without grid_step only supports are computed.
    Mass that the grid cannot hold counts as "later than grid_end".
    """

    def __init__(
        self,
        net: PcTPN,
        marking=None,
        *,
        max_depth: int = 6,
        horizon: float = math.inf,
        max_nodes: int = 20000,
        grid_step: float | None = None,
        grid_end: float | None = None,
    ):
        if max_depth < 0 or max_nodes < 1:
            raise ValueError(
                f"ReachabilityTree: need max_depth >= 0, max_nodes >= 1; got {max_depth}, {max_nodes}"
            )
        if not horizon > 0:
            raise ValueError(f"ReachabilityTree: horizon must be > 0, got {horizon}")
        self.net = net
        m0 = net.m0 if marking is None else np.asarray(marking, dtype=np.int64)
        if m0.shape != (net.n_places,) or np.any(m0 < 0):
            raise ValueError(f"ReachabilityTree: marking must be ({net.n_places},) and >= 0, got {m0}")
        self.grid = None
        if grid_step is not None:
            if not grid_step > 0:
                raise ValueError(f"ReachabilityTree: grid_step must be > 0, got {grid_step}")
            end = grid_end if grid_end is not None else (horizon if math.isfinite(horizon) else None)
            if end is None or not end > 0:
                raise ValueError("ReachabilityTree: a grid needs grid_end > 0 (or a finite horizon)")
            self.grid = grid_step * np.arange(int(math.ceil(end / grid_step)) + 1)
            self._delay_pmf: dict[int, np.ndarray] = {}
        self.supports_ = [
            (0.0, 0.0) if net.controllable[j] else duration_support(net.delays[j])
            for j in range(net.n_transitions)
        ]
        en = np.flatnonzero(net.enabled(m0))
        root_pmf = None
        if self.grid is not None:
            root_pmf = np.zeros(self.grid.size)
            root_pmf[0] = 1.0
        self.nodes: list[ReachNode] = [
            ReachNode(
                m0.copy(), -1, -1, 0, -1, {int(j): 0 for j in en}, (0.0, 0.0), (0.0, 0.0), 1.0, root_pmf
            )
        ]
        self.max_nodes = int(max_nodes)
        frontier = [0]
        while frontier:
            nxt = []
            for i in frontier:
                node = self.nodes[i]
                if node.depth >= max_depth or node.support[0] > horizon:
                    continue
                nxt.extend(self._expand(i))
            frontier = nxt

    # -- construction ---------------------------------------------------------------------------

    def _delay(self, j: int) -> np.ndarray:
        """pmf of the firing delay d_j on the grid (cell k holds (a_k - h/2, a_k + h/2])."""
        if j not in self._delay_pmf:
            if self.net.controllable[j]:
                pmf = np.zeros(self.grid.size)
                pmf[0] = 1.0
            else:
                h = self.grid[1] - self.grid[0] if self.grid.size > 1 else 1.0
                edges = np.concatenate([[-0.5 * h], self.grid + 0.5 * h])
                pmf = np.diff(duration_cdf(self.net.delays[j], edges))
            self._delay_pmf[j] = pmf
        return self._delay_pmf[j]

    def _add(self, node: ReachNode) -> int:
        if len(self.nodes) >= self.max_nodes:
            raise ValueError(
                f"ReachabilityTree: more than {self.max_nodes} nodes; lower max_depth or horizon"
            )
        self.nodes.append(node)
        return len(self.nodes) - 1

    def _child_enabling(self, father: ReachNode, j: int, m: np.ndarray, index: int) -> dict[int, int]:
        en = np.flatnonzero(self.net.enabled(m))
        return {
            int(k): (father.enabled_since[int(k)] if int(k) in father.enabled_since and k != j else index)
            for k in en
        }

    def _expand(self, i: int) -> list[int]:
        net, father = self.net, self.nodes[i]
        enabled = sorted(father.enabled_since)
        ctrl = [j for j in enabled if net.controllable[j]]
        new = []
        if ctrl:
            father.conflict = "controllable"
            for j in ctrl:
                m = father.marking + net.incidence[:, j]
                index = len(self.nodes)
                child = ReachNode(
                    m, i, j, father.depth + 1, father.enabled_since[j],
                    self._child_enabling(father, j, m, index), father.support, father.support, 1.0,
                    None if father.pmf is None else father.pmf.copy(),
                )
                new.append(self._add(child))
            father.children.extend(new)
            return new
        if not enabled:
            return new
        father.conflict = "uncontrollable"
        # eq. (6.4) on supports: alpha_bar = alpha_E + d
        bars = {}
        for j in enabled:
            e = self.nodes[father.enabled_since[j]]
            d_lo, d_hi = self.supports_[j]
            bars[j] = (e.support[0] + d_lo, e.support[1] + d_hi)
        latest = min(b[1] for b in bars.values())
        hats = self._conflict_pmfs(i, enabled) if self.grid is not None else None
        total = sum(float(h.sum()) for h in hats.values()) if hats is not None else 0.0
        for j in enabled:
            lo, hi = max(bars[j][0], father.support[0]), latest
            if hi < lo:
                continue  # impossible: a competitor always fires first (Algorithm 3)
            m = father.marking + net.incidence[:, j]
            index = len(self.nodes)
            prob, pmf = math.nan, None
            if hats is not None:
                mass = float(hats[j].sum())
                prob = mass / total if total > 0 else 0.0
                pmf = hats[j] / mass if mass > 0 else np.zeros(self.grid.size)
            child = ReachNode(
                m, i, j, father.depth + 1, father.enabled_since[j], self._child_enabling(father, j, m, index),
                (lo, hi), bars[j], prob, pmf,
            )
            new.append(self._add(child))
        father.children.extend(new)
        return new

    def _conflict_pmfs(self, i: int, enabled: list[int]) -> dict[int, np.ndarray]:
        """alpha_hat of eq. (6.6) for every transition of the uncontrollable conflict at node i."""
        father, size = self.nodes[i], self.grid.size
        bars = {}
        for j in enabled:
            e = self.nodes[father.enabled_since[j]]
            bars[j] = np.convolve(e.pmf, self._delay(j))[:size]
        # P(alpha_bar_c > a_k), a tie inside cell k counted half
        later = {j: 1.0 - np.cumsum(p) + 0.5 * p for j, p in bars.items()}
        father_before = np.cumsum(father.pmf)  # 1 - G_f(a_k) = P(alpha_f <= a_k)
        hats = {}
        for j in enabled:
            hat = bars[j].copy()
            if father.enabled_since[j] != i:
                hat *= father_before
            for c in enabled:
                if c != j:
                    hat *= later[c]
            hats[j] = np.clip(hat, 0.0, None)
        return hats

    # -- queries --------------------------------------------------------------------------------

    def child(self, i: int, transition) -> int:
        """Index of the child of node i reached by firing `transition` (name or index)."""
        j = self.net.index_of(transition)
        for c in self.nodes[i].children:
            if self.nodes[c].transition == j:
                return c
        raise ValueError(
            f"ReachabilityTree: node {i} has no child by {self.net.transitions[j]!r} "
            "(not enabled, impossible, or beyond depth/horizon)"
        )

    def follow(self, transitions) -> int:
        """Node reached from the root by firing `transitions` in order."""
        i = 0
        for t in transitions:
            i = self.child(i, t)
        return i

    def enab(self, i: int) -> int:
        """The farthest enabling ancestor enab(S_i) (6.2.1); -1 for the root."""
        return self.nodes[i].enab

    def path(self, i: int) -> list[int]:
        """Transitions fired from the root to node i."""
        out = []
        while self.nodes[i].parent >= 0:
            out.append(self.nodes[i].transition)
            i = self.nodes[i].parent
        return out[::-1]

    def reach_probability(self, i: int) -> float:
        """Product of the P_fi of the uncontrollable conflicts won along the path to node i."""
        p = 1.0
        while self.nodes[i].parent >= 0:
            p *= self.nodes[i].probability
            i = self.nodes[i].parent
        return p

    def pmf_support(self, i: int, tol: float = 1e-9) -> tuple[float, float]:
        """Support of the grid distribution of alpha_i: first and last grid points with mass > tol."""
        pmf = self.nodes[i].pmf
        if pmf is None:
            raise ValueError("ReachabilityTree: built without a grid (grid_step)")
        k = np.flatnonzero(pmf > tol)
        if k.size == 0:
            return (math.nan, math.nan)
        return float(self.grid[k[0]]), float(self.grid[k[-1]])

    def mean_arrival(self, i: int) -> float:
        """Mean of alpha_i on the grid."""
        pmf = self.nodes[i].pmf
        if pmf is None:
            raise ValueError("ReachabilityTree: built without a grid (grid_step)")
        return float(pmf @ self.grid / pmf.sum())
