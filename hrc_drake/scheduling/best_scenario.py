"""Best-scenario scheduler (thesis 7.2): a branch and bound over the reachability tree of a
pcTPN whose delays are known only by their supports [d_lo, d_hi] (Algorithms 2-3), with the
cost of eq. (7.1)-(7.2) on the time the robots are ready for the next collaboration, and the
P_a1 / P_c1 policy of 7.2.1 around it.

A plan is a path of the tree from the current marking to the firing of the collaboration's
commitment t_c (the robots are ready and start waiting for the human, Fig. 7.3). Each node
carries its arrival set [alpha_lo, alpha_hi]; a plan costs the mean of eq. (7.1) over the
arrival set of its last node, against the predicted window [P_c1, P_c2] of the human's start
of the collaboration. While planning, the human's transitions never fire (7.2.2: "t_h is not
allowed to fire"), and only the first controllable transitions of the best plan are applied
(receding horizon, 7.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hrc_drake.distributions import Distribution
from hrc_drake.messages import Forecast, shallow_copy
from hrc_drake.scheduling.config import TIE_BREAKS
from hrc_drake.scheduling.petri import PcTPN

# Ways to choose among plans of equal cost C* (7.2.2 leaves it open and names criteria):
# "most_work" keeps the plan with the most robot operations before t_c, the first criterion
# the text names; "first_found" keeps the first plan found, as Algorithm 2 is printed.

#: places holding the human's own state (compiler, 6.3.2)
_HUMAN_PLACE_PREFIXES = ("step:", "hwait:", "human:idle")


def delay_support(dist: Distribution) -> tuple[float, float]:
    """The support [d_lo, d_hi] of a firing delay (7.2.2). Bounded kinds give their bounds;
    a normal N(mu, sigma) truncated at `low` gives [max(low, mu - 3 sigma), mu + 3 sigma] and
    a lognormal its 0.135 % and 99.865 % quantiles (the same 3-sigma reach): our choice, as
    the text takes the supports from a few measured times."""
    kind = dist.kind
    if kind == "fixed":
        return float(dist.mean), float(dist.mean)
    if kind in ("uniform", "triangular"):
        return float(dist.low), float(dist.high)
    if kind == "normal":
        low = float(dist.low)
        return max(low, dist.mean - 3.0 * dist.std), max(low, dist.mean + 3.0 * dist.std)
    if kind == "lognormal":
        if dist.std == 0:
            return float(dist.mean), float(dist.mean)
        from scipy.stats import lognorm  # here: scipy.stats takes 0.6 s to import; few nets have one

        s2 = math.log1p((dist.std / dist.mean) ** 2)
        frozen = lognorm(s=math.sqrt(s2), scale=dist.mean / math.sqrt(1.0 + (dist.std / dist.mean) ** 2))
        return float(frozen.ppf(0.00135)), float(frozen.ppf(0.99865))
    if kind == "empirical":
        return float(min(dist.samples)), float(max(dist.samples))
    raise ValueError(f"delay_support: unknown distribution kind {kind!r}")


def waiting_cost(alpha: float, p_c1: float, p_c2: float, c_r: float, c_h: float) -> float:
    """Eq. (7.1): robots idle before P_c1 cost c_R per s, the human idle after P_c2 c_H per s."""
    if alpha < p_c1:
        return c_r * (p_c1 - alpha)
    if alpha > p_c2:
        return c_h * (alpha - p_c2)
    return 0.0


def plan_cost(alpha_lo: float, alpha_hi: float, p_c1: float, p_c2: float, c_r: float, c_h: float) -> float:
    """Eq. (7.2): the mean of eq. (7.1) over the arrival set [alpha_lo, alpha_hi] (its value
    at the point when the set is a point), in closed form: eq. (7.1) is piecewise linear."""
    if alpha_hi <= alpha_lo:
        return waiting_cost(alpha_lo, p_c1, p_c2, c_r, c_h)

    def integral(a: float, b: float) -> float:  # of eq. (7.1) over [a, b], a <= b
        total = 0.0
        lo, hi = a, min(b, p_c1)
        if hi > lo:  # c_R (P_c1 - x)
            total += c_r * ((p_c1 - lo) ** 2 - (p_c1 - hi) ** 2) / 2.0
        lo, hi = max(a, p_c2), b
        if hi > lo:  # c_H (x - P_c2)
            total += c_h * ((hi - p_c2) ** 2 - (lo - p_c2) ** 2) / 2.0
        return total

    return integral(alpha_lo, alpha_hi) / (alpha_hi - alpha_lo)


def cost_lower_bound(alpha_lo: float, p_c2: float, c_h: float) -> float:
    """C_hat of 7.2.2: a lower bound of the cost of every plan through a node, as alpha_lo
    never decreases down the tree: 0 while alpha_lo <= P_c2, else c_H (alpha_lo - P_c2)."""
    return 0.0 if alpha_lo <= p_c2 else c_h * (alpha_lo - p_c2)


def human_transitions(net: PcTPN) -> np.ndarray:
    """(T,) bool: the uncontrollable transitions of the human's own net (its intentions, the
    begin and end of actions it takes part in), which never fire while planning (7.2.2)."""
    human_places = np.array([p.startswith(_HUMAN_PLACE_PREFIXES) for p in net.places])
    # busy places of actions the human starts (begun by a transition consuming a human place);
    # not the part of a robot released early (Fig. 7.3): its release is the robot's
    robot_parts = np.array([p.startswith("part:") for p in net.places])
    starts = np.flatnonzero((net.pre[human_places] > 0).any(axis=0))
    for j in starts:
        human_places |= (net.post[:, j] > 0) & ~robot_parts
    touches = ((net.pre[human_places] > 0) | (net.post[human_places] > 0)).any(axis=0)
    return touches & ~net.controllable


@dataclass(frozen=True)
class PlanNode:
    """A node S_k of the reachability tree (Algorithm 3): marking, arrival set, the arrival
    set at which each enabled transition became enabled (the node S_e = enab), and the path."""

    marking: np.ndarray
    alpha_lo: float
    alpha_hi: float
    enabled_since: dict = field(default_factory=dict)
    path: tuple[int, ...] = ()
    work: int = 0


@dataclass
class Plan:
    """The best plan v* of Algorithm 2 (None when no plan reaches t_c within the horizon)."""

    path: tuple[int, ...] | None
    cost: float
    alpha_lo: float
    alpha_hi: float
    #: nodes created (the tree's size) and nodes pruned by the bound or as impossible
    nodes: int = 0
    pruned: int = 0
    truncated: bool = False


class BestScenarioPlanner:
    """Algorithms 2-3 on a pcTPN.

    target: the controllable transition t_c that ends a plan (a collaboration's commitment).
    supports: (T, 2) delay supports [d_lo, d_hi] (default: `delay_support` of the net's delays).
    c_r, c_h: the unit costs of eq. (7.1). horizon: T_sch (s): nodes whose arrival lower bound
    lies beyond now + T_sch are not expanded (7.1). ties: one of TIE_BREAKS. max_nodes: a
    guard on the tree's size (the plan so far is returned, `truncated` set).
    """

    def __init__(self, net: PcTPN, target, supports=None, c_r: float = 1.0, c_h: float = 1.0,
                 horizon: float = 60.0, ties: str = "most_work", max_nodes: int = 200_000):
        if ties not in TIE_BREAKS:
            raise ValueError(f"BestScenarioPlanner: ties must be one of {TIE_BREAKS}, got {ties!r}")
        if not (c_r >= 0 and c_h >= 0 and horizon > 0 and max_nodes >= 1):
            raise ValueError(f"BestScenarioPlanner: need c_r, c_h >= 0, horizon > 0, max_nodes >= 1; got "
                             f"{c_r}, {c_h}, {horizon}, {max_nodes}")
        self.net = net
        self.target = net.index_of(target)
        if not net.controllable[self.target]:
            raise ValueError(f"BestScenarioPlanner: target {net.transitions[self.target]!r} is not "
                             "controllable")
        if supports is None:
            supports = [delay_support(d) if not c else (0.0, 0.0)
                        for d, c in zip(net.delays, net.controllable, strict=True)]
        self.supports = np.asarray(supports, dtype=float).reshape(net.n_transitions, 2)
        if np.any(self.supports[:, 0] > self.supports[:, 1]) or np.any(self.supports < 0):
            raise ValueError("BestScenarioPlanner: supports need 0 <= d_lo <= d_hi")
        self.c_r, self.c_h = float(c_r), float(c_h)
        self.horizon = float(horizon)
        self.ties = ties
        self.max_nodes = int(max_nodes)
        # The net of Fig. 7.3 has no explicit robot waits: a robot idles only committed to the
        # collaboration. The compiled net's waits (6.3.1) are left out of the plans (a wait
        # already under way still ends).
        roles = np.array(net.role)
        explicit_waits = net.controllable & (roles == "wait")
        self.frozen = human_transitions(net) | explicit_waits
        # robot operations (the begin of an action by a robot) count as work for "most_work"
        self._work = net.controllable & (roles == "begin")

    def _enabled(self, marking) -> np.ndarray:
        return self.net.enabled(marking) & ~self.frozen

    def root(self, marking, now: float = 0.0, elapsed=None) -> PlanNode:
        """S_0: the current marking at time `now`; an uncontrollable transition enabled for
        `elapsed[j]` s was enabled at now - elapsed[j]."""
        marking = np.asarray(marking, dtype=np.int64)
        since = {}
        for j in np.flatnonzero(self._enabled(marking)):
            back = float(elapsed[j]) if elapsed is not None and not self.net.controllable[j] else 0.0
            since[int(j)] = (now - back, now - back)
        return PlanNode(marking, now, now, since)

    def child(self, node: PlanNode, j: int) -> PlanNode | None:
        """Algorithm 3: the node reached by firing t_j from `node`, or None when its arrival set
        is impossible. A controllable transition fires when it became enabled (alpha_e); an
        uncontrollable one d_lo..d_hi after. The lower bound is raised to the parent's, as
        alpha_lo never decreases down the tree (7.2.2): the printed last lines of Algorithm 3
        swap the indices i and k, and read literally the test could never fail."""
        e_lo, e_hi = node.enabled_since[j]
        if self.net.controllable[j]:
            lo, hi = e_lo, e_hi
        else:
            lo, hi = e_lo + self.supports[j, 0], e_hi + self.supports[j, 1]
        lo = max(lo, node.alpha_lo)
        if hi < lo:
            return None
        marking = node.marking + self.net.incidence[:, j]
        since = {}
        for k in np.flatnonzero(self._enabled(marking)):
            k = int(k)
            # enabled without interruption (also in the marking m_i - Pre_j while t_j fires):
            # its enabling node S_e, and so its enabling time, is kept
            kept = k != j and k in node.enabled_since and bool(
                np.all(self.net.pre[:, k] <= node.marking - self.net.pre[:, j]))
            since[k] = node.enabled_since[k] if kept else (lo, hi)
        work = node.work + int(self._work[j])
        return PlanNode(marking, lo, hi, since, (*node.path, j), work)

    def plan(self, marking, p_c1: float, p_c2: float, now: float = 0.0, elapsed=None) -> Plan:
        """Algorithm 2: the plan v* of least cost C (eq. 7.2) from `marking` to t_c, depth first,
        pruning a branch when its bound C_hat is not below C* (or above it, with ties
        "most_work", so plans of equal cost are compared by their work)."""
        if not p_c1 <= p_c2:
            raise ValueError(f"BestScenarioPlanner.plan: need P_c1 <= P_c2, got {p_c1}, {p_c2}")
        best: PlanNode | None = None
        best_cost = math.inf
        stack = [self.root(marking, now, elapsed)]
        nodes, pruned, truncated = 1, 0, False
        limit = now + self.horizon
        while stack:
            node = stack.pop()
            if node.alpha_lo > limit:
                pruned += 1
                continue
            for j in node.enabled_since:
                if nodes >= self.max_nodes:
                    truncated = True
                    break
                kid = self.child(node, j)
                nodes += 1
                if kid is None:
                    pruned += 1
                    continue
                if j == self.target:
                    cost = plan_cost(kid.alpha_lo, kid.alpha_hi, p_c1, p_c2, self.c_r, self.c_h)
                    if best is None or cost < best_cost or (
                            self.ties == "most_work" and cost == best_cost and kid.work > best.work):
                        best, best_cost = kid, cost
                    continue
                bound = cost_lower_bound(kid.alpha_lo, p_c2, self.c_h)
                if best is None or bound < best_cost or (self.ties == "most_work" and bound == best_cost):
                    stack.append(kid)
                else:
                    pruned += 1
            if truncated:
                break
        if best is None:
            return Plan(None, math.inf, math.nan, math.nan, nodes, pruned, truncated)
        return Plan(best.path, best_cost, best.alpha_lo, best.alpha_hi, nodes, pruned, truncated)

    def first_commands(self, plan: Plan) -> list[int]:
        """The controllable transitions of `plan` that fire at once (before its first
        uncontrollable one): the commands to send now (receding horizon, 7.1)."""
        out = []
        for j in plan.path or ():
            if not self.net.controllable[j]:
                break
            out.append(int(j))
        return out


class BestScenarioPolicy:
    """The use case a controller of 7.2.1 around Algorithm 2, with the interface of the other
    policies (``decide``, ``observe``, ``clone``).

    collaboration: the human-robot action whose commitment ends a plan (t_c); human_action:
    the human's autonomous operation (2) of 7.2.1 and feed_action: the robot operation (1)
    that supplies it. Before each decision `set_forecast` gives the predicted window of the
    human's start of the collaboration [P_c1, P_c2] and the lower percentile P_a1 of its start
    of `human_action` (absolute times, s). Case 1 of 7.2.1 (P_a1 < P_c1 and operation 2 lacks
    its parts) commands `feed_action`; cases 2 and 3 run the planner and apply the first
    commands of its plan that concern the deciding agent, else the agent waits. A human the
    net shows waiting for operation 2 is case 1 whatever the forecast (the planner never fires
    the human, so without this it would never supply a waiting human: our reading). Without a
    forecast the window is [now, now] (the human may be ready at once): our choice; so it is
    while the net says the human already waits for the collaboration.
    levels: the forecast's percentile levels of P_1 and P_2 (`set_forecast_from`).
    forecaster: an `OnlineForecaster` (Ch. 5) fed by `human_event`, for event-level runs; the
    Drake `Scheduler` gives the cell's predictor's forecasts instead.
    learn: widen each support to the delays observed (the "on line correction" 7.1 allows).
    """

    def __init__(self, net: PcTPN, collaboration: str, human_action: str = "", feed_action: str = "",
                 c_r: float = 1.0, c_h: float = 1.0, horizon: float = 60.0, ties: str = "most_work",
                 learn: bool = True, max_nodes: int = 200_000, levels=(0.2, 0.8), forecaster=None):
        if any(role in ("hold", "join") for role in net.role):
            raise ValueError("BestScenarioPolicy: the net starts joint actions by holds (6.3.3); the planner "
                             "of 7.2 targets the one commitment t_c of Fig. 7.3: compile it with "
                             "joint_actions=\"simultaneous\"")
        self.net = net
        self.forecaster = forecaster
        self.levels = (float(levels[0]), float(levels[1]))
        self.planner = BestScenarioPlanner(net, f"{collaboration}:commit", c_r=c_r, c_h=c_h, horizon=horizon,
                                           ties=ties, max_nodes=max_nodes)
        self.collaboration = collaboration
        self.human_action = human_action
        self.feed = net.index_of(f"{feed_action}:begin") if feed_action else None
        if self.feed is not None and not net.controllable[self.feed]:
            raise ValueError(f"BestScenarioPolicy: feed_action {feed_action!r} is not a robot action")
        self._human_inputs = self._inputs_of(human_action) if human_action else None
        self._human_waits = self._waits_of(collaboration)
        self._human_waits_for_action = self._waits_of(human_action) if human_action else np.zeros(0, int)
        self.learn = learn
        self.window: tuple[float, float, float] | None = None
        self.last_plan_: Plan | None = None

    def _waits_of(self, action: str) -> np.ndarray:
        """The places where the human waits to start `action` (6.3.2 hwait:<k>)."""
        begins = [j for j in range(self.net.n_transitions) if self.net.action[j] == action
                  and self.net.role[j] == "begin" and not self.net.controllable[j]]
        return np.array(sorted({i for j in begins for i in np.flatnonzero(self.net.pre[:, j])
                                if self.net.places[i].startswith("hwait:")}), dtype=int)

    def _inputs_of(self, action: str) -> np.ndarray:
        """The buffer places the human action's begin consumes (its parts)."""
        begins = [j for j in range(self.net.n_transitions) if self.net.action[j] == action
                  and self.net.role[j] == "begin" and not self.net.controllable[j]]
        if not begins:
            raise ValueError(f"BestScenarioPolicy: {action!r} is not a human action of the net")
        places = {i for j in begins for i in np.flatnonzero(self.net.pre[:, j])
                  if self.net.places[i].startswith("buf:")}
        return np.array(sorted(places), dtype=int)

    def set_forecast(self, p_c1: float, p_c2: float, p_a1: float = math.inf) -> None:
        """The predicted window of the collaboration's start and P_a1 (absolute times, s)."""
        if not (p_c1 <= p_c2) or math.isnan(p_a1):
            raise ValueError(f"BestScenarioPolicy.set_forecast: need P_c1 <= P_c2 and P_a1 a number, got "
                             f"{p_c1}, {p_c2}, {p_a1}")
        self.window = (float(p_c1), float(p_c2), float(p_a1))

    def set_forecast_from(self, forecast: Forecast, now: float) -> None:
        """`set_forecast` from the activity predictor's forecast (waiting times from
        forecast.time, Ch. 5) at the levels `levels`; a time beyond the predictor's reach
        (inf) becomes the end of the planning horizon, now + T_sch."""
        horizon_end = now + self.planner.horizon

        def at(action: str, level: float) -> float:
            if action not in forecast.actions:
                return horizon_end
            levels = np.asarray(forecast.percentile_levels, dtype=float)
            k = np.flatnonzero(np.isclose(levels, level))
            if k.size == 0:
                raise ValueError(f"BestScenarioPolicy: the forecast has no percentile level {level} "
                                 f"(levels {levels.tolist()})")
            w = float(np.asarray(forecast.waiting_percentiles)[forecast.actions.index(action), k[0]])
            return min(forecast.time + w, horizon_end) if math.isfinite(w) else horizon_end

        p_c1, p_c2 = at(self.collaboration, self.levels[0]), at(self.collaboration, self.levels[1])
        p_a1 = at(self.human_action, self.levels[0]) if self.human_action else math.inf
        self.set_forecast(min(p_c1, p_c2), max(p_c1, p_c2), p_a1)

    def human_event(self, action: str, kind: str, time: float) -> None:
        """A human event of the run, for the forecaster (event-level simulation)."""
        if self.forecaster is not None:
            self.forecaster.observe(action, kind, time)

    def decide(self, marking, agent: str, now: float = 0.0, elapsed=None) -> int:
        """The controllable transition to fire now for robot `agent` (7.2.1 cases 1-3)."""
        net = self.net
        if self.forecaster is not None:
            self.set_forecast_from(self.forecaster.forecast(now), now)
        choices = net.agent_choices(marking, agent, "BestScenarioPolicy")
        wait = net.transition_index.get(f"{agent}:wait")
        p_c1, p_c2, p_a1 = self.window if self.window is not None else (now, now, math.inf)
        if self._human_waits.size and np.any(np.asarray(marking)[self._human_waits] > 0):
            p_c1 = p_c2 = now  # the human is there: every second the robots are not costs c_H
        marking = np.asarray(marking)
        # a human already waiting for operation 2 wants it before anything else: case 1
        # whatever the forecast says (our reading; the planner never fires the human)
        waiting_for_it = bool(np.any(marking[self._human_waits_for_action] > 0))
        if (self.feed is not None and net.enabled(marking)[self.feed] and (p_a1 < p_c1 or waiting_for_it)
                and not np.all(marking[self._human_inputs] > 0)):
            if self.feed in choices:
                return int(self.feed)  # case 1: supply the human's next operation
            # case 1 for another agent: this one plans without it, which supplies the human
            marking = marking.copy()
            for other in net.agents[self.feed]:
                marking[net.place_index[f"avail:{other}"]] = 0
            choices = net.agent_choices(marking, agent, "BestScenarioPolicy")
        self.last_plan_ = plan = self.planner.plan(marking, p_c1, p_c2, now, elapsed)
        for j in self.planner.first_commands(plan):
            if agent in net.agents[j] and j in choices:
                return int(j)
        return int(wait) if wait is not None and wait in choices else int(choices[0])

    def observe(self, transition, delay: float) -> None:
        """An observed firing delay: the support grows to hold it (with `learn`)."""
        j = self.net.index_of(transition)
        if self.learn and not self.net.controllable[j] and math.isfinite(delay) and delay >= 0:
            lo, hi = self.planner.supports[j]
            if delay < lo or delay > hi:
                supports = self.planner.supports.copy()
                supports[j] = (min(lo, delay), max(hi, delay))
                self.planner.supports = supports

    def clone(self) -> BestScenarioPolicy:
        """A copy whose `observe` and forecasts do not touch this one (the net is shared)."""
        new = shallow_copy(self)
        new.planner = shallow_copy(self.planner)
        if self.forecaster is not None:
            new.forecaster = self.forecaster.clone()
        return new
