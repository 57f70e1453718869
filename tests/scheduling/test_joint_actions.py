"""Actions of two robot arms as thesis 6.3.3 has them (`compiler.JOINT_ACTIONS` "hold"): the first
arm free commits and holds, its partner joins the moment it is free, the holder gives up after
its patience; and the former "simultaneous" model kept as a named variant, whose arms waiting t_w
apart never meet."""

import math

import numpy as np
import pytest

from hrc_drake.distributions import Distribution
from hrc_drake.errors import ConfigError
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.baselines import RoundRobinPolicy
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import FlowError, check_structure, compile_flow
from hrc_drake.scheduling.config import BestScenarioScheduler, MonteCarloScheduler
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.fuzzy_scheduler import FuzzyPolicy
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy


def _fixed(t):
    return Distribution(kind="fixed", mean=float(t))


def _two_arms(joint_actions="hold", partner_time=5.0, patience=None, wait_quantum=1.5):
    """r1 makes a part in 3 s, r2 works once for 5 s on its own; then both arms use r1's part for 2 s."""
    buffers = [Buffer("raw", kind="raw"), Buffer("a", capacity=1), Buffer("one_job", capacity=1, initial=1),
               Buffer("solo_out", capacity=1), Buffer("product", kind="product")]
    flow = Flow(actions=[
        FlowAction("A", ["r1"], ["raw"], ["a"], duration=_fixed(3.0)),
        FlowAction("B", ["r2"], ["one_job"], ["solo_out"], duration=_fixed(partner_time)),
        FlowAction("J", ["r1", "r2"], ["a"], ["product"], duration=_fixed(2.0)),
    ])
    return compile_flow(flow, buffers, "human", [], ["r1", "r2"], wait_quantum=wait_quantum,
                        joint_actions=joint_actions, collab_patience=patience)


def _round_robin(net):
    return RoundRobinPolicy(net, programs={"r1": ["A", "J"], "r2": ["B", "J"]}, random_state=0)


def _begins(run, action):
    return sorted((round(t, 9), agent) for t, agent, a, kind in run.events if a == action and kind == "begin")


def test_the_first_arm_free_holds_and_its_partner_joins_the_moment_it_is_free():
    net = _two_arms()
    assert net.role[net.transition_index["J:hold:r1"]] == "hold"
    assert net.controllable[net.transition_index["J:hold:r1"]]
    join = net.transition_index["J:join:r2"]
    assert not net.controllable[join] and net.delays[join].mean == 0.0 and net.agents[join] == ("r2", "r1")
    run = simulate_cell(net, _round_robin(net), np.random.default_rng(0), max_time=7.5, wait_grid=False)
    # r1 holds from 3 s (its part is made); r2 ends B at 5 s and joins at once: J runs 5-7 s
    assert _begins(run, "J")[:2] == [(5.0, "r1"), (5.0, "r2")]
    assert run.product_times[0] == pytest.approx(7.0)
    assert not [e for e in run.events if e[1] == "r1" and e[3] == "wait_begin" and e[0] < 5.0]
    assert run.idle["r1"] == pytest.approx(2.0)  # the hold is idle time (cost c_R)


def test_the_simultaneous_variant_with_literal_waits_never_meets():
    """The former model: both arms must be free at once; r1 waits t_w = 1.5 s from 3 s, r2 from
    5 s: their waits end 0.5 s apart for ever and J never starts (use case a's artefact)."""
    net = _two_arms("simultaneous")
    assert "J:begin" in net.transition_index and "J:hold:r1" not in net.transition_index
    run = simulate_cell(net, _round_robin(net), np.random.default_rng(0), max_time=300.0, wait_grid=False)
    assert _begins(run, "J") == [] and not run.product_times
    # on the t_w grid (the wait_grid variant) they meet
    grid = simulate_cell(net, _round_robin(net), np.random.default_rng(0), n_products=1, wait_grid=True)
    assert _begins(grid, "J")


def test_the_holding_arm_gives_up_after_its_patience_and_puts_the_part_back():
    net = _two_arms(partner_time=100.0, patience=4.0)
    giveup = net.transition_index["J:giveup:r1"]
    assert net.delays[giveup].mean == 4.0 and net.agents[giveup] == ("r1",)
    m = net.m0.copy()
    for name in ("A:begin", "A:end"):
        m = m + net.incidence[:, net.transition_index[name]]
    m = m + net.incidence[:, net.transition_index["J:hold:r1"]]
    assert m[net.place_index["held:J:r1"]] == 1 and m[net.place_index["buf:a"]] == 0
    after = m + net.incidence[:, giveup]
    assert after[net.place_index["avail:r1"]] == 1 and after[net.place_index["buf:a"]] == 1
    assert not after[net.place_index["held:J:r1"]]


def test_a_free_partner_is_never_asked_to_decide_while_an_arm_holds_for_it():
    net = _two_arms()
    held = net.place_index["held:J:r1"]

    class Recording(RoundRobinPolicy):
        asked_while_held = 0

        def decide(self, marking, agent, now=0.0, elapsed=None):
            if marking[held] and agent == "r2":
                Recording.asked_while_held += 1
            return super().decide(marking, agent, now, elapsed)

    policy = Recording(net, programs={"r1": ["A", "J"], "r2": ["B", "J"]}, random_state=0)
    run = simulate_cell(net, policy, np.random.default_rng(0), n_products=5, wait_grid=False)
    assert len(run.product_times) == 5 and Recording.asked_while_held == 0


def test_never_giving_up_is_no_dead_marking():
    """With infinite patience, r2 holding K while r1 holds J would wait for ever; but the partner
    joins at once (zero delay, before any choice), so that marking is unreachable and the
    structure check finds no dead marking."""
    buffers = [Buffer("raw", kind="raw"), Buffer("a", capacity=1), Buffer("product", kind="product")]
    flow = Flow(actions=[
        FlowAction("A", ["r1"], ["raw"], ["a"], duration=_fixed(3.0)),
        FlowAction("J", ["r1", "r2"], ["a"], ["product"], duration=_fixed(2.0)),
        FlowAction("K", ["r1", "r2"], ["raw"], ["product"], duration=_fixed(2.0)),
    ])
    net = compile_flow(flow, buffers, "human", [], ["r1", "r2"], collab_patience=math.inf)
    assert "J:giveup:r1" not in net.transition_index
    assert check_structure(net)["complete"]


def test_joint_actions_must_be_a_known_model():
    with pytest.raises(FlowError, match="joint_actions"):
        _two_arms("whenever")
    with pytest.raises(ConfigError, match="joint_actions"):
        MonteCarloScheduler(joint_actions="whenever").validate("scheduler")
    with pytest.raises(ConfigError, match="joint_actions"):
        BestScenarioScheduler(collaboration="collab", joint_actions="hold").validate("scheduler")


def test_three_arms_start_together_in_either_model():
    buffers = [Buffer("raw", kind="raw"), Buffer("product", kind="product")]
    flow = Flow(actions=[FlowAction("lift", ["r1", "r2", "r3"], ["raw"], ["product"], duration=_fixed(1.0))])
    net = compile_flow(flow, buffers, "human", [], ["r1", "r2", "r3"])
    assert net.agents[net.transition_index["lift:begin"]] == ("r1", "r2", "r3")


@pytest.mark.parametrize("pattern", [1, 2])
def test_literal_monte_carlo_makes_products_on_use_case_a(pattern):
    """Algorithm 4 as written (trials of waits t_w, no grid) on use case a: with holds (6.3.3)
    the arms meet for the check and the collaboration; on the simultaneous net they never do."""
    flow, buffers, human, robots = tc.use_case_a(pattern)
    for joint, makes_products in (("hold", True), ("simultaneous", False)):
        net = compile_flow(flow, buffers, "human", human, robots, wait_quantum=3.0, joint_actions=joint)
        policy = MonteCarloPolicy(net, n_trials=20, horizon=15.0, random_state=3)
        assert not policy.wait_grid
        run = simulate_cell(net, policy, np.random.default_rng(1003), n_cycles=3, max_time=600.0)
        assert bool(run.product_times) == makes_products, joint
        if makes_products:
            assert run.time_per_product < 40.0


def test_the_fuzzy_tree_joins_before_any_choice():
    flow, buffers, human, robots = tc.use_case_a(1)
    net = compile_flow(flow, buffers, "human", human, robots, wait_quantum=3.0)
    run = simulate_cell(net, FuzzyPolicy(net, horizon=12.0, random_state=0), np.random.default_rng(0),
                        n_cycles=2, max_time=400.0)
    assert run.product_times


def test_the_drake_cell_holds_and_joins(tmp_path, diagrams_dir):
    """pcb_collab with the Monte Carlo scheduler as written (waits of t_w): one arm is commanded
    into the check and holds, its partner is commanded the moment it reports ready; products
    come. The simultaneous variant makes none."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import Tagged, load_scenario_with

    products = {}
    for joint in ("hold", "simultaneous"):
        path = tmp_path / f"{joint}.yaml"
        path.write_text(f"extends: {diagrams_dir / 'pcb_collab.yaml'}\nscheduler: !MonteCarloScheduler "
                        f"{{wait_quantum: 3.0, horizon: 15.0, joint_actions: {joint}}}\n")
        scenario = load_scenario_with(path, {"safety": Tagged("NoSafety", {})})
        result = simulate(build_cell(scenario, path), 120.0, progress=None)
        products[joint] = result.metrics["products_finished"]
        if joint == "hold":
            checks = sorted((c for c in result.log.decisions if c.action == "check"), key=lambda c: c.time)
            # commands come in pairs, the holder's first: each arm waits T_wait = 5 t_w for the other
            assert checks and all(c.give_up_after == 15.0 for c in checks)
            pairs = list(zip(checks[::2], checks[1::2], strict=False))
            assert all(a.agent != b.agent for a, b in pairs)
            assert any(b.time > a.time for a, b in pairs)  # an arm held before its partner joined
    assert products["hold"] >= 2 and products["simultaneous"] == 0


def test_give_up_delays_are_found_by_the_arcs_whatever_the_names():
    """Names may hold ':'; the give-up of a hold, of a join and of a commitment is the one that
    takes back what they commit."""
    from hrc_drake.scheduling.systems import _give_up_after

    buffers = [Buffer("raw", kind="raw"), Buffer("product", kind="product")]
    for joint in ("hold", "simultaneous"):
        flow = Flow(actions=[
            FlowAction("pcb:check", ["yumi:l", "yumi:r"], ["raw"], ["product"], duration=_fixed(2.0)),
            FlowAction("co:op", ["h", "yumi:l", "yumi:r"], ["raw"], ["product"], duration=_fixed(2.0)),
        ])
        net = compile_flow(flow, buffers, "h", ["co:op"], ["yumi:l", "yumi:r"], wait_quantum=1.0,
                           collab_patience=4.0, joint_actions=joint)
        committing = [j for j in range(net.n_transitions) if net.role[j] in ("hold", "commit", "join")]
        assert committing
        for j in committing:
            assert _give_up_after(net, j) == 4.0, net.transitions[j]
        assert _give_up_after(net, net.transition_index["yumi:l:wait"]) == math.inf


def test_the_fuzzy_root_never_decides_a_join():
    flow, buffers, human, robots = tc.use_case_a(1)
    net = compile_flow(flow, buffers, "human", human, robots, wait_quantum=3.0)
    m = net.m0.copy()
    m[net.place_index["buf:with_ic"]] += 1
    m[net.place_index["space:with_ic"]] -= 1
    m = m + net.incidence[:, net.transition_index["check:hold:yumi_left"]]
    assert net.enabled(m)[net.transition_index["check:join:yumi_right"]]
    j = FuzzyPolicy(net, horizon=12.0, random_state=0).decide(m, "yumi_right")
    assert net.controllable[j] and "yumi_right" in net.agents[j]
