"""Scheduler B of use case b (7.5.2): the Monte Carlo scheduler on uniform delays between the
smallest and the largest measured firing time (`UniformSupportDurationModel`), chosen by
`MonteCarloPolicy(durations=...)` and `MonteCarloScheduler.durations`; and the baselines' names."""

import numpy as np
import pytest

from hrc_drake.errors import ConfigError
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.config import (
    BestOfRolloutsPlanScheduler,
    MonteCarloScheduler,
    RandomEnabledScheduler,
)
from hrc_drake.scheduling.learning import DurationModel, UniformSupportDurationModel
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy


@pytest.fixture(scope="module")
def net_b():
    flow, buffers, pattern, robots = tc.use_case_b(1)
    return compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0, cost_robot=0.5,
                        cost_human=1.0, agent_costs=tc.USE_CASE_B_AGENT_COSTS)


def _action_end(net, name):
    return next(j for j in range(net.n_transitions) if net.role[j] == "end" and net.action[j] == name)


def test_learned_delays_are_uniform_on_the_observed_window(net_b):
    model = UniformSupportDurationModel(net_b, window=5, min_samples=3)
    j = _action_end(net_b, "pad")
    for delay in (20.0, 7.0, 9.5, 8.0, 12.0, 10.0):  # the window keeps the last 5: 7 .. 12
        model.partial_fit(j, delay)
    assert model.is_learned(j) and model.support(j) == (7.0, 12.0)
    draws = model.sample(j, np.random.default_rng(0), 20_000)
    assert draws.min() >= 7.0 and draws.max() <= 12.0
    assert draws.min() < 7.01 and draws.max() > 11.99  # the whole support is covered
    assert abs(draws.mean() - 9.5) < 0.05 and model.mean(j) == 9.5
    # not the empirical model: values between the observed ones are drawn
    assert np.unique(draws).size > 1000
    empirical = DurationModel(net_b, window=5, min_samples=3)
    for delay in (20.0, 7.0, 9.5, 8.0, 12.0, 10.0):
        empirical.partial_fit(j, delay)
    assert set(empirical.sample(j, np.random.default_rng(0), 1000)) <= {7.0, 9.5, 8.0, 12.0, 10.0}


def test_before_min_samples_the_prior_support(net_b):
    model = UniformSupportDurationModel(net_b, window=30, min_samples=3)
    j = _action_end(net_b, "pad")  # N(8, 1.5): the support is 8 -+ 4.5
    model.partial_fit(j, 8.0).partial_fit(j, 8.2)  # two, not yet three
    assert not model.is_learned(j)
    low, high = model.support(j)
    assert (low, high) == pytest.approx((3.5, 12.5))
    draws = model.sample(j, np.random.default_rng(1), 20_000)
    assert draws.min() >= low and draws.max() <= high
    assert draws.min() < low + 0.01 and draws.max() > high - 0.01
    fixed = [k for k in np.flatnonzero(~net_b.controllable) if net_b.delays[k].kind == "fixed"]
    assert fixed  # a fixed prior stays fixed
    k = int(fixed[0])
    assert model.is_deterministic(k)
    assert np.all(model.sample(k, np.random.default_rng(2), 10) == net_b.delays[k].mean)
    controllable = int(np.flatnonzero(net_b.controllable)[0])
    assert model.support(controllable) == (0.0, 0.0) and model.mean(controllable) == 0.0


def test_the_pools_of_the_trials_come_from_the_uniform_model(net_b):
    model = UniformSupportDurationModel(net_b, window=30, min_samples=3)
    j = _action_end(net_b, "trim")
    for delay in (5.0, 6.0, 7.0):
        model.partial_fit(j, delay)
    pools = model.sample_pools(np.random.default_rng(3), 40, 8)
    assert pools[:, j, :].min() >= 5.0 and pools[:, j, :].max() <= 7.0
    assert np.unique(pools[:, j, :]).size > 100
    assert np.all(pools[:, net_b.controllable, :] == 0)
    clone = model.clone()
    clone.partial_fit(j, 30.0)
    assert type(clone) is UniformSupportDurationModel
    assert model.support(j) == (5.0, 7.0) and clone.support(j) == (5.0, 30.0)


def test_monte_carlo_policy_takes_the_model_and_repeats_for_a_seed(net_b):
    assert type(MonteCarloPolicy(net_b).durations_) is DurationModel  # Scheduler A, the default
    with pytest.raises(ValueError, match="durations"):
        MonteCarloPolicy(net_b, durations="normal")
    m = net_b.m0.copy()  # a marking where the right arm has a real choice (the bench's latency marking)
    m[net_b.place_index["buf:tested"]] = 1
    m[net_b.place_index["space:tested"]] -= 1

    def decisions(seed):
        policy = MonteCarloPolicy(net_b, n_trials=40, horizon=30.0, random_state=seed,
                                  durations="uniform_support")
        assert type(policy.durations_) is UniformSupportDurationModel
        out = [policy.decide(m, "yumi_right", now=0.0)]
        policy.observe(_action_end(net_b, "pad"), 9.0)
        twin = policy.clone()
        assert type(twin.durations_) is UniformSupportDurationModel
        out.append(twin.decide(m, "yumi_right", now=3.0))
        return out, dict(policy.last_percentiles_)

    assert decisions(5) == decisions(5)
    run = [simulate_cell(net_b, MonteCarloPolicy(net_b, n_trials=20, horizon=15.0, random_state=2,
                                                 durations="uniform_support"),
                         np.random.default_rng(9), n_products=2, max_time=600.0) for _ in range(2)]
    assert run[0].events == run[1].events and len(run[0].product_times) == 2


def test_the_config_chooses_and_validates_the_model(net_b):
    pytest.importorskip("pydrake")
    from hrc_drake.scheduling import config, montecarlo
    from hrc_drake.scheduling.systems import make_policy

    assert set(config.DURATION_MODELS) == set(montecarlo.DURATION_MODELS)
    with pytest.raises(ConfigError) as err:
        MonteCarloScheduler(durations="uniform").validate("scheduler")
    assert err.value.field == "scheduler.durations"
    with pytest.raises(ConfigError) as err:
        make_policy(net_b, MonteCarloScheduler(durations="pdf"), seed=0)
    assert err.value.field == "scheduler.durations"
    policy = make_policy(net_b, MonteCarloScheduler(durations="uniform_support", window=7, min_samples=2), 0)
    model = policy.durations_
    assert type(model) is UniformSupportDurationModel and (model.window, model.min_samples) == (7, 2)
    assert type(make_policy(net_b, MonteCarloScheduler(), 0).durations_) is DurationModel


def test_yaml_tags_of_the_renamed_baselines_and_the_legacy_kinds():
    yaml = pytest.importorskip("pydrake.common.yaml")
    from dataclasses import dataclass, field

    from hrc_drake.cell.legacy import translate
    from hrc_drake.scheduling.config import NoScheduler, SchedulerConfig

    @dataclass
    class Holder:
        scheduler: SchedulerConfig = field(default_factory=NoScheduler)

    def load(text):
        return yaml.yaml_load_typed(schema=Holder, data=f"scheduler: {text}").scheduler

    assert load("!RandomEnabledScheduler {wait_quantum: 2.0}") == RandomEnabledScheduler(wait_quantum=2.0)
    assert load("!BestOfRolloutsPlanScheduler {n_candidates: 8}") == BestOfRolloutsPlanScheduler(
        n_candidates=8)
    assert load("!MonteCarloScheduler {durations: uniform_support}") == MonteCarloScheduler(
        durations="uniform_support")
    # the old kind names still load, as the classes named for what they do
    assert translate("scheduler", {"kind": "greedy"}) == [("scheduler", RandomEnabledScheduler())]
    assert translate("scheduler", {"kind": "deterministic", "params": {"n_candidates": 4}}) == [
        ("scheduler", BestOfRolloutsPlanScheduler(n_candidates=4))]
