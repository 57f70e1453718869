"""The trials of Algorithm 4 (7.3.1) as the text has them, and the named variants of their
generation (stratified roots, common random numbers, the agent-only root, the t_w grid)."""

import numpy as np
import pytest
from scipy.stats import chisquare

from hrc_drake.scheduling import montecarlo
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.learning import DurationModel
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy, simulate_trials


def _net(cell, quantum=1.0):
    flow, buffers, pattern, robots = cell()
    return compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=quantum)


def _all_enabled(net, marking):
    return np.flatnonzero(net.controllable & net.enabled(marking))


class _CountingDurations(DurationModel):
    """A DurationModel that records the number of pool rows each `sample_pools` call draws."""

    def __init__(self, net):
        super().__init__(net)
        self.rows = []

    def sample_pools(self, rng, n_trials, depth):
        self.rows.append(n_trials)
        return super().sample_pools(rng, n_trials, depth)


@pytest.mark.parametrize("compiled", [True, False])
def test_literal_roots_are_independent_uniform_draws_over_every_enabled_controllable_transition(compiled):
    net = _net(tc.fig_7_11, 3.0)  # at m0 both robots are free: A1, B1 and the two waits
    roots = _all_enabled(net, net.m0)
    assert {net.agents[j][0] for j in roots} == {"r1", "r2"} and roots.size == 4
    n = 2000
    batch = simulate_trials(net, net.m0, DurationModel(net), np.random.default_rng(3), n, 5.0, roots,
                            compiled=compiled)
    counts = np.array([(batch.paths[:, 0] == j).sum() for j in roots])
    assert counts.sum() == n
    assert chisquare(counts).pvalue > 1e-3  # uniform over the four
    # independent draws, not the stratified cycle n mod R
    assert not np.array_equal(batch.paths[:, 0], roots[np.arange(n) % roots.size])
    stratified = simulate_trials(net, net.m0, DurationModel(net), np.random.default_rng(3), n, 5.0, roots,
                                 compiled=compiled, stratified_roots=True)
    np.testing.assert_array_equal(stratified.paths[:, 0], roots[np.arange(n) % roots.size])


def test_literal_trials_draw_their_own_delays_and_common_random_numbers_share_them_per_group():
    net = _net(tc.fig_7_11, 3.0)
    roots = _all_enabled(net, net.m0)
    for variant, rows in (({}, 40), ({"stratified_roots": True, "common_random_numbers": True}, 10)):
        durations = _CountingDurations(net)
        simulate_trials(net, net.m0, durations, np.random.default_rng(0), 40, 20.0, roots, **variant)
        assert durations.rows[0] == rows  # one row of delays per trial, or per group of R = 4
    with pytest.raises(ValueError, match="stratified"):
        simulate_trials(net, net.m0, DurationModel(net), np.random.default_rng(0), 40, 20.0, roots,
                        common_random_numbers=True)
    # independent trials: two that fire the same sequence in the same order still differ in
    # their delays, so in their costs
    batch = simulate_trials(net, net.m0, DurationModel(net), np.random.default_rng(1), 400, 20.0, roots)
    by_path = {}
    for path, cost in zip(batch.paths, batch.costs, strict=True):
        by_path.setdefault(path.tobytes(), []).append(cost)
    assert any(len(set(c)) > 1 for c in by_path.values())


@pytest.mark.parametrize("compiled", [True, False])
def test_a_literal_wait_lasts_exactly_the_quantum_and_the_grid_variant_ends_on_the_next_tick(compiled):
    net = _net(tc.fig_7_6, 1.0)
    wait, wait_end = net.transition_index["robot:wait"], net.transition_index["robot:wait_end"]

    def ended(horizon, **variant):
        batch = simulate_trials(net, net.m0, DurationModel(net), np.random.default_rng(0), 30, horizon,
                                [wait], now=0.7, compiled=compiled, **variant)
        return np.array([wait_end in row for row in batch.paths])

    assert not ended(0.999).any() and ended(1.001).all()  # t_w = 1 s from the wait's start
    # on the grid a wait begun at 0.7 s ends at the tick 1.0 s, 0.3 s later
    assert not ended(0.299, wait_grid=True).any() and ended(0.301, wait_grid=True).all()


def test_the_cell_executes_the_policy_waits_a_quantum_or_on_the_grid():
    net = _net(tc.fig_7_6, 1.0)
    for grid in (False, True):
        policy = MonteCarloPolicy(net, n_trials=20, horizon=6.0, random_state=0, wait_grid=grid)
        run = simulate_cell(net, policy, np.random.default_rng(2), n_cycles=4)
        begun = [t for t, a, _, kind in run.events if a == "robot" and kind == "wait_begin"]
        ends = [t for t, a, _, kind in run.events if a == "robot" and kind == "wait_end"]
        assert len(ends) >= 2
        lengths = np.array(ends) - np.array(begun[: len(ends)])
        if grid:
            assert np.all(lengths <= 1.0 + 1e-9) and np.allclose(ends, np.round(ends))
            assert np.any(lengths < 1.0 - 1e-6)
        else:
            assert np.allclose(lengths, 1.0)


def test_the_policy_roots_at_every_enabled_controllable_transition_and_decides_for_its_agent():
    net = _net(tc.fig_7_11, 3.0)
    policy = MonteCarloPolicy(net, n_trials=200, horizon=20.0, random_state=0)
    j = policy.decide(net.m0, "r1")
    assert "r1" in net.agents[j]
    names = set(policy.last_percentiles_)
    assert names == {net.transitions[k] for k in _all_enabled(net, net.m0)}  # r2's choices too
    r1 = {n: p for n, p in policy.last_percentiles_.items() if "r1" in net.agents[net.transition_index[n]]}
    assert policy.last_percentiles_[net.transitions[j]] == min(r1.values())
    agent_only = MonteCarloPolicy(net, n_trials=200, horizon=20.0, random_state=0, root_choices="agent")
    agent_only.decide(net.m0, "r1")
    assert set(agent_only.last_percentiles_) == {net.transitions[k] for k in net.agent_choices(net.m0, "r1")}
    with pytest.raises(ValueError, match="root_choices"):
        MonteCarloPolicy(net, root_choices="mine")
    with pytest.raises(ValueError, match="stratified"):
        MonteCarloPolicy(net, common_random_numbers=True)


def test_delay_pools_are_refilled_instead_of_repeating(monkeypatch):
    """Shallow pools force refills: the compiled and numpy trials still agree draw for draw, and
    more delays are drawn than the first pools held."""
    monkeypatch.setattr(montecarlo, "_pool_depth", lambda net, durations, horizon: 2)
    net = _net(tc.fig_7_11, 3.0)
    roots = _all_enabled(net, net.m0)
    runs = []
    for compiled in (True, False):
        durations = _CountingDurations(net)
        runs.append(simulate_trials(net, net.m0, durations, np.random.default_rng(4), 30, 90.0, roots,
                                    compiled=compiled))
        assert len(durations.rows) > 1
    np.testing.assert_array_equal(runs[0].paths, runs[1].paths)
    np.testing.assert_array_equal(runs[0].costs, runs[1].costs)


def test_the_config_names_the_variants_and_validates_them():
    from hrc_drake.errors import ConfigError
    from hrc_drake.scheduling.config import MonteCarloScheduler
    from hrc_drake.scheduling.systems import make_policy

    net = _net(tc.fig_7_11, 3.0)
    literal = make_policy(net, MonteCarloScheduler(), seed=0)
    def options(policy):
        return policy.root_choices, policy.stratified_roots, policy.common_random_numbers, policy.wait_grid

    assert options(literal) == ("all_enabled", False, False, False)
    earlier = make_policy(net, MonteCarloScheduler(root_choices="agent", stratified_roots=True,
                                                   common_random_numbers=True, wait_grid=True), seed=0)
    assert options(earlier) == ("agent", True, True, True)
    for bad, field in ((MonteCarloScheduler(root_choices="mine"), "s.root_choices"),
                       (MonteCarloScheduler(common_random_numbers=True), "s.common_random_numbers"),
                       (MonteCarloScheduler(wait_grid=1), "s.wait_grid")):
        with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
            bad.validate("s")


def test_an_observed_zero_delay_is_learned_as_the_shortest_observable_one():
    """A pcTPN delay is positive: a zero-second observation (an artefact) must not let a trial
    fire round a loop of actions without its time advancing (found by the Monte Carlo property
    test: 5000 firings short of the horizon)."""
    from hrc_drake.scheduling.learning import MIN_OBSERVED_DELAY

    net = _net(tc.fig_7_11, 3.0)
    j = int(np.flatnonzero(~net.controllable)[0])
    model = DurationModel(net).partial_fit(j, 0.0).partial_fit(j, 2.5)
    assert list(model.samples_[j]) == [MIN_OBSERVED_DELAY, 2.5]
    with pytest.raises(ValueError):
        model.partial_fit(j, -0.01)
