"""Optional systems of a cell, chosen by the scenario (tracker, intention, predictor, scheduler,
motion model) and the replay's extra markers. With kind "none" a plain default is wired
(DESIGN.md: no tracker -> estimates are the measurements; no scheduler -> fixed programs).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Box as MeshcatBox
from pydrake.geometry import Cylinder, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import LeafSystem

from hrc_drake.cell.scenario import scenario_relative
from hrc_drake.cell.schema import Scenario
from hrc_drake.cell.systems import RobotCapsules, segment_pose
from hrc_drake.messages import EventLog, SkeletonEstimate, SkeletonFrame, SweptVolumes


class MeasurementAsEstimate(LeafSystem):
    """No tracker: the estimate is the last measurement (untracked points keep their last value)."""

    def __init__(self, workspace_center, workspace_size):
        super().__init__()
        self._frame = self.DeclareAbstractInputPort("skeleton_frame", AbstractValue.Make(SkeletonFrame()))
        self._lo = np.asarray(workspace_center, float) - 0.5 * np.asarray(workspace_size, float)
        self._hi = np.asarray(workspace_center, float) + 0.5 * np.asarray(workspace_size, float)
        self._last = np.full((8, 3), np.nan)
        self.DeclareAbstractOutputPort(
            "skeleton_estimate", lambda: AbstractValue.Make(SkeletonEstimate()), self._calc
        )

    def _calc(self, context, output):
        frame = self._frame.Eval(context)
        points = np.where(frame.tracked[:, None], frame.points, self._last)
        self._last = np.where(np.isfinite(points), points, self._last)
        inside = np.all((points >= self._lo) & (points <= self._hi), axis=1)
        output.set_value(
            SkeletonEstimate(
                time=frame.time,
                points=np.nan_to_num(points),
                spread=np.where(frame.tracked, 0.0, np.inf),
                tracked=frame.tracked.copy(),
                workspace_fraction=inside.astype(float),
                gaze=frame.gaze,
                gaze_valid=frame.gaze_valid,
            )
        )


def add_tracker(builder, scenario: Scenario, camera, camera_model, robot_capsules, systems, overrides, seed):
    """The skeleton tracker of Ch. 9 (or the measurement itself); returns the estimate port."""
    lay = scenario.layout
    kind = scenario.tracker.kind
    if kind == "none":
        tracker = builder.AddSystem(MeasurementAsEstimate(lay.workspace_center, lay.workspace_size))
    else:
        from hrc_drake.perception.systems import OcclusionTracker

        tracker = builder.AddSystem(
            OcclusionTracker(
                kind,
                dict(scenario.tracker.params),
                camera_model.is_hidden,
                lay.workspace_center,
                lay.workspace_size,
                rate=lay.camera.rate,
                seed=seed,
            )
        )
        builder.Connect(robot_capsules.get_output_port(), tracker.GetInputPort("occluding_capsules"))
        overrides.append(tracker.GetOutputPort("speed_override"))
    tracker.set_name("tracker")
    builder.Connect(camera.GetOutputPort("skeleton_frame"), tracker.GetInputPort("skeleton_frame"))
    systems["tracker"] = tracker
    return tracker.GetOutputPort("skeleton_estimate")


def add_intention(builder, scenario: Scenario, scenario_path, estimate_port, systems):
    if scenario.intention.kind == "none":
        return
    from hrc_drake.intention.systems import IntentionEstimator

    goals = scenario.layout.goals
    params = dict(scenario.intention.params)
    model = None
    if scenario.intention.model:
        from hrc_drake.intention.likelihood import IntentionModel

        model = IntentionModel.load(scenario_relative(scenario_path, scenario.intention.model))
    estimator = builder.AddSystem(
        IntentionEstimator(
            [g.name for g in goals],
            np.array([g.center for g in goals], float),
            model=model,
            threshold=params.get("threshold", 0.8),
            feedback_sequence=tuple(scenario.intention.names) or None,
        )
    )
    estimator.set_name("intention")
    builder.Connect(estimate_port, estimator.GetInputPort("skeleton_estimate"))
    systems["intention"] = estimator


def add_predictor(builder, scenario: Scenario, human_events_port, systems):
    from hrc_drake.prediction.config import legacy_config
    from hrc_drake.prediction.systems import apply_predictor_config

    # TEMPORARY: until the typed scenario schema lands (kind + params dict -> typed config)
    config = legacy_config(scenario.predictor.kind, scenario.predictor.params, "predictor")
    actions = [a.name for a in scenario.operator.actions]
    predictor = apply_predictor_config(config, builder, human_events=human_events_port, actions=actions)
    if predictor is not None:
        systems["predictor"] = predictor


def add_scheduler(builder, scenario: Scenario, human_events_port, executor, systems, seed):
    from hrc_drake.scheduling.config import legacy_config
    from hrc_drake.scheduling.systems import apply_scheduler_config

    # TEMPORARY: until the typed scenario schema lands (kind + params dict -> typed config)
    config = legacy_config(scenario.scheduler.kind, scenario.scheduler.params, "scheduler")
    scheduler = apply_scheduler_config(
        config,
        builder,
        human_events=human_events_port,
        robot_events=executor.GetOutputPort("robot_events"),
        robot_commands_input=executor.GetInputPort("robot_commands"),
        scenario=scenario,
        seed=seed,
    )
    if scheduler is not None:
        systems["scheduler"] = scheduler


def add_motion(
    builder, scenario: Scenario, body, estimate_port, robot_capsules, follower, systems, overrides, seed
):
    if scenario.motion_model.kind == "none":
        return
    from hrc_drake.motion.systems import HumanMotionPredictor, SpeedScaler

    params = dict(scenario.motion_model.params)
    predictor = builder.AddSystem(HumanMotionPredictor(body, scenario.motion_model.kind, params, seed=seed))
    predictor.set_name("human_motion_predictor")
    scaler = builder.AddSystem(SpeedScaler(params))
    scaler.set_name("speed_scaler")
    builder.Connect(estimate_port, predictor.GetInputPort("skeleton_estimate"))
    builder.Connect(predictor.GetOutputPort("swept_volumes"), scaler.GetInputPort("swept_volumes"))
    builder.Connect(robot_capsules.get_output_port(), scaler.GetInputPort("robot_capsules"))
    # Capsules a moment ahead on the path: only motion toward the operator is slowed (ISO/TS 15066).
    ahead = builder.AddSystem(
        RobotCapsules(
            robot_capsules.plant, robot_capsules.kinematics, follower.GetOutputPort("positions_ahead").size()
        )
    )
    ahead.set_name("robot_capsules_ahead")
    builder.Connect(follower.GetOutputPort("positions_ahead"), ahead.get_input_port())
    builder.Connect(ahead.get_output_port(), scaler.GetInputPort("robot_capsules_ahead"))
    overrides.append(scaler.GetOutputPort("speed_override"))
    systems["motion_predictor"] = predictor
    systems["speed_scaler"] = scaler


class ReplayMarkers(LeafSystem):
    """Animates what SceneGraph does not show: parts in buffers, measured and estimated skeleton
    points, swept volumes and intention flashes, as Meshcat objects recorded with the replay."""

    def __init__(self, scenario: Scenario, meshcat, world, systems, fps: float):
        super().__init__()
        self.meshcat = meshcat
        self.world = world
        self.systems = systems
        self._visible: dict[str, bool] = {}
        self._buffers = {b.name: b for b in scenario.layout.buffers if b.kind == "intermediate"}
        for b in self._buffers.values():
            for k in range(min(b.capacity, 4)):
                path = f"/markers/parts/{b.name}/{k}"
                meshcat.SetObject(path, MeshcatBox(0.035, 0.035, 0.035), Rgba(0.95, 0.75, 0.1, 1.0))
                offset = np.array([0.0, (k - (min(b.capacity, 4) - 1) / 2) * 0.045, 0.025])
                meshcat.SetTransform(path, RigidTransform(np.asarray(b.position, float) + offset))
                meshcat.SetProperty(path, "visible", False)
                self._visible[path] = False
        # Skeleton markers cost ~2 kB per replay frame: only where a tracker makes them worth it.
        self._show_skeleton = scenario.tracker.kind != "none"
        if self._show_skeleton:
            for name, color in (
                ("measured", Rgba(0.1, 0.4, 1.0, 1.0)),
                ("estimated", Rgba(1.0, 0.2, 0.2, 1.0)),
            ):
                for k in range(8):
                    meshcat.SetObject(f"/markers/skeleton/{name}/{k}", Sphere(0.025), color)
                    self._visible[f"/markers/skeleton/{name}/{k}"] = True
            # The belief's spread around a lost point: a unit sphere scaled to 2 standard deviations.
            for k in range(8):
                path = f"/markers/skeleton/spread/{k}"
                meshcat.SetObject(path, Sphere(1.0), Rgba(1.0, 0.3, 0.3, 0.25))
                meshcat.SetProperty(path, "visible", False)
                self._visible[path] = False
        self._frame_port = self.DeclareAbstractInputPort(
            "skeleton_frame", AbstractValue.Make(SkeletonFrame())
        )
        self._estimate_port = self.DeclareAbstractInputPort(
            "skeleton_estimate", AbstractValue.Make(SkeletonEstimate())
        )
        self._goals = {g.name: g for g in scenario.layout.goals}
        for g in self._goals.values():
            meshcat.SetObject(f"/markers/flash/{g.name}", Sphere(g.radius * 1.15), Rgba(1.0, 0.9, 0.1, 0.6))
            meshcat.SetTransform(f"/markers/flash/{g.name}", RigidTransform(np.asarray(g.center, float)))
            meshcat.SetProperty(f"/markers/flash/{g.name}", "visible", False)
            self._visible[f"/markers/flash/{g.name}"] = False
        self._intention_port = self.DeclareAbstractInputPort(
            "intention_events", AbstractValue.Make(EventLog())
        )
        self._flash_until: dict[str, float] = {}
        self._last_intention = 0
        # Swept volumes (thesis 8.1): a unit cylinder per body part, scaled to each capsule's bounds.
        self._swept_port = self.DeclareAbstractInputPort("swept_volumes", AbstractValue.Make(SweptVolumes()))
        self._show_swept = scenario.motion_model.kind != "none"
        if self._show_swept:
            for k in range(6):
                path = f"/markers/swept/{k}"
                meshcat.SetObject(path, Cylinder(1.0, 1.0), Rgba(0.6, 0.2, 0.9, 0.18))
                meshcat.SetProperty(path, "visible", False)
                self._visible[path] = False
        # A lamp above the robot: green at full speed, amber when slowed, red when stopped.
        self._override_port = self.DeclareVectorInputPort("speed_override", 1)
        self._lamps = {
            "full": Rgba(0.1, 0.9, 0.1, 1.0),
            "slow": Rgba(1.0, 0.7, 0.0, 1.0),
            "stop": Rgba(0.9, 0.1, 0.1, 1.0),
        }
        if scenario.robots:
            lamp = np.asarray(scenario.robots[0].base.xyz, float) + [0.0, 0.0, 0.75]
            for name, color in self._lamps.items():
                meshcat.SetObject(f"/markers/speed_lamp/{name}", Sphere(0.04), color)
                meshcat.SetTransform(f"/markers/speed_lamp/{name}", RigidTransform(lamp))
                meshcat.SetProperty(f"/markers/speed_lamp/{name}", "visible", name == "full")
                self._visible[f"/markers/speed_lamp/{name}"] = name == "full"
        else:
            self._lamps = {}
        self.DeclarePeriodicPublishEvent(1.0 / fps, 0.0, self._publish)

    def _set_visible(self, path: str, visible: bool, t: float) -> None:
        if self._visible.get(path) != visible:
            self.meshcat.SetProperty(path, "visible", visible, t)
            self._visible[path] = visible

    def _publish(self, context):
        t = context.get_time()
        for name, b in self._buffers.items():
            count = self.world.parts[name]
            for k in range(min(b.capacity, 4)):
                self._set_visible(f"/markers/parts/{name}/{k}", k < count, t)
        for port, name in ((self._frame_port, "measured"), (self._estimate_port, "estimated")):
            if not self._show_skeleton or not port.HasValue(context):
                continue
            value = port.Eval(context)
            for k in range(8):
                path = f"/markers/skeleton/{name}/{k}"
                p = value.points[k]
                shown = bool(np.all(np.isfinite(p))) and (name == "estimated" or bool(value.tracked[k]))
                if shown:
                    self.meshcat.SetTransform(path, RigidTransform(p), t)
                self._set_visible(path, shown, t)
                if name == "estimated":
                    spread_path = f"/markers/skeleton/spread/{k}"
                    lost = shown and not bool(value.tracked[k]) and np.isfinite(value.spread[k])
                    if lost:
                        radius = float(np.clip(2.0 * value.spread[k], 0.03, 0.6))
                        self.meshcat.SetTransform(spread_path, RigidTransform(p), t)
                        self.meshcat.SetProperty(spread_path, "scale", [radius] * 3, t)
                    self._set_visible(spread_path, lost, t)
        if self._intention_port.HasValue(context):
            for event in self._intention_port.Eval(context).since(self._last_intention):
                self._last_intention = event.seq
                self._flash_until[event.goal] = t + 0.6
        for goal in self._goals:
            self._set_visible(f"/markers/flash/{goal}", self._flash_until.get(goal, -1.0) > t, t)
        if self._show_swept and self._swept_port.HasValue(context):
            self._publish_swept(self._swept_port.Eval(context), t)
        if self._lamps and self._override_port.HasValue(context):
            level = float(self._override_port.Eval(context)[0])
            state = "full" if level >= 0.99 else ("stop" if level <= 0.01 else "slow")
            for name in self._lamps:
                self._set_visible(f"/markers/speed_lamp/{name}", name == state, t)

    def _publish_swept(self, swept, t: float) -> None:
        for k in range(6):
            path = f"/markers/swept/{k}"
            shown = k < len(swept.radius)
            if shown:
                start, end, radius = swept.start[k], swept.end[k], float(swept.radius[k])
                length = float(np.linalg.norm(end - start)) + 2.0 * radius
                self.meshcat.SetTransform(path, segment_pose(start, end), t)
                self.meshcat.SetProperty(path, "scale", [radius, radius, length], t)
            self._set_visible(path, shown, t)


def add_replay_markers(builder, scenario: Scenario, meshcat, world, systems, fps):
    markers = builder.AddSystem(ReplayMarkers(scenario, meshcat, world, systems, fps))
    markers.set_name("replay_markers")
    builder.Connect(systems["camera"].GetOutputPort("skeleton_frame"), markers.GetInputPort("skeleton_frame"))
    builder.Connect(
        systems["tracker"].GetOutputPort("skeleton_estimate"), markers.GetInputPort("skeleton_estimate")
    )
    if "intention" in systems:
        builder.Connect(
            systems["intention"].GetOutputPort("intention_events"), markers.GetInputPort("intention_events")
        )
    if "motion_predictor" in systems:
        builder.Connect(
            systems["motion_predictor"].GetOutputPort("swept_volumes"), markers.GetInputPort("swept_volumes")
        )
    builder.Connect(systems["speed_override"], markers.GetInputPort("speed_override"))
    return markers
