"""A unit test of one system through its Context: the activity predictor of thesis Ch. 5 learns
a strict cycle of three actions from its `human_events` input and forecasts the next one.

    python3 -m pytest examples/test_a_system_through_its_context.py    # as tests
    python3 examples/test_a_system_through_its_context.py              # the checks, with what they show

The system is built once; each test makes its own Context, fixes the input port to a value, and
advances a Simulator: what the system learned lives in that Context only.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hrc_drake.messages import EventLog, HumanEvent  # noqa: E402
from hrc_drake.prediction.config import HigherOrderMarkovPredictor  # noqa: E402
from hrc_drake.prediction.systems import ActivityPredictor  # noqa: E402

ACTIONS = ["pick", "place", "screw"]
CYCLES = 6


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
    """The forecast of a new Context of `system` fed `events` and simulated until `until`."""
    context = system.CreateDefaultContext()
    system.get_input_port().FixValue(context, events)
    simulator = Simulator(system, context)
    simulator.AdvanceTo(until)
    return system.GetOutputPort("forecast").Eval(simulator.get_context())


def trained_forecast(system: ActivityPredictor):
    """The forecast half a second after the last "screw" of CYCLES cycles ended ("pick" is next)."""
    events = cycle_events(cycles=CYCLES)
    return forecast_after(system, events, until=events.events[-1].time + 0.5)


def test_the_predictor_learns_the_cycle_and_names_the_next_action():
    system = ActivityPredictor(HigherOrderMarkovPredictor(order=2), ACTIONS)
    forecast = trained_forecast(system)
    assert forecast.actions == tuple(ACTIONS)
    assert ACTIONS[int(np.argmax(forecast.next_probabilities))] == "pick"
    assert forecast.next_probabilities[ACTIONS.index("pick")] > 0.8


def test_two_contexts_of_one_system_are_independent():
    system = ActivityPredictor(HigherOrderMarkovPredictor(order=2), ACTIONS)
    trained = trained_forecast(system)
    fresh = forecast_after(system, EventLog(), until=1.0)  # nothing seen: the uniform fallback
    assert np.allclose(fresh.next_probabilities, 1.0 / len(ACTIONS))
    assert trained.next_probabilities.max() > 0.8


def _probabilities(forecast) -> str:
    pairs = zip(forecast.actions, forecast.next_probabilities, strict=True)
    return ", ".join(f"{action} {p:.2f}" for action, p in pairs)


def main() -> None:
    """Run both checks and print the forecasts they are about."""
    system = ActivityPredictor(HigherOrderMarkovPredictor(order=2), ACTIONS)
    print(f"One ActivityPredictor (second-order Markov), fed {CYCLES} cycles of pick -> place -> screw; "
          f"after the last screw, next action: {_probabilities(trained_forecast(system))}")
    fresh = forecast_after(system, EventLog(), until=1.0)
    print(f"A new Context of the same system, fed nothing: {_probabilities(fresh)} (what the first "
          "Context learned is not in it)")
    for check in (test_the_predictor_learns_the_cycle_and_names_the_next_action,
                  test_two_contexts_of_one_system_are_independent):
        check()  # raises AssertionError where the system does not do what the check says
        print(f"passed: {check.__name__.removeprefix('test_').replace('_', ' ')}")


if __name__ == "__main__":
    main()
