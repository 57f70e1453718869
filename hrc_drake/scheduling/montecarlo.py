"""Monte Carlo receding-horizon scheduler on a pcTPN (thesis 7.3.1, Algorithm 4, 7.1).

N independent trials are simulated in lockstep (one numpy step fires one transition in every
trial). Each starts with a controllable transition drawn uniformly among all those enabled at the
root ("all simulations start with a controllable transition"); controllable conflicts are then
resolved uniformly at random, an uncontrollable conflict is won by the transition whose sampled
unconditioned arrival time (eq. 6.4: enabling time + delay) comes first, every delay is a fresh
draw, a robot's wait lasts exactly the quantum t_w (6.3.1), and every trial stops at the horizon
T_sch. Each trial's cost is C = c_R sum_i W_R,i + c_H W_H, the time-integral of the tokens in the
cost places. The trials' transition sequences form the partial reachability tree; Algorithm 4
back-propagates the costs (union at uncontrollable branchings, the child with the lowest
beta-percentile at controllable ones) and, of the root children that command the deciding robot,
the one with the lowest beta-percentile is fired now (our interface decides for one robot at a
time; a root child of another free robot is that robot's to take when it decides).

Departures from 7.3.1, each an option named for what it is (all off by default):
- `root_choices="agent"`: the root branches only over the deciding robot's choices;
- `stratified_roots`: trial n takes root choice n mod R instead of a uniform draw;
- `common_random_numbers` (with stratified roots): the R trials of a group share their delays and
  later random choices, so root children are compared on the same futures;
- `wait_grid`: a wait ends on the next multiple of t_w of absolute time (`wait_tick_delay`), so
  waiting robots meet on common ticks, instead of lasting t_w;
- `min_branch_samples` > 1, "branch pooling": below the root, rule (b) needs that many trials in
  every child, and thinner branchings are united as uncontrollable ones (see `evaluate_costs`).
The four first together are this module's earlier trials. The figures of each on use cases a and b
are in `tools/bench_scheduling.py` (arms monte_carlo_<variant>).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hrc_drake.messages import shallow_copy
from hrc_drake.scheduling import _kernels
from hrc_drake.scheduling.learning import DurationModel, UniformSupportDurationModel
from hrc_drake.scheduling.petri import PcTPN
from hrc_drake.scheduling.slowdown import DurationsByOperator


def wait_tick_delay(time, quantum: float):
    """Delay of a robot's explicit wait started at `time` on the t_w grid (the `wait_grid`
    variant; 6.3.1 gives a wait of exactly t_w): it ends on the next multiple of the quantum,
    so robots that wait meet on common ticks (needed by actions that take several arms)
    instead of drifting apart."""
    time = np.asarray(time, dtype=float)
    delay = quantum - np.mod(time, quantum)
    return np.where(delay < 1e-9 * quantum, quantum, delay)


def wait_delay(time, quantum: float, grid: bool = False):
    """Delay of a robot's explicit wait started at `time`: the quantum t_w (6.3.1), or with
    `grid` the time to the next multiple of t_w (`wait_tick_delay`, a variant)."""
    if grid:
        return wait_tick_delay(time, quantum)
    return np.full(np.shape(time), float(quantum)) if np.ndim(time) else float(quantum)


ROLLOUTS = ("uniform", "work_first")
#: which controllable transitions the trials' root branches over: "all_enabled" (7.3.1: every
#: controllable transition enabled at the root) or "agent" (only the deciding robot's, a variant)
ROOT_CHOICES = ("all_enabled", "agent")

#: the delay models of the trials: "empirical" (`DurationModel`, the scheduler of 7.3, Scheduler A
#: of 7.5.2) and "uniform_support" (`UniformSupportDurationModel`, Scheduler B of 7.5.2)
DURATION_MODELS = {"empirical": DurationModel, "uniform_support": UniformSupportDurationModel}


def copy_generator(rng: np.random.Generator) -> np.random.Generator:
    """An independent generator in the same state as `rng` (same future draws); ~3x cheaper
    than `copy.deepcopy`, used by the copy-on-write clones of the policies."""
    bit_generator = type(rng.bit_generator)(0)
    bit_generator.state = rng.bit_generator.state
    return np.random.Generator(bit_generator)


@dataclass
class TrialBatch:
    """Output of `simulate_trials`.

    paths: (N, L) fired transition indices per trial, -1 after the trial reached the horizon.
    costs: (N,) C of each trial; robot_wait, human_wait: (N,) the weighted W_R and W_H parts.
    """

    paths: np.ndarray
    costs: np.ndarray
    robot_wait: np.ndarray
    human_wait: np.ndarray


def _pool_depth(net: PcTPN, durations: DurationModel, horizon: float) -> int:
    means = [
        durations.mean(j) for j in np.flatnonzero(~net.controllable) if not durations.is_deterministic(j)
    ]
    means = [m for m in means if m > 0]
    if not means:
        return 1
    return int(np.clip(math.ceil(horizon / min(means)) + 2, 4, 64))


def simulate_trials(
    net: PcTPN,
    marking,
    durations: DurationModel,
    rng: np.random.Generator,
    n_trials: int,
    horizon: float,
    root_choices,
    elapsed=None,
    max_steps: int = 5000,
    now: float = 0.0,
    rollout: str = "uniform",
    compiled: bool = True,
    stratified_roots: bool = False,
    common_random_numbers: bool = False,
    wait_grid: bool = False,
    by_operator: DurationsByOperator | None = None,
) -> TrialBatch:
    """Run `n_trials` independent Monte Carlo trajectories of the net from `marking` up to
    `horizon` s (7.3.1, the trials of Algorithm 4).

    root_choices: the controllable transitions the first firing is drawn from, uniformly among
    those enabled (7.3.1 roots at every enabled controllable transition: pass them all).
    elapsed: (T,) seconds each currently enabled uncontrollable transition has already been
    enabled; its delay is then drawn conditioned on exceeding it (6.2.1).
    rollout: how controllable conflicts after the root are resolved. "uniform" (7.3.1): any
    enabled controllable transition with equal probability. "work_first": uniformly among the
    robots' actions and commitments, an explicit wait only when none is enabled.
    compiled: step the trials with `_kernels.trial_step` (default) or with numpy operations on
    all trials at once (the reference; same draws, paths and costs).
    Variants (departures from 7.3.1, off by default): stratified_roots: trial n takes root
    choice n mod R, so every root child gets samples; common_random_numbers (needs
    stratified_roots): the trials n // R of a group share their firing delays and the random
    keys of their later controllable choices; wait_grid: a wait started at absolute time
    `now` + t ends on the next multiple of t_w (`wait_tick_delay`) instead of lasting t_w;
    by_operator (`scheduling.slowdown.DurationsByOperator`): a robot action enabled while the
    trial's operator is in an activity under which it has learned durations draws from those.
    """
    if rollout not in ROLLOUTS:
        raise ValueError(f"simulate_trials: rollout must be one of {ROLLOUTS}, got {rollout!r}")
    if common_random_numbers and not stratified_roots:
        raise ValueError("simulate_trials: common_random_numbers needs stratified_roots (groups of R trials)")
    marking = np.asarray(marking, dtype=np.int64)
    if marking.shape != (net.n_places,) or np.any(marking < 0):
        raise ValueError(f"simulate_trials: marking must be ({net.n_places},) and >= 0")
    if not horizon > 0:
        raise ValueError(f"simulate_trials: horizon must be > 0, got {horizon}")
    if n_trials < 1:
        raise ValueError(f"simulate_trials: n_trials must be >= 1, got {n_trials}")
    en0 = net.enabled(marking)
    roots = np.array([j for j in np.atleast_1d(root_choices) if net.controllable[j] and en0[j]], dtype=int)
    if roots.size == 0:
        raise ValueError("simulate_trials: none of the root choices is an enabled controllable transition")
    n_tr, unc = net.n_transitions, ~net.controllable
    inc_t = net.incidence.T.copy()
    human_agent = getattr(net, "human_agent", "human")
    is_human_place = np.array([a == human_agent for a in net.idle_agent])
    human_w = np.where(is_human_place, net.cost, 0.0)
    robot_w = net.cost - human_w
    depth = _pool_depth(net, durations, horizon)
    rows = np.arange(n_trials)
    if common_random_numbers:
        # trial n belongs to group n // R (R root choices) and takes root choice n % R; the trials
        # of a group share their delays and the keys of their later controllable choices
        n_groups = -(-n_trials // roots.size)
        group = rows // roots.size
    else:
        n_groups, group = n_trials, rows
    pools = durations.sample_pools(rng, n_groups, depth)[group]
    pairs = [] if by_operator is None else by_operator.learned_pairs()
    if by_operator is None:
        activity_place = activity_of_place = np.zeros(0, dtype=np.int64)
        pair_of = np.full((n_tr, 1), -1, dtype=np.int64)
    else:
        activity_place, activity_of_place = by_operator.activities.places, by_operator.activities.activity
        pair_of = by_operator.pair_index(pairs)
    pair_pools = np.zeros((n_trials, 0, depth)) if not pairs else (
        by_operator.sample_pools(pairs, rng, n_groups, depth)[group])
    if stratified_roots:
        first_j = roots[rows % roots.size]
    else:
        first_j = roots[rng.integers(0, roots.size, size=n_trials)]
    count = np.zeros((n_trials, n_tr), dtype=np.int64)
    fire_at = np.full((n_trials, n_tr), np.inf)
    is_wait_end = np.array([r == "wait_end" for r in net.role], dtype=bool)
    key_bonus = np.zeros(n_tr)
    if rollout == "work_first":
        key_bonus[net.controllable & np.array([r != "wait" for r in net.role])] = 1.0
    # the trials read a wait's end from the grid when quantum > 0, else from its pool (t_w, fixed)
    quantum = getattr(net, "wait_quantum", 0.0) if wait_grid else 0.0

    # Clocks of the transitions already enabled at the root, conditioned on their elapsed time
    # (drawn as if enabled under the operator's activity now).
    root_activity = -1 if by_operator is None else by_operator.activities.of_marking(marking)
    for j in np.flatnonzero(en0 & unc):
        e = 0.0 if elapsed is None else float(elapsed[j])
        pair = pair_of[j, root_activity]
        cand = pair_pools[:, pair, :] if pair >= 0 else pools[:, j, :]
        if e <= 0:
            fire_at[:, j] = cand[:, 0]
            count[:, j] = 1
            continue
        later = cand > e
        first = np.argmax(later, axis=1)
        fire_at[:, j] = np.where(later.any(axis=1), cand[rows, first], e) - e
        count[:, j] = first + 1
    en_prev = np.broadcast_to(en0 & unc, (n_trials, n_tr)).copy()

    m = np.repeat(marking[None, :], n_trials, axis=0)
    m += inc_t[first_j]
    lockstep = _lockstep_compiled if compiled else _lockstep_numpy
    cols, cost_r, cost_h = lockstep(
        _Trials(net, m, pools, count, fire_at, en_prev, group, n_groups, key_bonus, is_wait_end, robot_w,
                human_w, inc_t, durations, np.ascontiguousarray(activity_place, dtype=np.int64),
                np.ascontiguousarray(activity_of_place, dtype=np.int64), pair_of, pair_pools, by_operator,
                pairs),
        rng, horizon, now, quantum, max_steps,
    )
    return TrialBatch(np.stack([first_j] + cols, axis=1), cost_r + cost_h, cost_r, cost_h)


@dataclass
class _Trials:
    """The lockstep state of `simulate_trials` after the root firing (arrays changed in place)."""

    net: PcTPN
    m: np.ndarray  # (N, P) markings
    pools: np.ndarray  # (N, T, depth) delays
    count: np.ndarray  # (N, T) firings drawn so far per transition
    fire_at: np.ndarray  # (N, T) clocks of the enabled uncontrollable transitions, else inf
    en_prev: np.ndarray  # (N, T) enabled uncontrollable transitions of the previous step
    group: np.ndarray  # (N,) common-random-number group of each trial
    n_groups: int
    key_bonus: np.ndarray  # (T,) added to the random keys of controllable choices
    is_wait_end: np.ndarray  # (T,) the ends of robot waits (on the t_w ticks)
    robot_w: np.ndarray  # (P,) cost weights of the robots' idle places
    human_w: np.ndarray  # (P,) and of the human's
    inc_t: np.ndarray  # (T, P) incidence, transposed
    durations: DurationModel  # draws more delays when a transition has used its pool
    activity_place: np.ndarray  # (K,) the places that show the operator's activity, by precedence
    activity_of_place: np.ndarray  # (K,) the activity each shows
    pair_of: np.ndarray  # (T, C + 1) the pair pool of (transition, operator activity), or -1
    pair_pools: np.ndarray  # (N, L, depth) delays of the learned (transition, activity) pairs
    by_operator: DurationsByOperator | None  # draws more pair delays with the pools
    pairs: list  # the L learned (transition, activity) pairs
    random_delay: np.ndarray | None = None  # (T,) the transitions whose delays are random

    def refill(self, rng: np.random.Generator) -> None:
        """Fresh delays once a trial has used the whole pool of a transition with a random delay
        (the pools grow by `depth` new draws per group), so no delay is used twice (a fixed one
        may: it is the same value); called before every step, in the same order by both lockstep
        forms."""
        depth = self.pools.shape[2]
        random = self.random_delay
        if random is None:
            random = self.random_delay = np.array(
                [not (self.net.controllable[j] or self.durations.is_deterministic(j))
                 for j in range(self.net.n_transitions)], dtype=bool)
            random[[j for j, _ in self.pairs]] = True  # learned per operator activity: drawn
        if random.any() and self.count[:, random].max() >= depth:
            more = self.durations.sample_pools(rng, self.n_groups, depth)[self.group]
            self.pools = np.concatenate([self.pools, more], axis=2)
            if self.pairs:
                more = self.by_operator.sample_pools(self.pairs, rng, self.n_groups, depth)[self.group]
                self.pair_pools = np.concatenate([self.pair_pools, more], axis=2)


def _no_horizon(max_steps: int) -> RuntimeError:
    return RuntimeError(
        f"simulate_trials: {max_steps} firings without reaching the horizon; the net has a loop of "
        "zero-delay transitions"
    )


def _lockstep_compiled(trials: _Trials, rng, horizon, now, quantum, max_steps):
    """The trials' steps by `_kernels.trial_step`, one call per step; the same draws, choices and
    costs as `_lockstep_numpy` (the costs are summed by the same numpy products)."""
    net = trials.net
    n_trials = trials.m.shape[0]
    unc = np.ascontiguousarray(~net.controllable)
    controllable = np.ascontiguousarray(net.controllable, dtype=bool)
    t, cost_r, cost_h = np.zeros(n_trials), np.zeros(n_trials), np.zeros(n_trials)
    alive = np.ones(n_trials, dtype=bool)
    dt, fired = np.empty(n_trials), np.full(n_trials, -1, dtype=np.int64)
    cols = []
    for _ in range(max_steps):
        trials.refill(rng)
        keys = rng.random((trials.n_groups, net.n_transitions))
        chosen, column = np.empty(n_trials, dtype=np.int64), np.empty(n_trials, dtype=np.int64)
        running = _kernels.trial_step(
            trials.m, net.arcs(), fired, unc, controllable, trials.is_wait_end, trials.pools, trials.count,
            trials.fire_at, trials.en_prev, t, alive, keys, trials.group, trials.key_bonus, float(horizon),
            float(now), float(quantum), dt, chosen, column, trials.activity_place, trials.activity_of_place,
            trials.pair_of, trials.pair_pools,
        )
        cost_r += (trials.m @ trials.robot_w) * dt
        cost_h += (trials.m @ trials.human_w) * dt
        if not running:
            return cols, cost_r, cost_h
        fired = chosen
        cols.append(column)
    raise _no_horizon(max_steps)


def _activities(trials: _Trials, m: np.ndarray) -> np.ndarray:
    """(N,) the operator's activity of each trial: that of its first marked activity place, else
    the last column of `pair_of` (no activity known)."""
    activity = np.full(m.shape[0], trials.pair_of.shape[1] - 1, dtype=np.int64)
    for place, shown in zip(trials.activity_place[::-1], trials.activity_of_place[::-1], strict=True):
        activity[m[:, place] > 0] = shown  # in reverse, so the first marked place wins
    return activity


def _lockstep_numpy(trials: _Trials, rng, horizon, now, quantum, max_steps):
    """The trials' steps as numpy operations on all trials at once (the reference of the
    compiled form): returns the path columns after the root and the robot and human costs."""
    net, m, count = trials.net, trials.m, trials.count
    fire_at, en_prev = trials.fire_at, trials.en_prev
    group, key_bonus, is_wait_end = trials.group, trials.key_bonus, trials.is_wait_end
    unc = ~net.controllable
    n_trials, n_tr = m.shape[0], net.n_transitions
    rows = np.arange(n_trials)
    t = np.zeros(n_trials)
    cost_r = np.zeros(n_trials)
    cost_h = np.zeros(n_trials)
    cols = []
    alive = np.ones(n_trials, dtype=bool)
    for _ in range(max_steps):
        trials.refill(rng)
        en = net.enabled_batch(m)
        newly = en & unc & ~en_prev
        if newly.any():
            n_idx, j_idx = np.nonzero(newly)
            k = count[n_idx, j_idx] % trials.pools.shape[2]
            delay = trials.pools[n_idx, j_idx, k]
            if trials.pairs:
                pair = trials.pair_of[j_idx, _activities(trials, m)[n_idx]]
                mine = pair >= 0
                delay[mine] = trials.pair_pools[n_idx[mine], pair[mine], k[mine]]
            if quantum > 0 and is_wait_end[j_idx].any():
                delay = np.where(is_wait_end[j_idx], wait_tick_delay(now + t[n_idx], quantum), delay)
            fire_at[n_idx, j_idx] = t[n_idx] + delay
            count[n_idx, j_idx] += 1
        fire_at[~en] = np.inf
        en_prev = en & unc
        ctrl_en = en & net.controllable
        j_unc = np.argmin(fire_at, axis=1)
        t_unc = fire_at[rows, j_unc]
        # events due now fire first, so robots freed at the same instant decide together
        has_ctrl = ctrl_en.any(axis=1) & alive & (t_unc > t)
        keys = np.where(ctrl_en, rng.random((trials.n_groups, n_tr))[group] + key_bonus, -1.0)
        j_ctrl = np.argmax(keys, axis=1)
        advance = alive & ~has_ctrl
        t_next = np.where(advance, np.minimum(t_unc, horizon), t)
        dt = t_next - t
        cost_r += (m @ trials.robot_w) * dt
        cost_h += (m @ trials.human_w) * dt
        t = t_next
        alive &= ~(advance & (t_unc > horizon))
        j = np.where(has_ctrl, j_ctrl, j_unc)
        if not alive.any():
            return cols, cost_r, cost_h
        # finished trials fire too (cheaper than masking): their time and costs are frozen and
        # their path entries are -1, so what happens to their marking is never read
        m += trials.inc_t[j]
        fire_at[rows, j] = np.inf
        en_prev[rows, j] = False
        cols.append(np.where(alive, j, -1))
    raise _no_horizon(max_steps)


def percentile_linear(values: np.ndarray, quantile: float) -> float:
    """`np.percentile(values, 100 quantile)` of a 1-d float array (its "linear" method, bit for bit:
    the same virtual index, neighbours and interpolation), without numpy's generic dispatch,
    which was 60 % of Algorithm 4's time."""
    n = values.size
    virtual = (n - 1) * quantile
    if virtual >= n - 1:
        return float(values.max())
    if virtual < 0:
        return float(values.min())
    below = math.floor(virtual)
    gamma = virtual - below
    part = np.partition(values, (below, below + 1))
    a, b = float(part[below]), float(part[below + 1])
    diff = b - a
    return b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma


def evaluate_costs(
    paths: np.ndarray, costs: np.ndarray, controllable: np.ndarray, beta: float, min_branch_samples: int = 1
):
    """Algorithm 4 (EVALUATECOSTS) on the reachability tree spanned by the trial paths.

    Returns (best root transition, {root transition: beta-percentile of its propagated costs}).
    A node's children are the distinct next transitions of the trials through it; a trial
    that ends at a node (nothing fires before T_sch) is one more uncontrollable outcome.
    min_branch_samples: below the root, rule (b) (inherit the child with the lowest
    percentile) is applied only when every child holds at least this many trials; otherwise
    the children are united as in rule (a). With few samples per child the minimum of their
    percentiles is biased low (the lowest of noisy estimates), and the bias grows with the
    number of later decisions, so a wait, which brings a decision every t_w, looks cheaper
    than work. 1 gives Algorithm 4 exactly.
    """
    if not 0 <= beta <= 1:
        raise ValueError(f"evaluate_costs: beta must be in [0, 1], got {beta}")
    if min_branch_samples < 1:
        raise ValueError(f"evaluate_costs: min_branch_samples must be >= 1, got {min_branch_samples}")
    paths = np.asarray(paths)
    costs = np.asarray(costs, dtype=float)
    length = paths.shape[1]
    quantile = 100.0 * beta / 100.0  # as np.percentile(c, 100 beta) divides it
    # Trials sorted by their paths (column 0 first): the trials through a node are one row range,
    # its children consecutive sub-ranges in ascending transition order (ended trials, -1, first).
    order = np.lexsort(paths.T[::-1])
    paths, costs = paths[order], costs[order]

    def node_costs(lo: int, hi: int, d: int) -> np.ndarray:
        while True:
            # below 2 min_branch_samples trials no branching can apply rule (b): all unite
            if hi - lo < 2 * min_branch_samples or d >= length:
                return costs[lo:hi]
            js = paths[lo:hi, d]
            if js[-1] < 0:  # every trial ended here
                return costs[lo:hi]
            if js[0] == js[-1]:
                d += 1
                continue
            break
        starts = [lo, *(np.flatnonzero(js[1:] != js[:-1]) + 1 + lo).tolist()]
        ends = [*starts[1:], hi]
        ended_end = lo
        if js[0] < 0:
            ended_end = ends[0]
            starts, ends = starts[1:], ends[1:]
        children = list(zip(starts, ends, strict=True))
        # the branching's kind is read off its trial of lowest original index, as unsorted
        first_trial = ended_end + int(np.argmin(order[ended_end:hi]))
        if controllable[paths[first_trial, d]] and min(e - s for s, e in children) >= min_branch_samples:
            best, best_p = None, np.inf
            for s, e in children:
                c = node_costs(s, e, d + 1)
                p = percentile_linear(c, quantile)
                if p < best_p:
                    best, best_p = c, p
            return best
        # rule (a), also for controllable branchings with too few trials per child
        return np.concatenate([costs[lo:ended_end]] + [node_costs(s, e, d + 1) for s, e in children])

    first = paths[:, 0]
    bounds = [0, *(np.flatnonzero(first[1:] != first[:-1]) + 1).tolist(), len(first)]
    percentiles = {}
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        percentiles[int(first[lo])] = percentile_linear(node_costs(lo, hi, 1), quantile)
    best = min(percentiles, key=lambda u: (percentiles[u], u))
    return best, percentiles


@dataclass
class CostNode:
    """A reachability-tree node for Algorithm 4 built by hand: `controllable` says whether its
    children are reached by controllable transitions; leaves carry cost samples."""

    controllable: bool = False
    children: dict = field(default_factory=dict)
    costs: np.ndarray = field(default_factory=lambda: np.zeros(0))


def evaluate_cost_tree(node: CostNode, beta: float, is_root: bool = True):
    """Algorithm 4 on an explicit tree. At the root returns (best child key, its costs)."""
    if is_root or node.controllable:
        best_key, best_c, best_p = None, np.zeros(0), np.inf
        for key, child in node.children.items():
            c = evaluate_cost_tree(child, beta, is_root=False)
            p = np.percentile(c, 100.0 * beta)
            if p < best_p:
                best_key, best_c, best_p = key, c, p
        return (best_key, best_c) if is_root else best_c
    if not node.children:
        return np.asarray(node.costs, dtype=float)
    return np.concatenate(
        [np.asarray(node.costs, dtype=float)]
        + [evaluate_cost_tree(c, beta, False) for c in node.children.values()]
    )


class MonteCarloPolicy:
    """Receding-horizon Monte Carlo scheduler (7.1 + 7.3.1, Algorithm 4).

    n_trials: N; horizon: T_sch (s); beta: percentile level of Algorithm 4 (0.5 = median).
    window, min_samples: the online duration model (`DurationModel`). learn: update it
    from `observe`. min_branch_samples: trials each child of a controllable branching below
    the root needs before rule (b) of Algorithm 4 applies (see `evaluate_costs`).
    durations: the delays the trials sample, a key of `DURATION_MODELS`: "empirical" (the
    observed delays, Scheduler A of use case b, 7.5.2) or "uniform_support" (uniform between
    the smallest and the largest observed delay, Scheduler B of 7.5.2).
    root_choices, stratified_roots, common_random_numbers, wait_grid: how the trials are
    generated; the defaults are 7.3.1's ("all_enabled", off, off, off), the others are the
    variants of `simulate_trials`. `wait_grid` is also how the cell should execute this
    policy's waits (`cellsim.simulate_cell` reads it), so the trials model the cell.
    durations_by_operator: a variant (issue 52): learn each robot action's durations per operator
    activity at its start (`observe(..., operator=)`) and draw the trials' robot actions from
    them (`scheduling.slowdown`), so the search prefers work the operator does not slow.
    """

    def __init__(
        self,
        net: PcTPN,
        n_trials: int = 100,
        horizon: float = 20.0,
        beta: float = 0.5,
        window: int = 30,
        min_samples: int = 3,
        learn: bool = True,
        random_state=None,
        min_branch_samples: int = 1,
        rollout: str = "uniform",
        durations: str = "empirical",
        root_choices: str = "all_enabled",
        stratified_roots: bool = False,
        common_random_numbers: bool = False,
        wait_grid: bool = False,
        durations_by_operator: bool = False,
    ):
        if n_trials < 1 or not horizon > 0 or not 0 <= beta <= 1:
            raise ValueError(
                f"MonteCarloPolicy: need n_trials >= 1, horizon > 0, 0 <= beta <= 1; "
                f"got {n_trials}, {horizon}, {beta}"
            )
        self.net = net
        self.n_trials = int(n_trials)
        self.horizon = float(horizon)
        self.beta = float(beta)
        self.learn = learn
        self.min_branch_samples = int(min_branch_samples)
        if rollout not in ROLLOUTS:
            raise ValueError(f"MonteCarloPolicy: rollout must be one of {ROLLOUTS}, got {rollout!r}")
        self.rollout = rollout
        if durations not in DURATION_MODELS:
            raise ValueError(
                f"MonteCarloPolicy: durations must be one of {tuple(DURATION_MODELS)}, got {durations!r}"
            )
        if root_choices not in ROOT_CHOICES:
            raise ValueError(
                f"MonteCarloPolicy: root_choices must be one of {ROOT_CHOICES}, got {root_choices!r}"
            )
        if common_random_numbers and not stratified_roots:
            raise ValueError("MonteCarloPolicy: common_random_numbers needs stratified_roots")
        self.root_choices = root_choices
        self.stratified_roots = bool(stratified_roots)
        self.common_random_numbers = bool(common_random_numbers)
        self.wait_grid = bool(wait_grid)
        self.durations = durations
        self.durations_ = DURATION_MODELS[durations](net, window=window, min_samples=min_samples)
        self.durations_by_operator = bool(durations_by_operator)
        self.by_operator_ = (DurationsByOperator(net, window=window, min_samples=min_samples)
                          if durations_by_operator else None)
        self.rng = np.random.default_rng(random_state)
        self.last_percentiles_: dict[str, float] = {}

    def decide(self, marking, agent: str, now: float = 0.0, elapsed=None) -> int:
        """The controllable transition to fire now for robot `agent` (an action, a commitment
        to a collaboration, or its wait): of the root children that command `agent`, the one
        with the lowest beta-percentile (Algorithm 4; a uniform draw among the agent's choices
        if no trial started with any of them)."""
        choices = self.net.agent_choices(marking, agent, "MonteCarloPolicy")
        if choices.size == 1:
            self.last_percentiles_ = {}
            return int(choices[0])
        roots = choices
        if self.root_choices == "all_enabled":
            roots = np.flatnonzero(self.net.controllable & self.net.enabled(marking))
        batch = simulate_trials(
            self.net,
            marking,
            self.durations_,
            self.rng,
            self.n_trials,
            self.horizon,
            roots,
            elapsed,
            now=now,
            rollout=self.rollout,
            stratified_roots=self.stratified_roots,
            common_random_numbers=self.common_random_numbers,
            wait_grid=self.wait_grid,
            by_operator=self.by_operator_,
        )
        _, percentiles = evaluate_costs(
            batch.paths, batch.costs, self.net.controllable, self.beta, self.min_branch_samples
        )
        self.last_percentiles_ = {self.net.transitions[j]: p for j, p in percentiles.items()}
        mine = [int(j) for j in choices if int(j) in percentiles]
        if not mine:
            return int(self.rng.choice(choices))
        return min(mine, key=lambda u: (percentiles[u], u))

    def clone(self) -> MonteCarloPolicy:
        """A copy that `decide` and `observe` may change without touching this one: its own
        random generator (same state) and duration model; the net is shared."""
        new = shallow_copy(self)
        new.durations_ = self.durations_.clone()
        if self.by_operator_ is not None:
            new.by_operator_ = self.by_operator_.clone()
        new.rng = copy_generator(self.rng)
        return new

    def observe(self, transition, delay: float, operator: str | None = None) -> None:
        """An observed firing delay of an uncontrollable transition (7.1 online learning);
        `operator`: the operator's activity when it was enabled (read with durations_by_operator)."""
        if self.learn:
            self.durations_.partial_fit(transition, delay)
            if self.by_operator_ is not None:
                self.by_operator_.partial_fit(transition, delay, operator)
