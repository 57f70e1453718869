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
from hrc_drake.perception.systems import MeasurementAsEstimate  # noqa: F401  (moved there; re-exported)


def add_tracker(builder, scenario: Scenario, camera, camera_model, robot_capsules, systems, overrides, seed):
    """The skeleton tracker of Ch. 9 (or the measurement itself); returns the estimate port."""
    from hrc_drake.perception.systems import apply_tracker_config

    lay = scenario.layout
    config = _tracker_config(scenario.tracker)
    tracker = apply_tracker_config(
        config,
        builder,
        skeleton_frame=camera.GetOutputPort("skeleton_frame"),
        occluding_capsules=robot_capsules.get_output_port(),
        is_hidden=camera_model.is_hidden,
        workspace_center=lay.workspace_center,
        workspace_size=lay.workspace_size,
        rate=lay.camera.rate,
        seed=seed,
    )
    if tracker.HasOutputPort("speed_override"):
        overrides.append(tracker.GetOutputPort("speed_override"))
    systems["tracker"] = tracker
    return tracker.GetOutputPort("skeleton_estimate")


# TEMPORARY: until the typed scenario schema lands
def _typed(cls, params: dict, field: str, renames: dict | None = None):
    """A config of `cls` from a flat scenario params dict (numbers), cast to the field types."""
    import dataclasses

    from hrc_drake.errors import ConfigError

    fields = {f.name: f for f in dataclasses.fields(cls)}
    values = {}
    for key, value in params.items():
        name = (renames or {}).get(key, key)
        if name not in fields:
            raise ConfigError(f"{field}.{key}", f"unknown parameter; known: {sorted(fields)}")
        kind = fields[name].type
        if kind in (bool, "bool"):
            values[name] = bool(value)
        elif kind in (int, "int"):
            if float(value) != int(float(value)):
                raise ConfigError(f"{field}.{key}", f"must be an integer, got {value!r}")
            values[name] = int(float(value))
        elif kind in (float, "float"):
            values[name] = float(value)
        else:
            values[name] = value
    config = cls(**values)
    config.validate(field)
    return config


# TEMPORARY: until the typed scenario schema lands
def _tracker_config(options):
    from hrc_drake.perception.config import KalmanTracker, NoTracker, ParticleFilterTracker

    if options.kind == "none":
        return NoTracker()
    params = dict(options.params)
    renames = {"threshold": "slow_down_threshold", "slow": "slow_factor"}
    if options.kind == "kalman":
        # The old flat dict accepted the particle filter's keys for the KF too; they did nothing.
        for key in ("particles", "crown", "systematic", "bootstrap_tracked", "calibration_frames", "gate"):
            params.pop(key, None)
        return _typed(KalmanTracker, params, "tracker.params", renames)
    params.pop("confidence", None)
    return _typed(ParticleFilterTracker, params, "tracker.params", renames)


def add_intention(builder, scenario: Scenario, scenario_path, estimate_port, systems):
    from hrc_drake.intention.config import GmmBayesIntention, NoIntention
    from hrc_drake.intention.systems import apply_intention_config

    # TEMPORARY: until the typed scenario schema lands (kind + params dict -> typed config)
    options = scenario.intention
    if options.kind == "none":
        config = NoIntention()
    else:
        config = _typed(GmmBayesIntention, dict(options.params), "intention.params")
        config.model = options.model
        config.feedback_sequence = list(options.names)
    goals = scenario.layout.goals
    estimator = apply_intention_config(
        config,
        builder,
        skeleton_estimate=estimate_port,
        goal_names=[g.name for g in goals],
        goal_centers=np.array([g.center for g in goals], float).reshape(-1, 3),
        model_dir=scenario_relative(scenario_path, "."),
        seed=scenario.seed,
    )
    if estimator is not None:
        systems["intention"] = estimator


def add_predictor(builder, scenario: Scenario, human_events_port, systems):
    if scenario.predictor.kind == "none":
        return
    from hrc_drake.prediction.systems import ActivityPredictor

    actions = [a.name for a in scenario.operator.actions]
    params = dict(scenario.predictor.params)
    # A forecast per half second is plenty for actions lasting seconds; each costs a waiting-time tree.
    rate = params.pop("rate", 2.0)
    predictor = builder.AddSystem(
        ActivityPredictor(actions, kind=scenario.predictor.kind, params=params, rate=rate)
    )
    predictor.set_name("activity_predictor")
    builder.Connect(human_events_port, predictor.GetInputPort("human_events"))
    systems["predictor"] = predictor


def add_scheduler(builder, scenario: Scenario, human_events_port, executor, systems, seed):
    if scenario.scheduler.kind == "none":
        return
    from hrc_drake.scheduling.systems import Scheduler, net_from_scenario

    net_keys = ("wait_quantum", "cost_robot", "cost_human")
    params = {k: v for k, v in scenario.scheduler.params.items() if k not in net_keys}
    robots = [arm.agent for robot in scenario.robots for arm in robot.arms]
    scheduler = builder.AddSystem(
        Scheduler(net_from_scenario(scenario), scenario.scheduler.kind, params, robots, seed)
    )
    scheduler.set_name("scheduler")
    builder.Connect(human_events_port, scheduler.GetInputPort("human_events"))
    builder.Connect(executor.GetOutputPort("robot_events"), scheduler.GetInputPort("robot_events"))
    builder.Connect(scheduler.GetOutputPort("robot_commands"), executor.GetInputPort("robot_commands"))
    systems["scheduler"] = scheduler


def add_motion(
    builder, scenario: Scenario, body, estimate_port, robot_capsules, follower, systems, overrides, seed
):
    import dataclasses

    from hrc_drake.motion.config import (
        GPMotionModel,
        NoMotionModel,
        SeparationSpeedScaling,
        WorstCaseMotionModel,
    )
    from hrc_drake.motion.systems import apply_motion_config

    # TEMPORARY: until the typed scenario schema lands. Today one flat dict holds the motion model's
    # and the speed scaler's keys; the kind names the model (gp_a/gp_b/gp_c: models A/B/C of 8.1.2).
    kind = scenario.motion_model.kind
    if kind == "none":
        config = NoMotionModel()
    else:
        params = dict(scenario.motion_model.params)
        scaler_keys = {f.name for f in dataclasses.fields(SeparationSpeedScaling)}
        where = "motion_model.params"
        scaling = _typed(SeparationSpeedScaling, {k: v for k, v in params.items() if k in scaler_keys}, where)
        model = {k: v for k, v in params.items() if k not in scaler_keys}
        if kind == "worst_case":
            # The old flat dict accepted GP keys for worst_case too; they changed nothing.
            gp_only = {"order", "n_trials", "percentile", "refresh_period", "max_samples", "smoothing_window",
                       "min_samples", "max_iter"}
            config = _typed(WorstCaseMotionModel, {k: v for k, v in model.items() if k not in gp_only}, where)
        else:
            config = _typed(GPMotionModel, model, where)
            config.variant = kind[-1].upper()
            config.validate("motion_model")
    if isinstance(config, NoMotionModel):
        return
    # Capsules a moment ahead on the path: only motion toward the operator is slowed (ISO/TS 15066).
    ahead = builder.AddSystem(
        RobotCapsules(
            robot_capsules.plant, robot_capsules.kinematics, follower.GetOutputPort("positions_ahead").size()
        )
    )
    ahead.set_name("robot_capsules_ahead")
    builder.Connect(follower.GetOutputPort("positions_ahead"), ahead.get_input_port())
    predictor, scaler = apply_motion_config(
        config,
        builder,
        speed_scaling=scaling,
        body_model=body,
        skeleton_estimate=estimate_port,
        robot_capsules=robot_capsules.get_output_port(),
        robot_capsules_ahead=ahead.get_output_port(),
        seed=seed,
    )
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
