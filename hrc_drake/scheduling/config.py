"""Typed configs of the robot scheduler, one dataclass per kind (thesis 6-7).

A scenario chooses one by its YAML tag, e.g. ``scheduler: !MonteCarloScheduler {n_trials: 100}``.
Every kind that runs a scheduler carries the fields of the pcTPN it plans on (wait quantum t_w,
idle costs c_R, c_H) and its update rate. No pydrake here, and real annotations (pydrake's
typed YAML loader reads them).
"""

import math
from dataclasses import dataclass, field
from typing import Union

from hrc_drake.errors import check

#: rollout policies of the Monte Carlo trials (hrc_drake.scheduling.montecarlo.ROLLOUTS)
ROLLOUTS = ("uniform", "work_first")
#: delay models of the Monte Carlo trials (hrc_drake.scheduling.montecarlo.DURATION_MODELS)
DURATION_MODELS = ("empirical", "uniform_support")
#: how an action of two robot agents starts (`hrc_drake.scheduling.compiler.compile_flow`):
#: "hold" (6.3.3, the default) the first arm free commits and holds until its partner frees;
#: "simultaneous" (a variant, the former model) one transition needs both arms free at the same
#: instant, so arms that come free at different times meet only when their waits of t_w happen to
#: end together. Actions of three or more robots always start simultaneously.
JOINT_ACTIONS = ("hold", "simultaneous")
#: roots of the Monte Carlo trials (hrc_drake.scheduling.montecarlo.ROOT_CHOICES)
ROOT_CHOICES = ("all_enabled", "agent")


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


@dataclass
class NoScheduler:
    """No scheduler: every robot runs its program in a fixed order (DESIGN.md default)."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class _SchedulerCommon:
    """The net and rate fields every scheduler kind shares."""

    #: t_w, the quantum of a robot's explicit wait (s), thesis 6.3.1
    wait_quantum: float = 1.0
    #: c_R, cost per second of an idle robot (thesis 7.3.1, C = c_R sum W_R + c_H W_H)
    cost_robot: float = 1.0
    #: c_H, cost per second of the idle human
    cost_human: float = 1.0
    #: how often the scheduler reads the event logs (Hz); a decision answers each "ready" event
    rate: float = 10.0
    #: robot agent -> its idle cost per second in place of c_R (a cart that only transports: 0, 6.3.4)
    agent_costs: dict[str, float] = field(default_factory=dict)
    #: how an action of two robot agents starts (JOINT_ACTIONS):
    #: "hold" (6.3.3: the first arm free commits and holds until its partner frees) or
    #: "simultaneous" (a variant: both arms must be free at the same instant)
    joint_actions: str = "hold"

    def _validate_common(self, path: str) -> None:
        check(
            _finite(self.wait_quantum) and 1e-3 <= self.wait_quantum <= 600,
            f"{path}.wait_quantum",
            f"{self.wait_quantum} must be in [0.001, 600] s",
        )
        for name in ("cost_robot", "cost_human"):
            value = getattr(self, name)
            check(_finite(value) and 0 <= value <= 1e6, f"{path}.{name}", f"{value} must be in [0, 1e6]")
        rate_ok = _finite(self.rate) and 0 < self.rate <= 50
        check(rate_ok, f"{path}.rate", f"{self.rate} must be in (0, 50] Hz")
        for agent, value in self.agent_costs.items():
            check(_finite(value) and 0 <= value <= 1e6, f"{path}.agent_costs.{agent}",
                  f"{value} must be in [0, 1e6]")
        check(self.joint_actions in JOINT_ACTIONS, f"{path}.joint_actions",
              f"{self.joint_actions!r} is not one of {list(JOINT_ACTIONS)}")

    def validate(self, path: str) -> None:
        """Raise ConfigError naming `path.<field>` for a bad value."""
        self._validate_common(path)


@dataclass
class RoundRobinScheduler(_SchedulerCommon):
    """Fixed cyclic program per robot agent, joins collaborations reactively (7.5.1)."""

    #: robot agent -> its program of action names; an agent left out runs its robot-only actions
    #: in flow order
    programs: dict[str, list[str]] = field(default_factory=dict)

    def validate(self, path: str) -> None:
        self._validate_common(path)
        for agent, names in self.programs.items():
            check(
                all(isinstance(n, str) and n for n in names),
                f"{path}.programs.{agent}",
                "must be a list of action names",
            )


@dataclass
class RandomEnabledScheduler(_SchedulerCommon):
    """A random enabled action of the agent, else its wait; no plan (baseline). Every decision
    is the deadlock repair 7.3.2 gives for [93]; it is neither [93] nor [76]
    (`baselines.RandomEnabledPolicy`)."""


@dataclass
class BestOfRolloutsPlanScheduler(_SchedulerCommon):
    """Long-horizon plan, the best of `n_candidates` rollouts on mean durations with the human
    following its known pattern (not treated as controllable, unlike [93] in 7.3.2), suspended
    on a deadlock for a random enabled robot action (the repair 7.3.2 gives for [93])
    (baseline, `baselines.BestOfRolloutsPlanPolicy`)."""

    #: horizon of the offline plan (s)
    plan_horizon: float = 600.0
    #: mean-duration rollouts the plan is chosen from
    n_candidates: int = 64

    def validate(self, path: str) -> None:
        self._validate_common(path)
        check(
            _finite(self.plan_horizon) and 0 < self.plan_horizon <= 86_400,
            f"{path}.plan_horizon",
            f"{self.plan_horizon} must be in (0, 86400] s",
        )
        check(
            _integer(self.n_candidates) and 1 <= self.n_candidates <= 100_000,
            f"{path}.n_candidates",
            f"{self.n_candidates} must be an integer in 1..100000",
        )


@dataclass
class MonteCarloScheduler(_SchedulerCommon):
    """Receding-horizon Monte Carlo scheduler, thesis 7.1 + 7.3.1 (Algorithm 4).

    `durations` chooses the delays of the trials: "empirical" (the default) is Scheduler A of
    use case b (7.5.2), the scheduler of 7.3; "uniform_support" is Scheduler B of 7.5.2, the same
    Monte Carlo search on uniform delays between the smallest and the largest measured firing
    time of each transition (`learning.UniformSupportDurationModel`)."""

    #: N, Monte Carlo trials per decision
    n_trials: int = 100
    #: T_sch, horizon of each trial (s)
    horizon: float = 20.0
    #: beta, percentile level of the trial costs compared by Algorithm 4 (0.5: the median)
    beta: float = 0.5
    #: observed delays kept per transition by the online duration model (sliding window)
    window: int = 30
    #: observed delays a transition needs before its empirical distribution replaces the prior
    min_samples: int = 3
    #: trials each child of a controllable branching below the root needs before rule (b) of
    #: Algorithm 4 applies: 1 is Algorithm 4 as written; more is "branch pooling", a variant
    #: that unites thinner branchings (use case a: 20 gives 30.59 s per product vs 32.70 s)
    min_branch_samples: int = 1
    #: how controllable conflicts after the root are resolved: "uniform" (7.3.1) or "work_first"
    rollout: str = "uniform"
    #: learn the delays online from observed firings (thesis 7.1)
    learn: bool = True
    #: the delay model of the trials: "empirical" (the last `window` observed delays, Scheduler A
    #: of 7.5.2) or "uniform_support" (uniform on [smallest, largest] observed delay, Scheduler B)
    durations: str = "empirical"
    #: what the trials' root branches over: "all_enabled" (7.3.1: every enabled controllable
    #: transition) or "agent" (a variant: only the deciding robot's choices)
    root_choices: str = "all_enabled"
    #: a variant: trial n takes root choice n mod R instead of a uniform draw (7.3.1)
    stratified_roots: bool = False
    #: a variant (needs stratified_roots): the R trials of a group share their delays and later
    #: random choices (common random numbers) instead of being independent (7.3.1)
    common_random_numbers: bool = False
    #: a variant: a robot's wait ends on the next multiple of t_w (robots that wait meet on
    #: common ticks, which actions of several arms need) instead of lasting t_w (6.3.1); the
    #: trials and the cell both wait so
    wait_grid: bool = False
    #: a variant (issue 52, safety-aware scheduling): learn each robot action's durations per
    #: operator activity at its start and slow the trials' robot actions by them, so the search
    #: prefers work the operator's presence does not slow (scheduling.slowdown); 7.3.1 draws
    #: each delay from the transition's one distribution
    durations_by_operator: bool = False

    def validate(self, path: str) -> None:
        self._validate_common(path)
        check(
            self.root_choices in ROOT_CHOICES,
            f"{path}.root_choices",
            f"{self.root_choices!r} is not one of {ROOT_CHOICES}",
        )
        for name in ("stratified_roots", "common_random_numbers", "wait_grid", "durations_by_operator"):
            value = getattr(self, name)
            check(isinstance(value, bool), f"{path}.{name}", f"{value!r} must be a bool")
        check(
            self.stratified_roots or not self.common_random_numbers,
            f"{path}.common_random_numbers",
            "needs stratified_roots: true (the trials of a group take the R root choices)",
        )
        check(
            _integer(self.n_trials) and 1 <= self.n_trials <= 100_000,
            f"{path}.n_trials",
            f"{self.n_trials} must be an integer in 1..100000",
        )
        check(
            _finite(self.horizon) and 0 < self.horizon <= 3600,
            f"{path}.horizon",
            f"{self.horizon} must be in (0, 3600] s",
        )
        check(_finite(self.beta) and 0 <= self.beta <= 1, f"{path}.beta", f"{self.beta} must be in [0, 1]")
        check(
            _integer(self.window) and 1 <= self.window <= 100_000,
            f"{path}.window",
            f"{self.window} must be an integer in 1..100000",
        )
        check(
            _integer(self.min_samples) and 1 <= self.min_samples <= 100_000,
            f"{path}.min_samples",
            f"{self.min_samples} must be an integer in 1..100000",
        )
        check(
            _integer(self.min_branch_samples) and 1 <= self.min_branch_samples <= 100_000,
            f"{path}.min_branch_samples",
            f"{self.min_branch_samples} must be an integer in 1..100000",
        )
        check(self.rollout in ROLLOUTS, f"{path}.rollout", f"{self.rollout!r} is not one of {ROLLOUTS}")
        check(
            self.durations in DURATION_MODELS,
            f"{path}.durations",
            f"{self.durations!r} is not one of {DURATION_MODELS}",
        )


#: How the best-scenario scheduler chooses among plans of equal cost (best_scenario.TIE_BREAKS).
TIE_BREAKS = ("most_work", "first_found")


@dataclass
class BestScenarioScheduler(_SchedulerCommon):
    """Best-scenario branch and bound, thesis 7.2 (Algorithms 2-3, cost eq. 7.1-7.2), with the
    P_a1 / P_c1 policy of 7.2.1. Needs the activity predictor: its forecast gives the window
    [P_c1, P_c2] of the human's start of `collaboration` and P_a1 of `human_action`."""

    #: the human-robot action whose commitment t_c ends a plan
    collaboration: str = ""
    #: the human's autonomous operation (2 of 7.2.1) and the robot action that supplies it
    #: (1 of 7.2.1): case 1 of the policy; "" for neither
    human_action: str = ""
    feed_action: str = ""
    #: T_sch (s): nodes arriving later are not expanded
    horizon: float = 60.0
    #: the two percentile levels of the predicted waiting time that bound [P_c1, P_c2] (7.2.1:
    #: "e.g. the 10th and the 80th"); each must be one of the predictor's percentile_levels
    percentiles: list[float] = field(default_factory=lambda: [0.2, 0.8])
    #: T_wait (s): how long the robots committed to the collaboration wait for the human before
    #: they are available again (t_W of Fig. 7.3); 0: five wait quanta, the net compiler's default
    max_wait: float = 0.0
    #: how plans of equal cost are chosen: "most_work" (the most robot operations before t_c,
    #: the first criterion 7.2.2 names) or "first_found" (Algorithm 2 as printed)
    ties: str = "most_work"
    #: widen each delay support to the delays observed (the on-line correction 7.1 allows)
    learn: bool = True
    #: guard on the reachability tree's size per decision
    max_nodes: int = 200_000
    #: the net of Fig. 7.3 commits the robots to the collaboration by one transition, the target
    #: t_c of every plan: the robots start joint actions together ("simultaneous", the only model
    #: the planner takes)
    joint_actions: str = "simultaneous"

    def validate(self, path: str) -> None:
        self._validate_common(path)
        check(self.joint_actions == "simultaneous", f"{path}.joint_actions",
              "the best-scenario planner (7.2) targets the one commitment t_c of Fig. 7.3's net; it takes "
              "only \"simultaneous\"")
        check(isinstance(self.collaboration, str) and self.collaboration != "", f"{path}.collaboration",
              "name the human-robot action whose commitment ends a plan")
        check(bool(self.human_action) == bool(self.feed_action), f"{path}.feed_action",
              "give human_action and feed_action together (case 1 of 7.2.1), or neither")
        check(_finite(self.horizon) and 0 < self.horizon <= 3600, f"{path}.horizon",
              f"{self.horizon} must be in (0, 3600] s")
        check(len(self.percentiles) == 2 and all(_finite(p) and 0 < p < 1 for p in self.percentiles)
              and self.percentiles[0] <= self.percentiles[1], f"{path}.percentiles",
              f"{self.percentiles} must be two levels 0 < low <= high < 1")
        check(_finite(self.max_wait) and 0 <= self.max_wait <= 3600, f"{path}.max_wait",
              f"{self.max_wait} must be in [0, 3600] s (0: five wait quanta)")
        check(self.ties in TIE_BREAKS, f"{path}.ties", f"{self.ties!r} is not one of {TIE_BREAKS}")
        check(_integer(self.max_nodes) and 10 <= self.max_nodes <= 10_000_000, f"{path}.max_nodes",
              f"{self.max_nodes} must be an integer in 10..10000000")


#: W_R measures and tie rules of the fuzzy scheduler (hrc_drake.scheduling.fuzzy_scheduler)
FUZZY_ROBOT_WAIT_MEASURES = ("seconds", "horizon_fraction")
FUZZY_TIE_RULES = ("first", "random")


@dataclass
class FuzzyScheduler(_SchedulerCommon):
    """Receding-horizon fuzzy scheduler, thesis 7.4 (Algorithm 5, eq. 7.3-7.18), the durations
    fuzzified online from the observed ones (7.5.3, eq. 7.19-7.20)."""

    #: T_sch (s); 7.5.3 uses 50 s
    horizon: float = 50.0
    #: T_sch from the events in it (issue 53): the time the cell takes for this many events at its
    #: expected rate (each agent one action end per mean delay, learned online), re-set at each
    #: decision. 7.5.3 chose its 50 s "to have at an average 4 events within the scheduling
    #: horizon"; null: the fixed `horizon`
    horizon_events: float | None = None
    #: w_1, w_2 of eq. (7.16): the weights of the human's and the robots' waits
    w_human: float = 1.0
    w_robot: float = 1.0
    #: the small constant of 7.4 (unreachable nodes, possibilities)
    eps: float = 0.01
    #: observed delays kept per transition, and how many before they replace the prior
    window: int = 30
    min_samples: int = 3
    learn: bool = True
    #: guard on the tree's size: the first level past it is left out whole, so the tree then
    #: reaches less far than T_sch (counted in the policy's stats_, the first cut logged). On
    #: torch_clock at T_sch = 50 s every tree is cut: merged, 300 nodes reach ~11 s (~70 ms),
    #: 10,000 ~26 s (~2 s); the full tree is out of reach (bench_scheduling's fuzzy.reach).
    #: Chosen for the decision time: over caps 150-2400 the event-level idle per product stays
    #: within 7.5-8.3 s (bench_scheduling's sweep_fuzzy_max_nodes)
    max_nodes: int = 300
    #: time-grid points of the fuzzy sets of eq. 7.4-7.9 that are not triangles
    grid_points: int = 41
    #: eq. (7.18) sums the possibilities of the leaves as written; True divides by their sum
    #: (a variant: the plain sum favours choices with more branchings)
    normalize_possibilities: bool = False
    #: build equal nodes of the tree once (same marking, arrival times, open waits, path costs):
    #: exact, the same J; False builds Algorithm 5's tree literally
    merge: bool = True
    #: W_R of 7.4.1: "seconds" (t_w per robot wait, the thesis) or "horizon_fraction" (t_w / T_sch
    #: per wait, a variant on the scale of W_H, which is an index of at most about 2)
    robot_wait_measure: str = "seconds"
    #: root children of equal J (the text names no rule): "first" the lowest transition index
    #: (the flow's order, waits last), "random" one drawn with the scenario's seed; counted either way
    ties: str = "first"

    def validate(self, path: str) -> None:
        self._validate_common(path)
        check(self.robot_wait_measure in FUZZY_ROBOT_WAIT_MEASURES, f"{path}.robot_wait_measure",
              f"{self.robot_wait_measure!r} must be one of {FUZZY_ROBOT_WAIT_MEASURES}")
        check(self.ties in FUZZY_TIE_RULES, f"{path}.ties", f"{self.ties!r} must be one of {FUZZY_TIE_RULES}")
        check(isinstance(self.merge, bool), f"{path}.merge", f"{self.merge!r} must be true or false")
        check(_finite(self.horizon) and 0 < self.horizon <= 3600, f"{path}.horizon",
              f"{self.horizon} must be in (0, 3600] s")
        events = self.horizon_events
        check(events is None or (_finite(events) and 0 < events <= 100), f"{path}.horizon_events",
              f"{events} must be in (0, 100] events (or null)")
        for name in ("w_human", "w_robot"):
            value = getattr(self, name)
            check(_finite(value) and 0 <= value <= 1e6, f"{path}.{name}", f"{value} must be in [0, 1e6]")
        check(_finite(self.eps) and 0 < self.eps < 1, f"{path}.eps", f"{self.eps} must be in (0, 1)")
        for name, low, high in (("window", 1, 100_000), ("min_samples", 1, 100_000),
                                ("max_nodes", 2, 1_000_000), ("grid_points", 5, 10_000)):
            value = getattr(self, name)
            check(_integer(value) and low <= value <= high, f"{path}.{name}",
                  f"{value} must be an integer in {low}..{high}")


@dataclass
class UniformScheduler(FuzzyScheduler):
    """The uniform scheduler of use case c (7.5.3, eq. 7.21-7.23): Algorithm 5 with the
    arrival times replaced by trapezoids on their supports and W_H without phi_2."""


#: Where a use case a robot takes the duration of its autonomous task from.
AUTONOMOUS_DURATION_SOURCES = ("config", "observed", "observed_by_operator")


@dataclass
class _CollaborationCommon:
    """The fields of the use case a robots (thesis 5.4.1, Fig. 5.14): one robot agent chooses, at
    each decision, between its autonomous task and assisting the human's collaboration; every
    other robot agent runs its program in order."""

    #: the robot agent that chooses (e.g. "yumi_right")
    agent: str = ""
    #: its autonomous task (the quality check of use case a)
    autonomous_action: str = ""
    #: its part of the collaboration, in order (e.g. place the PCB, then close and store)
    assist_actions: list[str] = field(default_factory=list)
    #: the human action whose begin initiates the collaboration (taking an enclosure)
    request_action: str = ""
    #: how long the autonomous task takes (s), the duration the waiting time is compared with
    autonomous_duration: float = 10.0
    #: "config": `autonomous_duration` throughout (the thesis: the duration is known to the robot
    #: program); "observed": the median of the robot's own completed autonomous tasks in this
    #: run, `autonomous_duration` until the first one ends (a variant, for a task whose duration
    #: varies with the robot's speed scaling); "observed_by_operator": the median of those begun
    #: while the operator was in the activity (human action last begun) they are in now, once
    #: there are 3, else as "observed" (a variant, issue 52: the safety controller slows the task
    #: by where the operator is)
    autonomous_duration_from: str = "config"
    #: the human action whose end gives the autonomous task its part (the IC insertion fills the
    #: feeder); "" when the autonomous task always has work. Without a part the robot pauses
    #: `wait_quantum` and decides again
    supplied_by: str = ""
    #: parts for the autonomous task in stock at the start
    initial_supply: int = 0
    #: results of the autonomous task in stock at the start (checked PCBs) when each assist uses
    #: one: without one the robot runs its autonomous task before it assists; -1: the assist
    #: uses none
    autonomous_stock: int = -1
    #: how long the robot pauses before it decides again when it can neither assist nor work (s)
    wait_quantum: float = 0.5
    #: how often the decision system reads the event logs (Hz)
    rate: float = 10.0

    def _validate_collaboration(self, path: str) -> None:
        for name in ("agent", "autonomous_action", "request_action"):
            value = getattr(self, name)
            check(isinstance(value, str) and value != "", f"{path}.{name}", "must be a name")
        check(len(self.assist_actions) > 0 and all(isinstance(a, str) and a for a in self.assist_actions),
              f"{path}.assist_actions", "must list at least one robot action")
        check(_finite(self.autonomous_duration) and 0 < self.autonomous_duration <= 3600,
              f"{path}.autonomous_duration", f"{self.autonomous_duration} must be in (0, 3600] s")
        check(self.autonomous_duration_from in AUTONOMOUS_DURATION_SOURCES,
              f"{path}.autonomous_duration_from",
              f"{self.autonomous_duration_from!r} must be one of {list(AUTONOMOUS_DURATION_SOURCES)}")
        check(_finite(self.rate) and 0 < self.rate <= 50, f"{path}.rate",
              f"{self.rate} must be in (0, 50] Hz")
        check(isinstance(self.supplied_by, str), f"{path}.supplied_by", "must be an action name or \"\"")
        check(_integer(self.initial_supply) and 0 <= self.initial_supply <= 1_000_000,
              f"{path}.initial_supply", f"{self.initial_supply} must be an integer >= 0")
        check(_finite(self.wait_quantum) and 1e-3 <= self.wait_quantum <= 600, f"{path}.wait_quantum",
              f"{self.wait_quantum} must be in [0.001, 600] s")
        check(_integer(self.autonomous_stock) and -1 <= self.autonomous_stock <= 1_000_000,
              f"{path}.autonomous_stock", f"{self.autonomous_stock} must be an integer >= -1")

    def validate(self, path: str) -> None:
        """Raise ConfigError naming `path.<field>` for a bad value."""
        self._validate_collaboration(path)


@dataclass
class PredictiveRobotScheduler(_CollaborationCommon):
    """Fig. 5.14: start the autonomous task when the p-percentile t_p of the predicted waiting
    time until `request_action` (the activity predictor's forecast, thesis 5.3) exceeds
    `autonomous_duration`; otherwise wait, ready to assist. Needs a predictor in the cell."""

    #: p, the percentile level of the waiting time (one of the predictor's levels, or between)
    percentile: float = 0.8

    def validate(self, path: str) -> None:
        self._validate_collaboration(path)
        check(_finite(self.percentile) and 0 < self.percentile < 1, f"{path}.percentile",
              f"{self.percentile} must be in (0, 1)")


@dataclass
class ReactiveRobotScheduler(_CollaborationCommon):
    """The reactive robot of 5.4.1: the autonomous task unless the human has already initiated
    the collaboration."""


@dataclass
class DataDrivenRobotScheduler(_CollaborationCommon):
    """The data-driven robot of Fig. 5.17: the rule of Fig. 5.14 with t_p the p-percentile of
    the observed intervals between consecutive collaboration requests."""

    #: p, the percentile level of the observed intervals
    percentile: float = 0.8

    def validate(self, path: str) -> None:
        self._validate_collaboration(path)
        check(_finite(self.percentile) and 0 < self.percentile < 1, f"{path}.percentile",
              f"{self.percentile} must be in (0, 1)")


#: The use case a decision systems (no pcTPN; `scheduling.systems.CollaborationScheduler`).
COLLABORATION_SCHEDULERS = (PredictiveRobotScheduler, ReactiveRobotScheduler, DataDrivenRobotScheduler)

#: The kinds whose decisions read the delays of the pcTPN, i.e. the flow's durations (their prior
#: until they observe an action: Monte Carlo trials, fuzzy trees, best-scenario supports, the
#: mean-duration plan). The others read none: no scheduler and the use case a kinds compile no
#: net, the round robin and the random baseline decide without timing.
TIMED_SCHEDULERS = (MonteCarloScheduler, FuzzyScheduler, BestScenarioScheduler, BestOfRolloutsPlanScheduler)

#: Every scheduler kind, as a scenario field type (chosen in YAML by tag).
SchedulerConfig = Union[  # noqa: UP007 - pydrake's typed YAML loader needs typing.Union
    NoScheduler,
    RoundRobinScheduler,
    RandomEnabledScheduler,
    BestOfRolloutsPlanScheduler,
    MonteCarloScheduler,
    BestScenarioScheduler,
    FuzzyScheduler,
    UniformScheduler,
    PredictiveRobotScheduler,
    ReactiveRobotScheduler,
    DataDrivenRobotScheduler,
]
