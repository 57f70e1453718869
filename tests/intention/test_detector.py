"""GoalRegionDetector on hand-made wrist trajectories (thesis Ch. 2: an action begins when a hand
enters its goal region G_a)."""

from __future__ import annotations

import numpy as np
import pytest

from hrc_drake.intention.detector import GoalRegionDetector

DT = 1.0 / 30.0
CENTERS = np.array([[0.5, 0.3, 0.9], [0.5, -0.3, 0.9]])
FAR = np.array([0.0, 0.0, 1.2])


def detector(**kwargs) -> GoalRegionDetector:
    return GoalRegionDetector(("g_left", "g_right"), CENTERS, [0.05, 0.05], actions=("take_a", "take_b"),
                              **kwargs)


def run(det, left, right=None, known=None, t0=0.0):
    """Feed samples k = 0..K-1 at t0 + k DT; left/right (K, 3); known (K, 2). Returns (det, events)."""
    left = np.asarray(left, dtype=float)
    right = np.broadcast_to(FAR, left.shape) if right is None else np.asarray(right, dtype=float)
    known = np.ones((len(left), 2), bool) if known is None else np.asarray(known, bool)
    events = []
    for k in range(len(left)):
        det, new = det.update(t0 + k * DT, np.stack([left[k], right[k]]), known[k])
        events += new
    return det, events


def path(*pieces):
    """Concatenate (position, samples) pieces into a (K, 3) trajectory."""
    return np.concatenate([np.tile(np.asarray(p, float), (n, 1)) for p, n in pieces])


def test_entry_then_exit_gives_begin_at_entry_and_end_at_exit():
    inside = CENTERS[0] + [0.01, 0, 0]
    det, events = run(detector(), path((FAR, 10), (inside, 30), (FAR, 10)))
    assert [(e.kind, e.action, e.hand, e.goal) for e in events] == [
        ("begin", "take_a", "left", "g_left"), ("end", "take_a", "left", "g_left")]
    assert events[0].time == pytest.approx(10 * DT)  # dated at the entry, not after the dwell
    assert events[1].time == pytest.approx(40 * DT)  # the first sample outside
    assert [e.seq for e in events] == [1, 2]
    assert det.active() == {}


def test_pass_through_shorter_than_dwell_is_no_action():
    crossing = CENTERS[0] + [0.02, 0, 0]
    _, events = run(detector(min_dwell=0.2), path((FAR, 5), (crossing, 4), (FAR, 5)))  # 4 samples = 0.13 s
    assert events == []


def test_jitter_at_the_border_inside_the_hysteresis_band_starts_and_ends_nothing_new():
    rng = np.random.default_rng(3)
    radius = 0.05
    # after a clear entry the wrist jitters around the region's border (r +- 0.01 m < 1.3 r)
    border = CENTERS[0] + np.outer(radius + rng.uniform(-0.01, 0.01, 60), [1.0, 0.0, 0.0])
    traj = np.concatenate([path((FAR, 5), (CENTERS[0], 10)), border, path((FAR, 3))])
    _, events = run(detector(), traj)
    assert [e.kind for e in events] == ["begin", "end"]
    # without hysteresis (exit at the entry radius) the same jitter ends and restarts actions
    _, no_band = run(detector(exit_scale=1.0, min_dwell=0.0), traj)
    assert len(no_band) > 2


def test_lost_wrist_holds_the_action_then_times_out_at_the_loss():
    inside = CENTERS[1] + [0, 0.01, 0]
    right = path((FAR, 5), (inside, 20), (inside, 40), (FAR, 5))
    known = np.ones((70, 2), bool)
    known[25:45, 1] = False  # 0.67 s lost inside: shorter than the timeout, the action goes on
    _, events = run(detector(lost_timeout=1.0), np.broadcast_to(FAR, (70, 3)), right, known)
    assert [e.kind for e in events] == ["begin", "end"]
    assert events[1].time == pytest.approx(65 * DT)
    known[25:, 1] = False  # lost for good: the action ends when the wrist was lost
    _, events = run(detector(lost_timeout=1.0), np.broadcast_to(FAR, (70, 3)), right, known)
    assert [(e.kind, e.time) for e in events] == [("begin", pytest.approx(5 * DT)),
                                                   ("end", pytest.approx(25 * DT))]


def test_a_lost_wrist_with_nan_or_large_spread_changes_nothing():
    det = detector(max_spread=0.1)
    points = np.zeros((8, 3))
    points[6] = CENTERS[0]
    spread = np.zeros(8)
    spread[6] = 0.5  # the tracker's particles are spread: the estimate is not usable
    wrists, known = det.known_wrists(points, spread)
    assert not known[0] and known[1]
    same, events = det.update(0.0, wrists, known)
    assert same is det and events == []
    wrists[0] = np.nan
    assert det.update(0.1, wrists, [True, True])[0] is det  # NaN counts as lost


def test_two_hands_in_two_regions_are_two_actions():
    left = path((FAR, 5), (CENTERS[0], 30), (FAR, 5))
    right = path((FAR, 10), (CENTERS[1], 25), (FAR, 5))
    _, events = run(detector(), left, right)
    assert [(e.kind, e.action, e.hand) for e in events] == [
        ("begin", "take_a", "left"), ("begin", "take_b", "right"),
        ("end", "take_a", "left"), ("end", "take_b", "right")]


def test_two_hands_in_one_region_are_one_action():
    left = path((FAR, 5), (CENTERS[0], 30), (FAR, 10))
    right = path((FAR, 10), (CENTERS[0] + [0, 0.01, 0], 30), (FAR, 5))
    _, events = run(detector(), left, right)
    assert [(e.kind, e.hand) for e in events] == [("begin", "left"), ("end", "right")]
    assert events[1].time == pytest.approx(40 * DT)  # when the last hand left


def test_a_hand_moving_from_one_region_into_the_next():
    left = path((FAR, 3), (CENTERS[0], 20), (CENTERS[1], 20), (FAR, 3))
    _, events = run(detector(), left)
    assert [(e.kind, e.action) for e in events] == [
        ("begin", "take_a"), ("end", "take_a"), ("begin", "take_b"), ("end", "take_b")]
    assert events[1].time == pytest.approx(events[2].time)


def test_nothing_new_returns_the_same_value():
    det, _ = run(detector(), path((FAR, 3), (CENTERS[0], 20)))
    again, events = det.update(20 * DT + 1.0, np.stack([CENTERS[0], FAR]), [True, True])
    assert again is det and events == []


@pytest.mark.parametrize("kwargs", [dict(entry_scale=0.0), dict(entry_scale=1.5, exit_scale=1.2),
                                    dict(min_dwell=-1.0), dict(max_spread=0.0),
                                    dict(lost_timeout=float("nan"))])
def test_bad_parameters_are_refused(kwargs):
    with pytest.raises(ValueError):
        detector(**kwargs)


def test_bad_goals_are_refused():
    with pytest.raises(ValueError):
        GoalRegionDetector(("a",), np.zeros((2, 3)), [0.05])
    with pytest.raises(ValueError):
        GoalRegionDetector(("a",), np.zeros((1, 3)), [-0.05])


def test_action_detector_system_emits_the_perceived_events_of_a_reach():
    """The LeafSystem on an estimate stream: the left wrist goes into goal g_left's region for
    0.5 s; the events log has its begin and end, with hand and goal, and a lost estimate (large
    spread) in the middle changes nothing."""
    from pydrake.common.value import AbstractValue
    from pydrake.systems.analysis import Simulator

    from hrc_drake.intention.config import GoalRegionActionDetector
    from hrc_drake.intention.systems import ActionDetector
    from hrc_drake.messages import SkeletonEstimate

    system = ActionDetector(GoalRegionActionDetector(), ["g_left", "g_right"], CENTERS, [0.05, 0.05],
                            actions=["take_a", "take_b"])
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    port = system.GetInputPort("skeleton_estimate")

    def estimate(left, spread=0.0):
        points = np.tile(FAR, (8, 1))
        points[6] = left
        return AbstractValue.Make(SkeletonEstimate(points=points, spread=np.full(8, spread)))

    simulator.Initialize()
    for until, left, spread in ((0.3, FAR, 0.0), (0.6, CENTERS[0], 0.0), (0.7, CENTERS[0], 1.0),
                                (0.8, CENTERS[0], 0.0), (1.2, FAR, 0.0)):
        port.FixValue(context, estimate(left, spread))
        simulator.AdvanceTo(until)
    events = system.GetOutputPort("human_events").Eval(context).events
    assert [(e.kind, e.action, e.hand, e.goal) for e in events] == [
        ("begin", "take_a", "left", "g_left"), ("end", "take_a", "left", "g_left")]
    assert events[0].time == pytest.approx(0.3, abs=DT + 1e-9)
    assert events[1].time == pytest.approx(0.8, abs=DT + 1e-9)


def _events(*rows):
    from hrc_drake.messages import HumanEvent

    return [HumanEvent(time=t, action=a, kind=k, seq=i + 1) for i, (t, a, k) in enumerate(rows)]


def test_detection_quality_matches_perceived_to_true_actions():
    from hrc_drake.intention.detector import detection_quality

    truth = _events((0.0, "a", "begin"), (2.0, "a", "end"), (3.0, "b", "begin"), (5.0, "b", "end"),
                    (6.0, "a", "begin"), (8.0, "a", "end"), (8.0, "wait", "wait_begin"))
    perceived = _events((0.5, "a", "begin"), (1.9, "a", "end"),   # a, 0.5 s late
                        (4.0, "a", "begin"), (4.3, "a", "end"),   # spurious: no true a then
                        (6.8, "a", "begin"), (7.9, "a", "end"))   # a, 0.8 s late; b is missed
    q = detection_quality(truth, perceived)
    assert q["event_precision"] == pytest.approx(2 / 3)
    assert q["event_recall"] == pytest.approx(2 / 3)
    assert q["spurious_actions"] == 1 and q["missed_actions"] == 1
    assert q["event_latency_median_s"] == pytest.approx(0.65)
    assert q["event_latency_p90_s"] == pytest.approx(0.5 + 0.9 * 0.3)
    perfect = detection_quality(truth, truth)
    assert perfect["event_precision"] == perfect["event_recall"] == 1.0
    assert perfect["event_latency_p90_s"] == 0.0


def test_end_rule_next_ends_an_action_when_the_next_begins_a_re_entry_included():
    # take a part at region A, work elsewhere (outside every region), come back to A, then go to B:
    # two consecutive instances of take_a (issue 38: the re-entry was lost, every second IC
    # insertion of pcb_ic's pattern 2)
    left = path((FAR, 3), (CENTERS[0], 10), (FAR, 20), (CENTERS[0], 10), (FAR, 5), (CENTERS[1], 10), (FAR, 3))
    _, events = run(detector(end_rule="next"), left)
    assert [(e.kind, e.action) for e in events] == [("begin", "take_a"), ("end", "take_a"),
                                                    ("begin", "take_a"), ("end", "take_a"),
                                                    ("begin", "take_b")]
    assert events[1].time == pytest.approx(events[2].time) == pytest.approx(33 * DT)  # the re-entry
    assert events[3].time == pytest.approx(events[4].time) == pytest.approx(48 * DT)
    # the earlier variant merges the re-entry into the action
    _, merged = run(detector(end_rule="next_merging_reentries"), left)
    assert [(e.kind, e.action) for e in merged] == [("begin", "take_a"), ("end", "take_a"),
                                                    ("begin", "take_b")]
    _, exits = run(detector(), left)  # "exit": every stay in a region is an action
    assert [e.action for e in exits if e.kind == "begin"] == ["take_a", "take_a", "take_b"]
    # a second hand entering while the first is inside is the same instance
    right = path((FAR, 8), (CENTERS[0] + [0.01, 0, 0], 10), (FAR, len(left) - 18))
    _, both = run(detector(end_rule="next"), left, right)
    assert [e.action for e in both if e.kind == "begin"] == ["take_a", "take_a", "take_b"]


def test_the_dwell_runs_in_the_exit_band_as_the_docstring_says():
    # a hand crossing region A (r = 0.05 m, entry 1.0 r, exit 1.3 r) on a chord 0.035 m off its
    # centre, from the entry (x = -0.036 m) to the band's edge (x = +0.055 m): at 0.3 m/s 0.30 s, an
    # action; at 0.7 m/s 0.13 s, not
    offset = 0.035

    def crossing(speed):
        x = np.arange(-0.08, 0.08, speed * DT)
        return CENTERS[0] + np.stack([x, np.full_like(x, offset), np.zeros_like(x)], axis=1)

    slow, fast = crossing(0.3), crossing(0.7)
    for track, actions in ((slow, 1), (fast, 0)):
        _, events = run(detector(min_dwell=0.2), np.concatenate([path((FAR, 5)), track, path((FAR, 5))]))
        assert sum(e.kind == "begin" for e in events) == actions
