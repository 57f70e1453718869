"""ActivityPredictor in a small diagram fed by a scripted event log."""

import numpy as np
import pytest

pytest.importorskip("pydrake")

from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder, LeafSystem  # noqa: E402

from hrc_drake.errors import ConfigError  # noqa: E402
from hrc_drake.messages import EventLog, Forecast, HumanEvent  # noqa: E402
from hrc_drake.prediction.config import (  # noqa: E402
    HigherOrderMarkovPredictor,
    NoPredictor,
    SuffixTreePredictor,
)
from hrc_drake.prediction.systems import ActivityPredictor  # noqa: E402


class ScriptedEvents(LeafSystem):
    """Emits the events of a script whose time has come."""

    def __init__(self, events):
        LeafSystem.__init__(self)
        self._events = tuple(events)
        self.DeclareAbstractOutputPort("events", lambda: AbstractValue.Make(EventLog()), self._calc)

    def _calc(self, context, output):
        now = context.get_time()
        output.set_value(EventLog(tuple(e for e in self._events if e.time <= now + 1e-9)))


def _script(cycles):
    """a (2 s) then b (1 s), back to back, plus a wait event the predictor must ignore."""
    events, t, seq = [], 0.0, 0
    for _ in range(cycles):
        for action, duration in (("a", 2.0), ("b", 1.0)):
            events.append(HumanEvent(time=t, action=action, kind="begin", seq=seq))
            events.append(HumanEvent(time=t + duration, action=action, kind="end", seq=seq + 1))
            seq += 2
            t += duration
    events.append(HumanEvent(time=t, action="a", kind="wait_begin", seq=seq))
    return events


def _diagram(script, config=None):
    builder = DiagramBuilder()
    source = builder.AddSystem(ScriptedEvents(script))
    config = config or HigherOrderMarkovPredictor(rate=10.0)
    predictor = builder.AddSystem(ActivityPredictor(config, ["a", "b"]))
    builder.Connect(source.get_output_port(0), predictor.GetInputPort("human_events"))
    diagram = builder.Build()
    return diagram, predictor


def test_forecast_in_a_diagram():
    diagram, predictor = _diagram(_script(6), HigherOrderMarkovPredictor(order=1, resolution=0.1, rate=10.0))
    simulator = Simulator(diagram)
    context = predictor.GetMyContextFromRoot(simulator.get_context())
    port = predictor.GetOutputPort("forecast")
    initial = port.Eval(context)
    assert isinstance(initial, Forecast)
    np.testing.assert_allclose(initial.next_probabilities, [0.5, 0.5])  # uniform fallback
    assert np.all(np.isinf(initial.waiting_percentiles))
    # at t = 15.5, "a" of the 6th cycle started at 15.0 (elapsed 0.5): b in 1.5 s, a in 2.5 s
    simulator.AdvanceTo(15.55)  # the update at 15.5 runs at the start of the step after it
    forecast = port.Eval(context)
    assert forecast.actions == ("a", "b")
    assert forecast.time == pytest.approx(15.5)
    assert forecast.next_probabilities[1] > 0.9
    np.testing.assert_allclose(forecast.waiting_percentiles[1], [1.5, 1.5, 1.5], atol=1e-9)
    np.testing.assert_allclose(forecast.waiting_percentiles[0], [2.5, 2.5, 2.5], atol=1e-9)
    np.testing.assert_allclose(predictor.core(context).waiting.durations("a"), [2.0] * 5)


def test_suffix_tree_kind_and_bad_events():
    diagram, predictor = _diagram(_script(3), SuffixTreePredictor(order=2, rate=5.0))
    simulator = Simulator(diagram)
    simulator.AdvanceTo(8.0)
    context = predictor.GetMyContextFromRoot(simulator.get_context())
    forecast = predictor.GetOutputPort("forecast").Eval(context)
    assert forecast.next_probabilities.sum() == pytest.approx(1.0)
    assert forecast.waiting_percentiles.shape == (2, 3)

    bad = [HumanEvent(time=0.0, action="c", kind="begin", seq=0)]
    diagram, _ = _diagram(bad)
    with pytest.raises(ValueError, match="'c'"):
        Simulator(diagram).AdvanceTo(0.2)
    with pytest.raises(ConfigError, match="predictor.order"):
        ActivityPredictor(HigherOrderMarkovPredictor(order=11), ["a"])
    with pytest.raises(ConfigError):
        ActivityPredictor(NoPredictor(), ["a"])
    with pytest.raises(ConfigError, match="not a predictor config"):
        ActivityPredictor("lstm", ["a"])
