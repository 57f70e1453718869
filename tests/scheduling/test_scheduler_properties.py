"""Property tests of the robot schedulers on random small assembly flows (Hypothesis): chains,
forks and joins of 2-6 actions with random agents, durations, buffers and human patterns, compiled
into pcTPN nets and run in the event-level cell simulator."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from hrc_drake.distributions import Distribution
from hrc_drake.scheduling.baselines import (
    BestOfRolloutsPlanPolicy,
    RandomEnabledPolicy,
    RoundRobinPolicy,
    is_deadlocked,
)
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import FlowError, compile_flow
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.montecarlo import DURATION_MODELS, ROLLOUTS, ROOT_CHOICES, MonteCarloPolicy

duration = st.one_of(
    st.floats(0.5, 5.0).map(lambda d: Distribution("fixed", mean=d)),
    st.tuples(st.floats(0.5, 4.0), st.floats(0.0, 2.0)).map(
        lambda g: Distribution("uniform", low=g[0], high=g[0] + g[1])),
)


@st.composite
def cells(draw):
    """A valid compiled net: actions 0..n-1, each fed by raw parts or by 1-2 earlier actions
    through its own buffers (chains, forks, joins); the human does its actions in flow order."""
    n = draw(st.integers(2, 6))
    robots = ["r1", "r2"][: draw(st.integers(1, 2))]
    teams = [("human",), ("r1",), ("human", "r1")]
    if len(robots) == 2:
        teams += [("r2",), ("r1", "r2"), ("human", "r2")]
    agents = [draw(st.sampled_from(teams)) for _ in range(n)]
    if all(a == ("human",) for a in agents):
        agents[0] = ("r1",)  # a robot to schedule
    parents = [[]] + [draw(st.lists(st.integers(0, i - 1), min_size=1, max_size=2, unique=True))
                      for i in range(1, n)]
    buffers = [Buffer("raw", kind="raw"), Buffer("done", kind="product")]
    inputs = [["raw"] if not parents[i] else [] for i in range(n)]
    outputs = [[] for _ in range(n)]
    for i in range(n):
        for p in parents[i]:
            capacity = draw(st.integers(1, 2))
            # mostly empty: a full buffer can block its producer's other outputs for good
            initial = min(draw(st.sampled_from([0, 0, 0, 1])), capacity)
            buffers.append(Buffer(f"b{p}_{i}", capacity=capacity, initial=initial))
            inputs[i].append(f"b{p}_{i}")
            outputs[p].append(f"b{p}_{i}")
    use_tool = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    actions = [FlowAction(f"a{i}", list(agents[i]), inputs[i], outputs[i] or ["done"],
                          resources=["tool"] if use_tool[i] else [], duration=draw(duration))
               for i in range(n)]
    pattern = [a.name for a in actions if "human" in a.agents]
    try:
        tools = {"tool": draw(st.integers(1, 2))}
        net = compile_flow(Flow(actions, tools), buffers, "human", pattern, robots,
                           wait_quantum=draw(st.sampled_from([0.5, 1.0])),
                           collab_patience=draw(st.sampled_from([None, 2.0])))
    except FlowError:  # a dead marking of this flow (e.g. a join starved by a full fork)
        assume(False)
    return net


def policies(kind, net, seed, draw):
    """A maker of the policy `kind` (parameters drawn once: each call gives the same policy)."""
    if kind == "montecarlo":
        params = dict(n_trials=draw(st.sampled_from([6, 16])), horizon=draw(st.sampled_from([4.0, 8.0])),
                      min_branch_samples=draw(st.sampled_from([1, 4])),
                      rollout=draw(st.sampled_from(ROLLOUTS)),
                      durations=draw(st.sampled_from(sorted(DURATION_MODELS))),
                      root_choices=draw(st.sampled_from(ROOT_CHOICES)), wait_grid=draw(st.booleans()))
        params["stratified_roots"] = params["common_random_numbers"] = draw(st.booleans())
        return lambda: MonteCarloPolicy(net, random_state=seed, **params)
    if kind == "random_enabled":
        return lambda: RandomEnabledPolicy(net, random_state=seed)
    if kind == "round_robin":
        return lambda: RoundRobinPolicy(net, random_state=seed)
    return lambda: BestOfRolloutsPlanPolicy(net, plan_horizon=20.0, n_candidates=6, random_state=seed)


class Checked:
    """Wraps a policy: checks and records every decision."""

    def __init__(self, policy, kind):
        self.policy, self.kind, self.decisions = policy, kind, []

    def observe(self, transition, delay):
        self.policy.observe(transition, delay)

    def decide(self, marking, agent, now=0.0, elapsed=None):
        net = self.policy.net
        marking = marking.copy()
        j = self.policy.decide(marking, agent, now=now, elapsed=elapsed)
        assert isinstance(j, (int, np.integer)) and 0 <= j < net.n_transitions
        en = net.enabled(marking)
        # an enabled controllable transition of this agent (its wait is one)
        assert net.controllable[j] and agent in net.agents[j] and en[j], (self.kind, net.transitions[j])
        begins = [k for k in net.agent_transitions(agent) if en[k] and net.role[k] == "begin"]
        if self.kind == "random_enabled" and begins:  # documented: whatever is enabled, wait only if none
            assert net.role[j] != "wait"
        if self.kind != "montecarlo" and begins and is_deadlocked(net, marking):  # deadlock repair
            assert net.role[j] != "wait"
        if self.kind == "montecarlo" and self.policy.last_percentiles_:
            # Algorithm 4: of the agent's root children, the one with the lowest beta-percentile;
            # the root children are enabled controllable transitions (the agent's, or any robot's)
            scores = self.policy.last_percentiles_
            names = {net.transitions[k] for k in net.agent_transitions(agent) if en[k]}
            roots = names if self.policy.root_choices == "agent" else {
                net.transitions[k] for k in np.flatnonzero(net.controllable & en)}
            assert set(scores) <= roots and len(names) > 1
            if self.policy.stratified_roots and self.policy.n_trials >= len(roots):
                assert set(scores) == roots
            if set(scores) & names:
                assert scores[net.transitions[j]] == min(scores[n] for n in names if n in scores)
            assert all(np.isfinite(v) and v >= 0 for v in scores.values())
        self.decisions.append((agent, int(j), float(now)))
        return j


@settings(max_examples=50, deadline=None)
@given(net=cells(), kind=st.sampled_from(["montecarlo", "random_enabled", "round_robin", "plan"]),
       seed=st.integers(0, 2**16), max_time=st.sampled_from([15.0, 30.0]), data=st.data())
def test_schedulers_choose_enabled_transitions_of_the_agent_and_repeat(net, kind, seed, max_time, data):
    make = policies(kind, net, seed, data.draw)

    def run():
        policy = Checked(make(), kind)
        cell = simulate_cell(net, policy, np.random.default_rng(seed), max_time=max_time)
        return policy.decisions, cell

    first, cell = run()
    assert first, "every robot is free at t = 0: at least one decision"
    assert cell.end_time <= max_time
    assert all(np.isfinite(v) and v >= 0 for v in cell.idle.values())
    again, cell2 = run()
    assert again == first and cell2.events == cell.events


@settings(max_examples=40, deadline=None)
@given(net=cells(), seed=st.integers(0, 2**16), walk=st.lists(st.integers(0, 10**6), max_size=25),
       data=st.data())
def test_every_policy_decides_well_from_any_reachable_marking(net, seed, walk, data):
    # untimed random firings from m0 reach markings the timed cell may never show the policies
    marking = net.m0.copy()
    for pick in walk:
        enabled = np.flatnonzero(net.enabled(marking))
        if enabled.size == 0:  # (check_structure found no dead marking, but its search is bounded)
            break
        marking = net.fire(marking, int(enabled[pick % enabled.size]))
    free = [r for r in net.robot_agents if marking[net.place_index[f"avail:{r}"]] > 0]
    for kind in ("montecarlo", "random_enabled", "round_robin", "plan"):
        policy = Checked(policies(kind, net, seed, data.draw)(), kind)
        for agent in free:
            policy.decide(marking, agent, now=float(len(walk)))


@settings(max_examples=30, deadline=None)
@given(net=cells(), seed=st.integers(0, 2**16),
       observed=st.lists(st.tuples(st.integers(0, 10**6), st.floats(allow_nan=True, allow_infinity=True)),
                         max_size=12))
def test_monte_carlo_refuses_a_busy_robot_and_decides_from_an_empty_cell(net, seed, observed):
    policy = MonteCarloPolicy(net, n_trials=6, horizon=4.0, random_state=seed, min_samples=1)
    uncontrollable = np.flatnonzero(~net.controllable)
    for pick, delay in observed:  # observed firing delays (7.1): finite and >= 0, else ValueError
        j = int(uncontrollable[pick % uncontrollable.size])
        if np.isfinite(delay) and delay >= 0:
            policy.observe(j, delay)
        else:
            with pytest.raises(ValueError):
                policy.observe(j, delay)
    Checked(policy, "montecarlo").decide(net.m0, net.robot_agents[0])
    for agent in net.robot_agents:
        busy = net.m0.copy()
        busy[net.place_index[f"avail:{agent}"]] = 0
        with pytest.raises(ValueError, match="no enabled transition"):
            policy.decide(busy, agent)
        # no part, spot or resource anywhere: the wait and raw-to-product actions of the agent alone
        alone = np.zeros_like(net.m0)
        alone[net.place_index[f"avail:{agent}"]] = 1
        choices = [k for k in net.agent_transitions(agent) if net.enabled(alone)[k]]
        j = policy.decide(alone, agent)
        assert j in choices and net.transition_index[f"{agent}:wait"] in choices
        if len(choices) == 1:
            assert policy.last_percentiles_ == {}
