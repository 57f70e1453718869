import numpy as np
import pytest

from hrc_drake.cell.world import CellWorld
from hrc_drake.messages import RobotCommand
from hrc_drake.robots.executor import ArmAgent, RobotMove, TaskExecutor
from hrc_drake.scheduling.flow import Buffer, FlowAction


def make(use_commands=False):
    world = CellWorld(
        [Buffer(name="raw", kind="raw"), Buffer(name="a", capacity=1), Buffer(name="out", kind="product")],
        [
            FlowAction(name="A", agents=["arm"], inputs=["raw"], outputs=["a"]),
            FlowAction(name="B", agents=["arm"], inputs=["a"], outputs=["out"]),
        ],
    )
    moves = {n: RobotMove(np.zeros((1, 2)), np.zeros(1)) for n in ("A", "B")}
    program = [] if use_commands else ["B", "A"]
    ex = TaskExecutor([ArmAgent("arm", 0, program)], moves, world, use_commands=use_commands)
    return ex, world, ex.path_requests


def kinds(ex):
    return [(e.action, e.kind) for e in ex.events]


def test_round_robin_waits_for_parts_then_runs():
    ex, world, requests = make()
    ex.update(0.0, [0])
    assert kinds(ex) == [("B", "wait_begin")]
    # B can never start before A: the program order deadlocks, the arm keeps waiting.
    ex.update(1.0, [0])
    assert kinds(ex) == [("B", "wait_begin")]
    assert ex.activity() == {"arm": "wait:B"}
    world.parts["a"] = 1
    ex.update(2.0, [0])
    assert kinds(ex)[-2:] == [("B", "wait_end"), ("B", "begin")]
    assert (ex.path_requests[0].channel, ex.path_requests[0].seq) == (0, 1)
    ex.update(3.0, [1])
    assert kinds(ex)[-2:] == [("B", "end"), ("A", "begin")]
    assert world.finished_products == 1
    seqs = [e.seq for e in ex.events]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)


def test_scheduler_commands():
    ex, world, requests = make(use_commands=True)
    ex.update(0.0, [0])
    assert kinds(ex) == [("", "ready")]
    ex.update(0.1, [0], (RobotCommand(0.1, "arm", None, seq=1, wait=1.0),))
    assert kinds(ex) == [("", "ready")]
    ex.update(1.2, [0])
    assert kinds(ex)[-1] == ("", "ready")
    ex.update(1.3, [0], (RobotCommand(1.3, "arm", "A", seq=2),))
    assert kinds(ex)[-1] == ("A", "begin")
    # A command already seen is ignored.
    ex.update(1.4, [0], (RobotCommand(1.3, "arm", "A", seq=2),))
    assert sum(1 for k in kinds(ex) if k == ("A", "begin")) == 1
    with pytest.raises(ValueError, match="unknown robot action"):
        ex.update(1.5, [0], (RobotCommand(1.5, "arm", "Z", seq=3),))


def test_program_must_name_known_actions():
    world = CellWorld([], [])
    with pytest.raises(ValueError, match="unknown robot action"):
        TaskExecutor([ArmAgent("arm", 0, ["X"])], {}, world, lambda *r: None)


def test_a_proactive_path_replaces_the_actions_motion_when_it_begins():
    ex, world, _ = make()
    world.parts["a"] = 1
    path = np.array([[0.1, 0.0], [0.2, 0.1], [0.3, 0.0]])
    ex.update(0.0, [0], paths={("arm", "B"): path})
    request = ex.path_requests[0]
    assert request.blended and np.array_equal(request.waypoints, path)
    assert request.dwells.tolist() == [0.0, 0.0, 0.0]  # the action's own (last) dwell
    ex.update(1.0, [1])  # A begins without a path of its own: its move
    request = ex.path_requests[0]
    assert not request.blended and request.waypoints.shape == (1, 2)
