"""Optional systems of a cell, chosen by the scenario (tracker, intention, predictor, scheduler,
motion model) and the replay's extra markers. With kind "none" a plain default is wired
(DESIGN.md: no tracker -> estimates are the measurements; no scheduler -> fixed programs).
"""

from __future__ import annotations

import numpy as np

from hrc_drake.cell.scenario import scenario_relative
from hrc_drake.cell.schema import Scenario
from hrc_drake.cell.systems import RobotCapsules


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
