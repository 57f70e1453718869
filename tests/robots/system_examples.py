"""Contract examples of the robot systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.messages import EventLog, PathRequest, PathStatus, RobotCommand, WorldSnapshot
from hrc_drake.robots.executor import ArmAgent, RobotMove, TaskExecutor
from hrc_drake.robots.path import JointPathFollower
from hrc_drake.robots.systems import PathFollower, RobotTaskExecutor
from tests.contract import SystemExample


def path_follower() -> SystemExample:
    """Two arms of two joints each, both at 70 % speed. A and B ask the same waypoints and differ
    only in the dwells of arm 0 (A pauses 0.1 s at its first waypoint, B 0.6 s), so a path
    memoised on the system under a key that leaves out the dwells makes B follow A's path and the
    two runs equal. In 1 s arm 0 of A finishes its path (path_done (1, 0)) while B's still
    lingers at its first waypoint, so the runs cross a path start, a dwell and a path end."""
    follower = JointPathFollower(np.zeros(4), [np.array([0, 1]), np.array([2, 3])],
                                 [np.full(2, 4.0), np.ones(2)])
    system = PathFollower(follower, period=0.02, lookahead=0.1)
    out = np.array([[0.4, 0.2], [0.1, 0.5]])
    back = PathRequest(channel=1, seq=1, waypoints=np.array([[-0.3, 0.3]]), dwells=np.zeros(1))
    pause = PathRequest(channel=0, seq=1, waypoints=out, dwells=np.array([0.1, 0.0]))
    linger = PathRequest(channel=0, seq=1, waypoints=out, dwells=np.array([0.6, 0.0]))
    return SystemExample(
        system,
        {"path_requests": (pause, back), "speed_override": [0.7]},
        {"path_requests": (linger, back), "speed_override": [0.7]},
        duration=1.0,
    )


def robot_task_executor() -> SystemExample:
    """One arm on scheduler commands with the world's request protocol. A: commanded to do "A",
    the world grants its request (the arm begins and asks its path); B: commanded to do "B", the
    world refuses (the arm waits). The path never finishes (path_done stays 0)."""
    moves = {
        "A": RobotMove(np.array([[0.3, 0.1], [0.0, 0.4]]), np.array([0.1, 0.0])),
        "B": RobotMove(np.array([[-0.2, 0.2]]), np.zeros(1)),
    }
    core = TaskExecutor([ArmAgent("arm", 0, [])], moves, use_commands=True, requests=True)
    system = RobotTaskExecutor(core, period=0.02)
    done = PathStatus((0,))
    granting = WorldSnapshot(time=0.0, buffers={"raw": 1}, activity={"arm": "idle"}, granted={"arm": 10**6})
    refusing = WorldSnapshot(time=0.0, buffers={"raw": 0}, activity={"arm": "idle"}, refused={"arm": 10**6})
    return SystemExample(
        system,
        {"path_done": done, "robot_commands": EventLog((RobotCommand(0.0, "arm", "A", seq=1),)),
         "world": granting},
        {"path_done": done, "robot_commands": EventLog((RobotCommand(0.0, "arm", "B", seq=1),)),
         "world": refusing},
        duration=0.3,
    )


EXAMPLES = {PathFollower: path_follower, RobotTaskExecutor: robot_task_executor}
