"""The best-scenario scheduler of thesis 7.2 on hand-worked nets: the cost of eq. (7.1)-(7.2),
the arrival sets of Algorithm 3, the branch and bound of Algorithm 2 and the 7.2.1 policy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hrc_drake.distributions import Distribution
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.best_scenario import (
    BestScenarioPlanner,
    BestScenarioPolicy,
    cost_lower_bound,
    delay_support,
    human_transitions,
    plan_cost,
    waiting_cost,
)
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.petri import PcTPN


def test_the_cost_curve_and_its_mean_over_an_arrival_set():
    # eq. (7.1) with P_c = [10, 20], c_R = 0.5, c_H = 2
    assert waiting_cost(4.0, 10, 20, 0.5, 2.0) == 3.0
    assert waiting_cost(15.0, 10, 20, 0.5, 2.0) == 0.0
    assert waiting_cost(23.0, 10, 20, 0.5, 2.0) == 6.0
    # eq. (7.2) by hand: over [8, 12], (1/4) * int_8^10 0.5 (10 - a) da = (1/4) * 1 = 0.25
    assert plan_cost(8.0, 12.0, 10, 20, 0.5, 2.0) == pytest.approx(0.25)
    # over [18, 24]: (1/6) * int_20^24 2 (a - 20) da = (1/6) * 16
    assert plan_cost(18.0, 24.0, 10, 20, 0.5, 2.0) == pytest.approx(16 / 6)
    assert plan_cost(5.0, 5.0, 10, 20, 0.5, 2.0) == 2.5  # a point: the curve itself
    rng = np.random.default_rng(0)
    for _ in range(50):  # against the mean of the curve on a fine grid
        lo, hi = np.sort(rng.uniform(0, 40, 2))
        grid = np.linspace(lo, hi, 20001)
        numeric = np.mean([waiting_cost(a, 10, 20, 0.5, 2.0) for a in grid])
        assert plan_cost(lo, hi, 10, 20, 0.5, 2.0) == pytest.approx(numeric, rel=1e-3, abs=1e-6)
    assert cost_lower_bound(15.0, 20.0, 2.0) == 0.0 and cost_lower_bound(25.0, 20.0, 2.0) == 10.0


def test_delay_supports():
    assert delay_support(Distribution("uniform", low=2.0, high=3.0)) == (2.0, 3.0)
    assert delay_support(Distribution("fixed", mean=4.0)) == (4.0, 4.0)
    assert delay_support(Distribution("normal", mean=6.0, std=1.0)) == (3.0, 9.0)
    assert delay_support(Distribution("normal", mean=1.0, std=1.0, low=0.5)) == (0.5, 4.0)
    assert delay_support(Distribution("empirical", samples=[3.0, 1.0, 2.0])) == (1.0, 3.0)
    lo, hi = delay_support(Distribution("lognormal", mean=5.0, std=1.0))
    assert 2.0 < lo < 5.0 < hi < 9.0


def _robot_then_collaborate(work: Distribution) -> PcTPN:
    """One robot: `r` (begin controllable, end after `work`) makes a part; `c` commits to the
    collaboration (t_c) and needs a robot that is available. Places: avail, busy, done."""
    pre = np.array([[1, 0, 1], [0, 1, 0], [0, 0, 0]])  # avail, busy, done x (r:begin, r:end, c:commit)
    post = np.array([[0, 1, 0], [1, 0, 0], [0, 1, 0]])
    return PcTPN(["avail", "busy", "done"], ["r:begin", "r:end", "c:commit"], pre, post, [True, False, True],
                 [Distribution("fixed", mean=0.0), work, Distribution("fixed", mean=0.0)], [1, 0, 0],
                 np.zeros(3), agents=[("robot",), ("robot",), ("robot",)], role=["begin", "end", "commit"])


def test_the_robot_works_first_when_the_human_is_far_and_commits_when_near():
    net = _robot_then_collaborate(Distribution("uniform", low=2.0, high=3.0))
    planner = BestScenarioPlanner(net, "c:commit", c_r=1.0, c_h=1.0, horizon=30.0)
    # the human starts in [2.5, 4]: commit now costs 2.5; work first arrives in [2, 3], cost 0.125
    far = planner.plan(net.m0, 2.5, 4.0)
    assert [net.transitions[j] for j in far.path] == ["r:begin", "r:end", "c:commit"]
    assert (far.alpha_lo, far.alpha_hi) == (2.0, 3.0) and far.cost == pytest.approx(0.125)
    assert planner.first_commands(far) == [0]
    # the human starts in [0, 1]: commit now costs 0; working first would cost 1.5
    near = planner.plan(net.m0, 0.0, 1.0)
    assert [net.transitions[j] for j in near.path] == ["c:commit"] and near.cost == 0.0
    # the same at t = 100 with the window moved along: arrival sets are absolute times
    later = planner.plan(net.m0, 102.5, 104.0, now=100.0)
    assert later.path == far.path and (later.alpha_lo, later.alpha_hi) == (102.0, 103.0)


def test_a_transition_under_way_arrives_after_its_remaining_delay():
    net = _robot_then_collaborate(Distribution("uniform", low=2.0, high=3.0))
    planner = BestScenarioPlanner(net, "c:commit", horizon=30.0)
    busy = np.array([0, 1, 0])
    plan = planner.plan(busy, 10.0, 12.0, now=10.0, elapsed=np.array([0.0, 1.5, 0.0]))
    assert [net.transitions[j] for j in plan.path] == ["r:end", "c:commit"]
    assert (plan.alpha_lo, plan.alpha_hi) == (10.5, 11.5)  # began at 8.5, ends 2-3 s after
    # begun at 7.5: it ends in [9.5, 10.5], raised to the root's 10 (alpha_lo never decreases)
    plan = planner.plan(busy, 10.0, 12.0, now=10.0, elapsed=np.array([0.0, 2.5, 0.0]))
    assert (plan.alpha_lo, plan.alpha_hi) == (10.0, 10.5)


def _race() -> PcTPN:
    """Two uncontrollable transitions enabled together: a ends in [0, 1], b in [5, 6]."""
    pre = np.array([[1, 0], [0, 1], [0, 0], [0, 0]])
    post = np.array([[0, 0], [0, 0], [1, 0], [0, 1]])
    return PcTPN(["pa", "pb", "qa", "qb"], ["a", "b"], pre, post, [False, False],
                 [Distribution("uniform", low=0.0, high=1.0), Distribution("uniform", low=5.0, high=6.0)],
                 [1, 1, 0, 0], np.zeros(4))


def test_algorithm_3_tags_an_arrival_set_impossible():
    net = _race()
    # Algorithm 3 alone (the net has no controllable target to plan for): b then a is
    # impossible, a then b is not
    planner = object.__new__(BestScenarioPlanner)
    planner.net, planner.supports = net, np.array([[0.0, 1.0], [5.0, 6.0]])
    planner.frozen = np.zeros(2, dtype=bool)
    planner._work = np.zeros(2, dtype=bool)
    root = planner.root(net.m0)
    after_b = planner.child(root, 1)
    assert (after_b.alpha_lo, after_b.alpha_hi) == (5.0, 6.0)
    assert planner.child(after_b, 0) is None  # a would have ended in [0, 1], before b: impossible
    after_a = planner.child(root, 0)
    assert (after_a.alpha_lo, after_a.alpha_hi) == (0.0, 1.0)
    b_after_a = planner.child(after_a, 1)
    assert (b_after_a.alpha_lo, b_after_a.alpha_hi) == (5.0, 6.0)  # b keeps its enabling time 0


def _use_case_a_net():
    """Use case a's net as the best-scenario planner takes it: joint actions start together."""
    flow, buffers, pattern, robots = tc.use_case_a(1)
    return compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=1.0,
                        joint_actions="simultaneous")


def test_the_human_and_the_explicit_waits_never_fire_while_planning():
    net = _use_case_a_net()
    human = {net.transitions[j] for j in np.flatnonzero(human_transitions(net))}
    assert human == {"intent:0", "ic#0:begin", "ic#0:end", "intent:1", "collab#1:begin", "collab#1:end"}
    planner = BestScenarioPlanner(net, "collab:commit", horizon=60.0)
    frozen = {net.transitions[j] for j in np.flatnonzero(planner.frozen)}
    assert frozen == human | {"yumi_left:wait", "yumi_right:wait"}


@pytest.mark.parametrize("ties", ["most_work", "first_found"])
def test_use_case_a_commits_at_once_when_the_human_is_near_and_fuses_when_far(ties):
    """m0: one checked board in stock, two free spots for fused boards. Near (P_c = [0, 2]):
    commit now, cost 0. Far (P_c = [20, 30]): the left arm fuses (twice: the spots) first."""
    net = _use_case_a_net()
    policy = BestScenarioPolicy(net, "collab", "ic", "fuse", horizon=60.0, ties=ties)
    policy.set_forecast(0.0, 2.0)
    assert net.transitions[policy.decide(net.m0, "yumi_left")] == "collab:commit"
    assert policy.last_plan_.cost == 0.0
    policy.set_forecast(20.0, 30.0)
    assert net.transitions[policy.decide(net.m0, "yumi_left")] == "fuse:begin"
    plan = policy.last_plan_
    assert [net.transitions[j] for j in plan.path] == ["fuse:begin", "fuse:end", "fuse:begin", "fuse:end",
                                                        "collab:commit"]
    # two fuses of N(6, 1), supports [3, 9] each: ready in [6, 18]; the mean of 0.5 (20 - a) ...
    assert (plan.alpha_lo, plan.alpha_hi) == (6.0, 18.0)
    assert plan.cost == pytest.approx(plan_cost(6.0, 18.0, 20.0, 30.0, 1.0, 1.0))
    # the right arm has no work of its own (7.2.1): it waits
    assert net.transitions[policy.decide(net.m0, "yumi_right")] == "yumi_right:wait"


def test_case_1_supplies_the_human_first():
    """P_a1 < P_c1 and the IC insertion lacks a fused board: the left arm fuses, without planning."""
    net = _use_case_a_net()
    policy = BestScenarioPolicy(net, "collab", "ic", "fuse", horizon=60.0)
    policy.set_forecast(0.0, 2.0, p_a1=-1.0)  # near collaboration, but the human wants its board first
    assert net.transitions[policy.decide(net.m0, "yumi_left")] == "fuse:begin"
    assert policy.last_plan_ is None
    with_board = net.m0.copy()
    with_board[net.place_index["buf:fused"]] = 1
    with_board[net.place_index["space:fused"]] -= 1
    assert net.transitions[policy.decide(with_board, "yumi_left")] == "collab:commit"  # case 2: planned


def test_observed_delays_widen_the_supports_and_clones_are_apart():
    net = _use_case_a_net()
    policy = BestScenarioPolicy(net, "collab", "ic", "fuse")
    twin = policy.clone()
    j = net.transition_index["fuse:end"]
    policy.observe(j, 11.0)
    assert tuple(policy.planner.supports[j]) == (3.0, 11.0)
    assert tuple(twin.planner.supports[j]) == (3.0, 9.0)
    with pytest.raises(ValueError):
        policy.set_forecast(5.0, 2.0)
    assert math.isinf(BestScenarioPlanner(net, "collab:commit").plan(
        np.zeros(net.n_places, dtype=int), 0.0, 1.0).cost)  # no robot available: no plan


def test_a_human_waiting_for_its_operation_is_supplied_whatever_the_forecast():
    """Pattern 2 (ic, ic, collab, collab): the human waits for its second IC with no fused board.
    A forecast of the collaboration at once would have the planner commit (the human never
    fires while planning) and the robots wait in vain: case 1 applies instead."""
    flow, buffers, pattern, robots = tc.use_case_a(2)
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0,
                       joint_actions="simultaneous")
    m = net.m0.copy()
    m[net.place_index["step:0"]] = 0
    m[net.place_index["hwait:1"]] = 1  # the human intends its step 1, the second IC
    policy = BestScenarioPolicy(net, "collab", "ic", "fuse")
    policy.set_forecast(0.0, 0.0, p_a1=0.0)
    assert net.transitions[policy.decide(m, "yumi_left")] == "fuse:begin"
    no_case_1 = BestScenarioPolicy(net, "collab")
    no_case_1.set_forecast(0.0, 0.0)
    assert net.transitions[no_case_1.decide(m, "yumi_left")] == "collab:commit"


def test_case_1_is_left_to_the_feeding_arm_whoever_decides_first():
    """Pattern 2 waits for its second IC with no fused board: case 1 (7.2.1) feeds it. The
    right arm, asked first, must not commit the left arm to the collaboration (a cell once
    stalled so: the human waited for a board the left arm never fused)."""
    flow, buffers, pattern, robots = tc.use_case_a(2)
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0,
                       joint_actions="simultaneous")
    policy = BestScenarioPolicy(net, "collab", "ic", "fuse", horizon=60.0)
    m = net.m0.copy()
    m[net.place_index["step:0"]] = 0
    m[net.place_index["hwait:0"]] = 1  # the human waits to start an IC
    policy.set_forecast(0.0, 5.0, 0.0)  # the forecast has the collaboration due too
    right = policy.decide(m, "yumi_right", now=0.0)
    assert "yumi_left" not in net.agents[right]
    assert net.transitions[policy.decide(m, "yumi_left", now=0.0)] == "fuse:begin"
