"""A unit test of one system through its Context: the activity predictor of thesis Ch. 5 learns
a strict cycle of three actions from its `human_events` input and forecasts the next one.

    python3 -m pytest examples/test_a_system_through_its_context.py

The system is built once; each test makes its own Context, fixes the input port to a value, and
advances a Simulator: what the system learned lives in that Context only.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.analysis import Simulator

from hrc_drake.messages import EventLog, HumanEvent
from hrc_drake.prediction.config import HigherOrderMarkovPredictor
from hrc_drake.prediction.systems import ActivityPredictor

ACTIONS = ["pick", "place", "screw"]


def cycle_events(cycles: int, period: float = 3.0) -> EventLog:
    """pick -> place -> screw, repeated, each action 1 s long and `period` s apart."""
    events, seq = [], 0
    for k in range(cycles * len(ACTIONS)):
        start = k * period
        for kind, time in (("begin", start), ("end", start + 1.0)):
            seq += 1
            events.append(HumanEvent(time=time, action=ACTIONS[k % len(ACTIONS)], kind=kind, seq=seq))
    return EventLog(tuple(events))


def forecast_after(system: ActivityPredictor, events: EventLog, until: float):
    context = system.CreateDefaultContext()
    system.get_input_port().FixValue(context, events)
    simulator = Simulator(system, context)
    simulator.AdvanceTo(until)
    return system.GetOutputPort("forecast").Eval(simulator.get_context())


def test_the_predictor_learns_the_cycle_and_names_the_next_action():
    system = ActivityPredictor(HigherOrderMarkovPredictor(order=2), ACTIONS)
    events = cycle_events(cycles=6)
    last = events.events[-1]  # "screw" ended: "pick" comes next
    forecast = forecast_after(system, events, until=last.time + 0.5)
    assert forecast.actions == tuple(ACTIONS)
    assert ACTIONS[int(np.argmax(forecast.next_probabilities))] == "pick"
    assert forecast.next_probabilities[ACTIONS.index("pick")] > 0.8


def test_two_contexts_of_one_system_are_independent():
    system = ActivityPredictor(HigherOrderMarkovPredictor(order=2), ACTIONS)
    trained = forecast_after(system, cycle_events(cycles=6), until=54.5)
    fresh = forecast_after(system, EventLog(), until=1.0)  # nothing seen: the uniform fallback
    assert np.allclose(fresh.next_probabilities, 1.0 / len(ACTIONS))
    assert trained.next_probabilities.max() > 0.8
