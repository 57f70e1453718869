"""Assembly flow -> pcTPN, thesis 6.3 (building blocks of Table 6.1, rules 6.3.1-6.3.3).

Places made for a flow:
- ``avail:<robot>`` robot availability (6.3.1), ``wait:<robot>`` the explicit wait (cost c_R);
- ``step:<k>`` the human is about to start pattern step k, ``hwait:<k>`` the human intends
  step k and waits for its preconditions (cost c_H) (6.3.2); without a pattern one
  ``human:idle`` place and one ``hwait:<action>`` per human action (a free choice of the human);
- ``busy:<action>`` (or ``busy:<action>#<k>`` for a human step) an action in progress;
- ``cwait:<action>`` robots committed to a human-robot collaboration, waiting (cost c_R per robot)
  (6.3.3, superposition of the robot and human nets);
- ``held:<action>:<robot>`` (joint actions of two robots, `JOINT_ACTIONS` "hold") the first arm
  free has committed to the action, taking its parts, and holds (cost c_R) until its partner
  frees, as both agents of 6.3.3 "are allowed to wait when the two red places are marked";
- ``buf:<b>`` parts in buffer b, ``space:<b>`` free spots of an intermediate buffer (a spot is
  freed when the next action *starts*, taking the part; the producer reserves it at its start);
- ``res:<r>`` units of a shared resource (returned when the action ends);
- ``part:<action>:<robot>`` a robot released early from an action is still at its part (Fig. 7.3).
Raw buffers never run out (no place); product buffers are unbounded and count finished products.
Transitions: ``<a>:begin`` (controllable for robot actions, uncontrollable with zero delay for
actions involving the human), ``<a>:end`` (uncontrollable, the action's duration),
``<robot>:wait`` / ``<robot>:wait_end`` (quantum t_w), ``intent:<k>`` (human intention),
``<a>:commit`` and ``<a>:giveup`` (robots start a collaboration, taking its parts, resources
and output spots, and wait for the human; they give up and put everything back after
``collab_patience`` s, like t_W of Fig. 7.3); for an action of two robots (hold model)
``<a>:hold:<robot>`` (role "hold"; ``<a>:commit:<robot>``, role "commit", when the human takes part),
``<a>:join:<partner>`` (role "join", uncontrollable, zero delay: the partner, once free, joins
at once; the action starts, or with the human the robots wait for it in ``cwait``) and
``<a>:giveup:<robot>`` (the holding arm gives up after ``collab_patience``),
``<a>:release:<robot>`` (uncontrollable, the
duration of the robot's part: an agent of `early_release` is available again before the action
ends, Fig. 7.3).
"""

from __future__ import annotations

import math
from collections import Counter, deque
from dataclasses import replace

import numpy as np

from hrc_drake.distributions import Distribution, validate_distribution
from hrc_drake.scheduling.config import JOINT_ACTIONS
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.petri import PcTPN

IDLE_ROLES = ("wait", "wait_end", "giveup", "commit", "hold")


class FlowError(ValueError):
    """A structural problem of an assembly flow; the message names the actions involved."""


def delay_of(action: FlowAction) -> Distribution:
    """The pcTPN delay of a flow action: its `duration`, 1 s when it gives none (`FlowAction`)."""
    return action.duration if action.duration is not None else Distribution()


class _NetBuilder:
    def __init__(self):
        self.places: list[str] = []
        self.m0: list[int] = []
        self.cost: list[float] = []
        self.idle_agent: list[str] = []
        self.transitions: list[str] = []
        self.pre: list[Counter] = []
        self.post: list[Counter] = []
        self.ctrl: list[bool] = []
        self.delays: list[Distribution] = []
        self.agents: list[tuple[str, ...]] = []
        self.action: list[str] = []
        self.role: list[str] = []

    def place(self, name, initial=0, cost=0.0, idle_agent=""):
        if name not in self.places:
            self.places.append(name)
            self.m0.append(int(initial))
            self.cost.append(float(cost))
            self.idle_agent.append(idle_agent)
        return name

    def transition(self, name, pre, post, controllable, delay, agents=(), action="", role="other"):
        self.transitions.append(name)
        self.pre.append(Counter(pre))
        self.post.append(Counter(post))
        self.ctrl.append(bool(controllable))
        self.delays.append(delay)
        self.agents.append(tuple(agents))
        self.action.append(action)
        self.role.append(role)

    def build(self) -> PcTPN:
        index = {p: i for i, p in enumerate(self.places)}
        n_p, n_t = len(self.places), len(self.transitions)
        pre = np.zeros((n_p, n_t), dtype=np.int64)
        post = np.zeros((n_p, n_t), dtype=np.int64)
        for j in range(n_t):
            for p, k in self.pre[j].items():
                pre[index[p], j] += k
            for p, k in self.post[j].items():
                post[index[p], j] += k
        return PcTPN(
            places=list(self.places),
            transitions=list(self.transitions),
            pre=pre,
            post=post,
            controllable=np.array(self.ctrl, dtype=bool),
            delays=list(self.delays),
            m0=np.array(self.m0, dtype=np.int64),
            cost=np.array(self.cost),
            idle_agent=list(self.idle_agent),
            agents=list(self.agents),
            action=list(self.action),
            role=list(self.role),
        )


def _fixed(t: float) -> Distribution:
    return Distribution(kind="fixed", mean=float(t))


def _hold_and_join(nb: _NetBuilder, a: FlowAction, robots: list[str], robot_cost: dict[str, float],
                   patience: float, takes: list[str], start: list[str], hold_role: str) -> None:
    """The start of an action of two robots as 6.3.3's superposition (`JOINT_ACTIONS` "hold"):
    either arm, when free, may commit (``<a>:<hold_role>:<r>``, controllable, taking the action's parts
    and spots) and holds in ``held:<a>:<r>`` at the cost of an idle robot; its partner joins
    the moment it is free (``<a>:join:<partner>``, uncontrollable with zero delay, marking
    `start`); the holding arm gives up after `patience` and puts the parts back."""
    for arm, partner in ((robots[0], robots[1]), (robots[1], robots[0])):
        held = nb.place(f"held:{a.name}:{arm}", cost=robot_cost[arm], idle_agent=arm)
        nb.transition(f"{a.name}:{hold_role}:{arm}", [f"avail:{arm}", *takes], [held], True, _fixed(0.0),
                      agents=[arm], action=a.name, role=hold_role)
        # the joining arm first: the Scheduler commands it when it reports ready
        nb.transition(f"{a.name}:join:{partner}", [held, f"avail:{partner}"], start, False, _fixed(0.0),
                      agents=[partner, arm], action=a.name, role="join")
        if math.isfinite(patience):
            nb.transition(f"{a.name}:giveup:{arm}", [held], [f"avail:{arm}", *takes], False,
                          _fixed(patience), agents=[arm], action=a.name, role="giveup")


def compile_flow(
    flow: Flow,
    buffers: list[Buffer],
    human_agent: str = "human",
    human_pattern: list[str] | None = None,
    robot_agents: list[str] | None = None,
    wait_quantum: float = 1.0,
    *,
    cost_robot: float = 1.0,
    cost_human: float = 1.0,
    human_intention: Distribution | None = None,
    collab_patience: float | None = None,
    agent_costs: dict[str, float] | None = None,
    check: bool = True,
    max_states: int = 5000,
    joint_actions: str = "hold",
) -> PcTPN:
    """Compile an assembly flow into a pcTPN (thesis 6.3, Table 6.1).

    human_pattern: the operator's cyclic sequence of action names (6.3.2 with a known
    pattern); empty or None lets the human choose freely among its actions.
    wait_quantum: t_w of the robots' explicit wait (6.3.1).
    cost_robot, cost_human: c_R and c_H of the cost places (7.3.1).
    human_intention: delay between the end of a human action and the intention to start the
    next one (default 0 s: the human wants to go on at once).
    collab_patience: how long robots committed to a human-robot collaboration wait before
    giving up (t_W of Fig. 7.3); default 5 t_w; math.inf never gives up.
    agent_costs: robot agent -> idle cost replacing c_R (e.g. 0 for a cart, 6.3.4).
    check: run the structural checks (`check_structure`) and raise FlowError on problems.
    joint_actions: how an action of two robots starts (`JOINT_ACTIONS`): "hold" (6.3.3) or
    the "simultaneous" variant.
    """
    robot_agents = list(robot_agents or [])
    pattern = list(human_pattern or [])
    if not wait_quantum > 0 or not math.isfinite(wait_quantum):
        raise FlowError(f"wait_quantum must be a positive number of seconds, got {wait_quantum}")
    if human_agent in robot_agents:
        raise FlowError(f"agent {human_agent!r} is both the human and a robot agent")
    if len(set(robot_agents)) != len(robot_agents):
        raise FlowError(f"robot agents repeat: {robot_agents}")
    patience = 5.0 * wait_quantum if collab_patience is None else float(collab_patience)
    if not patience > 0:
        raise FlowError(f"collab_patience must be > 0, got {collab_patience}")
    if joint_actions not in JOINT_ACTIONS:
        raise FlowError(f"joint_actions must be one of {list(JOINT_ACTIONS)}, got {joint_actions!r}")
    intention = human_intention or _fixed(0.0)
    agent_costs = dict(agent_costs or {})
    for ag in agent_costs:
        if ag not in robot_agents:
            raise FlowError(f"agent_costs: {ag!r} is not a robot agent")
    robot_cost = {r: float(agent_costs.get(r, cost_robot)) for r in robot_agents}
    validate_distribution(intention, where="human_intention")

    buf = {}
    for b in buffers:
        if b.name in buf:
            raise FlowError(f"buffer {b.name!r} is declared twice")
        if b.kind not in ("raw", "intermediate", "product"):
            raise FlowError(f"buffer {b.name!r}: kind {b.kind!r} is not raw | intermediate | product")
        if b.kind == "intermediate" and not 0 <= b.initial <= b.capacity:
            raise FlowError(
                f"buffer {b.name!r}: needs 0 <= initial <= capacity, got {b.initial}, {b.capacity}"
            )
        buf[b.name] = b
    names = [a.name for a in flow.actions]
    if len(set(names)) != len(names) or any(not n for n in names):
        raise FlowError(f"flow action names must be non-empty and unique, got {names}")
    by_name: dict[str, FlowAction] = {a.name: a for a in flow.actions}
    for a in flow.actions:
        if not a.agents:
            raise FlowError(f"flow action {a.name!r} has no agent")
        for ag in a.agents:
            if ag != human_agent and ag not in robot_agents:
                raise FlowError(
                    f"flow action {a.name!r}: agent {ag!r} is neither {human_agent!r} nor a robot agent"
                )
        for b in list(a.inputs) + list(a.outputs):
            if b not in buf:
                raise FlowError(f"flow action {a.name!r}: unknown buffer {b!r}")
        for b in a.outputs:
            if buf[b].kind == "raw":
                raise FlowError(f"flow action {a.name!r}: output buffer {b!r} is raw")
        for b in a.inputs:
            if buf[b].kind == "product":
                raise FlowError(f"flow action {a.name!r}: input buffer {b!r} is a product buffer")
        for r in a.resources:
            if r not in flow.resources:
                raise FlowError(f"flow action {a.name!r}: unknown resource {r!r}")
        validate_distribution(delay_of(a), where=f"duration of flow action {a.name!r}")
        for ag, part in a.early_release.items():
            if ag not in a.agents or ag == human_agent:
                raise FlowError(f"flow action {a.name!r}: early_release names {ag!r}, not one of its robots")
            if len(a.agents) < 2:
                raise FlowError(f"flow action {a.name!r}: early_release needs an action of several agents")
            validate_distribution(part, where=f"early_release.{ag} of flow action {a.name!r}")
    for step in pattern:
        if step not in by_name:
            raise FlowError(f"human pattern: unknown action {step!r}")
        if human_agent not in by_name[step].agents:
            raise FlowError(f"human pattern: action {step!r} is not assigned to {human_agent!r}")
    if pattern:
        unused = [a.name for a in flow.actions if human_agent in a.agents and a.name not in pattern]
        if unused:
            raise FlowError(f"human actions {unused} can never be enabled: they are not in the human pattern")

    nb = _NetBuilder()
    for r in robot_agents:
        nb.place(f"avail:{r}", initial=1)
        nb.place(f"wait:{r}", cost=robot_cost[r], idle_agent=r)
    for b in buffers:
        if b.kind == "intermediate":
            nb.place(f"buf:{b.name}", initial=b.initial)
            nb.place(f"space:{b.name}", initial=b.capacity - b.initial)
        elif b.kind == "product":
            nb.place(f"buf:{b.name}", initial=b.initial)
    for r, units in flow.resources.items():
        if int(units) < 1:
            raise FlowError(f"resource {r!r} has {units} units")
        nb.place(f"res:{r}", initial=int(units))

    def takes(a: FlowAction) -> list[str]:
        """Places consumed when `a` starts: parts, spots of its outputs, resources."""
        out = [f"buf:{b}" for b in a.inputs if buf[b].kind == "intermediate"]
        out += [f"space:{b}" for b in a.outputs if buf[b].kind == "intermediate"]
        return out + [f"res:{r}" for r in a.resources]

    def frees_at_start(a: FlowAction) -> list[str]:
        return [f"space:{b}" for b in a.inputs if buf[b].kind == "intermediate"]

    def gives_at_end(a: FlowAction) -> list[str]:
        return [f"buf:{b}" for b in a.outputs] + [f"res:{r}" for r in a.resources]

    human_actions = [a for a in flow.actions if human_agent in a.agents]
    # Human steps: (key, action); with a pattern the key is the step index.
    if pattern:
        steps = [(str(k), by_name[name]) for k, name in enumerate(pattern)]
        for k, _ in steps:
            nb.place(f"step:{k}", initial=1 if k == "0" else 0)
    else:
        steps = [(a.name, a) for a in human_actions]
        if human_actions:
            nb.place("human:idle", initial=1)

    def early_parts(a: FlowAction, tag: str) -> list[str]:
        """Places of the robots released early from `a` (Fig. 7.3), and their release transitions."""
        parts = []
        for r, part in a.early_release.items():
            place = nb.place(f"part:{tag}:{r}")
            nb.transition(f"{tag}:release:{r}", [place], [f"avail:{r}"], False, part, agents=[r],
                          action=a.name, role="end")
            parts.append(place)
        return parts

    for a in flow.actions:
        robots = [r for r in a.agents if r != human_agent]
        staying = [r for r in robots if r not in a.early_release]
        with_human = human_agent in a.agents
        held = joint_actions == "hold" and len(robots) == 2
        if not with_human:
            busy = nb.place(f"busy:{a.name}")
            start = [busy] + frees_at_start(a) + early_parts(a, a.name)
            if held:
                _hold_and_join(nb, a, robots, robot_cost, patience, takes(a), start, "hold")
            else:
                nb.transition(f"{a.name}:begin", [f"avail:{r}" for r in robots] + takes(a), start, True,
                              _fixed(0.0), agents=robots, action=a.name, role="begin")
            nb.transition(f"{a.name}:end", [busy], [f"avail:{r}" for r in staying] + gives_at_end(a), False,
                          delay_of(a), agents=staying, action=a.name, role="end")
            continue
        cwait = None
        if robots:
            cwait = nb.place(
                f"cwait:{a.name}", cost=sum(robot_cost[r] for r in robots), idle_agent=",".join(robots)
            )
            if held:
                _hold_and_join(nb, a, robots, robot_cost, patience, takes(a), [cwait], "commit")
            else:
                nb.transition(
                    f"{a.name}:commit",
                    [f"avail:{r}" for r in robots] + takes(a),
                    [cwait],
                    True,
                    _fixed(0.0),
                    agents=robots,
                    action=a.name,
                    role="commit",
                )
            if math.isfinite(patience):
                nb.transition(
                    f"{a.name}:giveup",
                    [cwait],
                    [f"avail:{r}" for r in robots] + takes(a),
                    False,
                    _fixed(patience),
                    agents=robots,
                    action=a.name,
                    role="giveup",
                )
        for k, act in steps:
            if act is not a:
                continue
            hwait = nb.place(f"hwait:{k}", cost=cost_human, idle_agent=human_agent)
            before = f"step:{k}" if pattern else "human:idle"
            if pattern:
                after = f"step:{(int(k) + 1) % len(steps)}"
            else:
                after = "human:idle"
            tag = f"{a.name}#{k}" if pattern else a.name
            busy = nb.place(f"busy:{tag}")
            nb.transition(f"intent:{k}", [before], [hwait], False, intention, action=a.name, role="intent")
            nb.transition(
                f"{tag}:begin",
                [hwait] + ([cwait] if cwait else takes(a)),
                [busy] + frees_at_start(a) + early_parts(a, tag),
                False,
                _fixed(0.0),
                agents=robots,
                action=a.name,
                role="begin",
            )
            nb.transition(
                f"{tag}:end",
                [busy],
                [after] + [f"avail:{r}" for r in staying] + gives_at_end(a),
                False,
                delay_of(a),
                agents=staying,
                action=a.name,
                role="end",
            )
    for r in robot_agents:
        nb.transition(f"{r}:wait", [f"avail:{r}"], [f"wait:{r}"], True, _fixed(0.0), agents=[r], role="wait")
        nb.transition(
            f"{r}:wait_end",
            [f"wait:{r}"],
            [f"avail:{r}"],
            False,
            _fixed(wait_quantum),
            agents=[r],
            role="wait_end",
        )
    net = nb.build()
    net.wait_quantum = float(wait_quantum)
    net.human_agent = human_agent
    net.robot_agents = list(robot_agents)
    net.human_pattern = list(pattern)
    net.product_places = np.array(
        [net.place_index[f"buf:{b.name}"] for b in buffers if b.kind == "product"], dtype=int
    )
    if check:
        check_structure(net, max_states=max_states)
    return net


def _progress_transitions(net: PcTPN) -> np.ndarray:
    return np.array([r not in ("wait", "wait_end") for r in net.role], dtype=bool)


def check_structure(net: PcTPN, max_states: int = 5000) -> dict:
    """Bounded untimed reachability search from m0 (thesis 6.1, timing ignored).

    Raises FlowError naming the actions when (a) a transition never fires in the explored
    graph ("can never be enabled"), or (b) a dead marking is reachable: one where only the
    robots' wait loops can fire, i.e. nothing in the cell can progress any more.
    Product places are left out of the search state (they only grow and enable nothing).
    Returns {"states": n, "complete": bool}.
    """
    keep = np.ones(net.n_places, dtype=bool)
    products = getattr(net, "product_places", np.zeros(0, dtype=int))
    keep[products] = False
    pre_k = net.pre[keep]
    inc_k = net.incidence[keep]
    progress = _progress_transitions(net)
    wait_end = np.array([r == "wait_end" for r in net.role], dtype=bool)
    start = net.m0[keep]
    seen = {start.tobytes(): None}
    parent: dict[bytes, tuple[bytes | None, int]] = {start.tobytes(): (None, -1)}
    queue = deque([start])
    fired = np.zeros(net.n_transitions, dtype=bool)
    complete = True
    dead = None
    join = np.array([r == "join" for r in net.role], dtype=bool)
    while queue:
        m = queue.popleft()
        en = np.all(pre_k <= m[:, None], axis=0)
        if np.any(en & join):  # a partner joins the moment it is free (zero delay): nothing else fires first
            en &= join
        # a robot in its wait comes back; deadness is judged on the markings without waits
        if not np.any(en & progress) and not np.any(en & wait_end):
            trace, key = [], m.tobytes()
            while parent[key][0] is not None:
                key, j = parent[key]
                trace.append(net.transitions[j])
            trace.reverse()
            marked = [net.places[i] for i, v in zip(np.flatnonzero(keep), m, strict=True) if v]
            waiting = sorted(
                {
                    net.action[j]
                    for j in range(net.n_transitions)
                    if net.action[j]
                    and progress[j]
                    and any(net.places[i] in marked for i in np.flatnonzero(net.pre[:, j]))
                }
            )
            dead = dead or (
                f"dead marking reachable: actions {waiting} wait on each other; marked places {marked}; "
                f"reached by firing {trace[-12:]}"
            )
        fired |= en
        for j in np.flatnonzero(en):
            nxt = m + inc_k[:, j]
            key = nxt.tobytes()
            if key in seen:
                continue
            if len(seen) >= max_states:
                complete = False
                continue
            seen[key] = None
            parent[key] = (m.tobytes(), int(j))
            queue.append(nxt)
    if complete:
        never = sorted({net.action[j] or net.transitions[j] for j in np.flatnonzero(~fired & progress)})
        if never:
            raise FlowError(f"actions {never} can never be enabled from the initial marking")
    if dead:
        raise FlowError(dead)
    return {"states": len(seen), "complete": complete}


def net_from_flow(flow, buffers, human_agent, human_pattern, robot_agents, config) -> PcTPN:
    """Compile a flow with the net fields of the scheduler `config` (wait_quantum t_w,
    cost_robot c_R, cost_human c_H, joint_actions, max_wait, agent_costs where the kind has them)."""
    return compile_flow(
        flow,
        buffers,
        human_agent,
        human_pattern,
        robot_agents,
        wait_quantum=float(config.wait_quantum),
        cost_robot=float(config.cost_robot),
        cost_human=float(config.cost_human),
        collab_patience=getattr(config, "max_wait", 0.0) or None,
        agent_costs=dict(getattr(config, "agent_costs", {})),
        joint_actions=getattr(config, "joint_actions", "hold"),
    )


def flow_with_operator_durations(scenario) -> Flow:
    """The scenario's flow where an action of the operator that gives no `duration` takes its
    `operator.actions` one: the operator's time lives there, and a timed scheduler's prior
    starts from it."""
    own = {a.name: a.duration for a in scenario.operator.actions}
    human = scenario.operator.name
    actions = [replace(a, duration=own[a.name]) if a.duration is None and human in a.agents and a.name in own
               else a for a in scenario.flow.actions]
    return replace(scenario.flow, actions=actions)


def net_from_scenario(scenario, config) -> PcTPN:
    """Compile the scenario's flow (`flow_with_operator_durations`) with the net fields of the
    scheduler `config` (`net_from_flow`)."""
    robots = [arm.agent for robot in scenario.robots for arm in robot.arms]
    return net_from_flow(flow_with_operator_durations(scenario), scenario.layout.buffers,
                         scenario.operator.name, scenario.operator.pattern, robots, config)
