"""Typed scheduler configs: YAML tags, validation with field paths, today's defaults; every kind
builds a policy, and a policy clone is copy-on-write."""

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pytest

from hrc_drake.errors import ConfigError
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.config import (
    BestOfRolloutsPlanScheduler,
    MonteCarloScheduler,
    NoScheduler,
    PredictiveRobotScheduler,
    RandomEnabledScheduler,
    RoundRobinScheduler,
    SchedulerConfig,
)

KINDS = [RoundRobinScheduler, RandomEnabledScheduler, BestOfRolloutsPlanScheduler, MonteCarloScheduler]


def test_fields_are_typed():
    for cls in [NoScheduler, *KINDS]:
        for f in dataclasses.fields(cls):
            assert f.type in (int, float, str, bool, dict[str, list[str]], dict[str, float]), (cls, f.name)


def test_yaml_tags_choose_the_kind():
    yaml = pytest.importorskip("pydrake.common.yaml")

    @dataclass
    class Holder:
        scheduler: SchedulerConfig = field(default_factory=NoScheduler)

    loaded = yaml.yaml_load_typed(schema=Holder, data="scheduler: !MonteCarloScheduler {n_trials: 100}")
    assert loaded.scheduler == MonteCarloScheduler(n_trials=100)
    loaded = yaml.yaml_load_typed(schema=Holder, data="scheduler: !RoundRobinScheduler {programs: {r: [x]}}")
    assert loaded.scheduler == RoundRobinScheduler(programs={"r": ["x"]})


@pytest.mark.parametrize(
    "config, field_path",
    [
        (MonteCarloScheduler(n_trials=0), "s.n_trials"),
        (MonteCarloScheduler(horizon=float("inf")), "s.horizon"),
        (MonteCarloScheduler(beta=1.5), "s.beta"),
        (MonteCarloScheduler(rollout="psychic"), "s.rollout"),
        (MonteCarloScheduler(min_branch_samples=0), "s.min_branch_samples"),
        (MonteCarloScheduler(durations="normal"), "s.durations"),
        (MonteCarloScheduler(durations=""), "s.durations"),
        (RandomEnabledScheduler(wait_quantum=0.0), "s.wait_quantum"),
        (RandomEnabledScheduler(cost_robot=-1.0), "s.cost_robot"),
        (RandomEnabledScheduler(agent_costs={"cart1": -0.5}), "s.agent_costs.cart1"),
        (RoundRobinScheduler(rate=100.0), "s.rate"),
        (BestOfRolloutsPlanScheduler(n_candidates=0), "s.n_candidates"),
        (PredictiveRobotScheduler(agent="r", autonomous_action="a", assist_actions=["b"], request_action="h",
                                  autonomous_duration_from="guess"), "s.autonomous_duration_from"),
    ],
)
def test_validate_names_the_field(config, field_path):
    with pytest.raises(ConfigError) as err:
        config.validate("s")
    assert err.value.field == field_path


def test_legacy_params_and_defaults():
    from hrc_drake.cell.legacy import translate

    old = {"kind": "monte_carlo", "params": {"n_trials": 40.0, "horizon": 20}}
    assert translate("scheduler", old) == [("scheduler", MonteCarloScheduler(n_trials=40, horizon=20.0))]
    assert translate("scheduler", {"kind": "none"}) == [("scheduler", NoScheduler())]
    with pytest.raises(ConfigError, match="scheduler.params.bogus"):
        translate("scheduler", {"kind": "greedy", "params": {"bogus": 1.0}})
    for cls in KINDS:
        config = cls()
        config.validate("scheduler")
        net_fields = (config.wait_quantum, config.cost_robot, config.cost_human, config.rate)
        assert net_fields == (1.0, 1.0, 1.0, 10.0)


@pytest.mark.parametrize("cls", KINDS)
def test_every_kind_builds_a_policy_and_clones_copy_on_write(cls):
    pytest.importorskip("pydrake")
    from hrc_drake.scheduling.systems import make_policy

    flow, buffers, pattern, robots = tc.fig_7_11()
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
    policy = make_policy(net, cls(), seed=0)
    state = policy.rng.bit_generator.state
    twin = policy.clone()
    m = net.m0.copy()
    first = [twin.decide(m, "r1") for _ in range(3)]
    if hasattr(twin, "durations_"):
        j = int(np.flatnonzero(~net.controllable)[0])
        twin.observe(j, 1.0)
        assert len(policy.durations_.samples_[j]) == 0 and len(twin.durations_.samples_[j]) == 1
    assert policy.rng.bit_generator.state == state  # the original's generator did not move
    again = policy.clone()
    assert [again.decide(m, "r1") for _ in range(3)] == first  # same state, same decisions
