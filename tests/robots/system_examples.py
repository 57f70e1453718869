"""Contract examples of the robot systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.messages import EventLog, PathRequest, PathStatus, RobotCommand, WorldSnapshot
from hrc_drake.robots.executor import ArmAgent, RobotMove, TaskExecutor
from hrc_drake.robots.path import JointPathFollower
from hrc_drake.robots.systems import PathFollower, RobotTaskExecutor
from tests.contract import SystemExample


def path_follower() -> SystemExample:
    """Two arms of two joints each. A: arm 0 moves out and arm 1 back at full speed;
    B: arm 0 moves elsewhere at half speed (arm 1 has no path). In 1 s arm 1 of A finishes its path
    (path_done (0, 1)), so the runs cross both a path start and a path end."""
    follower = JointPathFollower(np.zeros(4), [np.array([0, 1]), np.array([2, 3])], [np.ones(2), np.ones(2)])
    system = PathFollower(follower, period=0.02, lookahead=0.1)
    out = PathRequest(channel=0, seq=1, waypoints=np.array([[0.4, 0.2], [0.1, 0.5]]),
                      dwells=np.array([0.1, 0.0]))
    back = PathRequest(channel=1, seq=1, waypoints=np.array([[-0.3, 0.3]]), dwells=np.zeros(1))
    other = PathRequest(channel=0, seq=1, waypoints=np.array([[-0.5, 0.1]]), dwells=np.zeros(1))
    return SystemExample(
        system,
        {"path_requests": (out, back), "speed_override": [1.0]},
        {"path_requests": (other,), "speed_override": [0.5]},
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
