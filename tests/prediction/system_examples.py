"""Contract examples of the prediction systems (see tests/contract.py)."""

from __future__ import annotations

from hrc_drake.messages import EventLog, HumanEvent
from hrc_drake.prediction.config import HigherOrderMarkovPredictor
from hrc_drake.prediction.systems import ActivityPredictor
from tests.contract import SystemExample


def _log(pattern: str, durations: dict[str, float]) -> EventLog:
    """Back-to-back begin/end events of the actions in `pattern`, from t = 0."""
    events, t, seq = [], 0.0, 0
    for action in pattern:
        events.append(HumanEvent(time=t, action=action, kind="begin", seq=seq + 1))
        t += durations[action]
        events.append(HumanEvent(time=t, action=action, kind="end", seq=seq + 2))
        seq += 2
    return EventLog(tuple(events))


def activity_predictor() -> SystemExample:
    system = ActivityPredictor(HigherOrderMarkovPredictor(order=1, rate=4.0), ["a", "b", "c"])
    # a fixed log: the events whose time has come are those the predictor learns from
    return SystemExample(
        system,
        inputs_a={"human_events": _log("abcabcabc", {"a": 0.2, "b": 0.3, "c": 0.1})},
        inputs_b={"human_events": _log("acbacbacb", {"a": 0.5, "b": 0.2, "c": 0.4})},
        duration=2.0,
    )


EXAMPLES = {ActivityPredictor: activity_predictor}
