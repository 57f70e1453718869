"""Safety-aware scheduling (issue 52, item 3): the Monte Carlo scheduler with robot durations
learned per operator activity prefers the work away from where the operator is (or is forecast
to go), which the thesis's one distribution per transition (7.3.1) cannot see."""

import numpy as np
import pytest

from hrc_drake.distributions import Distribution
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.config import MonteCarloScheduler
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy, simulate_trials
from hrc_drake.scheduling.slowdown import DurationsByOperator, OperatorActivities, robot_action_ends
from hrc_drake.scheduling.systems import make_policy
from hrc_drake.scheduling.tracker import NetTracker


def _fixed(seconds):
    return Distribution(kind="fixed", mean=seconds)


def _shared_station_net():
    """The operator works 8 s at the shared station S (HS), then needs A's part (HA), then C's
    (HC). The robot's A (4 s) is done at S, C (9 s) away from it."""
    buffers = [Buffer("feed", "raw"), Buffer("a_out", "intermediate", 1), Buffer("c_out", "intermediate", 1),
               Buffer("done", "product")]
    flow = Flow(actions=[
        FlowAction("A", ["robot"], ["feed"], ["a_out"], duration=_fixed(4.0)),
        FlowAction("C", ["robot"], ["feed"], ["c_out"], duration=_fixed(9.0)),
        FlowAction("HS", ["human"], ["feed"], [], duration=_fixed(8.0)),
        FlowAction("HA", ["human"], ["a_out"], [], duration=_fixed(4.0)),
        FlowAction("HC", ["human"], ["c_out"], ["done"], duration=_fixed(4.0)),
    ])
    return compile_flow(flow, buffers, "human", ["HS", "HA", "HC"], ["robot"], wait_quantum=1.0)


def _policy(net, by_operator: bool, seed=1):
    """A policy that has seen A take 16 s while the operator was at S (the safety controller held
    the robot) and 4 s otherwise, C 9 s always.

    By hand, within the 20 s horizon: with the operator at S until 8 s, A first (16 s) leaves the
    operator waiting for its part 8-16 s (8 s); C first (0-9 s), then A with the operator gone
    (9-13 s), 8-13 s only (5 s). With A's one distribution (16 s in 3 of 15) A first costs 1 s
    (C 4-13 s, HC from 12 s) and C first 5 s."""
    policy = MonteCarloPolicy(net, n_trials=400, horizon=20.0, random_state=seed,
                              durations_by_operator=by_operator)
    a_end, c_end = net.transition_index["A:end"], net.transition_index["C:end"]
    for operator, a_seconds, times in (("HS", 16.0, 3), ("HA", 4.0, 6), ("HC", 4.0, 6)):
        for _ in range(times):
            policy.observe(a_end, a_seconds, operator=operator)
            policy.observe(c_end, 9.0, operator=operator)
    return policy


def _operator_at_station(net):
    tracker = NetTracker(net)
    tracker.human_event("HS", "begin", 0.0)
    return tracker


def _operator_going_to_station(net):
    """The operator has just finished HC and will go to S next: only the pattern says so."""
    tracker = NetTracker(net)
    tracker.m[:] = net.m0
    return tracker


def test_activities_read_off_the_marking_in_order_of_precedence():
    net = _shared_station_net()
    activities = OperatorActivities.of(net)
    assert activities.names == ("HS", "HA", "HC")
    assert activities.name_of_marking(net.m0) == "HS"  # step 0: the pattern's forecast
    tracker = _operator_at_station(net)
    first_marked = activities.places[np.flatnonzero(tracker.m[activities.places])[0]]
    assert net.places[first_marked] == "busy:HS#0"  # busy wins over the steps of the pattern
    assert activities.name_of_marking(tracker.m) == "HS"
    marking = tracker.m.copy()
    marking[net.place_index["busy:HS#0"]] = 0
    marking[net.place_index["hwait:1"]] = 1
    assert activities.name_of_marking(marking) == "HA"
    marking[net.place_index["hwait:1"]] = 0
    assert activities.of_marking(marking) == -1
    ends = robot_action_ends(net)
    assert {net.transitions[j] for j in np.flatnonzero(ends)} == {"A:end", "C:end"}


@pytest.mark.parametrize("where", [_operator_at_station, _operator_going_to_station])
def test_scheduler_chooses_the_action_away_from_the_forecast_operator(where):
    net = _shared_station_net()
    tracker = where(net)
    a_begin, c_begin = net.transition_index["A:begin"], net.transition_index["C:begin"]
    # one distribution per transition (7.3.1): A's median is 6 s, and HA needs A next
    literal = _policy(net, by_operator=False)
    assert literal.decide(tracker.m, "robot", now=0.0, elapsed=tracker.elapsed(0.0)) == a_begin
    # by operator activity: A would be held while the operator is at S, so C first
    aware = _policy(net, by_operator=True)
    assert aware.decide(tracker.m, "robot", now=0.0, elapsed=tracker.elapsed(0.0)) == c_begin
    costs = aware.last_percentiles_
    assert (costs["C:begin"], costs["A:begin"]) == (5.0, 8.0)  # the medians by hand (docstring)


def test_operator_elsewhere_keeps_the_literal_choice():
    """Away from S, A is 6 s under both models: the aware scheduler does what 7.3.1 does."""
    net = _shared_station_net()
    tracker = NetTracker(net)
    tracker.human_event("HS", "begin", 0.0)
    tracker.human_event("HS", "end", 8.0)
    tracker.human_event("HA", "wait_begin", 8.0)
    marking, elapsed = tracker.m, tracker.elapsed(8.0)
    assert OperatorActivities.of(net).name_of_marking(marking) == "HA"
    picks = [_policy(net, by).decide(marking, "robot", now=8.0, elapsed=elapsed) for by in (False, True)]
    assert picks[0] == picks[1] == net.transition_index["A:begin"]


@pytest.mark.parametrize("compiled", [True, False])
def test_trials_draw_a_learned_pair_only_under_its_activity(compiled):
    net = _shared_station_net()
    by_operator = DurationsByOperator(net, window=5, min_samples=2)
    a_end = net.transition_index["A:end"]
    for _ in range(2):
        by_operator.partial_fit(a_end, 24.0, "HS")
    by_operator.partial_fit(a_end, 3.0, "HA")  # one sample: not learned, the prior 6 s applies
    from hrc_drake.scheduling.learning import DurationModel

    roots = [net.transition_index["A:begin"]]
    at_station = _operator_at_station(net).m
    runs = [simulate_trials(net, at_station, DurationModel(net), np.random.default_rng(0), 20, 12.0, roots,
                            compiled=compiled, by_operator=model) for model in (by_operator, None)]
    # A begun with the operator at S ends at 24 s: the operator, done with HS at 8 s, waits for
    # A's part until the horizon (4 s); with its prior A ends at 4 s and HA starts at 8 s
    np.testing.assert_allclose(runs[0].human_wait, 4.0)
    np.testing.assert_allclose(runs[1].human_wait, 0.0)
    # begun while the operator is at HA (one sample: not learned), A takes its prior 6 s
    marking = at_station.copy()
    marking[net.place_index["busy:HS#0"]], marking[net.place_index["hwait:1"]] = 0, 1
    away = simulate_trials(net, marking, DurationModel(net), np.random.default_rng(0), 20, 12.0, roots,
                           compiled=compiled, by_operator=by_operator)
    # HA waits for A's part (prior 4 s), then HC for C's from 8 s to the horizon: 8 s
    np.testing.assert_allclose(away.human_wait, 8.0)


def test_both_trial_forms_agree_with_learned_pairs():
    net = _shared_station_net()
    policy = _policy(net, by_operator=True)
    marking = _operator_at_station(net).m
    roots = np.flatnonzero(net.controllable & net.enabled(marking))
    runs = [simulate_trials(net, marking, policy.durations_, np.random.default_rng(7), 50, 40.0, roots,
                            compiled=compiled, by_operator=policy.by_operator_) for compiled in (True, False)]
    np.testing.assert_array_equal(runs[0].paths, runs[1].paths)
    np.testing.assert_allclose(runs[0].costs, runs[1].costs)


def test_tracker_records_the_operator_activity_at_a_robot_action_start():
    net = _shared_station_net()
    policy = MonteCarloPolicy(net, n_trials=10, horizon=10.0, random_state=0, durations_by_operator=True,
                              min_samples=1)
    tracker = NetTracker(net, policy)
    tracker.human_event("HS", "begin", 0.0)
    tracker.command(net.transition_index["A:begin"], 1.0)
    tracker.human_event("HS", "end", 8.0)  # the operator leaves S while A runs
    tracker.robot_event("robot", "A", "end", 21.0)
    assert policy.by_operator_.means() == {("A:end", "HS"): 20.0}
    # off by default: the literal policy observes as 7.3.1 does and keeps no activities
    literal = MonteCarloPolicy(net, random_state=0)
    assert literal.by_operator_ is None and NetTracker(net, literal).activities is None


def test_config_flag_is_validated_and_reaches_the_policy():
    net = _shared_station_net()
    assert make_policy(net, MonteCarloScheduler(durations_by_operator=True), seed=0).by_operator_ is not None
    assert make_policy(net, MonteCarloScheduler(), seed=0).by_operator_ is None
    from hrc_drake.errors import ConfigError

    with pytest.raises(ConfigError, match="durations_by_operator"):
        make_policy(net, MonteCarloScheduler(durations_by_operator="yes"), seed=0)


def test_bad_observations_are_refused():
    net = _shared_station_net()
    model = DurationsByOperator(net)
    with pytest.raises(ValueError, match="finite"):
        model.partial_fit("A:end", float("nan"), "HS")
    with pytest.raises(ValueError, match=">= 1"):
        DurationsByOperator(net, window=0)
    # a human action's end or an unknown activity teaches nothing
    model.partial_fit("HS#0:end", 5.0, "HS").partial_fit("A:end", 5.0, "nobody")
    model.partial_fit("A:end", 5.0, None)
    assert model.samples_ == {}
