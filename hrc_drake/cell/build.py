"""Build a cell diagram from a scenario (DESIGN.md "Data flow of a cell").

`build_cell` wires the robot plant (kinematic or discrete dynamic), path follower and task
executor, the operator (synthetic or recorded), depth camera, optional tracker / intention /
predictor / scheduler / motion systems, the metrics recorder and, when asked, Meshcat.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams, Role, SceneGraph
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource, MatrixGain
from pydrake.systems.rendering import MultibodyPositionToGeometryPose

from hrc_drake.allocator import keep_freed_memory
from hrc_drake.cell import plugins
from hrc_drake.cell.replay import add_replay_markers, initial_view
from hrc_drake.cell.scenario import ScenarioError, operator_places, scenario_relative
from hrc_drake.cell.schema import Scenario
from hrc_drake.cell.systems import (
    CellWorldSystem,
    HumanCapsules,
    HumanGeometry,
    MetricsRecorder,
    MinOverride,
    RobotCapsules,
    register_scene,
    use_coarse_perception_meshes,
)
from hrc_drake.cell.world import CellWorld
from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import DepthCameraModel, RenderedCameraModel
from hrc_drake.human.config import RenderedDepthCamera
from hrc_drake.human.systems import DepthCamera, add_rendered_camera
from hrc_drake.intention.config import NoActionDetector, NoIntention
from hrc_drake.messages import EventLog
from hrc_drake.motion.config import NoMotionModel, NoProactivePlanner
from hrc_drake.perception.config import NoTracker
from hrc_drake.robots.description import robot_record
from hrc_drake.robots.executor import ArmAgent, RobotMove, TaskExecutor
from hrc_drake.robots.models import (
    RobotCapsuleKinematics,
    add_robots,
    arm_joint_limits,
    arm_position_indices,
    set_pd_gains,
)
from hrc_drake.robots.path import JointPathFollower
from hrc_drake.robots.poses import solve_named_poses
from hrc_drake.robots.systems import PathFollower, RobotTaskExecutor
from hrc_drake.scheduling.config import COLLABORATION_SCHEDULERS, NoScheduler


@dataclass
class Cell:
    """A built cell: the diagram (a description; every run lives in its own Context) and what
    a run needs to read back. Systems are found by name (`system`); the diagram exports its main
    ports: "human_events" (the truth), "robot_events", "speed_override", "positions",
    "skeleton_estimate" (where the cell perceives the human: a tracker, intention, action
    detector or motion model), "perceived_events" (where it has an action detector),
    "world" (the truth's `WorldSnapshot`)."""

    diagram: object
    scenario: Scenario
    plant: MultibodyPlant
    scene_graph: SceneGraph
    body: BodyModel
    agents: list[str]
    #: flow action -> the product buffers (types) it puts a finished product in
    product_actions: dict[str, tuple[str, ...]]
    #: flow actions of several agents -> their agents (a product is done when the last ends)
    shared_actions: dict[str, tuple[str, ...]] = field(default_factory=dict)
    meshcat: object = None
    visualizer: object = None
    #: the scenario file it was built from
    scenario_path: str = "<scenario>"

    def system(self, name: str):
        """The subsystem called `name` (e.g. "metrics", "cell_world", "tracker", "scheduler")."""
        return self.diagram.GetSubsystemByName(name)

    def has_system(self, name: str) -> bool:
        return self.diagram.HasSubsystemNamed(name)

    @property
    def recorder(self) -> MetricsRecorder:
        return self.system("metrics")

    @property
    def executor(self) -> RobotTaskExecutor:
        return self.system("robot_task_executor")

    @property
    def world_system(self) -> CellWorldSystem:
        return self.system("cell_world")

    def world(self, root_context):
        """The `CellWorld` (truth) of a run, from the diagram's root context."""
        world_system = self.world_system
        return world_system.world(world_system.GetMyContextFromRoot(root_context))

    def safety(self, root_context) -> dict:
        """The ISO/TS 15066 verdict and figures of a run (`safety.verdict.summarize`): verdict code
        and line, violations by kind with their episodes, SSM breach time, stops, contacts."""
        monitor = self.system("safety_monitor")
        stops = 0
        if self.has_system("safety_controller"):
            controller = self.system("safety_controller")
            stops = controller.protective_stops(controller.GetMyContextFromRoot(root_context))
        return monitor.summary(monitor.GetMyContextFromRoot(root_context), stops)

    def safety_trace(self, root_context):
        """The judge's samples (time, min clearance, clearance and S_p of the SSM pair nearest its
        S_p, in breach) and its episodes (violations and logged contacts)."""
        monitor = self.system("safety_monitor")
        context = monitor.GetMyContextFromRoot(root_context)
        return list(monitor.run(context).trace), monitor.episodes(context)

    def log(self, root_context):
        """The `MetricsLog` of a run, from the diagram's root context."""
        recorder = self.recorder
        log = recorder.log(recorder.GetMyContextFromRoot(root_context))
        if self.has_system("scheduler"):
            scheduler = self.system("scheduler")
            context = scheduler.GetMyContextFromRoot(root_context)
            log.decisions = list(scheduler.GetOutputPort("robot_commands").Eval(context).events)
        return log


#: rate (Hz) of the operator's logic and the path follower: the camera's 30 Hz, so that their
#: updates share the simulator's steps (each distinct event time costs a step)
CELL_RATE = 30.0
#: period (s) of the robot task executor's decisions
EXECUTOR_PERIOD = 0.1
def _add_robots(plant, scenario: Scenario, scenario_path):
    return add_robots(plant, scenario.robots, scenario_path)


def _product_actions(scenario: Scenario) -> dict[str, tuple[str, ...]]:
    """Each flow action that finishes products -> the product buffers it puts one product in."""
    kinds = {b.name: b.kind for b in scenario.layout.buffers}
    out = {}
    for a in scenario.flow.actions:
        products = tuple(b for b in a.outputs if kinds.get(b) == "product")
        if products:
            out[a.name] = products
    return out


def _operator_system(scenario: Scenario, body: BodyModel, rng):
    from hrc_drake.human.operator import SyntheticOperator, tasks_from_schema
    from hrc_drake.human.systems import OperatorSource

    op = scenario.operator
    tasks = tasks_from_schema(op, operator_places(scenario))
    rest_q = body.rest_q(base_xy=op.base.xyz[:2], yaw=op.base.rpy[2])
    operator = SyntheticOperator(body, tasks, list(op.pattern), rest_q, rng, agent=op.name,
                                 **plugins.operator_behaviour(scenario))
    return OperatorSource(operator, rate=CELL_RATE)


def _recorded_source(scenario: Scenario, scenario_path):
    """The recorded skeleton file of the scenario, relative to the scenario's folder."""
    from hrc_drake.human.recorded import load_skeleton_csv
    from hrc_drake.human.systems import RecordedSkeletonSource

    path = scenario_relative(scenario_path, scenario.operator.recorded)
    if not path.is_file():
        raise ScenarioError(scenario_path, "operator.recorded", f"no such file: {path}")
    try:
        times, points, tracked = load_skeleton_csv(path)
    except ValueError as err:
        raise ScenarioError(scenario_path, "operator.recorded", str(err)) from err
    return RecordedSkeletonSource(times, points, tracked)


def _add_plant(builder, scenario: Scenario, scenario_path):
    """The robots' plant: kinematic (positions imposed, no dynamics) or a discrete plant with PD joints."""
    if any(r.mode == "dynamic" for r in scenario.robots):
        plant, scene_graph = AddMultibodyPlantSceneGraph(
            builder, time_step=min(r.time_step for r in scenario.robots)
        )
        robots = _add_robots(plant, scenario, scenario_path)
        for instance, robot in robots:
            set_pd_gains(plant, instance, model=robot_record(robot, scenario_path))
        plant.Finalize()
        return plant, scene_graph, robots, True
    scene_graph = builder.AddSystem(SceneGraph())
    plant = MultibodyPlant(0.0)
    plant.RegisterAsSourceForSceneGraph(scene_graph)
    robots = _add_robots(plant, scenario, scenario_path)
    plant.Finalize()
    return plant, scene_graph, robots, False


def _add_robot_motion(builder, plant, scene_graph, robots, records, dynamic, named_poses, use_scheduler, flow,
                      hold_new_paths: bool = False, preview: dict | None = None):
    """Task executor and path follower of every arm agent, driving the plant. An arm on a
    flow action of several agents stays on it until all are done, unless released early.

    Returns the executor, follower, arm agents and the port (and its size) whose first nq
    entries are the robots' current positions.
    """
    q0 = np.zeros(plant.num_positions())
    arm_indices, v_max, agents, moves = [], [], [], {}
    for instance, robot in robots:
        for arm in robot.arms:
            idx = arm_position_indices(plant, instance, records[robot.name], arm.arm)
            _, _, vel = arm_joint_limits(plant, instance, records[robot.name], arm.arm)
            if arm.home:
                q0[idx] = named_poses[(robot.name, arm.home)]
            agents.append(ArmAgent(arm.agent, len(arm_indices), list(arm.program)))
            arm_indices.append(idx)
            v_max.append(vel)
        for action in robot.actions:
            waypoints = np.array([named_poses[(robot.name, p)] for p in action.poses])
            move = RobotMove(waypoints, np.full(len(waypoints), action.dwell))
            # an action may have a part per arm (a two-arm action): each arm agent its own
            for arm in robot.arms:
                if arm.arm == action.arm:
                    moves[(arm.agent, action.name)] = move
    arm_agents = {a.agent for a in agents}
    holds = {(agent, a.name) for a in flow.actions if len(a.agents) > 1
             for agent in a.agents if agent in arm_agents and agent not in a.early_release}
    follower = builder.AddSystem(
        PathFollower(JointPathFollower(q0, arm_indices, v_max), period=1.0 / CELL_RATE,
                     hold_new_paths=hold_new_paths, **(preview or {}))
    )
    follower.set_name("path_follower")
    executor = builder.AddSystem(
        RobotTaskExecutor(
            TaskExecutor(agents, moves, use_commands=use_scheduler, requests=True, holds=holds),
            period=EXECUTOR_PERIOD,
        )
    )
    executor.set_name("robot_task_executor")
    builder.Connect(executor.GetOutputPort("path_requests"), follower.GetInputPort("path_requests"))
    builder.Connect(follower.GetOutputPort("path_done"), executor.GetInputPort("path_done"))

    nq = plant.num_positions()
    if not dynamic:
        to_pose = builder.AddSystem(MultibodyPositionToGeometryPose(plant))
        builder.Connect(follower.GetOutputPort("positions"), to_pose.get_input_port())
        builder.Connect(to_pose.get_output_port(), scene_graph.get_source_pose_port(plant.get_source_id()))
        return executor, follower, agents, follower.GetOutputPort("positions"), nq
    # The follower's path becomes the desired state [q_d, v_d = 0] of each instance's PD actuators.
    for instance, _ in robots:
        actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(instance)]
        selector = np.zeros((2 * len(actuators), nq))
        for row, actuator in enumerate(actuators):
            selector[row, actuator.joint().position_start()] = 1.0
        gain = builder.AddSystem(MatrixGain(selector))
        builder.Connect(follower.GetOutputPort("positions"), gain.get_input_port())
        builder.Connect(gain.get_output_port(), plant.get_desired_state_input_port(instance))
        plant.SetDefaultPositions(instance, q0[_instance_position_indices(plant, instance)])
    return executor, follower, agents, plant.get_state_output_port(), plant.num_multibody_states()


def camera_model(scenario: Scenario) -> DepthCameraModel:
    """The depth camera of the scenario's layout (thesis 9.1 measurement model)."""
    cam = scenario.layout.camera
    return DepthCameraModel(
        cam.position,
        cam.target,
        [(np.asarray(o.center, float), np.asarray(o.size, float)) for o in scenario.layout.occluders],
        noise_std=cam.noise_std,
        rate=cam.rate,
        margin=cam.margin,
        gaze_valid_angle=cam.gaze_valid_angle,
    )


def rendered_camera_model(scenario: Scenario, body: BodyModel) -> RenderedCameraModel | None:
    """The rendered depth camera of the layout, or None where the camera is the analytic one."""
    cam = scenario.layout.camera
    if not isinstance(cam.sensor, RenderedDepthCamera):
        return None
    return RenderedCameraModel.from_config(cam, cam.sensor, body.capsule_radius)


def _add_human(
    builder, scenario, scenario_path, body, robot_capsules, scene_graph, camera_seed, rng, systems
):
    """The operator (synthetic or recorded), its capsules in SceneGraph and the depth camera.

    Returns the camera (or recorded source), the human-capsules system, the human events port
    and the operator source (None for a recorded skeleton). systems["camera_model"] is the
    analytic camera, or None where the camera reads a rendered depth image (then the tracker
    reads the camera's "depth_frame").
    """
    rendered = rendered_camera_model(scenario, body)
    model = camera_model(scenario)
    systems["camera_model"] = model if rendered is None else None
    operator_source = None
    if scenario.operator.recorded:
        # A recorded skeleton is already a measurement: it stands for the camera.
        camera = builder.AddSystem(_recorded_source(scenario, scenario_path))
        camera.set_name("recorded_skeleton")
        human_capsules = builder.AddSystem(HumanCapsules(body, source="points"))
        builder.Connect(camera.GetOutputPort("skeleton"), human_capsules.get_input_port())
        human_events_port = builder.AddSystem(
            ConstantValueSource(AbstractValue.Make(EventLog()))
        ).get_output_port()
    else:
        operator_source = builder.AddSystem(_operator_system(scenario, body, rng))
        operator_source.set_name("operator")
        human_events_port = operator_source.GetOutputPort("human_events")
        human_capsules = builder.AddSystem(HumanCapsules(body, source="q"))
        builder.Connect(operator_source.GetOutputPort("q"), human_capsules.get_input_port())
        if rendered is None:
            camera = builder.AddSystem(DepthCamera(model, camera_seed))
            camera.set_name("depth_camera")
            builder.Connect(robot_capsules.get_output_port(), camera.GetInputPort("occluding_capsules"))
        else:
            # the robot, body, table, buffers and occluders are in the rendered image
            camera = add_rendered_camera(builder, scene_graph, rendered, camera_seed)
        builder.Connect(operator_source.GetOutputPort("skeleton"), camera.GetInputPort("skeleton"))
        builder.Connect(operator_source.GetOutputPort("gaze"), camera.GetInputPort("gaze"))
    human_capsules.set_name("human_capsules")
    systems["camera"] = camera
    systems["human_events"] = human_events_port
    # A translucent body lets the replay show the tracker's markers inside it.
    color = [0.95, 0.65, 0.45, 0.45] if _has_tracker(scenario) else [0.95, 0.65, 0.45, 1.0]
    human_geometry = builder.AddSystem(HumanGeometry(scene_graph, body, color=color))
    human_geometry.set_name("human_geometry")
    builder.Connect(human_capsules.GetOutputPort("capsules"), human_geometry.get_input_port())
    builder.Connect(
        human_geometry.get_output_port(), scene_graph.get_source_pose_port(human_geometry.source_id)
    )
    return camera, human_capsules, human_events_port, operator_source


def _has_tracker(scenario: Scenario) -> bool:
    return not isinstance(scenario.tracker, NoTracker)


def _perceives(scenario: Scenario) -> bool:
    """Whether the cell estimates the skeleton: a tracker, or a system that reads the estimate
    (without them a "no tracker" estimate would measure the camera for nobody)."""
    from hrc_drake.safety.config import NoSafety

    return (
        _has_tracker(scenario)
        or not isinstance(scenario.safety, NoSafety)
        or not isinstance(scenario.intention, NoIntention)
        or not isinstance(scenario.action_detector, NoActionDetector)
        or not isinstance(scenario.motion_model, NoMotionModel)
        or not isinstance(scenario.proactive_planner, NoProactivePlanner)
    )


def kernel_groups(scenario: Scenario) -> list[str]:
    """The kernel groups (`hrc_drake.kernels.GROUPS`) the cell of `scenario` runs, for
    `kernels.compile_ahead`: the capsule geometry and the body model always, and each optional
    system's own (a motion model tracks the skeleton with the Kalman model of `perception`; the
    waiting times of every activity predictor are `prediction`'s; of the schedulers, those that
    roll out Monte Carlo trials use `scheduling`'s)."""
    from hrc_drake.intention.config import GmmBayesIntention, SegmenterActionDetector
    from hrc_drake.motion.config import WorstCaseMotionModel
    from hrc_drake.perception.config import KalmanTracker, ParticleFilterTracker
    from hrc_drake.prediction.config import NoPredictor
    from hrc_drake.safety.config import NoSafety
    from hrc_drake.scheduling.config import BestOfRolloutsPlanScheduler, MonteCarloScheduler

    wanted = {
        "perception": isinstance(scenario.tracker, ParticleFilterTracker | KalmanTracker)
        or isinstance(scenario.motion_model, WorstCaseMotionModel),
        "motion": isinstance(scenario.motion_model, WorstCaseMotionModel),
        "intention": isinstance(scenario.intention, GmmBayesIntention)
        or isinstance(scenario.action_detector, SegmenterActionDetector),
        "prediction": not isinstance(scenario.predictor, NoPredictor),
        "scheduling": isinstance(scenario.scheduler, MonteCarloScheduler | BestOfRolloutsPlanScheduler),
        "safety": not isinstance(scenario.safety, NoSafety),
    }
    return ["geometry", "human", *(name for name, used in wanted.items() if used)]


def _add_world(builder, scenario: Scenario, operator_source, executor):
    """The truth (`CellWorldSystem`): arbitrates the agents' requests, tells them the answers."""
    world = CellWorld(scenario.layout.buffers, scenario.flow.actions, scenario.flow.resources)
    sources = ["robots"] + (["operator"] if operator_source is not None else [])
    world_system = builder.AddSystem(CellWorldSystem(world, sources, period=1.0 / CELL_RATE))
    world_system.set_name("cell_world")
    snapshot = world_system.GetOutputPort("snapshot")
    builder.Connect(executor.GetOutputPort("world_requests"), world_system.GetInputPort("requests_robots"))
    builder.Connect(executor.GetOutputPort("activity"), world_system.GetInputPort("robot_activity"))
    builder.Connect(snapshot, executor.GetInputPort("world"))
    if operator_source is not None:
        builder.Connect(
            operator_source.GetOutputPort("world_requests"), world_system.GetInputPort("requests_operator")
        )
        builder.Connect(snapshot, operator_source.GetInputPort("world"))
    return world_system


def has_safety_controller(scenario: Scenario) -> bool:
    """Whether the scenario's safety mode runs a controller (any but `NoSafety`)."""
    from hrc_drake.safety.config import NoSafety

    return not isinstance(scenario.safety, NoSafety)


def _add_speed_override(builder, overrides, follower, systems) -> None:
    """The smallest of the speed rules' overrides (1 when there is none) drives the path follower,
    through the ISO/TS 15066 safety controller where the cell has one (`_add_safety`)."""
    min_override = builder.AddSystem(MinOverride(max(len(overrides), 1)))
    min_override.set_name("speed_override")
    for k, port in enumerate(overrides):
        builder.Connect(port, min_override.get_input_port(k))
    if not overrides:
        one = builder.AddSystem(ConstantVectorSource([1.0]))
        builder.Connect(one.get_output_port(), min_override.get_input_port(0))
    systems["requested_override"] = min_override.get_output_port()
    controller = systems.get("safety_controller")
    if controller is None:
        builder.Connect(min_override.get_output_port(), follower.GetInputPort("speed_override"))
    else:
        builder.Connect(min_override.get_output_port(), controller.GetInputPort("requested_override"))
        builder.Connect(controller.GetOutputPort("speed_override"), follower.GetInputPort("speed_override"))
    systems["speed_override"] = follower.GetOutputPort("speed_override_applied")


def capsule_payloads(scenario: Scenario, plant, capsule_kin, scenario_path=None) -> np.ndarray:
    """m_L (K,) of each robot capsule: the payload of the arm whose chain moves it
    (`scenario.arm_payloads`), 0 for a capsule no arm moves (a robot's body)."""
    from hrc_drake.cell.scenario import arm_payloads
    payload = arm_payloads(scenario)
    bodies = [int(b) for b in capsule_kin.capsule_bodies]
    out = np.zeros(len(bodies))
    for robot in scenario.robots:
        instance = plant.GetModelInstanceByName(robot.name)
        model = robot_record(robot, scenario_path or scenario.source_path)
        for arm in robot.arms:
            first = plant.GetJointByName(model.arm(arm.arm).joints[0], instance)
            moved = {int(b) for b in plant.GetBodiesKinematicallyAffectedBy([first.index()])}
            carried = payload.get(arm.agent, 0.0)
            for k, body in enumerate(bodies):
                if body in moved:
                    out[k] = max(out[k], carried)
    return out


def _preview_of(safety) -> dict:
    """The follower's path preview for a predictive safety controller (none otherwise)."""
    steps = safety.preview_steps() if hasattr(safety, "preview_steps") else 0
    return {"preview_steps": steps, "preview_step": safety.preview_step} if steps else {}


def _add_safety(builder, scenario: Scenario, scenario_path, plant, capsule_kin, body, follower,
                positions_port, estimate_port, human_capsules, systems, frame_port=None) -> None:
    """The ISO/TS 15066 safety controller of the scenario's mode and the contact monitor (always:
    a cell without a safety system still has its contacts counted in its verdict); the controller
    reads the camera's measurement (`frame_port`) beside the estimate."""
    from hrc_drake.cell.scenario import judge_values, robot_claims, safety_limits
    from hrc_drake.safety.regions import FixedBox
    from hrc_drake.safety.systems import apply_safety_config

    lay = scenario.layout
    table = lay.table
    fixed = [FixedBox((table.center[0], table.center[1], table.height - 0.5 * table.size[2]),
                      tuple(table.size))]
    fixed += [FixedBox(tuple(o.center), tuple(o.size)) for o in lay.occluders]
    zones = (np.array([z.center for z in lay.collaborative_zones], float).reshape(-1, 3),
             np.array([z.radius for z in lay.collaborative_zones], float))
    swept = systems.get("motion_predictor")
    standard, changed = judge_values(scenario, scenario_path)
    controller, monitor = apply_safety_config(
        scenario.safety, builder, plant=plant, kinematics=capsule_kin, body_model=body,
        limits=safety_limits(scenario, scenario_path), zones=zones, fixed_boxes=tuple(fixed),
        positions=positions_port, velocities_full=follower.GetOutputPort("velocities_full"),
        velocities_full_ahead=follower.GetOutputPort("velocities_full_ahead"),
        positions_full_next=follower.GetOutputPort("positions_full_next"),
        velocities_full_next=follower.GetOutputPort("velocities_full_next"),
        path_preview=follower.GetOutputPort("path_preview"),
        skeleton_estimate=estimate_port, skeleton_frame=frame_port,
        human_capsules=human_capsules.GetOutputPort("capsules"), requested_override=None,
        judge_values=standard, judge_changes=changed,
        payloads=capsule_payloads(scenario, plant, capsule_kin, scenario_path),
        swept_volumes=None if swept is None else swept.GetOutputPort("swept_volumes"),
        swept_horizon=float(getattr(scenario.motion_model, "horizon", 0.0)),
        camera_noise=lay.camera.noise_std, monitor_period=1.0 / CELL_RATE,
        robot_claims=robot_claims(scenario, scenario_path))
    if controller is not None:
        systems["safety_controller"] = controller
    systems["safety_monitor"] = monitor


def _add_recorder(
    builder, world_system, human_events_port, executor, human_capsules, robot_capsules, systems,
    record_forecast: bool = False, safety_distance: float = -np.inf,
):
    """The metrics recorder; `record_forecast`: also the predictor's forecasts (only the use case
    a report plots them: elsewhere the log would grow for nothing); samples under
    `safety_distance` are counted."""
    recorder = builder.AddSystem(MetricsRecorder(safety_distance=safety_distance))
    recorder.set_name("metrics")
    builder.Connect(human_events_port, recorder.GetInputPort("human_events"))
    builder.Connect(executor.GetOutputPort("robot_events"), recorder.GetInputPort("robot_events"))
    builder.Connect(human_capsules.GetOutputPort("points"), recorder.GetInputPort("human_points"))
    builder.Connect(human_capsules.GetOutputPort("capsules"), recorder.GetInputPort("human_capsules"))
    builder.Connect(robot_capsules.get_output_port(), recorder.GetInputPort("robot_capsules"))
    builder.Connect(systems["speed_override"], recorder.GetInputPort("speed_override"))
    builder.Connect(world_system.GetOutputPort("snapshot"), recorder.GetInputPort("world"))
    if "intention" in systems:
        builder.Connect(
            systems["intention"].GetOutputPort("intention_events"), recorder.GetInputPort("intention_events")
        )
    if "perceived_events" in systems:
        builder.Connect(systems["perceived_events"], recorder.GetInputPort("perceived_events"))
    if "predictor" in systems and record_forecast:
        builder.Connect(systems["predictor"].GetOutputPort("forecast"), recorder.GetInputPort("forecast"))
    return recorder


def _add_meshcat(builder, scenario: Scenario, scene_graph, meshcat, systems, replay_fps: float):
    meshcat.Delete()
    meshcat.SetProperty("/Axes", "visible", False)
    # the first view frames the whole cell (robots, table, operator, camera), not just the table
    meshcat.SetCameraPose(*initial_view(scenario))
    params = MeshcatVisualizerParams(publish_period=1.0 / replay_fps, role=Role.kIllustration)
    visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
    add_replay_markers(builder, scenario, meshcat, systems, replay_fps)
    return visualizer


def build_cell(
    scenario: Scenario,
    scenario_path: str | Path | None = None,
    meshcat=None,
    replay_fps: float = 10.0,
    named_poses: dict | None = None,
) -> Cell:
    """Build the cell diagram of `scenario`; with `meshcat`, also a MeshcatVisualizer (live or replay).

    scenario_path: the file whose folder the scenario's file names (a recording, a model) are read
    from, and that reports name; by default the file `load_scenario` read it from
    (`Scenario.source_path`), so `build_cell(load_scenario(path))` needs no second path; for a
    scenario made in code, "<scenario>" (names read from the working folder).

    Also keeps freed heap memory in the process (`allocator.keep_freed_memory`), for simulators
    the caller makes. The numba kernels compile (or load from the disk cache) when a system first
    calls them (`hrc_drake.kernels`): only those of the cell's systems.
    """
    if scenario_path is None:
        scenario_path = scenario.source_path or "<scenario>"
    keep_freed_memory()
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(scenario.seed).spawn(8)]

    def seed(k: int) -> int:
        return int(rngs[k].integers(2**31))

    if named_poses is None:
        named_poses = solve_named_poses(scenario.robots, scenario_path)
    builder = DiagramBuilder()
    plant, scene_graph, robots, dynamic = _add_plant(builder, scenario, scenario_path)
    records = {robot.name: robot_record(robot, scenario_path) for _, robot in robots}
    executor, follower, agents, positions_port, positions_size = _add_robot_motion(
        builder,
        plant,
        scene_graph,
        robots,
        records,
        dynamic,
        named_poses,
        not isinstance(scenario.scheduler, NoScheduler),
        scenario.flow,
        # a safety controller sees a path before it moves (`PathFollower.hold_new_paths`)
        hold_new_paths=has_safety_controller(scenario),
        preview=_preview_of(scenario.safety),
    )
    capsule_kin = RobotCapsuleKinematics(plant, [(inst, records[r.name]) for inst, r in robots])
    robot_capsules = builder.AddSystem(RobotCapsules(plant, capsule_kin, positions_size))
    robot_capsules.set_name("robot_capsules")
    builder.Connect(positions_port, robot_capsules.get_input_port())

    body = BodyModel(scenario.operator.segments)
    systems: dict = {}
    camera, human_capsules, human_events_port, operator_source = _add_human(
        builder, scenario, scenario_path, body, robot_capsules, scene_graph, seed(1), rngs[0], systems
    )
    register_scene(scene_graph, scenario)
    if camera.HasOutputPort("depth_frame"):
        use_coarse_perception_meshes(scene_graph)  # fine capsules would cost ~2 ms each per frame
    world_system = _add_world(builder, scenario, operator_source, executor)
    systems["world"] = world_system.GetOutputPort("snapshot")

    overrides = []
    estimate_port = None
    if _perceives(scenario):
        estimate_port = plugins.add_tracker(
            builder, scenario, camera, systems["camera_model"], robot_capsules, systems, overrides, seed(2)
        )
    plugins.add_intention(builder, scenario, scenario_path, estimate_port, systems, seed(5))
    plugins.add_action_detector(builder, scenario, estimate_port, systems)
    decision_events = plugins.decision_events(scenario, human_events_port, systems)
    plugins.add_predictor(builder, scenario, decision_events, systems)
    plugins.add_scheduler(builder, scenario, decision_events, executor, systems, seed(3))
    plugins.add_motion(
        builder, scenario, body, estimate_port, robot_capsules, follower, systems, overrides, seed(4)
    )
    plugins.add_proactive_planner(builder, scenario, records, named_poses, estimate_port, decision_events,
                                  executor, systems, seed(6))
    # the analytic camera's frame is the measurement with the layout's noise_std, which the
    # controller takes as its spread; a rendered camera's skeleton (extracted from a depth image)
    # has no such bound: there the controller keeps the tracker's estimate and its spread
    frame_port = None
    if estimate_port is not None and systems.get("camera_model") is not None:
        frame_port = camera.GetOutputPort("skeleton_frame")
    _add_safety(builder, scenario, scenario_path, plant, capsule_kin, body, follower, positions_port,
                estimate_port, human_capsules, systems, frame_port)
    _add_speed_override(builder, overrides, follower, systems)
    _add_recorder(builder, world_system, human_events_port, executor, human_capsules, robot_capsules, systems,
                  record_forecast=isinstance(scenario.scheduler, COLLABORATION_SCHEDULERS),
                  safety_distance=scenario.safety_distance)
    visualizer = None
    if meshcat is not None:
        visualizer = _add_meshcat(builder, scenario, scene_graph, meshcat, systems, replay_fps)
    if estimate_port is not None:
        builder.ExportOutput(estimate_port, "skeleton_estimate")
    builder.ExportOutput(human_events_port, "human_events")
    if "perceived_events" in systems:
        builder.ExportOutput(systems["perceived_events"], "perceived_events")
    builder.ExportOutput(executor.GetOutputPort("robot_events"), "robot_events")
    builder.ExportOutput(systems["speed_override"], "speed_override")
    builder.ExportOutput(follower.GetOutputPort("positions"), "positions")
    builder.ExportOutput(world_system.GetOutputPort("snapshot"), "world")
    diagram = builder.Build()
    diagram.set_name("cell")
    return Cell(
        diagram=diagram,
        scenario=scenario,
        plant=plant,
        scene_graph=scene_graph,
        body=body,
        agents=[scenario.operator.name] + [a.agent for a in agents],
        product_actions=_product_actions(scenario),
        shared_actions={a.name: tuple(a.agents) for a in scenario.flow.actions if len(a.agents) > 1},
        meshcat=meshcat,
        visualizer=visualizer,
        scenario_path=str(scenario_path),
    )


def _instance_position_indices(plant, instance) -> np.ndarray:
    """Indices into the plant's q of `instance`'s positions, in the instance's own order."""
    return np.sort(
        np.array(
            [
                plant.get_joint(j).position_start() + k
                for j in plant.GetJointIndices(instance)
                for k in range(plant.get_joint(j).num_positions())
            ],
            dtype=int,
        )
    )
