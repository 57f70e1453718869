"""Optional systems of a cell, chosen by the scenario (tracker, intention, predictor, scheduler,
motion model) and the replay's extra markers. With kind "none" a plain default is wired
(DESIGN.md: no tracker -> estimates are the measurements; no scheduler -> fixed programs).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from hrc_drake.cell.scenario import scenario_relative
from hrc_drake.cell.schema import Scenario
from hrc_drake.cell.systems import RobotCapsules
from hrc_drake.messages import SkeletonEstimate, SkeletonFrame


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
