import numpy as np
import pytest

from hrc_drake.distributions import Distribution, mean_duration, sample_duration
from hrc_drake.scheduling.compiler import FlowError, compile_flow
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.montecarlo import CostNode, evaluate_cost_tree, evaluate_costs, percentile_linear
from hrc_drake.scheduling.petri import PcTPN

FIX = Distribution("fixed", mean=2.0)


def test_sample_duration_kinds_and_errors():
    rng = np.random.default_rng(0)
    x = sample_duration(Distribution("normal", mean=1.0, std=2.0), rng, 20000)
    assert x.min() >= 0.0  # truncated at low = 0
    assert abs(x.mean() - mean_duration(Distribution("normal", mean=1.0, std=2.0))) < 0.05
    assert sample_duration(FIX, rng) == 2.0
    e = sample_duration(Distribution("empirical", samples=[1.0, 3.0]), rng, 100)
    assert set(np.unique(e)) <= {1.0, 3.0}
    a = sample_duration(Distribution("uniform", low=1, high=2), np.random.default_rng(5), 4)
    b = sample_duration(Distribution("uniform", low=1, high=2), np.random.default_rng(5), 4)
    assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="unknown distribution"):
        sample_duration(Distribution("gamma"), rng)
    with pytest.raises(ValueError, match="no samples"):
        sample_duration(Distribution("empirical"), rng)


def _tiny_net():
    # p0 -t0-> p1 ; p1 + p2 -t1-> p0 (t1 needs two tokens in p2)
    pre = np.array([[1, 0], [0, 1], [0, 2]])
    post = np.array([[0, 1], [1, 0], [0, 0]])
    return PcTPN(["p0", "p1", "p2"], ["t0", "t1"], pre, post, [True, False], [FIX, FIX], [1, 0, 1], [0, 0, 0])


def test_enabling_and_firing_eq_6_1_6_2():
    net = _tiny_net()
    assert net.enabled([1, 0, 1]).tolist() == [True, False]
    m1 = net.fire([1, 0, 1], "t0")
    assert m1.tolist() == [0, 1, 1]
    assert net.enabled(m1).tolist() == [False, False]  # Pre^ij <= m^i needs 2 tokens in p2
    assert net.enabled([0, 1, 2]).tolist() == [False, True]
    assert net.fire([0, 1, 2], 1).tolist() == [1, 0, 0]
    with pytest.raises(ValueError, match="not enabled"):
        net.fire(m1, "t1")
    batch = net.enabled_batch(np.array([[1, 0, 1], [0, 1, 2]]))
    assert batch.tolist() == [[True, False], [False, True]]


def _buffers(*names, cap=1):
    return [Buffer("raw", kind="raw"), Buffer("out", kind="product")] + [
        Buffer(n, capacity=cap) for n in names
    ]


def _col(net, name):
    j = net.transition_index[name]
    pre = {net.places[i]: int(v) for i, v in enumerate(net.pre[:, j]) if v}
    post = {net.places[i]: int(v) for i, v in enumerate(net.post[:, j]) if v}
    return pre, post


def test_block_robot_action_and_wait():
    flow = Flow([FlowAction("a", ["r"], ["raw"], ["out"], duration=FIX)])
    net = compile_flow(flow, _buffers(), robot_agents=["r"], wait_quantum=1.5)
    assert _col(net, "a:begin") == ({"avail:r": 1}, {"busy:a": 1})
    assert _col(net, "a:end") == ({"busy:a": 1}, {"avail:r": 1, "buf:out": 1})
    assert _col(net, "r:wait") == ({"avail:r": 1}, {"wait:r": 1})
    assert net.controllable[net.transition_index["a:begin"]]
    assert not net.controllable[net.transition_index["a:end"]]
    assert net.delays[net.transition_index["r:wait_end"]].mean == 1.5
    assert net.cost[net.place_index["wait:r"]] == 1.0


def test_block_buffered_action_resource_and_and_join():
    flow = Flow(
        [
            FlowAction("p", ["r1"], ["raw"], ["b"], resources=["tool"], duration=FIX),
            FlowAction("q", ["r2"], ["b", "b"], ["out"], duration=FIX),  # AND of two parts
        ],
        resources={"tool": 1},
    )
    net = compile_flow(flow, _buffers("b", cap=2), robot_agents=["r1", "r2"])
    # buffered action: reserve a spot at the start, deliver the part at the end; resource returned at the end
    assert _col(net, "p:begin") == ({"avail:r1": 1, "space:b": 1, "res:tool": 1}, {"busy:p": 1})
    assert _col(net, "p:end") == ({"busy:p": 1}, {"avail:r1": 1, "buf:b": 1, "res:tool": 1})
    # the consumer frees the two spots when it starts
    assert _col(net, "q:begin") == ({"avail:r2": 1, "buf:b": 2}, {"busy:q": 1, "space:b": 2})
    assert net.m0[net.place_index["space:b"]] == 2


def test_block_fork_and_or():
    # FORK: one action feeds two buffers; OR: two actions compete for the same part
    flow = Flow(
        [
            FlowAction("f", ["r1"], ["raw"], ["b1", "b2"], duration=FIX),
            FlowAction("x", ["r2"], ["b1"], ["out"], duration=FIX),
            FlowAction("y", ["r2"], ["b1"], ["out"], duration=FIX),
            FlowAction("z", ["r1"], ["b2"], ["out"], duration=FIX),
        ]
    )
    net = compile_flow(flow, _buffers("b1", "b2"), robot_agents=["r1", "r2"])
    assert _col(net, "f:end")[1] == {"avail:r1": 1, "buf:b1": 1, "buf:b2": 1}
    m = net.m0.copy()
    m[net.place_index["buf:b1"]] = 1
    en = net.enabled(m)
    assert en[net.transition_index["x:begin"]] and en[net.transition_index["y:begin"]]
    m2 = net.fire(m, "x:begin")
    assert not net.enabled(m2)[net.transition_index["y:begin"]]


def test_block_human_and_collaboration():
    flow = Flow(
        [
            FlowAction("h", ["human"], ["raw"], ["b"], duration=FIX),
            FlowAction("c", ["human", "r"], ["b"], ["out"], duration=FIX),
        ]
    )
    net = compile_flow(flow, _buffers("b"), "human", ["h", "c"], ["r"], wait_quantum=1.0, cost_human=2.0)
    assert _col(net, "intent:0") == ({"step:0": 1}, {"hwait:0": 1})
    assert _col(net, "h#0:begin") == ({"hwait:0": 1, "space:b": 1}, {"busy:h#0": 1})
    assert not net.controllable[net.transition_index["h#0:begin"]]
    assert _col(net, "c:commit") == ({"avail:r": 1, "buf:b": 1}, {"cwait:c": 1})
    assert _col(net, "c#1:begin") == ({"hwait:1": 1, "cwait:c": 1}, {"busy:c#1": 1, "space:b": 1})
    assert _col(net, "c#1:end") == ({"busy:c#1": 1}, {"step:0": 1, "avail:r": 1, "buf:out": 1})
    assert _col(net, "c:giveup")[1] == {"avail:r": 1, "buf:b": 1}
    assert net.cost[net.place_index["hwait:0"]] == 2.0


def test_structural_errors_name_actions():
    with pytest.raises(FlowError, match="unknown buffer 'nope'"):
        compile_flow(
            Flow([FlowAction("a", ["r"], ["nope"], [], duration=FIX)]), _buffers(), robot_agents=["r"]
        )
    # 'b' is never filled: action 'a' can never be enabled (robot loops in its wait forever)
    flow = Flow([FlowAction("a", ["r"], ["b"], ["out"], duration=FIX)])
    with pytest.raises(FlowError, match=r"\['a'\] can never be enabled"):
        compile_flow(flow, _buffers("b"), robot_agents=["r"])
    # OR at the robot: 'x' gives the part back to the human, 'y' ships it; after 'y' the human
    # waits forever for 'b' -> a dead marking is reachable
    flow = Flow(
        [
            FlowAction("h1", ["human"], ["b"], ["c"], duration=FIX),
            FlowAction("x", ["r"], ["c"], ["b"], duration=FIX),
            FlowAction("y", ["r"], ["c"], ["out"], duration=FIX),
        ]
    )
    bufs = [Buffer("out", kind="product"), Buffer("b", capacity=1, initial=1), Buffer("c", capacity=1)]
    with pytest.raises(FlowError, match=r"dead marking reachable: actions \['h1'"):
        compile_flow(flow, bufs, "human", ["h1"], ["r"])
    flow.actions.pop()  # without 'y' the loop h1 -> x -> h1 runs forever
    compile_flow(flow, bufs, "human", ["h1"], ["r"])
    flow.actions.append(FlowAction("h2", ["human"], ["raw"], ["out"], duration=FIX))
    with pytest.raises(FlowError, match="not in the human pattern"):
        compile_flow(flow, bufs + [Buffer("raw", kind="raw")], "human", ["h1"], ["r"])


def test_algorithm_4_on_a_hand_built_tree():
    # root -> t1 (controllable node with children c1 / c2), t2 (uncontrollable conflict)
    leaf = lambda *c: CostNode(costs=np.array(c, dtype=float))  # noqa: E731
    t1 = CostNode(controllable=True, children={"c1": leaf(5, 6, 7), "c2": leaf(1, 9, 10)})
    t2 = CostNode(controllable=False, children={"u1": leaf(2, 3), "u2": leaf(8)})
    root = CostNode(children={"t1": t1, "t2": t2})
    best, costs = evaluate_cost_tree(root, beta=0.5)
    # t1 inherits c1 (median 6 < 9); t2 is the union {2, 3, 8} (median 3) -> t2 wins
    assert best == "t2" and sorted(costs.tolist()) == [2.0, 3.0, 8.0]
    best, costs = evaluate_cost_tree(root, beta=1.0)  # by maximum: t1 -> c1 max 7 < t2 max 8
    assert best == "t1" and costs.tolist() == [5.0, 6.0, 7.0]
    # the same tree as trial paths: transitions 0=t1, 1=t2 (root), 2=c1, 3=c2 controllable; 4=u1, 5=u2
    ctrl = np.array([True, True, True, True, False, False])
    paths = np.array([[0, 2], [0, 2], [0, 2], [0, 3], [0, 3], [0, 3], [1, 4], [1, 4], [1, 5]])
    costs = np.array([5, 6, 7, 1, 9, 10, 2, 3, 8], dtype=float)
    best, pct = evaluate_costs(paths, costs, ctrl, 0.5)
    assert best == 1 and pct == {0: 6.0, 1: 3.0}


def test_algorithm_4_min_branch_samples_unites_thin_branchings():
    # root 0 leads to a controllable branching with one trial per child (costs 1 and 9);
    # root 1 to three trials of cost 4 through an uncontrollable transition
    ctrl = np.array([True, True, True, True, False])
    paths = np.array([[0, 2], [0, 3], [1, 4], [1, 4], [1, 4]])
    costs = np.array([1.0, 9.0, 4.0, 4.0, 4.0])
    best, pct = evaluate_costs(paths, costs, ctrl, 0.5)  # Algorithm 4: the lucky 1 wins
    assert best == 0 and pct == {0: 1.0, 1: 4.0}
    best, pct = evaluate_costs(paths, costs, ctrl, 0.5, min_branch_samples=2)
    assert best == 1 and pct == {0: 5.0, 1: 4.0}  # {1, 9} united: median 5
    with pytest.raises(ValueError, match="min_branch_samples"):
        evaluate_costs(paths, costs, ctrl, 0.5, min_branch_samples=0)


def _algorithm_4_reference(paths, costs, controllable, beta, min_branch_samples=1):
    """Algorithm 4 written directly on the unsorted trials (np.unique per node, np.percentile)."""
    q = 100.0 * beta

    def node(idx, d):
        if idx.size < 2 * min_branch_samples or d >= paths.shape[1]:
            return costs[idx]
        js = paths[idx, d]
        ended = js < 0
        if ended.all():
            return costs[idx]
        cont, jc = idx[~ended], js[~ended]
        children, sizes = np.unique(jc, return_counts=True)
        if controllable[jc[0]] and sizes.min() >= min_branch_samples:
            return min((node(cont[jc == u], d + 1) for u in children), key=lambda c: np.percentile(c, q))
        return np.concatenate([costs[idx[ended]]] + [node(cont[jc == u], d + 1) for u in children])

    idx = np.arange(len(costs))
    return {int(u): float(np.percentile(node(idx[paths[:, 0] == u], 1), q)) for u in np.unique(paths[:, 0])}


@pytest.mark.parametrize("min_branch_samples", [1, 3])
def test_algorithm_4_on_sorted_trials_equals_the_direct_tree_walk(min_branch_samples):
    rng = np.random.default_rng(5)
    for trial in range(60):
        n, length, n_tr = int(rng.integers(2, 120)), int(rng.integers(1, 7)), int(rng.integers(2, 6))
        controllable = rng.random(n_tr) < 0.6
        controllable[:2] = True
        paths = rng.integers(0, n_tr, size=(n, length))
        paths[:, 0] = rng.integers(0, 2, size=n)
        for row, end in enumerate(rng.integers(1, length + 1, size=n)):
            paths[row, end:] = -1  # trials that reached the horizon
        costs = rng.gamma(2.0, 10.0, size=n).round(int(trial % 3))  # rounding makes ties
        for beta in (0.0, 0.3, 0.5, 0.8, 1.0):
            expected = _algorithm_4_reference(paths, costs, controllable, beta, min_branch_samples)
            best, got = evaluate_costs(paths, costs, controllable, beta, min_branch_samples)
            assert got == expected
            assert best == min(expected, key=lambda u: (expected[u], u))


def test_percentile_linear_is_numpys_percentile_bit_for_bit():
    rng = np.random.default_rng(2)
    for n in (1, 2, 3, 7, 50, 101):
        values = rng.normal(size=n) * 10.0 ** rng.integers(-3, 4)
        for beta in (0.0, 0.1, 0.25, 0.5, 0.8, 0.95, 1.0, 1 / 3):
            quantile = 100 * beta / 100  # what np.percentile(values, 100 beta) works with
            assert percentile_linear(values, quantile) == np.percentile(values, 100 * beta)
