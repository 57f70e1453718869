"""Property tests of the goal-region detector on arbitrary streams (Hypothesis): frames with
NaN, inf, huge values, lost points, jumps and time going backwards."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hrc_drake.intention.detector import GoalRegionDetector

CENTERS = np.array([[0.5, 0.2, 0.8], [0.5, -0.2, 0.8], [0.7, 0.0, 0.8]])

near_a_region = st.tuples(st.integers(0, 2), st.lists(st.floats(-0.12, 0.12), min_size=3, max_size=3)).map(
    lambda g: list(CENTERS[g[0]] + np.array(g[1])))  # inside, at the border or just outside
anywhere = st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=3, max_size=3)  # huge, NaN, inf
wrist = st.one_of(near_a_region, near_a_region, anywhere)
frame = st.tuples(
    st.one_of(st.floats(-1.0, 30.0), st.just(math.nan), st.just(math.inf)),  # time, not always forward
    st.tuples(wrist, wrist).map(lambda w: w[0] + w[1]),
    st.tuples(st.booleans(), st.booleans()),
)


def run(detector, frames):
    events = []
    for time, coords, known in frames:
        with np.errstate(over="ignore", invalid="ignore"):
            detector, new = detector.update(time, np.reshape(coords, (2, 3)), known)
        events += new
    return detector, events


@settings(max_examples=150, deadline=None)
@given(frames=st.lists(frame, max_size=60), end_rule=st.sampled_from(["exit", "next"]),
       min_dwell=st.sampled_from([0.0, 0.2]))
def test_any_stream_gives_well_formed_events_and_the_same_ones_twice(frames, end_rule, min_dwell):
    half = len(frames) // 2  # the first half in time order (dwells elapse), the rest as drawn
    frames = sorted(frames[:half], key=lambda f: f[0] if f[0] == f[0] else 0.0) + frames[half:]
    detector = GoalRegionDetector(("a", "b", "c"), CENTERS, np.full(3, 0.07), end_rule=end_rule,
                                  min_dwell=min_dwell)
    final, events = run(detector, frames)
    assert [e.seq for e in events] == list(range(1, len(events) + 1))
    assert all(math.isfinite(e.time) for e in events)
    open_actions: dict[str, int] = {}
    for e in events:  # per action: begin, end, begin, ... never two begins or an end first
        assert e.kind in ("begin", "end")
        depth = open_actions.get(e.action, 0) + (1 if e.kind == "begin" else -1)
        assert depth in (0, 1), (e, events)
        open_actions[e.action] = depth
    under_way = {a for a, d in open_actions.items() if d == 1}
    if end_rule == "next":  # at most one action under way
        assert len(under_way) <= 1
    else:  # an action is under way exactly while a hand is in its region
        assert set(final.active()) == under_way
    assert run(detector, frames)[1] == events
