"""Fuzzy receding-horizon scheduler on a pcTPN (thesis 7.4, Algorithm 5, eq. 7.3-7.18), the
fuzzyfication of observed durations (7.5.3, eq. 7.19-7.20) and the uniform scheduler of use
case c (7.5.3, eq. 7.21-7.23).

The firing delays d of the uncontrollable transitions are triangular fuzzy numbers; the
reachability tree (6.2.1) is built breadth first as Algorithm 5, its arrival times alpha are
fuzzy numbers, a node S_Ci whose arrival time is not below T_sch is left out, and the fitness J
(eq. 7.12-7.18) is propagated from the leaves to the root; the root child with the largest J is
fired now (7.1, receding horizon).

Where the text leaves a choice open, the simplest reading is taken:
- eq. (7.7) writes L(alpha_bar_Cl, t) for the proposition "alpha_bar_Cl > t"; App. D names
  that proposition G (eq. D.10) and the probabilistic eq. (6.6) uses G_Ci there, so G is used.
- eq. (7.4) (the cut by L(alpha_f, t)) applies to the transitions enabled before the father's
  arrival time, as G_f in eq. (6.6) (Fig. 6.8: not for transitions enabled on arriving in S_f).
  A transition enabled on arriving in S_f starts after alpha_f by construction, and cutting
  alpha_f + d by L(alpha_f, .) would treat alpha_f as two unrelated fuzzy numbers. "Arriving"
  means the node where the arrival time last changed (`FuzzyNode.epoch`): controllable and
  zero-delay firings keep the father's arrival time (6.2.1).
- an uncontrollable transition with crisp zero delay enabled on arriving in S_f (a human who
  starts at once, a start whose preconditions just came) fires at alpha_f before any other,
  with possibility 1: its exact eq. (7.4)-(7.9) result for a crisp alpha_f.
- "alpha_Ci is below T_sch" (Algorithm 5, line 20): possibility 1 that alpha_Ci <= T_sch, i.e.
  the lower end of its core is <= T_sch.
- a node with P_fi < eps is left out (P_fi = 0 makes eq. (7.9) undefined).
- W_R (7.4.1): t_w times the number of robot waits fired on the path (6.3.1). W_H: one term
  eq. (7.12) per token that entered and left a human-wait place along the path (alpha_I at the
  node after the insertion, alpha_S after the removal), summed; a token still there at a leaf
  counts with alpha_S = T_sch (the wait lasts at least to the horizon); a token already there
  at the root counts from the root (alpha_I = crisp 0: the past is not the plan's). phi_3 is
  clipped to [0, 1] and is 0 when S_2 <= I_1. J = inf when w_1 W_H + w_2 W_R = 0.
- `serialize_robots` (default True): at a controllable conflict only the transitions of the
  first robot agent (net.robot_agents order) with an enabled controllable transition are
  branched; the others decide in the child (the same arrival time), as the cell asks free
  robots one at a time. Algorithm 5 line 10 branches on all of them, which repeats every
  combination once per order; False does that.
- a join of a held action of two robots (`config.JOINT_ACTIONS` "hold") fires at alpha_f with
  possibility 1 before any controllable conflict below the root: the partner joins the moment it
  is free, as the cell has it (the root is the deciding robot's choice, never a join).
- ties of J at the root (the text names no rule) go to the lowest transition index (the flow
  order; waits come last), or with `ties="random"` to one drawn by the seeded generator; the
  policy counts them (`FuzzyStats.ties`).
- the root's arrival time is crisp 0 (times are relative to `now`); a transition enabled e s
  ago has alpha_E = crisp(-e), so eq. (7.4) at the root conditions it on not having fired yet;
  one overdue (its whole support before 0) fires at crisp 0.
- `max_nodes` bounds the tree: the first level of Algorithm 5 that would exceed it is left out
  whole (its fathers stay leaves), so the horizon is then shorter than T_sch; the tree says how
  far it reached (`depth_reached`), the policy counts cut trees and logs the first.
- `merge` (default): a node equal to one already built (marking, arrival time, enab times and
  epochs, open human waits, path costs; floats bit for bit) is built once and linked (a DAG):
  exact, J is the tree's. On torch_clock it reaches a few seconds further per node budget; the
  full tree to T_sch = 50 s is out of reach (10,000 merged nodes reach about 26 s in ~2 s).
- W_R in seconds (t_w per wait, 6.3.1) is the text's; `robot_wait_measure="horizon_fraction"`
  (t_w / T_sch per wait) is a variant that puts it on the scale of W_H (an index <= ~2).
- of several crisp winners of a conflict tied at the same instant, one is fired (the lowest
  index) unless it disables another: the other orders are the same evolution.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from hrc_drake.distributions import Distribution, duration_cdf, mean_duration, validate_distribution
from hrc_drake.messages import shallow_copy
from hrc_drake.scheduling.fuzzy import (
    FuzzyNumber,
    SampledFuzzySet,
    intersection_height,
    trapezoid_from_support,
)
from hrc_drake.scheduling.learning import DurationModel
from hrc_drake.scheduling.montecarlo import copy_generator
from hrc_drake.scheduling.petri import PcTPN

_log = logging.getLogger(__name__)

# -- fuzzyfication (7.5.3) ----------------------------------------------------------------------


def _triangle_from_moments(mean: float, sigma: float, below: float) -> FuzzyNumber:
    """eq. (7.19)-(7.20) given T_M, sigma and F(T_M) = S / (1 + S)."""
    if sigma <= 0:
        return FuzzyNumber.crisp(mean)
    sigma_l = sigma * below  # sigma S / (1 + S)
    sigma_r = sigma * (1.0 - below)  # sigma / (1 + S), the second sigma_L of (7.20) read sigma_R
    return FuzzyNumber.triangular(max(0.0, mean - sigma_l), mean, mean + sigma_r)


def fuzzify_samples(samples) -> FuzzyNumber:
    """The triangular set <T_1, T_M, T_2> of samples D_1..D_M, eq. (7.19)-(7.20).

    T_M is the mean, sigma the standard deviation of the samples (that of their empirical
    distribution f, ddof = 0), S = (#D_j <= T_M) / (#D_j > T_M), so sigma_L = sigma S / (1 + S)
    and sigma_R = sigma / (1 + S) (the text's second sigma_L is sigma_R). Equal samples give a
    crisp number."""
    d = np.asarray(samples, dtype=float)
    if d.ndim != 1 or d.size == 0 or not np.all(np.isfinite(d)) or np.any(d < 0):
        raise ValueError("fuzzify_samples: needs a non-empty 1-D array of finite durations >= 0")
    mean = float(d.mean())
    sigma = float(d.std())
    if sigma <= 0:
        return FuzzyNumber.crisp(mean)
    below = float(np.count_nonzero(d <= mean)) / d.size
    return _triangle_from_moments(mean, sigma, below)


def _distribution_std(dist: Distribution) -> float:
    kind = dist.kind
    if kind == "fixed":
        return 0.0
    if kind == "normal":
        if dist.std == 0:
            return 0.0
        from scipy.stats import truncnorm  # here: scipy.stats takes 0.6 s to import (first runs)

        lower = (dist.low - dist.mean) / dist.std
        return float(truncnorm.std(lower, np.inf, loc=dist.mean, scale=dist.std))
    if kind == "uniform":
        return (dist.high - dist.low) / math.sqrt(12.0)
    if kind == "triangular":
        a, c, b = dist.low, dist.mode, dist.high
        return math.sqrt((a * a + b * b + c * c - a * b - a * c - b * c) / 18.0)
    if kind == "lognormal":
        return float(dist.std)
    raise ValueError(f"no closed-form std for kind {kind!r}")


def fuzzify_distribution(dist: Distribution) -> FuzzyNumber:
    """The prior d of a transition before enough samples are observed: eq. (7.19)-(7.20) with the
    distribution's own mean, standard deviation and F(T_M) in place of the samples' (empirical
    distributions use their samples)."""
    validate_distribution(dist)
    if dist.kind == "empirical":
        return fuzzify_samples(dist.samples)
    mean = mean_duration(dist)
    sigma = _distribution_std(dist)
    below = float(duration_cdf(dist, np.array([mean]))[0]) if sigma > 0 else 1.0
    return _triangle_from_moments(mean, sigma, below)


# -- fitness (7.4.1) ----------------------------------------------------------------------------


def human_wait_index(
    inserted: FuzzyNumber, removed: FuzzyNumber, horizon: float, with_phi2: bool = True
) -> float:
    """W_H = phi_1 phi_2 phi_3 of eq. (7.12)-(7.15) (phi_1 phi_3, eq. (7.23), without phi_2).

    inserted, removed: alpha_I = <I_1, I_M, I_2> and alpha_S = <S_1, S_M, S_2>, the arrival times
    after a token enters and leaves the human-wait place; horizon: T_sch. For a trapezoid the
    peak I_M, S_M is the middle of the core. phi_3 is clipped to [0, 1] (0 when S_2 <= I_1)."""
    phi1 = 1.0 - intersection_height(inserted, removed)
    span = removed.d - inserted.a
    phi3 = 0.0 if span <= 0 else min(1.0, max(0.0, (removed.a - inserted.a) / span))
    if not with_phi2:
        return phi1 * phi3
    s_m = 0.5 * (removed.b + removed.c)
    i_m = 0.5 * (inserted.b + inserted.c)
    phi2 = 1.0 + (s_m - i_m) / horizon
    return phi1 * phi2 * phi3


# -- the fuzzy reachability tree (Algorithm 5) --------------------------------------------------


@dataclass(eq=False)
class FuzzyNode:
    """A node S_i = <m_i, alpha_i> of the fuzzy reachability tree (eq. 6.3).

    marking: (P,) m_i. parent, transition: father and the transition fired from it (-1 at the
    root). arrival: alpha_i. epoch: the node where the arrival time last changed (itself after an
    uncontrollable firing with a new arrival time, else the father's). enab: for every enabled
    transition, (epoch of enab(S_i) for it, alpha_E). possibility: P_fi (eq. 7.8), 1 after a
    controllable or zero-delay firing. reach: F_i of eq. (7.11). open_waits: human-wait place ->
    alpha_I of the token in it. human_wait: summed W_H of the waits closed on the path (7.12).
    robot_waits: robot waits fired on the path. conflict: "controllable", "uncontrollable" or ""
    (a leaf). fitness: J (eq. 7.16-7.18).
    """

    marking: np.ndarray
    parent: int
    transition: int
    depth: int
    arrival: FuzzyNumber
    epoch: int
    enab: dict
    possibility: float = 1.0
    reach: float = 1.0
    open_waits: dict = field(default_factory=dict)
    human_wait: float = 0.0
    robot_waits: int = 0
    children: list = field(default_factory=list)
    child_possibility: list = field(default_factory=list)
    conflict: str = ""
    fitness: float = math.nan


_ZERO = FuzzyNumber.crisp(0.0)
_NEW_EPOCH = -2
#: W_R of 7.4.1: "seconds" t_w per robot wait (the thesis), "horizon_fraction" t_w / T_sch per
#: wait (a variant: the scale of W_H's phi_2 - 1, so w_1 and w_2 weigh comparable indices)
ROBOT_WAIT_MEASURES = ("seconds", "horizon_fraction")
#: ties of J at the root: "first" the lowest transition index, "random" one drawn by the seeded rng
TIE_RULES = ("first", "random")


class FuzzyReachabilityTree:
    """Algorithm 5 (TREE COMPUTATION) with the Conflict routine of eq. (7.3)-(7.11) and the
    fitness J of eq. (7.12)-(7.18); see the module docstring for the readings taken.

    delays: (T,) FuzzyNumber firing delays d (controllable ones are ignored: they fire at once).
    horizon: T_sch (s). roots: the transitions the root may fire (default: Algorithm 5's).
    elapsed: (T,) seconds each transition enabled at the root has been enabled.
    eps: the small constant of 7.4 (nodes with max alpha_tilde < eps or P_fi < eps are left out).
    grid_points: points of the grids on which the non-triangular sets of eq. (7.4)-(7.9) are
    sampled (plus their breakpoints). arrival_shape: "triangular" (eq. 7.10) or "trapezoidal"
    (eq. 7.22, core shrunk by trapezoid_eps). with_phi2: False for eq. (7.23).
    w_human, w_robot: w_1, w_2 of eq. (7.16). normalize_possibilities: divide the sum of
    eq. (7.18) by sum_i P_fi (False: eq. 7.18 as written). merge: build equal nodes once (a DAG,
    exact: the same J; see `_build`). robot_wait_measure: see ROBOT_WAIT_MEASURES.
    After the build: truncated, cut_nodes, depth_reached (s), merged.
    """

    def __init__(
        self,
        net: PcTPN,
        delays,
        horizon: float,
        marking=None,
        *,
        roots=None,
        elapsed=None,
        eps: float = 1e-2,
        grid_points: int = 41,
        max_nodes: int = 300,
        arrival_shape: str = "triangular",
        trapezoid_eps: float = 1e-3,
        with_phi2: bool = True,
        w_human: float = 1.0,
        w_robot: float = 1.0,
        wait_time: float | None = None,
        serialize_robots: bool = True,
        normalize_possibilities: bool = False,
        merge: bool = True,
        robot_wait_measure: str = "seconds",
    ):
        if not horizon > 0 or not math.isfinite(horizon):
            raise ValueError(f"FuzzyReachabilityTree: horizon must be finite and > 0, got {horizon}")
        if not 0 < eps < 1 or grid_points < 3 or max_nodes < 1:
            raise ValueError(
                f"FuzzyReachabilityTree: need 0 < eps < 1, grid_points >= 3, max_nodes >= 1; "
                f"got {eps}, {grid_points}, {max_nodes}"
            )
        if arrival_shape not in ("triangular", "trapezoidal"):
            raise ValueError(f"FuzzyReachabilityTree: arrival_shape {arrival_shape!r}")
        if robot_wait_measure not in ROBOT_WAIT_MEASURES:
            raise ValueError(f"FuzzyReachabilityTree: robot_wait_measure {robot_wait_measure!r}")
        if len(delays) != net.n_transitions:
            raise ValueError(
                f"FuzzyReachabilityTree: {len(delays)} delays for {net.n_transitions} transitions"
            )
        self.net = net
        self.delays = [_ZERO if net.controllable[j] else delays[j] for j in range(net.n_transitions)]
        self.horizon = float(horizon)
        self.eps = float(eps)
        self.grid_points = int(grid_points)
        self.max_nodes = int(max_nodes)
        self.trapezoidal = arrival_shape == "trapezoidal"
        self.trapezoid_eps = float(trapezoid_eps)
        self.with_phi2 = bool(with_phi2)
        self.w_human, self.w_robot = float(w_human), float(w_robot)
        self.serialize_robots = bool(serialize_robots)
        self.normalize_possibilities = bool(normalize_possibilities)
        self.merge = bool(merge)
        self.robot_wait_measure = robot_wait_measure
        self.wait_time = float(getattr(net, "wait_quantum", 1.0) if wait_time is None else wait_time)
        human = getattr(net, "human_agent", "human")
        human_places = [i for i in range(net.n_places) if net.idle_agent[i] == human]
        self._opens = [[i for i in human_places if net.post[i, j] > 0] for j in range(net.n_transitions)]
        self._closes = [[i for i in human_places if net.pre[i, j] > 0] for j in range(net.n_transitions)]
        self._is_wait = [r == "wait" for r in net.role]
        self._is_join = [r == "join" for r in net.role]
        self._immediate = [
            (not net.controllable[j]) and self.delays[j].is_crisp and self.delays[j].a == 0.0
            for j in range(net.n_transitions)
        ]
        self._robot_order = list(getattr(net, "robot_agents", []))
        m0 = net.m0 if marking is None else np.asarray(marking, dtype=np.int64)
        if m0.shape != (net.n_places,) or np.any(m0 < 0):
            raise ValueError(f"FuzzyReachabilityTree: marking must be ({net.n_places},) and >= 0")
        self.roots = None if roots is None else {int(j) for j in np.atleast_1d(roots)}
        en = np.flatnonzero(net.enabled(m0))
        enab = {}
        for j in en:
            e = 0.0 if elapsed is None else float(elapsed[j])
            enab[int(j)] = (0, _ZERO) if e <= 0 else (-1, FuzzyNumber.crisp(-e))
        waiting = {i: _ZERO for i in human_places if m0[i] > 0}
        self.nodes: list[FuzzyNode] = [FuzzyNode(m0.copy(), -1, -1, 0, _ZERO, 0, enab, open_waits=waiting)]
        self.truncated = False
        #: children linked to a node already built instead of a new one (`merge`)
        self.merged = 0
        #: nodes left unexpanded by max_nodes, and the least arrival time (core's lower end)
        #: among them: how far ahead every branch was explored (T_sch when not truncated)
        self.cut_nodes = 0
        self.depth_reached = self.horizon
        self._build()
        self._fitness()

    # -- Algorithm 5 -----------------------------------------------------------------------------

    def _build(self):
        """Algorithm 5 level by level (Open2 -> Open). A level that would take the tree past
        max_nodes is not added at all, so every branch is explored to the same level.

        With `merge` a child equal to a node already built (`_key`: the same marking, arrival
        time, enab arrival times and epochs, open human waits and path costs W_H, W_R) is not
        built again: the father links to that node, whose subtree (and so J) is the same. The
        tree becomes a DAG whose possibilities P_fi are on its edges."""
        open_ = [0]
        table = {self._key(0): 0} if self.merge else None
        while open_:
            staged, count = [], len(self.nodes)
            seen: dict = {}
            for i in open_:
                children = self._children(i)
                if table is None:
                    count += len(children)
                else:
                    for child in children:
                        key = self._key_of_child(i, child)
                        if key not in table and key not in seen:
                            seen[key] = True
                            count += 1
                if count > self.max_nodes and i != 0:  # the root's children are always added
                    self.truncated = True
                    self.cut_nodes = len(open_)
                    for k, _ in staged + [(i, children)]:
                        self.nodes[k].conflict = ""
                    self.depth_reached = min(
                        self.horizon, min(self.nodes[k].arrival.b for k in open_)
                    )
                    return
                staged.append((i, children))
            open_ = []
            for i, children in staged:
                father = self.nodes[i]
                for child in children:
                    if table is not None:
                        key = self._key_of_child(i, child)
                        index = table.get(key)
                        if index is not None:
                            father.children.append(index)
                            father.child_possibility.append(child.possibility)
                            self.merged += 1
                            continue
                    self.nodes.append(child)
                    index = len(self.nodes) - 1
                    if table is not None:
                        table[key] = index
                    if child.epoch == _NEW_EPOCH:  # a new arrival time: the node is its own epoch
                        child.epoch = index
                    new = (child.epoch, child.arrival)
                    child.enab = {k: (new if v is None else v) for k, v in child.enab.items()}
                    father.children.append(index)
                    father.child_possibility.append(child.possibility)
                    open_.append(index)

    @staticmethod
    def _corners(x: FuzzyNumber) -> tuple:
        return (x.a, x.b, x.c, x.d)

    def _key(self, i: int) -> tuple:
        """What the subtree of node i depends on (see `_build`); times compared bit for bit."""
        node = self.nodes[i]
        c = self._corners
        enab = tuple((j, e == node.epoch, c(a)) for j, (e, a) in sorted(node.enab.items()))
        return self._pack(node, enab)

    def _key_of_child(self, i: int, child: FuzzyNode) -> tuple:
        """`_key` of a child not yet added (its enab entries of new transitions are None)."""
        f, c = self.nodes[i], self._corners
        new_epoch = child.epoch == _NEW_EPOCH
        enab = tuple(
            (j, True, c(child.arrival)) if v is None else (j, (not new_epoch) and v[0] == f.epoch, c(v[1]))
            for j, v in sorted(child.enab.items())
        )
        return self._pack(child, enab)

    def _pack(self, node: FuzzyNode, enab: tuple) -> tuple:
        c = self._corners
        waits = tuple((p, c(a)) for p, a in sorted(node.open_waits.items()))
        return (node.marking.tobytes(), c(node.arrival), enab, waits, round(node.human_wait, 12),
                node.robot_waits)

    def _children(self, i: int) -> list[FuzzyNode]:
        net, f = self.net, self.nodes[i]
        enabled = sorted(f.enab)
        joins = [j for j in enabled if self._is_join[j]] if i > 0 else []
        if joins:  # a free partner joins a held action at once (6.3.3), before anyone decides
            f.conflict = "uncontrollable"
            return [self._child(i, joins[0], f.arrival, 1.0, same_epoch=True)]
        ctrl = [j for j in enabled if net.controllable[j]]
        if i == 0 and self.roots is not None:
            ctrl = [j for j in ctrl if j in self.roots]
        elif ctrl and self.serialize_robots:
            ctrl = self._first_robot(ctrl)
        if ctrl:
            f.conflict = "controllable"
            return [self._child(i, j, f.arrival, 1.0, same_epoch=True) for j in ctrl]
        unc = [j for j in enabled if not net.controllable[j]]
        if not unc:
            return []
        f.conflict = "uncontrollable"
        out = []
        for j, arrival, possibility, same in self._conflict(i, unc):
            if arrival.b <= self.horizon:  # alpha_Ci below T_sch (Algorithm 5, line 20)
                out.append(self._child(i, j, arrival, possibility, same_epoch=same))
        if not out:
            f.conflict = ""
        return out

    def _first_robot(self, ctrl: list[int]) -> list[int]:
        agents = self.net.agents
        order = self._robot_order or sorted({a for j in ctrl for a in agents[j]})
        for agent in order:
            mine = [j for j in ctrl if agent in agents[j]]
            if mine:
                return mine
        return ctrl

    def _child(self, i: int, j: int, arrival: FuzzyNumber, possibility: float, same_epoch: bool):
        """Child of node i by firing j (eq. 6.2); the enab entries of newly enabled transitions
        are None until the child's index (its epoch when same_epoch is False) is known."""
        net, f = self.net, self.nodes[i]
        m = f.marking + net.incidence[:, j]
        en = np.flatnonzero(net.enabled(m))
        enab = {int(k): (f.enab[int(k)] if (int(k) in f.enab and k != j) else None) for k in en}
        waits = f.open_waits
        human_wait = f.human_wait
        if self._opens[j] or self._closes[j]:
            waits = dict(waits)
            for p in self._closes[j]:
                if p in waits:
                    human_wait += human_wait_index(waits.pop(p), arrival, self.horizon, self.with_phi2)
            for p in self._opens[j]:
                waits[p] = arrival
        return FuzzyNode(
            m,
            i,
            j,
            f.depth + 1,
            arrival,
            f.epoch if same_epoch else _NEW_EPOCH,
            enab,
            possibility,
            min(possibility, f.reach),
            waits,
            human_wait,
            f.robot_waits + (1 if self._is_wait[j] else 0),
        )

    # -- Conflict (eq. 7.3-7.11) ------------------------------------------------------------------

    def _conflict(self, i: int, unc: list[int]):
        """(transition, alpha_Ci, P_fi, keeps the father's arrival) for the children of the
        uncontrollable conflict at node i."""
        f = self.nodes[i]
        immediate = [j for j in unc if self._immediate[j] and f.enab[j][0] == f.epoch]
        if immediate:
            return [(j, f.arrival, 1.0, True) for j in immediate]
        # Stage 1: alpha_bar_Ci, eq. (7.3)-(7.6)
        bars = []
        for j in unc:
            epoch, alpha_e = f.enab[j]
            beta = alpha_e + self.delays[j]  # eq. (7.3)
            if epoch == f.epoch:
                bar = beta
            else:
                bar = self._stage1(f.arrival, beta)
                if bar is None and epoch == -1 and i == 0:
                    bar = _ZERO  # overdue at the root: fires now
            if bar is not None:
                bars.append((j, bar))
        out = []
        for k, (j, bar) in enumerate(bars):
            others = [b for n, (_, b) in enumerate(bars) if n != k]
            res = self._stage2(bar, others)
            if res is not None:
                out.append((j, res[0], res[1], False))
        return self._drop_tied(f.marking, out)

    def _drop_tied(self, marking, out):
        """Of crisp winners tied at the same instant, keep one (the lowest index) unless firing
        it disables the other: the orders of independent simultaneous firings are one evolution
        (the others fire next, at the same time)."""
        kept = []
        for j, arrival, p, same in out:
            if arrival.is_crisp:
                dup = False
                for k, a2, _, _ in kept:
                    if a2.is_crisp and a2.a == arrival.a:
                        after = marking + self.net.incidence[:, k]
                        if np.all(self.net.pre[:, j] <= after):
                            dup = True
                            break
                if dup:
                    continue
            kept.append((j, arrival, p, same))
        return kept

    def _grid(self, lo: float, hi: float, sets) -> np.ndarray:
        pts = [np.linspace(lo, hi, self.grid_points)]
        for s in sets:
            bp = np.asarray(s.breakpoints())
            pts.append(bp[(bp > lo) & (bp < hi)])
        return np.unique(np.concatenate(pts))

    def _stage1(self, alpha_f: FuzzyNumber, beta: FuzzyNumber):
        """alpha_bar = alpha_tilde / p with alpha_tilde = min(L(alpha_f, t), beta(t)), eq. (7.4)-(7.6);
        None when max alpha_tilde < eps (S_Ci unreachable)."""
        if beta.a >= alpha_f.d:
            return beta  # L(alpha_f, t) = 1 on beta's support
        if beta.is_crisp:
            return beta if alpha_f.L(beta.a) >= self.eps else None
        if beta.d <= alpha_f.a:
            return None
        t = self._grid(max(beta.a, alpha_f.a), beta.d, (beta, alpha_f))
        tilde = np.minimum(alpha_f.L(t), beta.membership(t))
        p = float(tilde.max())  # eq. (7.6)
        if p < self.eps:
            return None
        return SampledFuzzySet(t, tilde / p)  # eq. (7.5)

    def _stage2(self, bar, others):
        """(alpha_Ci, P_fi) from alpha_hat = min(alpha_bar_Ci, G(alpha_bar_Cl, t) for l != i),
        eq. (7.7)-(7.10); None when P_fi < eps."""
        if bar.is_crisp:
            r = bar.a
            p = min((float(o.G(r)) for o in others), default=1.0)
            return (bar, p) if p >= self.eps else None
        lo, hi = bar.support
        if all(o.support[0] >= hi for o in others):
            return self._shape(bar), 1.0  # G = 1 on the whole support: alpha_hat = alpha_bar
        end = min([hi] + [o.support[1] for o in others])
        if end <= lo:
            return None
        t = self._grid(lo, end, (bar, *others))
        hat = bar.membership(t)
        for o in others:
            hat = np.minimum(hat, o.G(t))
        p = float(hat.max())  # eq. (7.8)
        if p < self.eps:
            return None
        if self.trapezoidal:
            return trapezoid_from_support(lo, end, self.trapezoid_eps), p  # eq. (7.22)
        top = np.flatnonzero(hat >= p * (1.0 - 1e-12))
        peak = 0.5 * (t[top[0]] + t[top[-1]])
        return FuzzyNumber.triangular(lo, min(max(peak, lo), end), end), p  # eq. (7.9)-(7.10)

    def _shape(self, bar) -> FuzzyNumber:
        if self.trapezoidal:
            lo, hi = bar.support
            return trapezoid_from_support(lo, hi, self.trapezoid_eps)  # eq. (7.22)
        if isinstance(bar, FuzzyNumber):
            return bar
        return bar.to_triangular()  # eq. (7.10)

    # -- fitness (eq. 7.12-7.18) -----------------------------------------------------------------

    def leaf_cost(self, i: int) -> tuple[float, float]:
        """(W_H, W_R) of the path to node i (7.4.1)."""
        node = self.nodes[i]
        end = FuzzyNumber.crisp(self.horizon)
        w_h = node.human_wait + sum(
            human_wait_index(a, end, self.horizon, self.with_phi2) for a in node.open_waits.values()
        )
        w_r = node.robot_waits * self.wait_time
        if self.robot_wait_measure == "horizon_fraction":
            w_r /= self.horizon
        return w_h, w_r

    def _order(self) -> list[int]:
        """Every node after all of its children (post-order of the DAG from the root)."""
        done = bytearray(len(self.nodes))
        order, stack = [], [(0, 0)]
        while stack:
            i, k = stack.pop()
            children = self.nodes[i].children
            while k < len(children) and done[children[k]]:
                k += 1
            if k < len(children):
                stack.append((i, k + 1))
                stack.append((children[k], 0))
            elif not done[i]:
                done[i] = 1
                order.append(i)
        return order

    def _fitness(self):
        order = range(len(self.nodes) - 1, -1, -1) if not self.merged else self._order()
        for i in order:
            node = self.nodes[i]
            if not node.children:
                w_h, w_r = self.leaf_cost(i)
                cost = self.w_human * w_h + self.w_robot * w_r
                node.fitness = math.inf if cost <= 0 else 1.0 / cost  # eq. (7.16)
            elif node.conflict == "controllable":
                node.fitness = max(self.nodes[c].fitness for c in node.children)  # eq. (7.17)
            else:
                pairs = list(zip(node.children, node.child_possibility, strict=True))
                total = sum(self.nodes[c].fitness * p for c, p in pairs)
                if self.normalize_possibilities:
                    total /= sum(p for _, p in pairs)
                node.fitness = total  # eq. (7.18)

    # -- queries ---------------------------------------------------------------------------------

    def child(self, i: int, transition) -> int:
        """Index of the child of node i reached by firing `transition` (name or index)."""
        j = self.net.index_of(transition)
        for c in self.nodes[i].children:
            if self.nodes[c].transition == j:
                return c
        raise ValueError(f"FuzzyReachabilityTree: node {i} has no child by {self.net.transitions[j]!r}")

    def follow(self, transitions) -> int:
        """Node reached from the root by firing `transitions` in order."""
        i = 0
        for t in transitions:
            i = self.child(i, t)
        return i

    def best_root_children(self) -> list[int]:
        """The root children whose J equals the largest (relative tolerance 1e-9: equal up to
        rounding; two infinite J are equal), in transition index order."""
        children = self.nodes[0].children
        if not children:
            raise ValueError("FuzzyReachabilityTree: the root has no child")
        best = max(self.nodes[c].fitness for c in children)
        tied = [c for c in children
                if self.nodes[c].fitness == best or math.isclose(self.nodes[c].fitness, best, rel_tol=1e-9)]
        return sorted(tied, key=lambda c: self.nodes[c].transition)

    def best_root_child(self, rng=None) -> int:
        """The root child with the largest J; ties go to the lowest transition index (the flow
        order, waits last), or with `rng` to one drawn uniformly."""
        tied = self.best_root_children()
        if rng is None or len(tied) == 1:
            return tied[0]
        return tied[int(rng.integers(len(tied)))]


# -- policies ----------------------------------------------------------------------------------


class FuzzyPolicy:
    """Receding-horizon fuzzy scheduler (7.1 + 7.4, Algorithm 5) with online fuzzyfication of
    the observed durations (7.5.3, eq. 7.19-7.20).

    horizon: T_sch (s). w_human, w_robot: w_1, w_2 of eq. (7.16). eps: the small constant of
    7.4. window, min_samples: a transition's d is `fuzzify_samples` of its last `window`
    observed delays once it has `min_samples`, before that `fuzzify_distribution` of the net's
    delay. learn: update from `observe`. max_nodes, grid_points, serialize_robots,
    normalize_possibilities, merge, robot_wait_measure: see `FuzzyReachabilityTree`. ties: the
    rule for root children of equal J (TIE_RULES; the text names none); random_state: seeds the
    "random" rule. `stats_` counts the decisions with a choice, those decided by a tie, the trees
    cut by max_nodes and the least depth any tree reached (s); the first cut tree is logged.
    """

    arrival_shape = "triangular"
    with_phi2 = True
    trapezoid_eps = 1e-3

    def __init__(
        self,
        net: PcTPN,
        horizon: float = 50.0,
        w_human: float = 1.0,
        w_robot: float = 1.0,
        eps: float = 1e-2,
        window: int = 30,
        min_samples: int = 3,
        learn: bool = True,
        max_nodes: int = 300,
        grid_points: int = 41,
        serialize_robots: bool = True,
        normalize_possibilities: bool = False,
        random_state=None,
        merge: bool = True,
        robot_wait_measure: str = "seconds",
        ties: str = "first",
        horizon_events: float | None = None,
    ):
        if not horizon > 0 or not math.isfinite(horizon):
            raise ValueError(f"{type(self).__name__}: horizon must be finite and > 0, got {horizon}")
        if not (w_human >= 0 and w_robot >= 0):
            raise ValueError(
                f"{type(self).__name__}: w_human, w_robot must be >= 0, got {w_human}, {w_robot}"
            )
        if robot_wait_measure not in ROBOT_WAIT_MEASURES or ties not in TIE_RULES:
            raise ValueError(f"{type(self).__name__}: robot_wait_measure {robot_wait_measure!r} not in "
                             f"{ROBOT_WAIT_MEASURES} or ties {ties!r} not in {TIE_RULES}")
        self.merge, self.robot_wait_measure, self.ties = bool(merge), robot_wait_measure, ties
        self.stats_ = FuzzyStats()
        self.net = net
        self.horizon = float(horizon)
        if horizon_events is not None and not (math.isfinite(horizon_events) and 0 < horizon_events <= 100):
            raise ValueError(f"{type(self).__name__}: horizon_events must be in (0, 100], got "
                             f"{horizon_events}")
        self.horizon_events = None if horizon_events is None else float(horizon_events)
        self.w_human, self.w_robot = float(w_human), float(w_robot)
        self.eps = float(eps)
        self.learn = learn
        self.max_nodes = int(max_nodes)
        self.grid_points = int(grid_points)
        self.serialize_robots = serialize_robots
        self.normalize_possibilities = normalize_possibilities
        self.durations_ = DurationModel(net, window=window, min_samples=min_samples)
        self.rng = np.random.default_rng(random_state)
        self._delay_cache: dict[int, FuzzyNumber] = {}
        self.last_fitness_: dict[str, float] = {}
        self.last_tree_size_ = 0
        self.last_depth_reached_ = math.nan

    def fuzzy_delay(self, j: int) -> FuzzyNumber:
        """d of transition j: eq. (7.19)-(7.20) on its observed delays, or on its prior (cached
        until the next observation of j)."""
        if self.net.controllable[j]:
            return _ZERO
        if j not in self._delay_cache:
            self._delay_cache[j] = self._make_delay(j)
        return self._delay_cache[j]

    def _make_delay(self, j: int) -> FuzzyNumber:
        if self.durations_.is_learned(j):
            return fuzzify_samples(list(self.durations_.samples_[j]))
        return fuzzify_distribution(self.net.delays[j])

    def event_rate(self) -> float:
        """The cell's expected events per second: each agent ends one action (or wait) per mean
        delay of its uncontrollable transitions (a delay's value: the mean of its fuzzy number's
        four corners), the learned delays where there are, else the net's."""
        rate = 0.0
        # the human's transitions name no agent (its pattern drives them): one more agent
        owners = [agents or ("human",) for agents in self.net.agents]
        for agent in sorted({a for agents in owners for a in agents}):
            delays = [self.fuzzy_delay(j) for j in range(self.net.n_transitions)
                      if not self.net.controllable[j] and agent in owners[j]]
            means = [(d.a + d.b + d.c + d.d) / 4.0 for d in delays]
            means = [m for m in means if m > 0]
            if means:
                rate += 1.0 / float(np.mean(means))
        return rate

    def current_horizon(self) -> float:
        """T_sch: `horizon`, or with `horizon_events` the time the cell takes for that many events
        at `event_rate` (7.5.3 chose 50 s "to have at an average 4 events within the scheduling
        horizon"), within [1, 3600] s."""
        if self.horizon_events is None:
            return self.horizon
        rate = self.event_rate()
        return float(np.clip(self.horizon_events / rate, 1.0, 3600.0)) if rate > 0 else self.horizon

    def tree(self, marking, roots=None, elapsed=None) -> FuzzyReachabilityTree:
        """The fuzzy reachability tree from `marking` with the current d."""
        return FuzzyReachabilityTree(
            self.net,
            [self.fuzzy_delay(j) for j in range(self.net.n_transitions)],
            self.current_horizon(),
            marking,
            roots=roots,
            elapsed=elapsed,
            eps=self.eps,
            grid_points=self.grid_points,
            max_nodes=self.max_nodes,
            arrival_shape=self.arrival_shape,
            trapezoid_eps=self.trapezoid_eps,
            with_phi2=self.with_phi2,
            w_human=self.w_human,
            w_robot=self.w_robot,
            serialize_robots=self.serialize_robots,
            normalize_possibilities=self.normalize_possibilities,
            merge=self.merge,
            robot_wait_measure=self.robot_wait_measure,
        )

    def decide(self, marking, agent: str, now: float = 0.0, elapsed=None) -> int:
        """The controllable transition to fire now for robot `agent`: the root child of the
        fuzzy reachability tree with the largest J (7.4.1). `now` is not used: the tree's times
        are relative to the present and waits last the crisp t_w (7.5.3)."""
        choices = self.net.agent_choices(marking, agent, type(self).__name__)
        if choices.size == 1:
            self.last_fitness_ = {}
            return int(choices[0])
        tree = self.tree(marking, roots=choices, elapsed=elapsed)
        self.last_tree_size_ = len(tree.nodes)
        self.last_depth_reached_ = tree.depth_reached
        self.last_fitness_ = {
            self.net.transitions[tree.nodes[c].transition]: tree.nodes[c].fitness
            for c in tree.nodes[0].children
        }
        tied = len(tree.best_root_children()) > 1
        best = tree.best_root_child(self.rng if self.ties == "random" else None)
        if tree.truncated and not self.stats_.truncated:
            _log.warning("%s: the tree was cut at max_nodes = %d, reaching %.1f s of T_sch = %.1f s "
                         "(counted in stats_.truncated)", type(self).__name__, self.max_nodes,
                         tree.depth_reached, tree.horizon)
        self.stats_ = self.stats_.add(len(tree.nodes), tree.depth_reached, tree.truncated, tied)
        return int(tree.nodes[best].transition)

    def observe(self, transition, delay: float) -> None:
        """An observed firing delay of an uncontrollable transition (7.1 online learning)."""
        if self.learn:
            j = self.net.index_of(transition)
            self.durations_.partial_fit(j, delay)
            self._delay_cache.pop(j, None)

    def clone(self):
        """A copy that `decide` and `observe` may change without touching this one (its own
        duration model and generator state; the net is shared)."""
        new = shallow_copy(self)
        new.durations_ = self.durations_.clone()
        new.rng = copy_generator(self.rng)
        new._delay_cache = dict(self._delay_cache)
        return new


@dataclass(frozen=True)
class FuzzyStats:
    """Counts over a policy's decisions with a choice (immutable: `add` returns a new one).

    decisions; ties: decided by the tie rule between root children of equal J; truncated:
    trees cut by max_nodes; depth_min: the least depth reached (s); nodes_total."""

    decisions: int = 0
    ties: int = 0
    truncated: int = 0
    depth_min: float = math.inf
    nodes_total: int = 0

    def add(self, nodes: int, depth: float, truncated: bool, tied: bool) -> FuzzyStats:
        return FuzzyStats(self.decisions + 1, self.ties + int(tied), self.truncated + int(truncated),
                          min(self.depth_min, depth), self.nodes_total + nodes)

    def __deepcopy__(self, memo):
        return self


class UniformPolicy(FuzzyPolicy):
    """The uniform scheduler of use case c (7.5.3, eq. 7.21-7.23): FuzzyPolicy with every d
    replaced by the trapezoid d' with alpha_0(d') = alpha_0(d) (eq. 7.21, whose alpha_1(d) is
    read alpha_0(d): alpha_1 of a triangle is one point) and alpha_1(d') shrunk by
    `trapezoid_eps`, every conditioned arrival time by the trapezoid with its alpha_0
    (eq. 7.22), and W_H = phi_1 phi_3 (eq. 7.23)."""

    arrival_shape = "trapezoidal"
    with_phi2 = False

    def __init__(self, net: PcTPN, *args, trapezoid_eps: float = 1e-3, **kwargs):
        if not trapezoid_eps > 0:
            raise ValueError(f"UniformPolicy: trapezoid_eps must be > 0, got {trapezoid_eps}")
        super().__init__(net, *args, **kwargs)
        self.trapezoid_eps = float(trapezoid_eps)

    def _make_delay(self, j: int) -> FuzzyNumber:
        """d' of eq. (7.21): the trapezoid on the support of the triangular d."""
        d = super()._make_delay(j)
        return trapezoid_from_support(d.a, d.d, self.trapezoid_eps)
