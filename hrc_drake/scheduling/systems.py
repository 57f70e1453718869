"""Drake adapter of the assistive scheduler (thesis 7.1, Fig. 7.1).

`Scheduler` reads the human's and the robots' event logs, keeps its belief of the pcTPN in step
(`NetTracker`), and answers every RobotEvent(kind="ready") with one RobotCommand for that agent
(receding horizon: a new decision each time an agent is free).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from hrc_drake.messages import EventLog, RobotCommand
from hrc_drake.scheduling.baselines import DeterministicPlanScheduler, GreedyScheduler, RoundRobinScheduler
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.montecarlo import MonteCarloScheduler
from hrc_drake.scheduling.petri import PcTPN
from hrc_drake.scheduling.tracker import NetTracker

KINDS = ("monte_carlo", "round_robin", "greedy", "deterministic")


def make_policy(net: PcTPN, kind: str, params: dict, seed: int):
    """Scheduler core for a scenario option ``scheduler: {kind, params}``.

    monte_carlo params: n_trials (100), horizon (20), beta (0.5), window (30), min_samples (3),
    min_branch_samples (20), rollout ("uniform").
    deterministic params: plan_horizon (600), n_candidates (64).
    """
    params = dict(params or {})
    if kind == "monte_carlo":
        return MonteCarloScheduler(
            net,
            n_trials=int(params.get("n_trials", 100)),
            horizon=float(params.get("horizon", 20.0)),
            beta=float(params.get("beta", 0.5)),
            window=int(params.get("window", 30)),
            min_samples=int(params.get("min_samples", 3)),
            min_branch_samples=int(params.get("min_branch_samples", 20)),
            rollout=str(params.get("rollout", "uniform")),
            random_state=seed,
        )
    if kind == "round_robin":
        return RoundRobinScheduler(net, random_state=seed)
    if kind == "greedy":
        return GreedyScheduler(net, random_state=seed)
    if kind == "deterministic":
        return DeterministicPlanScheduler(
            net,
            plan_horizon=float(params.get("plan_horizon", 600.0)),
            n_candidates=int(params.get("n_candidates", 64)),
            random_state=seed,
        )
    raise ValueError(f"scheduler kind {kind!r} is not one of {KINDS}")


def net_from_scenario(scenario) -> PcTPN:
    """Compile the scenario's flow (scheduler param wait_quantum, default 1 s; c_R, c_H as
    cost_robot / cost_human)."""
    params = scenario.scheduler.params or {}
    robots = [arm.agent for robot in scenario.robots for arm in robot.arms]
    return compile_flow(
        scenario.flow,
        scenario.layout.buffers,
        scenario.operator.name,
        scenario.operator.pattern,
        robots,
        wait_quantum=float(params.get("wait_quantum", 1.0)),
        cost_robot=float(params.get("cost_robot", 1.0)),
        cost_human=float(params.get("cost_human", 1.0)),
    )


class Scheduler(LeafSystem):
    """Assistive scheduler on a pcTPN (thesis 7.1 receding horizon, 7.3 Monte Carlo).

    Inputs: "human_events" (EventLog of HumanEvent), "robot_events" (EventLog of RobotEvent).
    Output: "robot_commands" (EventLog of RobotCommand, seq increasing).
    kind: monte_carlo | round_robin | greedy | deterministic; params: see `make_policy`.
    The core (policy + belief) lives on the system: build a new Scheduler for each run.
    """

    def __init__(
        self, net: PcTPN, kind: str, params: dict, robot_agents: list[str], seed: int, rate: float = 10.0
    ):
        super().__init__()
        if not 0 < rate <= 50:
            raise ValueError(f"Scheduler: rate must be in (0, 50] Hz, got {rate}")
        unknown = [a for a in robot_agents if f"avail:{a}" not in net.place_index]
        if unknown:
            raise ValueError(f"Scheduler: robot agents {unknown} are not in the net")
        self.net = net
        self.robot_agents = list(robot_agents)
        self.policy = make_policy(net, kind, params, seed)
        self.tracker = NetTracker(net, self.policy)
        self._commands: list[RobotCommand] = []
        self._last_human = -1
        self._last_robot = -1
        self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self.DeclareAbstractInputPort("robot_events", AbstractValue.Make(EventLog()))
        self._count_index = self.DeclareDiscreteState(1)
        self.DeclareAbstractOutputPort(
            "robot_commands",
            lambda: AbstractValue.Make(EventLog()),
            self._calc_commands,
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)

    @classmethod
    def from_flow(
        cls,
        flow,
        buffers,
        human_agent,
        human_pattern,
        robot_agents,
        kind="monte_carlo",
        params=None,
        seed=0,
        rate=10.0,
        wait_quantum=1.0,
    ):
        net = compile_flow(flow, buffers, human_agent, human_pattern, robot_agents, wait_quantum)
        return cls(net, kind, params or {}, robot_agents, seed, rate)

    @property
    def commands(self) -> tuple[RobotCommand, ...]:
        """Every RobotCommand issued so far (for tests and reports after a run)."""
        return tuple(self._commands)

    def _calc_commands(self, context, output):
        n = int(context.get_discrete_state(self._count_index).get_value()[0])
        output.set_value(EventLog(tuple(self._commands[:n])))

    def _update(self, context, discrete_state):
        t = context.get_time()
        human = (
            self.get_input_port(0).Eval(context) if self.get_input_port(0).HasValue(context) else EventLog()
        )
        robot = (
            self.get_input_port(1).Eval(context) if self.get_input_port(1).HasValue(context) else EventLog()
        )
        # Events are applied in time order across the two logs.
        merged = [(e.time, 0, e) for e in human.since(self._last_human)]
        merged += [(e.time, 1, e) for e in robot.since(self._last_robot)]
        merged.sort(key=lambda x: (x[0], x[1]))
        ready = []
        for _, source, e in merged:
            if source == 0:
                self._last_human = e.seq
                self.tracker.human_event(e.action, e.kind, e.time)
            else:
                self._last_robot = e.seq
                if e.agent not in self.robot_agents:
                    continue
                self.tracker.robot_event(e.agent, e.action, e.kind, e.time)
                if e.kind == "ready" and e.agent not in ready:
                    ready.append(e.agent)
        for agent in ready:
            avail = self.net.place_index[f"avail:{agent}"]
            if self.tracker.m[avail] <= 0:
                continue  # already commanded with a partner in this tick
            j = int(self.policy.decide(self.tracker.m, agent, now=t, elapsed=self.tracker.elapsed(t)))
            self.tracker.command(j, t)
            net = self.net
            action = None if net.role[j] == "wait" else net.action[j]
            for a in net.agents[j]:
                self._commands.append(
                    RobotCommand(
                        time=t,
                        agent=a,
                        action=action,
                        seq=len(self._commands) + 1,
                        wait=net.wait_quantum if action is None else 0.0,
                    )
                )
        discrete_state.get_mutable_vector(self._count_index).SetFromVector(
            np.array([float(len(self._commands))])
        )


__all__ = ["Scheduler", "make_policy", "net_from_scenario", "KINDS"]
