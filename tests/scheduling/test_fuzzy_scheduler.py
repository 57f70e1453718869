"""The fuzzy scheduler of thesis 7.4 (Algorithm 5, eq. 7.3-7.18), the fuzzyfication of 7.5.3
(eq. 7.19-7.20) and the uniform scheduler (eq. 7.21-7.23), on hand-worked nets."""

import math

import numpy as np
import pytest

from hrc_drake.distributions import Distribution, sample_duration
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.fuzzy import FuzzyNumber
from hrc_drake.scheduling.fuzzy_scheduler import (
    FuzzyPolicy,
    FuzzyReachabilityTree,
    UniformPolicy,
    fuzzify_distribution,
    fuzzify_samples,
    human_wait_index,
)
from hrc_drake.scheduling.petri import PcTPN

T = FuzzyNumber.triangular
C = FuzzyNumber.crisp
FIXED = Distribution("fixed", mean=1.0)


def _race_net(shared: bool) -> PcTPN:
    """Two uncontrollable transitions enabled at m0: t_a (pa -> pb) and t_c (pc -> pd); with
    `shared` both also need the token of place r (Fig. 6.5 Example A: firing one disables the other)."""
    places = ["pa", "pb", "pc", "pd", "r"]
    pre = np.zeros((5, 2), dtype=int)
    post = np.zeros((5, 2), dtype=int)
    pre[0, 0], post[1, 0] = 1, 1
    pre[2, 1], post[3, 1] = 1, 1
    if shared:
        pre[4, :] = 1
    return PcTPN(
        places, ["t_a", "t_c"], pre, post, [False, False], [FIXED, FIXED], [1, 0, 1, 0, 1], np.zeros(5)
    )


def _net_7_6():
    flow, buffers, pattern, robots = tc.fig_7_6()
    return compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=1.0)


# -- fuzzyfication (eq. 7.19-7.20) -------------------------------------------------------------


def test_fuzzify_samples_hand_worked_with_the_sigma_r_slip_fixed():
    # D = 1, 2, 3, 4, 10: T_M = 4, sigma = sqrt(10), 4 of 5 samples <= T_M so S = 4,
    # sigma_L = sigma 4/5, sigma_R = sigma 1/5 (the text's second sigma_L read sigma_R)
    d = fuzzify_samples([1, 2, 3, 4, 10])
    s = math.sqrt(10.0)
    assert (d.a, d.b, d.d) == pytest.approx((4 - 0.8 * s, 4.0, 4 + 0.2 * s))
    assert d.is_triangular
    # T_1 = max(0, T_M - sigma_L): D = 0, 0, 0, 9: T_M = 2.25, sigma_L = 0.75 sigma > T_M
    d = fuzzify_samples([0, 0, 0, 9])
    s = np.std([0, 0, 0, 9])
    assert (d.a, d.b, d.d) == pytest.approx((0.0, 2.25, 2.25 + 0.25 * s))
    assert fuzzify_samples([3.0, 3.0, 3.0]) == C(3.0)
    with pytest.raises(ValueError):
        fuzzify_samples([])
    with pytest.raises(ValueError):
        fuzzify_samples([1.0, -1.0])


def test_fuzzify_samples_of_a_normal_and_of_the_distribution_agree():
    """For N(10, 2): T_M ~ 10, S ~ 1, so sigma_L ~ sigma_R ~ sigma / 2 = 1; the prior
    fuzzyfication of the distribution itself is the large-sample limit."""
    rng = np.random.default_rng(0)
    dist = Distribution("normal", mean=10.0, std=2.0, low=0.0)
    samples = sample_duration(dist, rng, 20000)
    d = fuzzify_samples(samples)
    assert (d.a, d.b, d.d) == pytest.approx((9.0, 10.0, 11.0), abs=0.06)
    prior = fuzzify_distribution(dist)
    assert (prior.a, prior.b, prior.d) == pytest.approx((d.a, d.b, d.d), abs=0.06)
    # a right-skewed lognormal: more samples below the mean, so sigma_L > sigma_R (eq. 7.20)
    skew = Distribution("lognormal", mean=10.0, std=5.0)
    d = fuzzify_samples(sample_duration(skew, rng, 20000))
    prior = fuzzify_distribution(skew)
    assert d.b - d.a > d.d - d.b
    assert (prior.a, prior.b, prior.d) == pytest.approx((d.a, d.b, d.d), abs=0.15)


def test_fuzzify_distribution_hand_worked():
    # U[2, 4]: T_M = 3, sigma = 2 / sqrt(12), F(T_M) = 1/2
    d = fuzzify_distribution(Distribution("uniform", low=2.0, high=4.0))
    half = 1.0 / math.sqrt(12.0)
    assert (d.a, d.b, d.d) == pytest.approx((3 - half, 3.0, 3 + half))
    assert fuzzify_distribution(Distribution("fixed", mean=5.0)) == C(5.0)
    assert fuzzify_distribution(Distribution("empirical", samples=[1, 2, 3, 4, 10])) == fuzzify_samples(
        [1, 2, 3, 4, 10]
    )


# -- W_H (eq. 7.12-7.15, 7.23) -----------------------------------------------------------------


def test_human_wait_index_hand_worked():
    # disjoint: phi_1 = 1, phi_2 = 1 + (4 - 1)/50, phi_3 = (3 - 0)/(5 - 0)
    assert human_wait_index(T(0, 1, 2), T(3, 4, 5), 50.0) == pytest.approx(1.06 * 0.6)
    # overlapping: max_t min = 1/2 at t = 3, phi_2 = 1 + 2/50, phi_3 = 2/6
    assert human_wait_index(T(0, 2, 4), T(2, 4, 6), 50.0) == pytest.approx(0.5 * 1.04 / 3)
    assert human_wait_index(T(0, 2, 4), T(2, 4, 6), 50.0, with_phi2=False) == pytest.approx(0.5 / 3)
    # no wait: the start comes with the intention
    assert human_wait_index(T(1, 2, 3), T(1, 2, 3), 50.0) == 0.0
    assert human_wait_index(C(2.0), C(2.0), 50.0) == 0.0
    # a longer wait costs more
    assert human_wait_index(C(0.0), C(20.0), 50.0) > human_wait_index(C(0.0), C(5.0), 50.0)


# -- the Conflict routine (eq. 7.3-7.11) -------------------------------------------------------


def test_conflict_stage_2_uses_g_for_the_competitors_hand_worked():
    """Example A with d_a = <0, 2, 4> and d_c = crisp 1, both enabled at the root (no cut):
    t_c wins with P = G(<0,2,4>, 1) = 1 - (1/4)/2 = 7/8 at crisp 1; t_a's alpha_hat is
    mu_a on [0, 1], so P = mu_a(1) = 1/2 and alpha = <0, 1, 1> (eq. 7.10). (With L in place of
    G, eq. (7.7) as printed, t_a would get P = 1 and t_c P = 1/8.)"""
    net = _race_net(shared=True)
    tree = FuzzyReachabilityTree(net, [T(0, 2, 4), C(1.0)], horizon=10.0)
    a, c = tree.child(0, "t_a"), tree.child(0, "t_c")
    assert tree.nodes[c].possibility == pytest.approx(0.875)
    assert tree.nodes[c].arrival == C(1.0)
    assert tree.nodes[a].possibility == pytest.approx(0.5, abs=1e-9)
    assert (tree.nodes[a].arrival.a, tree.nodes[a].arrival.b, tree.nodes[a].arrival.d) == pytest.approx(
        (0.0, 1.0, 1.0)
    )
    assert tree.nodes[0].conflict == "uncontrollable" and tree.nodes[a].children == []


def test_conflict_stage_1_cuts_by_the_father_hand_worked():
    """Independent race, d_a = <0, 2, 4>, d_c = crisp 3.
    Root: t_c wins with P = G(<0,2,4>, 3) = 1/8 at crisp 3; t_a wins with P = 1, alpha_hat = mu_a
    on [0, 3] -> <0, 2, 3>.
    After t_c (alpha_f = crisp 3), t_a, enabled since the root, is cut by L(crisp 3, t) (eq. 7.4):
    alpha_tilde = mu_a on [3, 4], p = mu_a(3) = 1/2 (eq. 7.6), alpha_bar = alpha_tilde / p; it is
    alone, so alpha = <3, 3, 4> (eq. 7.10), P = 1 and F = min(1, 1/8) (eq. 7.11).
    After t_a (alpha_f = <0, 2, 3>), t_c is crisp 3 with L(<0,2,3>, 3) = 1: alpha = crisp 3."""
    net = _race_net(shared=False)
    tree = FuzzyReachabilityTree(net, [T(0, 2, 4), C(3.0)], horizon=10.0)
    c, a = tree.child(0, "t_c"), tree.child(0, "t_a")
    assert tree.nodes[c].possibility == pytest.approx(0.125) and tree.nodes[c].arrival == C(3.0)
    assert tree.nodes[a].possibility == pytest.approx(1.0)
    assert (tree.nodes[a].arrival.a, tree.nodes[a].arrival.b, tree.nodes[a].arrival.d) == pytest.approx(
        (0.0, 2.0, 3.0)
    )
    ca = tree.child(c, "t_a")
    arr = tree.nodes[ca].arrival
    assert (arr.a, arr.b, arr.d) == pytest.approx((3.0, 3.0, 4.0), abs=1e-9)
    assert tree.nodes[ca].possibility == pytest.approx(1.0)
    assert tree.nodes[ca].reach == pytest.approx(0.125)
    ac = tree.child(a, "t_c")
    assert tree.nodes[ac].arrival == C(3.0) and tree.nodes[ac].possibility == 1.0


def test_unreachable_children_and_the_horizon_are_left_out():
    # t_c (crisp 5) can never beat t_a (crisp 1) in Example A: G(crisp 1, 5) = 0 < eps
    net = _race_net(shared=True)
    tree = FuzzyReachabilityTree(net, [C(1.0), C(5.0)], horizon=10.0)
    assert [net.transitions[tree.nodes[k].transition] for k in tree.nodes[0].children] == ["t_a"]
    # a triangle that only overlaps the other's support at its start: P = mu(1) = 0.004 < eps
    tree = FuzzyReachabilityTree(net, [C(1.0), T(0.996, 2, 3)], horizon=10.0)
    assert len(tree.nodes[0].children) == 1
    # "below T_sch": the core must start by T_sch; <9, 11, 12> is not below 10, <9, 10, 12> is
    race = _race_net(shared=False)
    tree = FuzzyReachabilityTree(race, [T(9, 11, 12), C(20.0)], horizon=10.0)
    assert tree.nodes[0].children == []
    tree = FuzzyReachabilityTree(race, [T(9, 10, 12), C(20.0)], horizon=10.0)
    assert len(tree.nodes[0].children) == 1


def test_simultaneous_crisp_winners_are_fired_in_one_order_unless_they_conflict():
    race = _race_net(shared=False)
    tree = FuzzyReachabilityTree(race, [C(2.0), C(2.0)], horizon=10.0)
    (first,) = tree.nodes[0].children  # t_a, then t_c at the same instant
    assert race.transitions[tree.nodes[first].transition] == "t_a"
    (second,) = tree.nodes[first].children
    assert race.transitions[tree.nodes[second].transition] == "t_c" and tree.nodes[second].arrival == C(2.0)
    tree = FuzzyReachabilityTree(_race_net(shared=True), [C(2.0), C(2.0)], horizon=10.0)
    assert len(tree.nodes[0].children) == 2  # a real conflict: both outcomes


def test_elapsed_time_conditions_the_root_and_overdue_fires_now():
    race = _race_net(shared=False)
    # t_a = <0, 2, 4> enabled 1 s ago: alpha_E = crisp(-1), <-1, 1, 3> cut at 0 keeps [0, 3] with
    # its peak 1 -> <0, 1, 3>; t_c = crisp 5 enabled 7 s ago is overdue -> crisp 0
    tree = FuzzyReachabilityTree(race, [T(0, 2, 4), C(5.0)], horizon=10.0, elapsed=np.array([1.0, 7.0]))
    c = tree.child(0, "t_c")
    assert tree.nodes[c].arrival == C(0.0) and tree.nodes[c].possibility == 1.0
    a = tree.child(c, "t_a")
    arr = tree.nodes[a].arrival
    assert (arr.a, arr.b, arr.d) == pytest.approx((0.0, 1.0, 3.0), abs=0.05)


def test_zero_delay_transitions_keep_the_arrival_time_and_fire_first():
    net = _net_7_6()
    tree = FuzzyReachabilityTree(
        net,
        [FuzzyPolicy(net).fuzzy_delay(j) for j in range(net.n_transitions)],
        6.0,
        roots=[net.transition_index["action1:begin"]],
    )
    # root -> action1:begin -> intent:0 (zero delay) -> action2#0:begin (zero delay): all at 0
    i = tree.follow(["action1:begin", "intent:0", "action2#0:begin"])
    assert tree.nodes[i].arrival == C(0.0)
    assert [tree.nodes[k].possibility for k in (tree.nodes[i].parent, i)] == [1.0, 1.0]
    assert len(tree.nodes[tree.nodes[i].parent].children) == 1


def test_a_zero_delay_transition_beats_a_competitor_enabled_before_its_father():
    """t_a (<0, 2, 4>) then t_z (crisp 0 delay) race t_c (<1, 3, 5>), enabled since the root.
    After t_a, t_z fires at alpha_a with possibility 1 and t_c cannot come in between (without
    the rule, eq. 7.4-7.9 would treat alpha_a in t_z's alpha_bar and in L(alpha_a, .) as two
    unrelated numbers and let t_c win with a positive possibility)."""
    places = ["pa", "pb", "pe", "pc", "pd"]
    pre = np.zeros((5, 3), dtype=int)
    post = np.zeros((5, 3), dtype=int)
    pre[0, 0], post[1, 0] = 1, 1  # t_a: pa -> pb
    pre[1, 1], post[2, 1] = 1, 1  # t_z: pb -> pe
    pre[3, 2], post[4, 2] = 1, 1  # t_c: pc -> pd
    net = PcTPN(
        places, ["t_a", "t_z", "t_c"], pre, post, [False] * 3, [FIXED] * 3, [1, 0, 0, 1, 0], np.zeros(5)
    )
    tree = FuzzyReachabilityTree(net, [T(0, 2, 4), C(0.0), T(1, 3, 5)], horizon=20.0)
    a = tree.child(0, "t_a")
    assert 0 < tree.nodes[a].possibility <= 1 and 0 < tree.nodes[tree.child(0, "t_c")].possibility < 1
    (z,) = tree.nodes[a].children
    assert net.transitions[tree.nodes[z].transition] == "t_z"
    assert tree.nodes[z].arrival == tree.nodes[a].arrival and tree.nodes[z].possibility == 1.0
    assert tree.nodes[z].epoch == tree.nodes[a].epoch  # the arrival time did not change


# -- fitness and decisions (eq. 7.16-7.18, 7.4.1) -----------------------------------------------


def _robot_only_net():
    """One robot, one action of 2 s (crisp), t_w = 1 s."""
    buffers = [Buffer("raw", kind="raw"), Buffer("out", kind="product")]
    flow = Flow(
        actions=[FlowAction("a", ["robot"], ["raw"], ["out"], duration=Distribution("fixed", mean=2.0))]
    )
    return compile_flow(flow, buffers, "human", [], ["robot"], wait_quantum=1.0)


def test_fitness_hand_worked_on_a_robot_alone():
    """T_sch = 3: starting `a` at once never waits (J = inf, eq. 7.16 with W = 0); waiting first
    (W_R = t_w = 1) and then working is the best of the wait subtree (J = 1, eq. 7.17)."""
    net = _robot_only_net()
    policy = FuzzyPolicy(net, horizon=3.0)
    j = policy.decide(net.m0, "robot")
    assert net.transitions[j] == "a:begin"
    assert policy.last_fitness_ == {"a:begin": math.inf, "robot:wait": pytest.approx(1.0)}
    policy = FuzzyPolicy(net, horizon=3.0, w_robot=4.0)
    policy.decide(net.m0, "robot")
    assert policy.last_fitness_["robot:wait"] == pytest.approx(0.25)


@pytest.mark.parametrize("normalize", [False, True])
def test_fitness_propagation_eq_7_16_to_7_18_on_fig_7_6(normalize):
    net = _net_7_6()
    policy = FuzzyPolicy(net, horizon=8.0, normalize_possibilities=normalize)
    tree = policy.tree(net.m0, roots=net.agent_transitions("robot"))
    wait = net.transition_index["robot:wait"]
    checked = {"leaf": 0, "controllable": 0, "uncontrollable": 0}
    for i, node in enumerate(tree.nodes):
        kids = [tree.nodes[c] for c in node.children]
        if not kids:
            w_h, w_r = tree.leaf_cost(i)
            path = []
            k = i
            while tree.nodes[k].parent >= 0:
                path.append(tree.nodes[k].transition)
                k = tree.nodes[k].parent
            assert w_r == path.count(wait) * net.wait_quantum
            assert node.fitness == (math.inf if w_h + w_r == 0 else pytest.approx(1.0 / (w_h + w_r)))
            checked["leaf"] += 1
        elif node.conflict == "controllable":
            assert node.fitness == max(k.fitness for k in kids)
            checked["controllable"] += 1
        else:
            total = sum(k.fitness * k.possibility for k in kids)
            if normalize:
                total /= sum(k.possibility for k in kids)
            assert node.fitness == pytest.approx(total)
            checked["uncontrollable"] += 1
    assert min(checked.values()) > 0
    # some conflict of this tree has possibilities that do not sum to 1 (eq. 7.18 as written)
    sums = [
        sum(tree.nodes[c].possibility for c in n.children)
        for n in tree.nodes
        if n.conflict == "uncontrollable"
    ]
    assert any(abs(s - 1.0) > 0.1 for s in sums)


@pytest.mark.parametrize("cls", [FuzzyPolicy, UniformPolicy])
def test_fig_7_6_decisions(cls):
    """Fig. 7.6: at t = 0 the robot should start action 1 (the collaboration needs its part);
    once both parts are there and the human waits for the collaboration, it should commit."""
    net = _net_7_6()
    policy = cls(net, horizon=10.0)
    assert net.transitions[policy.decide(net.m0, "robot")] == "action1:begin"
    assert policy.last_fitness_["action1:begin"] > policy.last_fitness_["robot:wait"]
    m = net.m0
    for t in ("action1:begin", "intent:0", "action2#0:begin", "action1:end", "action2#0:end", "intent:1"):
        m = net.fire(m, t)
    assert net.transitions[policy.decide(m, "robot")] == "action3:commit"
    # the human waiting at the root counts: waiting longer costs more than the robot's own wait
    assert policy.last_fitness_["action3:commit"] > policy.last_fitness_["robot:wait"]
    with pytest.raises(ValueError, match="no enabled transition"):
        policy.decide(net.fire(m, "action3:commit"), "robot")


def test_serialized_robots_give_the_same_decision_as_algorithm_5_literally():
    """Use case a: the quality check ends for both arms at once, so both are free in one node."""
    flow, buffers, pattern, robots = tc.use_case_a(1)
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
    fast = FuzzyPolicy(net, horizon=20.0, max_nodes=10**6)
    full = FuzzyPolicy(net, horizon=20.0, max_nodes=10**6, serialize_robots=False)
    assert fast.decide(net.m0, "yumi_left") == full.decide(net.m0, "yumi_left")
    assert fast.last_tree_size_ < full.last_tree_size_
    assert fast.last_fitness_ == pytest.approx(full.last_fitness_)


def _path(tree, i):
    out = []
    while tree.nodes[i].parent >= 0:
        out.append(tree.nodes[i].transition)
        i = tree.nodes[i].parent
    return out[::-1]


def test_max_nodes_truncates_whole_levels():
    net = _net_7_6()
    delays = [FuzzyPolicy(net).fuzzy_delay(j) for j in range(net.n_transitions)]
    roots = net.agent_transitions("robot")
    full = FuzzyReachabilityTree(net, delays, 10.0, roots=roots, max_nodes=100_000)
    small = FuzzyReachabilityTree(net, delays, 10.0, roots=roots, max_nodes=60)
    assert not full.truncated and small.truncated and len(small.nodes) <= 60
    deepest = max(n.depth for n in small.nodes)
    for i, node in enumerate(small.nodes):
        twin = full.follow(_path(small, i))
        if node.depth < deepest:  # above the last level the small tree is the full one
            assert len(node.children) == len(full.nodes[twin].children)
        else:
            assert node.children == [] and full.nodes[twin].children != [] or node.children == []
    assert any(
        full.nodes[full.follow(_path(small, i))].children for i, n in enumerate(small.nodes) if not n.children
    )
    # the root's children are always there
    tiny = FuzzyReachabilityTree(net, delays, 10.0, roots=roots, max_nodes=1)
    assert len(tiny.nodes[0].children) == 2 and tiny.best_root_child() > 0


# -- the uniform scheduler (eq. 7.21-7.23) -----------------------------------------------------


def test_uniform_policy_uses_trapezoids_on_the_same_supports():
    net = _net_7_6()
    fuzzy, uniform = FuzzyPolicy(net), UniformPolicy(net, trapezoid_eps=0.01)
    j = net.transition_index["action2#0:end"]
    d, d2 = fuzzy.fuzzy_delay(j), uniform.fuzzy_delay(j)
    assert d.is_triangular and (d2.a, d2.b, d2.c, d2.d) == pytest.approx((d.a, d.a + 0.01, d.d - 0.01, d.d))
    wait_end = net.transition_index["robot:wait_end"]
    assert uniform.fuzzy_delay(wait_end) == C(1.0)
    tree = uniform.tree(net.m0, roots=net.agent_transitions("robot"))
    assert not tree.with_phi2
    # the race of action 1 (crisp 3) and action 2 (<2.71, 2.72, 3.28, 3.29>): action 2 wins on
    # [2.71, 3], a trapezoid with that support (eq. 7.22); action 1 wins with G(d', 3) = 1/2
    first = tree.follow(["action1:begin", "intent:0", "action2#0:begin"])
    end2 = tree.child(first, "action2#0:end")
    arr = tree.nodes[end2].arrival
    assert (arr.a, arr.d) == pytest.approx((d.a, 3.0)) and arr.c - arr.b == pytest.approx(3.0 - d.a - 0.02)
    end1 = tree.child(first, "action1:end")
    assert tree.nodes[end1].possibility == pytest.approx(0.5)


# -- the policy interface ----------------------------------------------------------------------


def test_observe_refits_the_delay_and_clone_is_copy_on_write():
    net = _net_7_6()
    policy = FuzzyPolicy(net, min_samples=3)
    j = net.transition_index["action2#0:end"]
    prior = policy.fuzzy_delay(j)
    twin = policy.clone()
    for d in (5.0, 6.0, 10.0):
        twin.observe(j, d)
    assert twin.fuzzy_delay(j) == fuzzify_samples([5.0, 6.0, 10.0])
    assert policy.fuzzy_delay(j) == prior and len(policy.durations_.samples_[j]) == 0
    frozen = FuzzyPolicy(net, learn=False)
    frozen.observe(j, 100.0)
    assert frozen.fuzzy_delay(j) == prior


def test_the_policy_runs_the_fig_7_11_cell_deterministically():
    flow, buffers, pattern, robots = tc.fig_7_11()
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
    runs = [
        simulate_cell(net, FuzzyPolicy(net, horizon=30.0), np.random.default_rng(7), n_cycles=1)
        for _ in range(2)
    ]
    assert runs[0].events == runs[1].events
    assert len(runs[0].cycle_ends) == 1 and len(runs[0].product_times) >= 2
    run = simulate_cell(net, UniformPolicy(net, horizon=30.0), np.random.default_rng(7), n_cycles=1)
    assert len(run.cycle_ends) == 1


def test_bad_parameters_are_refused():
    net = _net_7_6()
    with pytest.raises(ValueError, match="horizon"):
        FuzzyPolicy(net, horizon=0.0)
    with pytest.raises(ValueError, match="w_human"):
        FuzzyPolicy(net, w_human=-1.0)
    with pytest.raises(ValueError, match="trapezoid_eps"):
        UniformPolicy(net, trapezoid_eps=0.0)
    with pytest.raises(ValueError, match="delays"):
        FuzzyReachabilityTree(net, [C(0.0)], 10.0)
    with pytest.raises(ValueError, match="eps"):
        FuzzyReachabilityTree(net, [C(0.0)] * net.n_transitions, 10.0, eps=0.0)


# -- exact merging, visible cuts, ties, W_R's measure (issue 38) --------------------------------


def _torch_clock_net():
    """The torch_clock.yaml flow (use case c, 7.5.3) compiled with t_w = 5 s, without Drake."""
    def fixed(mean):
        return Distribution("fixed", mean=mean)

    def normal(mean, std):
        return Distribution("normal", mean=mean, std=std)

    spec = [  # name, agent, inputs, outputs, duration
        ("R1", "yumi_right", ["front_feeder"], ["torch_front"], fixed(9.0)),
        ("H1", "human", ["torch_front", "body_feeder"], ["torch_body"], normal(9.0, 1.5)),
        ("L1", "yumi_left", ["torch_body"], ["station_A"], fixed(5.0)),
        ("H2", "human", ["battery_feeder"], ["batteries"], normal(8.0, 1.2)),
        ("R2", "yumi_right", ["batteries", "station_A"], ["torch_ready"], fixed(9.0)),
        ("H3", "human", ["torch_ready"], ["torch_out"], normal(10.0, 1.5)),
        ("R3", "yumi_right", ["dial_feeder"], ["dial"], fixed(9.0)),
        ("H4", "human", ["dial", "hands_feeder"], ["dial_hands"], normal(9.0, 1.5)),
        ("L2", "yumi_left", ["glass_feeder"], ["glass_frame"], fixed(8.0)),
        ("L3", "yumi_left", ["glass_frame", "dial_hands", "bottom_feeder"], ["clock_assembly"], fixed(9.0)),
        ("R4", "yumi_right", ["clock_assembly"], ["clock_delivery"], fixed(5.0)),
        ("H5", "human", ["clock_delivery"], ["clock_out"], normal(11.0, 2.0)),
    ]
    flow = Flow(actions=[FlowAction(n, [a], i, o, duration=d) for n, a, i, o, d in spec])
    layout = [  # name, capacity (0: raw, -1: product), in torch_clock.yaml's order
        ("front_feeder", 0), ("dial_feeder", 0), ("glass_feeder", 0), ("bottom_feeder", 0), ("station_A", 1),
        ("glass_frame", 1), ("clock_assembly", 1), ("torch_front", 2), ("dial", 2), ("torch_ready", 1),
        ("batteries", 2), ("clock_delivery", 1), ("torch_body", 1), ("dial_hands", 2), ("body_feeder", 0),
        ("battery_feeder", 0), ("hands_feeder", 0), ("torch_out", -1), ("clock_out", -1),
    ]
    kinds = {0: {"kind": "raw"}, -1: {"kind": "product"}}
    buffers = [Buffer(b, **kinds.get(c, {"capacity": c})) for b, c in layout]
    return compile_flow(flow, buffers, "human", ["H1", "H4", "H2", "H5", "H3"], ["yumi_right", "yumi_left"],
                        wait_quantum=5.0)


@pytest.mark.parametrize("normalize", [False, True])
def test_merged_tree_has_the_literal_trees_fitness(normalize):
    """Building equal nodes once (a DAG) changes no J: on the torch_clock net (T_sch = 15 s, both
    complete) every root child's J is the literal Algorithm 5 tree's, with fewer nodes."""
    net = _torch_clock_net()
    policy = FuzzyPolicy(net)
    delays = [policy.fuzzy_delay(j) for j in range(net.n_transitions)]
    m = net.m0
    for t in ("R1:begin", "intent:0"):
        m = net.fire(m, t)
    for agent in ("yumi_left",):
        roots = net.agent_choices(m, agent)
        trees = [FuzzyReachabilityTree(net, delays, 15.0, m, roots=roots, max_nodes=10**6, merge=merge,
                                       normalize_possibilities=normalize) for merge in (True, False)]
        assert not trees[0].truncated and not trees[1].truncated
        assert trees[0].merged > 0 and len(trees[0].nodes) < len(trees[1].nodes)
        assert trees[1].merged == 0
        fits = [{t.nodes[c].transition: t.nodes[c].fitness for c in t.nodes[0].children} for t in trees]
        assert fits[0] == pytest.approx(fits[1], rel=1e-12)


def test_a_cut_tree_says_how_far_it_reached_and_the_policy_counts_and_logs_it(caplog):
    net = _torch_clock_net()
    m = net.fire(net.fire(net.m0, "R1:begin"), "intent:0")
    policy = FuzzyPolicy(net, horizon=50.0, max_nodes=300)
    with caplog.at_level("WARNING"):
        policy.decide(m, "yumi_left")
    assert policy.stats_.decisions == 1 and policy.stats_.truncated == 1
    assert 0 < policy.last_depth_reached_ < 50.0 and policy.stats_.depth_min == policy.last_depth_reached_
    assert "cut at max_nodes" in caplog.text
    full = FuzzyPolicy(net, horizon=8.0, max_nodes=10**6)
    full.decide(m, "yumi_left")
    assert full.stats_.truncated == 0 and full.last_depth_reached_ == 8.0


def test_ties_are_counted_and_the_random_rule_is_seeded():
    """The left arm's L2 now or after a wait: within a short horizon both paths have the same
    waits, so J ties; "first" takes the lowest index (L2), "random" draws with the seed."""
    net = _torch_clock_net()
    m = net.fire(net.fire(net.m0, "R1:begin"), "intent:0")
    first = FuzzyPolicy(net, horizon=50.0)
    assert net.transitions[first.decide(m, "yumi_left")] == "L2:begin"
    assert len(set(first.last_fitness_.values())) == 1 and first.stats_.ties == 1
    picks = []
    for seed in range(12):
        policy = FuzzyPolicy(net, horizon=50.0, ties="random", random_state=seed)
        picks.append(net.transitions[policy.decide(m, "yumi_left")])
        twin = FuzzyPolicy(net, horizon=50.0, ties="random", random_state=seed)
        assert net.transitions[twin.decide(m, "yumi_left")] == picks[-1]
        assert policy.stats_.ties == 1
    assert set(picks) == {"L2:begin", "yumi_left:wait"}
    with pytest.raises(ValueError, match="ties"):
        FuzzyPolicy(net, ties="coin")


def test_robot_waits_as_a_fraction_of_the_horizon():
    """W_R's variant: t_w / T_sch per robot wait in place of t_w seconds."""
    net = _net_7_6()
    delays = [FuzzyPolicy(net).fuzzy_delay(j) for j in range(net.n_transitions)]
    roots = net.agent_transitions("robot")
    trees = {m: FuzzyReachabilityTree(net, delays, 10.0, roots=roots, robot_wait_measure=m)
             for m in ("seconds", "horizon_fraction")}
    wait = trees["seconds"].child(0, "robot:wait")
    w_h, w_r = trees["seconds"].leaf_cost(wait)
    w_h2, w_r2 = trees["horizon_fraction"].leaf_cost(wait)
    assert w_r == pytest.approx(1.0) and w_r2 == pytest.approx(0.1) and w_h2 == pytest.approx(w_h)
    with pytest.raises(ValueError, match="robot_wait_measure"):
        FuzzyReachabilityTree(net, delays, 10.0, robot_wait_measure="hours")
