"""Synthetic operator: goals reached, waiting, events, determinism, head leading the hand."""

import numpy as np
import pytest

from hrc_drake.distributions import Distribution
from hrc_drake.human.body import BodyModel
from hrc_drake.human.config import Operator, OperatorAction, Segments
from hrc_drake.human.operator import (
    BOTH_HANDS_OFFSET,
    HEAD_LEAD,
    REACH_FRACTION,
    RETURN_TIME,
    OperatorTask,
    SyntheticOperator,
    sampler_from_distribution,
    tasks_from_schema,
)
from hrc_drake.messages import HEAD, L_WRIST, R_WRIST

DT = 0.02
BUFFER = np.array([0.68, 0.30, 0.80])
GOAL = np.array([0.62, 0.00, 0.80])
SCREW = np.array([0.62, -0.15, 0.85])


class FakeWorld:
    """Refuses `action` while time is inside `closed` (a (start, end) window); logs calls."""

    def __init__(self, closed=None, action=None):
        self.closed, self.action, self.now = closed, action, 0.0
        self.finished, self.tries = [], []

    def try_start(self, agent, action):
        self.tries.append((self.now, action))
        if self.closed and action == self.action and self.closed[0] <= self.now < self.closed[1]:
            return False
        return True

    def finish(self, agent, action):
        self.finished.append((self.now, action))


def make_operator(seed=0, world=None):
    body = BodyModel(Segments())
    tasks = {
        "pick_place": OperatorTask("pick_place", [BUFFER, GOAL], "right", lambda rng: rng.uniform(3.0, 4.0)),
        "screw": OperatorTask("screw", [SCREW], "both", lambda rng: 2.0),
    }
    return SyntheticOperator(body, tasks, ["pick_place", "screw"], body.rest_q((1.05, 0.0), np.pi),
                             np.random.default_rng(seed), world=world)


def run(op, t_end, world=None, trace=None):
    events = []
    for k in range(int(round(t_end / DT)) + 1):
        if world is not None:
            world.now = k * DT
        events += op.update(k * DT)
        if trace is not None:
            trace.append(op.points(k * DT))
    return events


def test_reaches_each_goal_at_phase_end():
    op = make_operator()
    trace = []
    events = run(op, 12.0, trace=trace)
    at = lambda t: trace[int(np.floor(t / DT + 1e-9))]  # noqa: E731  last sample before t
    begins = [e for e in events if e.kind == "begin"]
    ends = [e for e in events if e.kind == "end"]
    assert [e.action for e in begins[:4]] == ["pick_place", "screw", "pick_place", "screw"]
    checked = 0
    for begin, end in zip(begins, ends, strict=False):
        duration = end.time - begin.time
        if begin.action == "pick_place":
            for k, goal in enumerate((BUFFER, GOAL)):
                phase_end = begin.time + (k + 1) * duration / 2
                assert np.linalg.norm(at(phase_end)[R_WRIST] - goal) < 0.02
                checked += 1
        else:
            assert duration == pytest.approx(2.0)
            left = np.array([0.0, -1.0, 0.0])  # facing -x, the operator's left is -y
            p = at(end.time)
            assert np.linalg.norm(p[L_WRIST] - (SCREW + BOTH_HANDS_OFFSET * left)) < 0.02
            assert np.linalg.norm(p[R_WRIST] - (SCREW - BOTH_HANDS_OFFSET * left)) < 0.02
            checked += 1
    assert checked >= 5
    assert not op.unreachable


def test_events_sequence_and_world_calls():
    world = FakeWorld()
    op = make_operator(world=world)
    events = run(op, 20.0, world)
    seqs = [e.seq for e in events]
    assert seqs == list(range(1, len(events) + 1))
    kinds = [e.kind for e in events]
    assert kinds[:4] == ["begin", "end", "begin", "end"]
    assert all(e.agent == "human" for e in events)
    assert [a for _, a in world.finished] == [e.action for e in events if e.kind == "end"]
    times = [e.time for e in events]
    assert times == sorted(times)
    for begin, end in zip(events[0::2], events[1::2], strict=False):
        assert begin.action == end.action
        if begin.action == "pick_place":
            assert 3.0 <= end.time - begin.time <= 4.0
    assert list(op.events) == events


def test_waits_when_world_refuses():
    world = FakeWorld(closed=(0.0, 3.0), action="pick_place")
    op = make_operator(world=world)
    events = run(op, 3.5, world)
    assert [e.kind for e in events] == ["wait_begin", "wait_end", "begin"]
    assert events[0].time == 0.0 and events[0].action == "pick_place"
    assert events[1].time == pytest.approx(3.0) and events[2].time == pytest.approx(3.0)
    # while waiting the wrists rest in front of the torso at the rest height
    p = op.points(2.9)
    for wrist, hand in ((L_WRIST, "left"), (R_WRIST, "right")):
        np.testing.assert_allclose(p[wrist], op.rest_wrists[hand], atol=0.02)
        assert p[wrist][2] == pytest.approx(op.rest_height, abs=0.02)
    assert op.current_action == "pick_place"


def test_wait_between_actions_returns_to_rest():
    world = FakeWorld(closed=(0.0, 1e9), action="screw")
    op = make_operator(world=world)
    events = run(op, 4.0 + RETURN_TIME + 0.5, world)
    kinds = [e.kind for e in events]
    assert kinds == ["begin", "end", "wait_begin"]
    assert op.state == "waiting" and op.current_action is None
    assert op.current_goal("right") is None
    t = events[-1].time + RETURN_TIME + 0.1
    np.testing.assert_allclose(op.points(t)[R_WRIST], op.rest_wrists["right"], atol=0.02)


def test_deterministic_for_a_seed():
    a, b, c = make_operator(5), make_operator(5), make_operator(6)
    ea, eb, ec = run(a, 15.0), run(b, 15.0), run(c, 15.0)
    assert ea == eb
    assert [e.time for e in ea] != [e.time for e in ec]
    np.testing.assert_array_equal(a.q(7.3), b.q(7.3))


def test_head_turns_before_the_hand():
    op = make_operator()
    run(op, 0.0)
    start = op.points(0.0)[R_WRIST]
    # during the head lead the hand is still, at its end the gaze points at the first goal
    assert np.linalg.norm(op.points(HEAD_LEAD)[R_WRIST] - start) < 1e-9
    assert np.linalg.norm(op.points(HEAD_LEAD + 0.1)[R_WRIST] - start) > 1e-3
    head = op.points(HEAD_LEAD)[HEAD]
    to_goal = (BUFFER - head) / np.linalg.norm(BUFFER - head)
    assert np.arccos(np.clip(op.gaze(HEAD_LEAD) @ to_goal, -1, 1)) < 0.05
    np.testing.assert_allclose(op.current_goal("right"), BUFFER)
    assert op.current_goal("left") is None
    assert REACH_FRACTION < 1.0


def test_pose_is_continuous():
    world = FakeWorld(closed=(5.0, 7.0), action="pick_place")
    op = make_operator(world=world)
    run(op, 12.0, world)
    t = np.arange(0, 12.0, DT)
    pts = np.array([op.points(x) for x in t])
    jumps = np.linalg.norm(np.diff(pts, axis=0), axis=-1).max()
    assert jumps < 0.05  # < 2.5 m/s at 50 Hz
    assert np.all(np.isfinite(pts))
    g = np.array([op.gaze(x) for x in t])
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0)
    for x in (5.5, 9.1, 11.9):  # the operator's closed-form gaze agrees with the body model
        np.testing.assert_allclose(op.gaze(x), op.body.gaze(op.q(x), op.head_yaw_pitch(x)), atol=1e-12)


def test_errors():
    body = BodyModel()
    task = OperatorTask("a", [GOAL], "right", lambda rng: 1.0)
    rest = body.rest_q((1.05, 0.0), np.pi)
    with pytest.raises(ValueError, match="unknown actions"):
        SyntheticOperator(body, {"a": task}, ["b"], rest, np.random.default_rng(0))
    with pytest.raises(ValueError, match="hand"):
        SyntheticOperator(body, {"a": OperatorTask("a", [GOAL], "foot", task.duration_sampler)}, ["a"], rest,
                          np.random.default_rng(0))
    with pytest.raises(ValueError, match="goals"):
        short_goal = OperatorTask("a", [[1, 2]], "left", task.duration_sampler)
        SyntheticOperator(body, {"a": short_goal}, ["a"], rest, np.random.default_rng(0))
    op = SyntheticOperator(body, {"a": task}, ["a"], rest, np.random.default_rng(0))
    op.update(1.0)
    with pytest.raises(ValueError, match="backwards"):
        op.update(0.5)
    bad = SyntheticOperator(body, {"a": OperatorTask("a", [GOAL], "right", lambda rng: -1.0)}, ["a"], rest,
                            np.random.default_rng(0))
    with pytest.raises(ValueError, match="duration"):
        bad.update(0.0)


def test_samplers():
    rng = np.random.default_rng(0)
    assert sampler_from_distribution(Distribution("fixed", mean=2.5))(rng) == 2.5
    u = [sampler_from_distribution(Distribution("uniform", low=1, high=2))(rng) for _ in range(200)]
    assert 1 <= min(u) and max(u) <= 2
    normal = sampler_from_distribution(Distribution("normal", mean=1.0, std=1.0, low=0.8))
    n = [normal(rng) for _ in range(200)]
    assert min(n) >= 0.8
    ln = [sampler_from_distribution(Distribution("lognormal", mean=3.0, std=0.5))(rng) for _ in range(4000)]
    assert np.mean(ln) == pytest.approx(3.0, rel=0.03) and np.std(ln) == pytest.approx(0.5, rel=0.1)
    e = {sampler_from_distribution(Distribution("empirical", samples=[1.0, 2.0]))(rng) for _ in range(50)}
    assert e == {1.0, 2.0}
    triangular = sampler_from_distribution(Distribution("triangular", low=1, mode=2, high=4))
    tri = [triangular(rng) for _ in range(200)]
    assert 1 <= min(tri) and max(tri) <= 4
    with pytest.raises(ValueError, match="unknown distribution"):
        sampler_from_distribution(Distribution("gamma"))
    with pytest.raises(ValueError, match="low <= high"):
        sampler_from_distribution(Distribution("uniform", low=2, high=1))


def test_tasks_from_schema():
    action = OperatorAction("pick", ["buf", "goal"], "right", Distribution("fixed", mean=2))
    op_schema = Operator(actions=[action])
    tasks = tasks_from_schema(op_schema, {"buf": BUFFER, "goal": GOAL})
    assert tasks["pick"].hand == "right" and len(tasks["pick"].goals) == 2
    np.testing.assert_allclose(tasks["pick"].goals[1], GOAL)
    assert tasks["pick"].duration_sampler(np.random.default_rng()) == 2
    with pytest.raises(ValueError, match="unknown goal 'goal'"):
        tasks_from_schema(op_schema, {"buf": BUFFER})


def test_request_protocol_waits_for_the_worlds_answer():
    from hrc_drake.messages import WorldSnapshot

    op = make_operator()
    nobody = WorldSnapshot()
    assert op.update(0.0, nobody) == [] and op.state == "requesting"
    (request,) = op.new_requests
    assert (request.kind, request.action, request.agent, request.seq) == ("start", "pick_place", "human", 1)
    # no answer yet: nothing happens, no request is repeated
    assert op.update(0.1, nobody) == [] and op.new_requests == ()
    assert not op.will_change(0.1, nobody)
    # refused: the operator waits, once
    refused = WorldSnapshot(refused={"human": 1})
    assert [e.kind for e in op.update(0.2, refused)] == ["wait_begin"] and op.state == "waiting"
    assert op.update(0.3, refused) == []
    # granted: the wait ends and the action begins at the time the operator learns it
    granted = WorldSnapshot(granted={"human": 1}, refused={"human": 1})
    assert op.will_change(0.4, granted)
    events = op.update(0.4, granted)
    assert [(e.kind, e.time) for e in events] == [("wait_end", 0.4), ("begin", 0.4)]
    # at its end the operator reports the finish and asks for the next action
    end = events[-1].time + 10.0
    events = op.update(end, granted)
    assert [e.kind for e in events] == ["end"]
    assert [(r.kind, r.action) for r in op.new_requests] == [("finish", "pick_place"), ("start", "screw")]


@pytest.mark.parametrize("hands", [("right",), ("left", "right")])
def test_the_ik_jacobian_is_the_derivative_of_its_residual_also_at_the_bounds(hands):
    op = make_operator()
    q0 = op.rest_config
    apart = 0.1 * BOTH_HANDS_OFFSET
    targets = [GOAL] if len(hands) == 1 else [SCREW + apart, SCREW - apart]
    free, _, _, residual, jacobian, lower, upper = op._wrist_problem(hands, targets, q0)
    rng = np.random.default_rng(3)
    points = [lower + rng.uniform(0.1, 0.9, len(free)) * (upper - lower) for _ in range(3)]
    points.append(np.where(np.isfinite(upper), upper, 1.0))  # every joint at its upper bound
    for x in points:
        central = np.empty((len(residual(x)), len(free)))
        for j in range(len(free)):
            h = np.zeros(len(free))
            h[j] = 1e-6
            central[:, j] = (residual(x + h) - residual(x - h)) / 2e-6
        assert jacobian(x).shape == central.shape
        np.testing.assert_allclose(jacobian(x), central, atol=2e-6 * max(1.0, np.abs(x).max()) + 1e-6)
