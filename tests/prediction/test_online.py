"""The event-level forecaster gives the forecasts of the Drake ActivityPredictor on the same
events (one core, two drivers)."""

import numpy as np
import pytest

pytest.importorskip("pydrake")

from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402

from hrc_drake.messages import EventLog, HumanEvent  # noqa: E402
from hrc_drake.prediction.config import HigherOrderMarkovPredictor  # noqa: E402
from hrc_drake.prediction.online import OnlineForecaster  # noqa: E402
from hrc_drake.prediction.systems import ActivityPredictor  # noqa: E402


def _events():
    out, t, seq = [], 0.0, 0
    for action, duration in [("a", 3.0), ("b", 2.0), ("a", 3.5), ("b", 2.5), ("c", 1.0), ("a", 3.0)]:
        out += [HumanEvent(t, action, "begin", seq + 1), HumanEvent(t + duration, action, "end", seq + 2)]
        seq, t = seq + 2, t + duration + 0.5
    return out[:-1]  # the last "a" still running


def test_the_online_forecaster_forecasts_as_the_activity_predictor():
    config = HigherOrderMarkovPredictor(order=2, rate=2.0)
    events = _events()
    system = ActivityPredictor(config, ["a", "b", "c"])
    context = system.CreateDefaultContext()
    system.GetInputPort("human_events").FixValue(context, AbstractValue.Make(EventLog(tuple(events))))
    Simulator(system, context).AdvanceTo(16.0)
    drake = system.GetOutputPort("forecast").Eval(context)
    online = OnlineForecaster(config, ["a", "b", "c"])
    for e in events:
        online.observe(e.action, e.kind, e.time)
    assert drake.time == 15.5  # the last periodic update before 16 s; every event came before it
    ours = online.forecast(drake.time)
    assert ours.time == drake.time
    np.testing.assert_allclose(ours.next_probabilities, drake.next_probabilities, atol=1e-12)
    np.testing.assert_allclose(ours.waiting_percentiles, drake.waiting_percentiles, atol=1e-9)
    assert np.isfinite(ours.waiting_percentiles).any()
    fresh = OnlineForecaster(config, ["a", "b", "c"]).forecast(0.0)  # before any begin: uniform, inf
    assert np.allclose(fresh.next_probabilities, 1 / 3) and np.isinf(fresh.waiting_percentiles).all()
    with pytest.raises(ValueError, match="unknown action"):
        online.observe("z", "begin", 17.0)
