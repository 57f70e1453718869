"""Reachability tree, enab(S) and arrival times (thesis 6.2.1) on the examples of Fig. 6.5/6.6.

The figures are missing from the text; the nets are reconstructed in `thesis_cells`
(fig_6_5_example_a/b) from the prose: the expected supports below are the ones the text states.
"""

import numpy as np
import pytest

from hrc_drake.distributions import Distribution, duration_cdf, duration_support
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.reachability import ReachabilityTree

STEP = 0.0025


def test_example_a_supports_probabilities_and_densities():
    net = tc.fig_6_5_example_a()
    tree = ReachabilityTree(net, max_depth=2, grid_step=STEP, grid_end=2.0)
    s1, s2 = tree.child(0, "t1"), tree.child(0, "t2")
    assert tree.enab(s1) == 0 and tree.enab(s2) == 0
    # unconditioned supports [0, 1], [0, 0.75]; the real support of alpha_1 is [0, 0.75]
    assert tree.nodes[s1].unconditioned == (0.0, 1.0)
    assert tree.nodes[s2].unconditioned == (0.0, 0.75)
    assert tree.nodes[s1].support == (0.0, 0.75)
    assert tree.nodes[s2].support == (0.0, 0.75)
    assert tree.pmf_support(s1) == pytest.approx((0.0, 0.75), abs=STEP)
    # P(U[0,1] < U[0,0.75]) = 0.375 (eq. 6.6); alpha_1 density (1 - a/0.75)/0.375 has mean 0.25
    assert tree.nodes[s1].probability == pytest.approx(0.375, abs=2e-3)
    assert tree.nodes[s2].probability == pytest.approx(0.625, abs=2e-3)
    assert tree.mean_arrival(s1) == pytest.approx(0.25, abs=2e-3)
    assert tree.mean_arrival(s2) == pytest.approx(0.30, abs=2e-3)
    assert tree.nodes[0].conflict == "uncontrollable" and tree.nodes[s1].children == []


def test_example_b_supports_and_farthest_enabling_ancestor():
    net = tc.fig_6_5_example_b()
    tree = ReachabilityTree(net, max_depth=4, grid_step=STEP, grid_end=3.0)
    # t4 (0.5 s) can never beat t3 (0 s) at the root: that child is impossible
    assert [net.transitions[tree.nodes[c].transition] for c in tree.nodes[0].children] == ["t3"]
    s_a = tree.follow(["t3"])
    s_f = tree.follow(["t3", "t4"])
    assert tree.nodes[s_f].support == (0.5, 0.5)
    assert tree.enab(s_f) == 0  # t4 enabled since the root
    s1, s2 = tree.child(s_f, "t1"), tree.child(s_f, "t2")
    assert tree.enab(s1) == s_a  # t1 enabled since t3 fired
    assert tree.enab(s2) == s_f  # t2 enabled on arriving in S_f
    # unconditioned supports [0, 1] and [0.5, 1.25]; real support of alpha_2 is [0.5, 1]
    assert tree.nodes[s1].unconditioned == (0.0, 1.0)
    assert tree.nodes[s2].unconditioned == (0.5, 1.25)
    assert tree.nodes[s2].support == (0.5, 1.0)
    assert tree.nodes[s1].support == (0.5, 1.0)
    assert tree.pmf_support(s2) == pytest.approx((0.5, 1.0), abs=STEP)
    # t4 beats t1 with probability 1/2; from S_f, t1 wins with 2/3
    assert tree.nodes[s_f].probability == pytest.approx(0.5, abs=2e-3)
    assert tree.nodes[s1].probability == pytest.approx(2 / 3, abs=3e-3)
    assert tree.reach_probability(s2) == pytest.approx(1 / 6, abs=2e-3)
    assert tree.mean_arrival(s2) == pytest.approx(2 / 3, abs=3e-3)


def test_example_b_matches_direct_sampling():
    rng = np.random.default_rng(0)
    n = 200_000
    d1, d2 = rng.uniform(0, 1, n), rng.uniform(0, 0.75, n)
    # t3 fires at 0, t4 at 0.5; t1 races t4 then t2
    reach_f = d1 > 0.5
    a2 = 0.5 + d2
    wins2 = reach_f & (a2 < d1)
    net = tc.fig_6_5_example_b()
    tree = ReachabilityTree(net, max_depth=4, grid_step=STEP, grid_end=3.0)
    s2 = tree.follow(["t3", "t4", "t2"])
    assert tree.reach_probability(s2) == pytest.approx(wins2.mean(), abs=4e-3)
    assert tree.mean_arrival(s2) == pytest.approx(a2[wins2].mean(), abs=4e-3)
    assert a2[wins2].min() >= 0.5 and a2[wins2].max() <= 1.0


def test_controllable_conflicts_keep_the_fathers_arrival_time():
    flow, buffers, pattern, robots = tc.fig_7_6()
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=1.0)
    tree = ReachabilityTree(net, max_depth=3, horizon=10.0)
    root = tree.nodes[0]
    assert root.conflict == "controllable"
    # human intention (uncontrollable) is also enabled but the robot's choices fire first
    names = sorted(net.transitions[tree.nodes[c].transition] for c in root.children)
    assert names == ["action1:begin", "robot:wait"]
    for c in root.children:
        assert tree.nodes[c].support == (0.0, 0.0) and tree.nodes[c].probability == 1.0
    # after the robot waits: the intention (0 s) fires at once, the wait's end (1 s) cannot win
    s = tree.follow(["robot:wait"])
    assert [net.transitions[tree.nodes[c].transition] for c in tree.nodes[s].children] == ["intent:0"]
    with pytest.raises(ValueError, match="no child"):
        tree.child(s, "robot:wait_end")


def test_supports_cdfs_and_bad_input():
    assert duration_support(Distribution("uniform", low=2, high=4)) == (2.0, 4.0)
    assert duration_support(Distribution("normal", mean=5, std=1))[1] == np.inf
    x = np.array([-1.0, 0.0, 1.0, 3.0, 10.0])
    assert duration_cdf(Distribution("uniform", low=0, high=3), x).tolist() == pytest.approx(
        [0, 0, 1 / 3, 1, 1]
    )
    assert duration_cdf(Distribution("fixed", mean=1.0), x).tolist() == [0, 0, 1, 1, 1]
    tri = duration_cdf(Distribution("triangular", low=0, mode=1, high=2), np.array([1.0, 2.0]))
    assert tri.tolist() == pytest.approx([0.5, 1.0])
    net = tc.fig_6_5_example_a()
    with pytest.raises(ValueError, match="grid_end"):
        ReachabilityTree(net, grid_step=0.01)
    with pytest.raises(ValueError, match="more than 2 nodes"):
        ReachabilityTree(net, max_nodes=2)
