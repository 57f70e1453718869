"""Contract examples of the cell systems (see tests/contract.py)."""

from functools import cache

import numpy as np
from pydrake.geometry import Meshcat, SceneGraph
from pydrake.multibody.plant import MultibodyPlant

from hrc_drake.cell.replay import ReplayMarkers
from hrc_drake.cell.schema import Goal, Layout, Scenario
from hrc_drake.cell.systems import (
    CellWorldSystem,
    HumanCapsules,
    HumanGeometry,
    MetricsRecorder,
    MinOverride,
    RobotCapsules,
)
from hrc_drake.cell.world import CellWorld
from hrc_drake.human.body import BodyModel
from hrc_drake.intention.bayes import IntentionEvent
from hrc_drake.messages import (
    HUMAN_AGENT,
    AgentActivity,
    Capsules,
    EventLog,
    HumanEvent,
    RobotEvent,
    SkeletonEstimate,
    SkeletonFrame,
    SweptVolumes,
    WorldRequest,
    WorldSnapshot,
)
from hrc_drake.robots.config import Pose, Robot
from hrc_drake.robots.models import RobotCapsuleKinematics, add_robot
from hrc_drake.scheduling.flow import Buffer, FlowAction
from tests.contract import SystemExample

BODY = BodyModel()


def _q(x: float, arm: float) -> np.ndarray:
    """The operator standing at (x, 0) facing the robot (-x), right shoulder flexed by `arm`."""
    q = BODY.rest_q((x, 0.0), np.pi)
    q[8] = arm
    return q


def human_capsules() -> SystemExample:
    system = HumanCapsules(BODY, source="q")
    return SystemExample(system, {"q": _q(1.05, 0.2)}, {"q": _q(0.9, 1.0)}, duration=0.2)


def human_capsules_from_points() -> SystemExample:
    system = HumanCapsules(BODY, source="points")
    return SystemExample(system, {"skeleton": BODY.points(_q(1.05, 0.2)).ravel()},
                         {"skeleton": BODY.points(_q(0.9, 1.0)).ravel()}, duration=0.2)


def human_geometry() -> SystemExample:
    """Stands alone beside a SceneGraph it registers with (no diagram needed for its own contract)."""
    system = HumanGeometry(SceneGraph(), BODY)
    return SystemExample(system, {"capsules": Capsules(*BODY.capsules(_q(1.05, 0.2)))},
                         {"capsules": Capsules(*BODY.capsules(_q(0.9, 1.0)))}, duration=0.2)


@cache
def _irb140():
    """A continuous plant with one IRB 140 (6 joints; cheaper than the YuMi) and its capsules."""
    plant = MultibodyPlant(0.0)
    instance = add_robot(plant, "irb140", "irb", (0.0, 0.0, 0.0))
    plant.Finalize()
    return plant, RobotCapsuleKinematics(plant, [(instance, "irb140")])


def robot_capsules() -> SystemExample:
    """Input "positions" is longer than nq (e.g. a plant state [q, v]): only the first nq count."""
    plant, kinematics = _irb140()
    nq = plant.num_positions()
    system = RobotCapsules(plant, kinematics, 2 * nq)
    bent = np.zeros(2 * nq)
    bent[:3] = [0.5, 0.4, -0.3]
    return SystemExample(system, {"positions": np.zeros(2 * nq)}, {"positions": bent}, duration=0.2)


def _world() -> CellWorld:
    """raw -(human "fetch")-> tray (capacity 1) -(arm "mount")-> product."""
    return CellWorld(
        [Buffer(name="raw", kind="raw"), Buffer(name="tray", capacity=1), Buffer(name="out", kind="product")],
        [
            FlowAction(name="fetch", agents=[HUMAN_AGENT], inputs=["raw"], outputs=["tray"]),
            FlowAction(name="mount", agents=["arm"], inputs=["tray"], outputs=["out"]),
        ],
    )


def cell_world_system() -> SystemExample:
    """A: the operator asks to fetch a part (granted: the tray's room is reserved) and the arm asks
    to mount one (refused: the tray is empty, the request stays pending). B: only the arm asks
    (refused)."""
    system = CellWorldSystem(_world(), [HUMAN_AGENT, "robot"], period=0.02)
    human = EventLog((WorldRequest(0.0, HUMAN_AGENT, "fetch", "start", 1),))
    arm = EventLog((WorldRequest(0.0, "arm", "mount", "start", 1),))
    return SystemExample(
        system,
        {"requests_human": human, "requests_robot": arm,
         "robot_activity": AgentActivity((("arm", "request:mount"),))},
        {"requests_human": EventLog(), "requests_robot": arm,
         "robot_activity": AgentActivity((("arm", "wait:mount"),))},
        duration=0.2,
    )


def min_override() -> SystemExample:
    system = MinOverride(2)
    return SystemExample(system, {"override_0": [0.4], "override_1": [0.9]},
                         {"override_0": [1.0], "override_1": [0.2]}, duration=0.2)


def _recorder_inputs(x: float, human: tuple, products: int, override: float) -> dict:
    q = _q(x, 0.4)
    robot = Capsules(np.array([[0.3, 0.0, 0.8]]), np.array([[0.5, 0.1, 1.0]]), np.array([0.06]))
    return {
        "human_events": EventLog(human),
        "robot_events": EventLog((RobotEvent(0.0, "arm", "mount", "begin", 1),)),
        "intention_events": EventLog((IntentionEvent(0.05, "right", "tray", seq=1),)),
        "human_points": BODY.points(q).ravel(),
        "human_capsules": Capsules(*BODY.capsules(q)),
        "robot_capsules": robot,
        "speed_override": [override],
        "world": WorldSnapshot(time=0.0, buffers={"tray": 1}, finished_products=products),
    }


def metrics_recorder() -> SystemExample:
    """No outputs: what it records is its state, read with `log(context)`. With nothing to
    compare on output ports, inputs_matter=False; tests/cell/test_cell_systems.py runs the same
    contract on `log(context)` (A and B record different events, distances and overrides)."""
    system = MetricsRecorder(period=0.1)
    fetched = (HumanEvent(0.0, "fetch", "begin", 1), HumanEvent(0.2, "fetch", "end", 2))
    a = _recorder_inputs(1.05, fetched, 0, 1.0)
    b = _recorder_inputs(0.8, (HumanEvent(0.0, "fetch", "wait_begin", 1),), 1, 0.3)
    return SystemExample(system, a, b, duration=0.5, inputs_matter=False)


@cache
def _meshcat() -> Meshcat:
    """One Meshcat server for every example (each one opens a port)."""
    return Meshcat()


def _scenario() -> Scenario:
    return Scenario(
        layout=Layout(
            goals=[Goal(name="tray", center=[0.5, 0.2, 0.8]), Goal(name="fixture", center=[0.4, -0.2, 0.8])],
            buffers=[Buffer(name="tray", capacity=2, position=[0.5, 0.2, 0.76])],
        ),
        robots=[Robot(name="yumi", base=Pose(xyz=[0.0, 0.0, 0.75]))],
    )


def _markers_inputs(goal: str, parts: int, override: float, x: float) -> dict:
    points = BODY.points(_q(x, 0.4))
    tracked = np.ones(8, dtype=bool)
    tracked[6] = False
    measured = points.copy()
    measured[6] = np.nan
    return {
        "world": WorldSnapshot(time=0.0, buffers={"tray": parts}),
        "skeleton_frame": SkeletonFrame(time=0.0, points=measured, tracked=tracked),
        "skeleton_estimate": SkeletonEstimate(time=0.0, points=points, spread=np.full(8, 0.05),
                                              tracked=tracked),
        "intention_events": EventLog((IntentionEvent(0.0, "right", goal, seq=1),)),
        "swept_volumes": SweptVolumes(time=0.0, names=("torso",), start=points[[0]], end=points[[1]],
                                      radius=np.array([0.2]), horizon=0.3),
        "speed_override": [override],
    }


def replay_markers() -> SystemExample:
    """No outputs (it draws in Meshcat): its run is its state, the goals flashing after intention
    events. inputs_matter=False as there is no output to compare; A makes "tray" flash and B
    "fixture", and tests/cell/test_cell_systems.py runs the contract on that state."""
    system = ReplayMarkers(_scenario(), _meshcat(), fps=20.0, show_skeleton=True, show_swept=True)
    return SystemExample(system, _markers_inputs("tray", 1, 1.0, 1.05),
                         _markers_inputs("fixture", 2, 0.3, 0.9), duration=0.5, inputs_matter=False)


EXAMPLES = {
    HumanCapsules: human_capsules,
    HumanGeometry: human_geometry,
    RobotCapsules: robot_capsules,
    CellWorldSystem: cell_world_system,
    MinOverride: min_override,
    MetricsRecorder: metrics_recorder,
    ReplayMarkers: replay_markers,
}
#: More examples of one class (the contract test takes one per class; tests/cell use these).
MORE_EXAMPLES = {"human_capsules_from_points": human_capsules_from_points}
