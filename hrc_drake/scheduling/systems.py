"""Drake adapter of the assistive scheduler (thesis 7.1, Fig. 7.1).

`Scheduler` reads the human's and the robots' event logs, keeps its belief of the pcTPN in step
(`NetTracker`), and answers every RobotEvent(kind="ready") with one RobotCommand for that agent
(receding horizon: a new decision each time an agent is free).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import AbstractStateIndex, EventStatus, LeafSystem

from hrc_drake.errors import ConfigError
from hrc_drake.messages import EventLog, Forecast, Immutable, RobotCommand
from hrc_drake.scheduling.baselines import BestOfRolloutsPlanPolicy, RandomEnabledPolicy, RoundRobinPolicy
from hrc_drake.scheduling.best_scenario import BestScenarioPolicy
from hrc_drake.scheduling.collaboration import (
    ASSIST,
    AUTONOMOUS,
    WAIT,
    CollaborationDecision,
    DataDrivenPercentilePolicy,
    PredictiveRobotPolicy,
    ReactiveRobotPolicy,
)
from hrc_drake.scheduling.compiler import net_from_flow, net_from_scenario
from hrc_drake.scheduling.config import (
    COLLABORATION_SCHEDULERS,
    BestOfRolloutsPlanScheduler,
    BestScenarioScheduler,
    DataDrivenRobotScheduler,
    FuzzyScheduler,
    MonteCarloScheduler,
    NoScheduler,
    PredictiveRobotScheduler,
    RandomEnabledScheduler,
    ReactiveRobotScheduler,
    RoundRobinScheduler,
    UniformScheduler,
)
from hrc_drake.scheduling.fuzzy_scheduler import FuzzyPolicy, UniformPolicy
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy, wait_delay
from hrc_drake.scheduling.petri import PcTPN
from hrc_drake.scheduling.tracker import NetTracker
from hrc_drake.systems import Frozen, declare_state, get_state, input_or, set_state


def make_policy(net: PcTPN, config, seed: int, path: str = "scheduler"):
    """The scheduling policy (core) a scheduler config describes, validated first."""
    if isinstance(config, NoScheduler):
        raise ConfigError(path, "NoScheduler describes no scheduling policy")
    if not hasattr(config, "validate"):
        raise ConfigError(path, f"{type(config).__name__} is not a scheduler config")
    config.validate(path)
    if isinstance(config, MonteCarloScheduler):
        return MonteCarloPolicy(
            net,
            n_trials=config.n_trials,
            horizon=config.horizon,
            beta=config.beta,
            window=config.window,
            min_samples=config.min_samples,
            learn=config.learn,
            random_state=seed,
            min_branch_samples=config.min_branch_samples,
            rollout=config.rollout,
            durations=config.durations,
            root_choices=config.root_choices,
            stratified_roots=config.stratified_roots,
            common_random_numbers=config.common_random_numbers,
            wait_grid=config.wait_grid,
            durations_by_operator=config.durations_by_operator,
        )
    if isinstance(config, FuzzyScheduler):  # UniformScheduler too
        kind = UniformPolicy if isinstance(config, UniformScheduler) else FuzzyPolicy
        return kind(net, horizon=config.horizon, w_human=config.w_human, w_robot=config.w_robot,
                    eps=config.eps, window=config.window, min_samples=config.min_samples, learn=config.learn,
                    max_nodes=config.max_nodes, grid_points=config.grid_points,
                    normalize_possibilities=config.normalize_possibilities, random_state=seed,
                    merge=config.merge, robot_wait_measure=config.robot_wait_measure, ties=config.ties,
                    horizon_events=config.horizon_events)
    if isinstance(config, BestScenarioScheduler):
        for field, action in (("collaboration", config.collaboration), ("feed_action", config.feed_action)):
            key = f"{action}:commit" if field == "collaboration" else f"{action}:begin"
            if action and key not in net.transition_index:
                kind = "a human-robot collaboration" if field == "collaboration" else "a robot action"
                raise ConfigError(f"{path}.{field}", f"{action!r} is not {kind} of the flow")
        try:
            return BestScenarioPolicy(net, config.collaboration, config.human_action, config.feed_action,
                                      c_r=config.cost_robot, c_h=config.cost_human, horizon=config.horizon,
                                      ties=config.ties, learn=config.learn, max_nodes=config.max_nodes,
                                      levels=tuple(config.percentiles))
        except ValueError as err:
            raise ConfigError(f"{path}.human_action", str(err)) from None
    if isinstance(config, RoundRobinScheduler):
        try:
            return RoundRobinPolicy(net, programs=config.programs or None, random_state=seed)
        except ValueError as err:
            raise ConfigError(f"{path}.programs", str(err)) from None
    if isinstance(config, RandomEnabledScheduler):
        return RandomEnabledPolicy(net, random_state=seed)
    if isinstance(config, BestOfRolloutsPlanScheduler):
        return BestOfRolloutsPlanPolicy(
            net, plan_horizon=config.plan_horizon, n_candidates=config.n_candidates, random_state=seed
        )
    raise ConfigError(path, f"{type(config).__name__} is not a scheduler config")


class SchedulerCore:
    """What a Scheduler changes during a run: the policy (learned durations, random generator,
    program pointers), the belief of the net (NetTracker, observing into the policy), the last
    event seq read from each log and the commands issued (an immutable EventLog). Kept frozen in
    the Context; `clone` copies only what an update writes (copy-on-write)."""

    def __init__(self, policy, tracker: NetTracker):
        self.policy = policy
        self.tracker = tracker
        self.last_human = -1
        self.last_robot = -1
        self.commands = EventLog()
        #: robot agents that reported "ready" and have had no command since: only they may be
        #: commanded (the belief can free an arm early, e.g. at the human's end of a collaboration
        #: the arm still holds)
        self.idle: frozenset[str] = frozenset()

    def clone(self) -> SchedulerCore:
        new = object.__new__(SchedulerCore)
        new.policy = self.policy.clone()
        new.tracker = self.tracker.clone(new.policy)
        new.last_human, new.last_robot, new.commands = self.last_human, self.last_robot, self.commands
        new.idle = self.idle
        return new


def _give_up_after(net: PcTPN, j: int) -> float:
    """How long the robots of commanded transition j wait for their partners: the fixed delay of
    the give-up transition (T_wait, Fig. 7.3) that takes back what j commits (a commitment to a
    collaboration, an arm's hold on an action of two robots, 6.3.3, or, for the arm that joins
    a hold, the holder's), else inf. Found by the net's arcs, not by names (names may hold ':')."""
    if net.role[j] not in ("commit", "hold", "join"):
        return math.inf
    waiting = {int(i) for i in np.flatnonzero(net.post[:, j])
               if net.places[i].startswith(("held:", "cwait:"))}
    if not waiting and net.role[j] == "join":  # an action of two robots: its holder's patience
        waiting = {int(i) for i in np.flatnonzero(net.pre[:, j]) if net.places[i].startswith("held:")}
    for k in range(net.n_transitions):
        pre = {int(i) for i in np.flatnonzero(net.pre[:, k])}
        if net.role[k] == "giveup" and net.action[k] == net.action[j] and pre and pre <= waiting:
            return float(net.delays[k].mean)
    return math.inf


def _join_of(net: PcTPN, marking, agent: str) -> int | None:
    """The join by which free `agent` takes its place beside a partner that holds for an action
    of both (6.3.3; the agent joins at once, not by the policy's choice), or None."""
    enabled = net.enabled(marking)
    for k in range(net.n_transitions):
        if net.role[k] == "join" and net.agents[k][0] == agent and enabled[k]:
            return k
    return None


class Scheduler(LeafSystem):
    """Assistive scheduler on a pcTPN (thesis 7.1 receding horizon, 7.3 Monte Carlo).

    Inputs: "human_events" (EventLog of HumanEvent), "robot_events" (EventLog of RobotEvent),
    "forecast" (the activity predictor's `Forecast`, read by the best-scenario policy before
    each decision; unconnected for the others).
    Output: "robot_commands" (EventLog of RobotCommand, seq increasing).
    config: a kind of `hrc_drake.scheduling.config` (not NoScheduler); `net` should be compiled
    with its net fields (`net_from_scenario`). seed: of the policy's random generator.
    Only arms that reported "ready" and have had no command since are commanded (the policy
    sees the others as unavailable); a wait ends on the t_w grid; a commitment to a
    collaboration is revoked after its give-up delay (T_wait, `RobotCommand.give_up_after`).

    State (in the Context, set again at initialization): abstract 0, Frozen(SchedulerCore),
    replaced (copy-on-write) only when new events arrive. Updated at `config.rate` Hz.
    """

    def __init__(self, net: PcTPN, config, robot_agents: list[str], seed: int):
        super().__init__()
        if isinstance(config, NoScheduler):
            raise ConfigError("scheduler", "NoScheduler builds no Scheduler")
        policy = make_policy(net, config, seed)  # validates the config
        unknown = [a for a in robot_agents if f"avail:{a}" not in net.place_index]
        if unknown:
            raise ValueError(f"Scheduler: robot agents {unknown} are not in the net")
        self.net = net
        self.config = config
        self.robot_agents = list(robot_agents)
        self._patience = [_give_up_after(net, j) for j in range(net.n_transitions)]
        self._initial_core = SchedulerCore(policy, NetTracker(net, policy))
        self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self.DeclareAbstractInputPort("robot_events", AbstractValue.Make(EventLog()))
        self._forecast = self.DeclareAbstractInputPort("forecast", AbstractValue.Make(Forecast()))
        self._core_index = declare_state(self, lambda context: Frozen(self._initial_core))
        self.DeclareAbstractOutputPort(
            "robot_commands",
            lambda: AbstractValue.Make(EventLog()),
            self._calc_commands,
            # hrc_drake.systems.state_ticket passes an int, which pydrake 1.51 refuses: the index type here
            prerequisites_of_calc={self.abstract_state_ticket(AbstractStateIndex(self._core_index))},
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / config.rate, 0.0, self._update)

    @classmethod
    def from_flow(cls, flow, buffers, human_agent, human_pattern, robot_agents, config, seed=0):
        """A Scheduler on the net compiled from a flow with the config's net fields."""
        net = net_from_flow(flow, buffers, human_agent, human_pattern, robot_agents, config)
        return cls(net, config, robot_agents, seed)

    def core(self, context) -> SchedulerCore:
        """The scheduler's core in `context` (read only: do not change it)."""
        return get_state(context, self._core_index).core

    def commands(self, context) -> tuple[RobotCommand, ...]:
        """Every RobotCommand issued so far in `context`."""
        return self.core(context).commands.events

    def _calc_commands(self, context, output):
        output.set_value(get_state(context, self._core_index).core.commands)

    def _update(self, context, state):
        t = context.get_time()
        core = get_state(context, self._core_index).core
        human = input_or(self.get_input_port(0), context, EventLog())
        robot = input_or(self.get_input_port(1), context, EventLog())
        # Events are applied in time order across the two logs.
        merged = [(e.time, 0, e) for e in human.since(core.last_human)]
        merged += [(e.time, 1, e) for e in robot.since(core.last_robot)]
        if not merged:  # nothing new: the core stays as it is (no copy)
            return EventStatus.DidNothing()
        merged.sort(key=lambda x: (x[0], x[1]))
        core = core.clone()
        tracker, net = core.tracker, self.net
        ready = []
        for _, source, e in merged:
            if source == 0:
                core.last_human = e.seq
                tracker.human_event(e.action, e.kind, e.time)
            else:
                core.last_robot = e.seq
                if e.agent not in self.robot_agents:
                    continue
                tracker.robot_event(e.agent, e.action, e.kind, e.time)
                if e.kind == "ready" and e.agent not in ready:
                    ready.append(e.agent)
        commands = list(core.commands.events)
        if ready and hasattr(core.policy, "set_forecast_from") and self._forecast.HasValue(context):
            core.policy.set_forecast_from(self._forecast.Eval(context), t)
        idle = set(core.idle) | set(ready)

        def masked() -> np.ndarray:
            """The belief as the policy sees it: only the really idle arms are available."""
            marking = tracker.m.copy()
            for other in self.robot_agents:
                if other not in idle:
                    marking[net.place_index[f"avail:{other}"]] = 0
            return marking

        # first every idle arm whose partner holds for an action of both joins it (6.3.3: at once,
        # not by the policy's choice); the belief fires the join when the cell starts the action
        # (the robots' "begin", `NetTracker._settle_holds`), so a join the cell never starts
        # leaves the belief as it was
        orders = []
        for agent in sorted(idle):
            j = _join_of(net, masked(), agent)
            if j is not None and tracker.m[net.place_index[f"avail:{agent}"]] > 0:
                idle.discard(agent)
                orders.append((j, (agent,)))
        for agent in ready:
            avail = net.place_index[f"avail:{agent}"]
            if tracker.m[avail] <= 0 or agent not in idle:
                continue  # already commanded with a partner in this tick, or joining
            marking = masked()
            j = int(core.policy.decide(marking, agent, now=t, elapsed=tracker.elapsed(t)))
            if not (net.controllable[j] and agent in net.agents[j] and net.enabled(marking)[j]):
                raise ValueError(f"Scheduler: the policy chose {net.transitions[j]!r} for {agent!r}, "
                                 "which is not an enabled controllable transition of that agent")
            idle -= set(net.agents[j])
            tracker.command(j, t)
            orders.append((j, net.agents[j]))
        for j, agents in orders:
            action = None if net.role[j] == "wait" else net.action[j]
            for a in agents:
                commands.append(
                    RobotCommand(
                        time=t,
                        agent=a,
                        action=action,
                        seq=len(commands) + 1,
                        # a wait lasts t_w (6.3.1) as the policy's trials model it; with the
                        # grid (the baselines, MonteCarloScheduler.wait_grid) it ends on the
                        # next multiple of t_w, where arms that wait meet for an action of both
                        wait=float(wait_delay(t, net.wait_quantum, getattr(core.policy, "wait_grid", True)))
                        if action is None else 0.0,
                        give_up_after=self._patience[j],
                    )
                )
        if len(commands) != len(core.commands.events):
            core.commands = EventLog(tuple(commands))
        core.idle = frozenset(idle)
        set_state(state, self._core_index, Frozen(core))
        return EventStatus.Succeeded()


@dataclass(frozen=True)
class CollaborationRun(Immutable):
    """What a `CollaborationScheduler` changes during a run: its policy (immutable), the last
    event seq read from each log, whether a collaboration request waits for an assist and
    whether a committed assist waits for its request, the assists begun, the autonomous tasks'
    durations, the position of every agent in its program, the commands issued and the
    decisions taken."""

    policy: object
    last_human: int = 0
    last_robot: int = 0
    #: the human initiated a collaboration that no assist has taken up yet
    request_pending: bool = False
    #: the robot committed to an assist before the human initiated it (on the forecast): until
    #: that assist is done, the next request seen is the one it serves
    awaiting_request: bool = False
    assists: int = 0
    #: parts supplied to the autonomous task so far (initial stock included) and tasks commanded
    supplied: int = 0
    autonomous: int = 0
    #: begin time of the autonomous task under way (nan: none) and the durations of those done
    autonomous_begin: float = math.nan
    autonomous_durations: tuple = ()
    #: the human action last begun (the operator's activity, as perceived), the activity when the
    #: autonomous task under way began, and (activity, duration) of every autonomous task done
    operator_activity: str = ""
    autonomous_activity: str = ""
    autonomous_by_activity: tuple = ()
    position: tuple = ()
    commands: EventLog = EventLog()
    decisions: tuple = ()


class CollaborationScheduler(LeafSystem):
    """The robot's decision system of use case a (thesis 5.4.1, Fig. 5.14; `scheduling.collaboration`).

    Inputs "human_events" (EventLog of HumanEvent: perceived or true, as the scenario says),
    "robot_events" (EventLog of RobotEvent) and, for `PredictiveRobotScheduler`, "forecast"
    (the activity predictor's `Forecast`). Output "robot_commands" (EventLog of RobotCommand).
    When `config.agent` is ready it assists (its `assist_actions`, in order) if the human has
    begun `request_action` and no assist has taken the request up (an assist committed before
    the request serves the first request seen until it is done: one missed or late request does
    not shift every later one), and otherwise asks its policy: the autonomous task, or the
    assist (the executor then waits for the human's parts, "ready to assist"). When the
    autonomous task is chosen but has no part yet, it pauses `wait_quantum` s and decides
    again; without a result of the autonomous task for the assist it works first; with neither
    it pauses too. Every other agent gets its program in order. The decisions are kept
    (`decisions(context)`: (time, choice, t_p)). With `autonomous_duration_from: observed` the
    rule compares t_p with the median of the robot's completed autonomous tasks; with
    `observed_by_operator`, of those begun while the operator was in the activity they are in now
    (the human action last begun), once there are `BY_OPERATOR_MIN_SAMPLES` of them. State: one
    abstract value `CollaborationRun`.
    """

    def __init__(self, config, programs: dict[str, list[str]]):
        super().__init__()
        config.validate("scheduler")
        if config.agent not in programs:
            raise ConfigError("scheduler.agent", f"unknown robot agent '{config.agent}' ({sorted(programs)})")
        self.config = config
        self.agents = tuple(programs)
        self.programs = {a: tuple(p) for a, p in programs.items()}
        self._initial = CollaborationRun(_collaboration_policy(config), position=(0,) * len(self.agents),
                                         supplied=config.initial_supply)
        self._human = self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self._robot = self.DeclareAbstractInputPort("robot_events", AbstractValue.Make(EventLog()))
        self._forecast = self.DeclareAbstractInputPort("forecast", AbstractValue.Make(Forecast()))
        self._run = declare_state(self, lambda context: self._initial)
        self.DeclareAbstractOutputPort("robot_commands", lambda: AbstractValue.Make(EventLog()),
                                       self._calc_commands,
                                       {self.abstract_state_ticket(AbstractStateIndex(self._run))})
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / config.rate, 0.0, self._update)

    def decisions(self, context) -> tuple:
        """(time, choice, t_p) of every decision of `config.agent` in `context`."""
        return get_state(context, self._run).decisions

    def _calc_commands(self, context, output):
        output.set_value(get_state(context, self._run).commands)

    def _update(self, context, state):
        run = get_state(context, self._run)
        human = input_or(self._human, context, EventLog()).since(run.last_human)
        robot = input_or(self._robot, context, EventLog()).since(run.last_robot)
        if not human and not robot:
            return EventStatus.DidNothing()
        t = context.get_time()
        policy, assists = run.policy, run.assists
        pending, awaiting = run.request_pending, run.awaiting_request
        supplied, autonomous = run.supplied, run.autonomous
        activity = run.operator_activity
        for e in human:
            if e.kind == "begin":
                activity = e.action
            if e.action == self.config.request_action and e.kind == "begin":
                if awaiting:
                    awaiting = False  # the request the committed assist was waiting for
                else:
                    pending = True
                if isinstance(policy, DataDrivenPercentilePolicy):
                    policy = policy.observe(e.time)
            if e.action == self.config.supplied_by and e.kind == "end":
                supplied += 1
        begun, durations, policy, began_under, by_activity = self._observe_autonomous(
            run, robot, policy, activity)
        position = list(run.position)
        commands, decisions = list(run.commands.events), list(run.decisions)
        ready = [e.agent for e in robot if e.kind == "ready" and e.agent in self.programs]
        for agent in dict.fromkeys(ready):
            k = self.agents.index(agent)
            if agent == self.config.agent:
                has_work = not self.config.supplied_by or supplied > autonomous
                stock = self.config.autonomous_stock
                can_assist = stock < 0 or stock + autonomous > assists
                awaiting = awaiting and position[k] > 0  # back at step 0: the assist is done
                action, position[k], committed, decision = self._choose(
                    t, policy, position[k], pending, has_work, can_assist, context)
                if committed:
                    awaiting, pending, assists = not pending, False, assists + 1
                autonomous += action == self.config.autonomous_action
                decisions.append((t, decision.choice, decision.waiting_time))
            elif self.programs[agent]:
                program = self.programs[agent]
                action, position[k] = program[position[k] % len(program)], position[k] + 1
            else:
                continue  # an agent without a program stays idle
            commands.append(RobotCommand(time=t, agent=agent, action=action, seq=len(commands) + 1,
                                         wait=self.config.wait_quantum if action is None else 0.0))
        set_state(state, self._run, CollaborationRun(
            policy, human[-1].seq if human else run.last_human, robot[-1].seq if robot else run.last_robot,
            pending, awaiting, assists, supplied, autonomous, begun, durations, activity, began_under,
            by_activity, tuple(position), EventLog(tuple(commands)), tuple(decisions)))
        return EventStatus.Succeeded()

    def _observe_autonomous(self, run: CollaborationRun, robot, policy, activity: str):
        """(begin time of the autonomous task under way, durations of those done, policy, the
        operator's activity when the task under way began, (activity, duration) of those done):
        with `autonomous_duration_from: observed` the policy compares with their median, with
        `observed_by_operator` with the median of those begun under the operator's `activity`."""
        begun, durations = run.autonomous_begin, run.autonomous_durations
        began_under, by_activity = run.autonomous_activity, run.autonomous_by_activity
        for e in robot:
            if e.agent == self.config.agent and e.action == self.config.autonomous_action:
                if e.kind == "begin":
                    begun, began_under = e.time, activity
                elif e.kind == "end" and begun == begun:
                    by_activity += ((began_under, e.time - begun),)
                    begun, durations = math.nan, durations + (e.time - begun,)
        source = self.config.autonomous_duration_from
        changed = durations != run.autonomous_durations or activity != run.operator_activity
        if durations and changed and source != "config" and hasattr(policy, "autonomous_duration"):
            same = [d for a, d in by_activity if a == activity] if source == "observed_by_operator" else []
            pool = same if len(same) >= BY_OPERATOR_MIN_SAMPLES else durations
            policy = replace(policy, autonomous_duration=float(np.median(pool)))
        return begun, durations, policy, began_under, by_activity

    def _choose(self, t, policy, step, pending, has_work, can_assist, context):
        """(action, next assist step, whether it commits to a new assist, decision) of the
        choosing agent: inside an assist sequence the next assist action; else the policy's
        choice (Fig. 5.14), with a pause (action None) when that is the autonomous task and it has
        no part, and the autonomous task first when the assist would need a result of it that is
        not there."""
        sequence = self.config.assist_actions
        if step > 0:  # in the middle of an assist: its next action
            return sequence[step], (step + 1) % len(sequence), False, CollaborationDecision(ASSIST)
        forecast = input_or(self._forecast, context, Forecast())
        decision = policy.decide(t, pending, forecast)
        if decision.choice == AUTONOMOUS and not has_work:
            # The autonomous task is the choice but its part has not come: decide again when it
            # may have (the reactive robot "keeps executing its autonomous task", 5.4.1).
            return None, 0, False, CollaborationDecision(WAIT, decision.waiting_time, "nothing to check yet")
        if decision.choice != AUTONOMOUS and not can_assist:
            if not has_work:  # nothing to assist with, nothing to work on: pause, decide again
                return None, 0, False, CollaborationDecision(WAIT, decision.waiting_time, "nothing to do yet")
            decision = CollaborationDecision(AUTONOMOUS, decision.waiting_time,
                                             "no checked part for the assist: the autonomous task first")
        if decision.choice == AUTONOMOUS:
            return self.config.autonomous_action, 0, False, decision
        return sequence[0], 1 % len(sequence), True, decision


#: autonomous tasks begun under an operator activity before `observed_by_operator` takes their
#: median instead of that of all of them
BY_OPERATOR_MIN_SAMPLES = 3


def _collaboration_policy(config):
    """The core of a use case a scheduler config."""
    if isinstance(config, PredictiveRobotScheduler):
        return PredictiveRobotPolicy(config.request_action, config.autonomous_duration, config.percentile)
    if isinstance(config, DataDrivenRobotScheduler):
        return DataDrivenPercentilePolicy(config.autonomous_duration, config.percentile)
    if isinstance(config, ReactiveRobotScheduler):
        return ReactiveRobotPolicy()
    raise ConfigError("scheduler", f"{type(config).__name__} is not a use case a scheduler")


def apply_scheduler_config(
    config,
    builder,
    *,
    human_events,
    robot_events,
    robot_commands_input=None,
    net: PcTPN | None = None,
    scenario=None,
    robot_agents: list[str] | None = None,
    seed: int = 0,
    forecast=None,
) -> Scheduler | CollaborationScheduler | None:
    """Add the Scheduler `config` describes to `builder` (named "scheduler"); None for NoScheduler.

    human_events, robot_events: output ports of the two event logs; robot_commands_input: the
    input port the commands go to (e.g. the task executor's), if any. The net is `net`, or
    compiled from `scenario` with the config's net fields; robot_agents default to the
    scenario's arms. A use case a kind (`COLLABORATION_SCHEDULERS`) builds a
    `CollaborationScheduler` instead, on the arms' programs, reading `forecast` (the predictor's
    output port) where given.
    """
    if isinstance(config, NoScheduler):
        return None
    if isinstance(config, COLLABORATION_SCHEDULERS):
        if scenario is None:
            raise ValueError("apply_scheduler_config: a use case a scheduler needs the scenario")
        programs = {arm.agent: list(arm.program) for robot in scenario.robots for arm in robot.arms}
        scheduler = builder.AddSystem(CollaborationScheduler(config, programs))
        scheduler.set_name("scheduler")
        builder.Connect(human_events, scheduler.GetInputPort("human_events"))
        builder.Connect(robot_events, scheduler.GetInputPort("robot_events"))
        if forecast is not None:
            builder.Connect(forecast, scheduler.GetInputPort("forecast"))
        if robot_commands_input is not None:
            builder.Connect(scheduler.GetOutputPort("robot_commands"), robot_commands_input)
        return scheduler
    if net is None:
        if scenario is None:
            raise ValueError("apply_scheduler_config: give the net or the scenario")
        config.validate("scheduler")
        net = net_from_scenario(scenario, config)
    if robot_agents is None:
        if scenario is None:
            raise ValueError("apply_scheduler_config: give robot_agents or the scenario")
        robot_agents = [arm.agent for robot in scenario.robots for arm in robot.arms]
    scheduler = builder.AddSystem(Scheduler(net, config, robot_agents, seed))
    scheduler.set_name("scheduler")
    builder.Connect(human_events, scheduler.GetInputPort("human_events"))
    builder.Connect(robot_events, scheduler.GetInputPort("robot_events"))
    if forecast is not None and isinstance(config, BestScenarioScheduler):
        builder.Connect(forecast, scheduler.GetInputPort("forecast"))
    if robot_commands_input is not None:
        builder.Connect(scheduler.GetOutputPort("robot_commands"), robot_commands_input)
    return scheduler


__all__ = ["CollaborationScheduler", "Scheduler", "SchedulerCore", "apply_scheduler_config", "make_policy",
           "net_from_scenario"]
