"""The IntentionEstimator wired in the box-with-USB-pen cell (thesis 3.1.3, Fig. 3.6).

The feedback machine with sequence (goal 4, goal 1) must tell the operator "understood" for the
collaborative station while the box is being brought there, i.e. before the "bring" action ends.
"""

from pathlib import Path

import pytest

pytest.importorskip("pydrake")
from pydrake.systems.analysis import Simulator  # noqa: E402

from hrc_drake.messages import HumanEvent  # noqa: E402

SCENARIO = Path(__file__).resolve().parents[2] / "diagrams" / "box_usb.yaml"
DURATION = 40.0


@pytest.fixture(scope="module")
def box_usb_run():
    if not SCENARIO.exists():
        pytest.skip(f"{SCENARIO} is missing")
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.scenario import load_scenario

    scenario = load_scenario(SCENARIO)
    assert scenario.intention.feedback_sequence == ["g4_station", "g1_home"]
    cell = build_cell(scenario, SCENARIO)
    simulator = Simulator(cell.diagram)
    simulator.Initialize()
    simulator.AdvanceTo(DURATION)
    estimator = cell.system("intention")
    context = estimator.GetMyContextFromRoot(simulator.get_context())
    log = estimator.GetOutputPort("intention_events").Eval(context)
    recorded = cell.log(simulator.get_context())
    human = [e for e in recorded.events if isinstance(e, HumanEvent)]
    return recorded, log, human


def _intervals(human, action):
    begins = [e.time for e in human if e.action == action and e.kind == "begin"]
    ends = [e.time for e in human if e.action == action and e.kind == "end"]
    return list(zip(begins, ends, strict=False))


def test_station_is_understood_before_the_bring_action_ends(box_usb_run):
    _, log, human = box_usb_run
    brings = _intervals(human, "bring")
    assert brings, "no bring action completed in the run"
    station = [e.time for e in log.events if e.goal == "g4_station" and e.kind == "understood"]
    for begin, end in brings:
        assert any(begin < t < end for t in station), (begin, end, station)


def test_feedback_alternates_station_and_home_on_real_reaches(box_usb_run):
    recorded, log, human = box_usb_run
    events = log.events
    assert len(events) >= 3
    assert [e.seq for e in events] == list(range(1, len(events) + 1))
    assert all(e.kind == "understood" and e.hand in ("left", "right") for e in events)
    # the machine of Fig. 3.6 waits for goal 4, then goal 1, then goal 4 again ...
    assert [e.goal for e in events] == [("g4_station", "g1_home")[k % 2] for k in range(len(events))]
    times = [e.time for e in events]
    assert times == sorted(times) and 0.0 < times[0] and times[-1] <= DURATION
    # goal 4 is announced only while an action that goes there (bring, tape) is under way
    to_station = _intervals(human, "bring") + _intervals(human, "tape")
    open_end = [e.time for e in human if e.action in ("bring", "tape") and e.kind == "begin"]
    if len(open_end) > len(to_station):
        to_station.append((open_end[-1], DURATION))
    for e in events:
        if e.goal == "g4_station":
            assert any(b < e.time <= end for b, end in to_station), (e, to_station)
    # the cell's event log records every feedback event (replay flashes and reports read it)
    logged = [e for e in recorded.events if getattr(e, "agent", "") == "intention"]
    assert len(logged) == len(events)
