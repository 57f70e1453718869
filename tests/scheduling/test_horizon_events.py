"""Issue 53 item 2: T_sch from the events in the horizon (`horizon_events`): the time the cell
takes for that many events at its expected rate, each agent ending one action (or wait) per mean
delay of its uncontrollable transitions; 7.5.3 chose its 50 s for "an average 4 events"."""

from __future__ import annotations

import pytest

from hrc_drake.distributions import Distribution
from hrc_drake.errors import ConfigError
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.config import FuzzyScheduler
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.fuzzy_scheduler import FuzzyPolicy, UniformPolicy


def _net(human_s=10.0, robot_s=4.0, wait_s=2.0):
    """The human's action H (fixed human_s), the robot r1's R (fixed robot_s) fed by it, r1's
    waits of t_w = wait_s."""
    buffers = [Buffer("raw", kind="raw"), Buffer("mid", capacity=1), Buffer("done", kind="product")]
    actions = [FlowAction("H", ["human"], ["raw"], ["mid"], duration=Distribution("fixed", mean=human_s)),
               FlowAction("R", ["r1"], ["mid"], ["done"], duration=Distribution("fixed", mean=robot_s))]
    return compile_flow(Flow(actions, {}), buffers, "human", ["H"], ["r1"], wait_quantum=wait_s)


def test_t_sch_is_the_time_of_that_many_events_at_the_cells_rate():
    net = _net()
    # by hand: the human ends H every 10 s; r1 ends R (4 s) or a wait (2 s): a mean delay of 3 s.
    # 1/10 + 1/3 = 0.4333 events/s, so 4 events take 9.23 s
    policy = FuzzyPolicy(net, horizon_events=4.0)
    assert policy.event_rate() == pytest.approx(1 / 10 + 1 / 3)
    assert policy.current_horizon() == pytest.approx(4.0 / (1 / 10 + 1 / 3))
    assert FuzzyPolicy(net).current_horizon() == 50.0  # the fixed T_sch by default
    tree = policy.tree(net.m0, roots=net.agent_choices(net.m0, "r1", "test"))
    assert tree.horizon == pytest.approx(9.2308, abs=1e-3)


def test_learned_delays_move_t_sch():
    net = _net()
    policy = UniformPolicy(net, horizon_events=4.0, min_samples=1)
    before = policy.current_horizon()
    policy.observe("H#0:end", 30.0)  # the human turns out three times slower
    assert policy.current_horizon() == pytest.approx(4.0 / (1 / 30 + 1 / 3))
    assert policy.current_horizon() > before


@pytest.mark.parametrize("events", [0.0, -1.0, 101.0, float("nan")])
def test_a_bad_event_count_is_refused(events):
    with pytest.raises(ValueError, match="horizon_events"):
        FuzzyPolicy(_net(), horizon_events=events)
    with pytest.raises(ConfigError) as err:
        FuzzyScheduler(horizon_events=events).validate("scheduler")
    assert err.value.field == "scheduler.horizon_events"
