"""The decision rule of Fig. 5.14 (thesis 5.4.1) and its baselines on hand-made forecasts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hrc_drake.messages import Forecast
from hrc_drake.scheduling.collaboration import (
    ASSIST,
    AUTONOMOUS,
    WAIT,
    DataDrivenPercentilePolicy,
    PredictiveRobotPolicy,
    ReactiveRobotPolicy,
    waiting_percentile,
)


def forecast(enclosure_wait, levels=(0.2, 0.5, 0.8)):
    """A forecast of two actions: "ic_insert" soon, "enclosure" (the collaboration request) at the
    given percentiles (one per level)."""
    return Forecast(time=0.0, actions=("ic_insert", "enclosure"), next_probabilities=np.array([0.5, 0.5]),
                    percentile_levels=np.asarray(levels, float),
                    waiting_percentiles=np.array([[1.0, 2.0, 3.0], list(enclosure_wait)], float))


def test_predictive_robot_starts_the_check_when_the_collaboration_is_far():
    policy = PredictiveRobotPolicy("enclosure", autonomous_duration=12.0, percentile=0.8)
    far = policy.decide(0.0, False, forecast([10.0, 15.0, 20.0]))
    assert far.choice == AUTONOMOUS and far.waiting_time == 20.0


def test_predictive_robot_waits_when_the_forecast_says_the_collaboration_is_near():
    policy = PredictiveRobotPolicy("enclosure", autonomous_duration=12.0, percentile=0.8)
    near = policy.decide(0.0, False, forecast([2.0, 5.0, 9.0]))
    assert near.choice == WAIT and near.waiting_time == 9.0
    # the percentile decides: at p = 0.5 the same forecast gives t_p = 5 s
    assert PredictiveRobotPolicy("enclosure", 4.0, percentile=0.5).decide(0.0, False, forecast(
        [2.0, 5.0, 9.0])).choice == AUTONOMOUS


def test_predictive_robot_assists_once_the_human_initiated_the_collaboration():
    policy = PredictiveRobotPolicy("enclosure", autonomous_duration=12.0)
    assert policy.decide(0.0, True, forecast([50.0, 60.0, 70.0])).choice == ASSIST


def test_waiting_percentile_interpolates_between_levels_and_is_inf_when_unknown():
    f = forecast([2.0, 5.0, 9.0])
    assert waiting_percentile(f, "enclosure", 0.65) == pytest.approx(7.0)
    assert waiting_percentile(f, "enclosure", 0.9) == math.inf  # beyond the levels
    assert waiting_percentile(f, "no_such_action", 0.5) == math.inf
    assert waiting_percentile(forecast([2.0, 5.0, math.inf]), "enclosure", 0.65) == math.inf
    # an unknown waiting time (no training yet: inf) lets the robot work
    assert PredictiveRobotPolicy("enclosure", 12.0).decide(0.0, False, Forecast()).choice == AUTONOMOUS


def test_reactive_robot_ignores_the_forecast():
    policy = ReactiveRobotPolicy()
    assert policy.decide(0.0, False, forecast([0.1, 0.2, 0.3])).choice == AUTONOMOUS
    assert policy.decide(0.0, True).choice == ASSIST


def test_data_driven_percentile_uses_the_intervals_between_requests():
    policy = DataDrivenPercentilePolicy(autonomous_duration=12.0, percentile=0.8)
    assert policy.decide(5.0, False).choice == AUTONOMOUS  # no interval yet
    for t in (0.0, 30.0, 60.0, 90.0):  # every 30 s
        policy = policy.observe(t)
    soon = policy.decide(80.0 + 30.0, False)  # 20 s after the last request: t_p = 10 s
    assert soon.choice == WAIT and soon.waiting_time == pytest.approx(10.0)
    later = policy.decide(90.0 + 5.0, False)  # t_p = 25 s
    assert later.choice == AUTONOMOUS and later.waiting_time == pytest.approx(25.0)
    overdue = policy.decide(90.0 + 45.0, False)
    assert overdue.choice == WAIT and overdue.waiting_time == 0.0


@pytest.mark.parametrize("kwargs", [dict(autonomous_duration=0.0), dict(autonomous_duration=math.inf),
                                    dict(autonomous_duration=5.0, percentile=1.0)])
def test_bad_policy_parameters_are_refused(kwargs):
    with pytest.raises(ValueError):
        PredictiveRobotPolicy("enclosure", **kwargs)
