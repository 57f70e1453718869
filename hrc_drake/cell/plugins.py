"""The optional systems of a cell, chosen by the scenario's typed configs (tracker, intention,
predictor, scheduler, motion model), wired by each area's `apply_<x>_config`. A "No..." kind
wires a plain default (DESIGN.md: no tracker -> the estimate is the measurement; no scheduler ->
fixed programs) or nothing.
"""

from __future__ import annotations

import numpy as np

from hrc_drake.cell.scenario import SEGMENTER_LIBRARY_SECONDS, operator_places, scenario_relative
from hrc_drake.cell.schema import Scenario
from hrc_drake.cell.systems import RobotCapsules
from hrc_drake.errors import ConfigError


def add_tracker(builder, scenario: Scenario, camera, camera_model, robot_capsules, systems, overrides, seed):
    """The skeleton tracker of Ch. 9 (or the measurement itself); returns the estimate port."""
    from hrc_drake.perception.config import NoTracker
    from hrc_drake.perception.systems import apply_tracker_config

    lay = scenario.layout
    rate = lay.camera.rate
    if isinstance(scenario.tracker, NoTracker):
        # The measurement stands for the estimate: refresh what it holds at the rate of the
        # fastest system that reads it, so those reads find the camera frame already measured.
        readers = [getattr(c, "rate", 0.0) for c in (scenario.intention, scenario.motion_model)]
        rate = min(rate, max(readers)) if max(readers) > 0 else rate
    # A rendered camera gives the tracker its depth image for L_c1 (eq. 9.10); the analytic one
    # its sight-line test with the robot's capsules.
    rendered = camera.HasOutputPort("depth_frame")
    tracker = apply_tracker_config(
        scenario.tracker,
        builder,
        skeleton_frame=camera.GetOutputPort("skeleton_frame"),
        occluding_capsules=None if rendered else robot_capsules.get_output_port(),
        is_hidden=None if rendered else camera_model.is_hidden,
        depth_frame=camera.GetOutputPort("depth_frame") if rendered else None,
        workspace_center=lay.workspace_center,
        workspace_size=lay.workspace_size,
        rate=rate,
        seed=seed,
    )
    if tracker.HasOutputPort("speed_override"):
        overrides.append(tracker.GetOutputPort("speed_override"))
    systems["tracker"] = tracker
    return tracker.GetOutputPort("skeleton_estimate")


def add_intention(builder, scenario: Scenario, scenario_path, estimate_port, systems, seed):
    """The intended-goal estimator of 3.1 on the estimate, if the scenario has one."""
    from hrc_drake.intention.systems import apply_intention_config

    goals = scenario.layout.goals
    estimator = apply_intention_config(
        scenario.intention,
        builder,
        skeleton_estimate=estimate_port,
        goal_names=[g.name for g in goals],
        goal_centers=np.array([g.center for g in goals], float).reshape(-1, 3),
        model_dir=scenario_relative(scenario_path, "."),
        seed=seed,
    )
    if estimator is not None:
        systems["intention"] = estimator


def add_action_detector(builder, scenario: Scenario, estimate_port, systems):
    """The action detector on the goal regions of the operator's actions (thesis Ch. 2), if the
    scenario has one; systems["perceived_events"] is then its events port."""
    from hrc_drake.cell.scenario import action_regions
    from hrc_drake.intention.config import NoActionDetector, SegmenterActionDetector
    from hrc_drake.intention.systems import apply_action_detector_config

    if isinstance(scenario.action_detector, NoActionDetector):
        return
    if isinstance(scenario.action_detector, SegmenterActionDetector):
        from hrc_drake.intention.systems import apply_segmenter_config

        detector = apply_segmenter_config(scenario.action_detector, builder, skeleton_estimate=estimate_port,
                                          segmenter=fitted_segmenter(scenario), agent=scenario.operator.name)
        systems["action_detector"] = detector
        systems["perceived_events"] = detector.GetOutputPort("human_events")
        return
    regions = action_regions(scenario)
    goals = {g.name: g for g in scenario.layout.goals}
    detector = apply_action_detector_config(
        scenario.action_detector,
        builder,
        skeleton_estimate=estimate_port,
        goal_names=[goal for _, goal in regions],
        goal_centers=np.array([goals[goal].center for _, goal in regions], float).reshape(-1, 3),
        goal_radii=[goals[goal].radius for _, goal in regions],
        actions=[action for action, _ in regions],
        agent=scenario.operator.name,
    )
    if detector is not None:
        systems["action_detector"] = detector
        systems["perceived_events"] = detector.GetOutputPort("human_events")


def pattern_precedence(pattern) -> list[tuple[str, str]]:
    """(before, after) pairs of consecutive actions of an operator's pattern, in the order of their
    first appearance (a pattern that repeats actions gives no cycle)."""
    first = {name: k for k, name in reversed(list(enumerate(pattern)))}
    pairs = []
    for before, after in zip(pattern[:-1], pattern[1:], strict=True):
        if first[before] < first[after] and (before, after) not in pairs:
            pairs.append((before, after))
    return pairs


#: a glance at a robot looks this far above its base: about the middle of a YuMi's body (m;
#: assumption)
ROBOT_LOOK_HEIGHT = 0.35


def operator_behaviour(scenario: Scenario) -> dict:
    """`SyntheticOperator`'s keyword arguments of the scenario's `operator.behaviour`: the
    behaviour, the layout's goals and buffers (glances, aborted reaches) and the robots (glances)."""
    return {
        "behaviour": scenario.operator.behaviour,
        "other_goals": list(operator_places(scenario).values()),
        "robot_points": [np.asarray(r.base.xyz, dtype=float) + np.array([0.0, 0.0, ROBOT_LOOK_HEIGHT])
                         for r in scenario.robots],
    }


def operator_stream(scenario: Scenario, cycles: int, rate: float, seed: int, segments=None,
                    max_seconds: float | None = None):
    """A synthetic operator of the scenario doing `cycles` cycles of its pattern on its own (no
    world: it never waits), sampled at `rate` with the camera's noise: (frames (T, 8, 3), labels
    (T,): the action running at each frame, None between actions). segments: the operator's
    anthropometrics (default the scenario's); the recording stops after `max_seconds`."""
    import warnings

    from hrc_drake.human.body import BodyModel
    from hrc_drake.human.operator import SyntheticOperator, tasks_from_schema

    op = scenario.operator
    body = BodyModel(op.segments if segments is None else segments)
    rng = np.random.default_rng(seed)
    rest_q = body.rest_q(base_xy=op.base.xyz[:2], yaw=op.base.rpy[2])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the cell itself warns once about goals out of reach
        operator = SyntheticOperator(body, tasks_from_schema(op, operator_places(scenario)),
                                     list(op.pattern) * cycles, rest_q, rng, **operator_behaviour(scenario))
    max_seconds = SEGMENTER_LIBRARY_SECONDS if max_seconds is None else max_seconds
    noise = scenario.layout.camera.noise_std
    frames, labels, current = [], [], None
    t, remaining = 0.0, len(op.pattern) * cycles
    while remaining > 0 and t <= max_seconds:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            events = operator.update(t)
        for event in events:
            if event.kind == "begin":
                current = event.action
            elif event.kind == "end" and current is not None:
                current, remaining = None, remaining - 1
        frames.append(operator.points(t) + rng.normal(0.0, noise, (8, 3)))
        labels.append(current)
        t += 1.0 / rate
    return np.array(frames), labels


def library_segments(scenario: Scenario, config):
    """The anthropometrics of the library's operator: the scenario's, arms and shoulders scaled
    by `config.library_arm_scale` and `config.library_shoulder_scale`."""
    import dataclasses

    s = scenario.operator.segments
    return dataclasses.replace(s, upper_arm=config.library_arm_scale * s.upper_arm,
                               forearm=config.library_arm_scale * s.forearm,
                               shoulder_width=config.library_shoulder_scale * s.shoulder_width)


def label_segments(labels) -> list[tuple[int, int, str]]:
    """(start, end, action) of the runs of frames labelled with one action (None: no action)."""
    segments, start = [], 0
    for k in range(1, len(labels) + 1):
        if k == len(labels) or labels[k] != labels[start]:
            if labels[start] is not None:
                segments.append((start, k, labels[start]))
            start = k
    return segments


def segmenter_library(scenario: Scenario, config, seed: int) -> list:
    """The library of 4.1.5 for `SegmenterActionDetector`: [(action, frames (T, 8, 3))], every
    action of `config.training_cycles` cycles of `operator_stream` by the `library_segments`
    operator."""
    frames, labels = operator_stream(scenario, config.training_cycles, config.rate, seed,
                                     library_segments(scenario, config))
    return [(action, frames[start:end]) for start, end, action in label_segments(labels) if end - start >= 2]


def new_segmenter(config, centres, seed: int):
    """An unfitted `Segmenter` with the settings of a `SegmenterActionDetector` config."""
    from hrc_drake.intention.segmentation import GeneticSettings, Segmenter

    genetic = GeneticSettings(population=config.population, generations=config.generations)
    return Segmenter(max(1, int(round(config.window * config.rate))), batch_windows=config.batch_windows,
                     order=config.order, n_bins=config.n_bins, centres=centres, genetic=genetic, seed=seed,
                     observation_potential=config.observation_potential)


def fitted_segmenter(scenario: Scenario):
    """The `Segmenter` of the scenario's `SegmenterActionDetector`, fitted on `segmenter_library`
    with the pattern's precedence (4.1.5); the goal centres are the layout's goals."""
    config = scenario.action_detector
    seed = int(np.random.default_rng([scenario.seed, 4]).integers(2**31))
    centres = np.array([g.center for g in scenario.layout.goals], float).reshape(-1, 3)
    segmenter = new_segmenter(config, centres if len(centres) else None, seed)
    pattern = list(scenario.operator.pattern)
    library = segmenter_library(scenario, config, seed)
    actions = list(dict.fromkeys(pattern))
    missing = sorted(set(actions) - {action for action, _ in library})
    if missing:
        raise ConfigError("action_detector.training_cycles",
                          f"the operator's library (at most {SEGMENTER_LIBRARY_SECONDS:.0f} s of their work) "
                          f"holds no realisation of {missing}: shorter actions are needed")
    return segmenter.fit(library, pattern_precedence(pattern), actions=actions, seed=seed)


def decision_events(scenario: Scenario, human_events_port, systems):
    """The human events the predictor and the scheduler read (scenario `human_events`)."""
    perceived = scenario.human_events == "perceived" or (
        scenario.human_events == "auto" and "perceived_events" in systems)
    return systems["perceived_events"] if perceived else human_events_port


def add_predictor(builder, scenario: Scenario, human_events_port, systems):
    """The activity predictor of Ch. 5 on the human events, if the scenario has one."""
    from hrc_drake.prediction.systems import apply_predictor_config

    predictor = apply_predictor_config(
        scenario.predictor,
        builder,
        human_events=human_events_port,
        actions=[a.name for a in scenario.operator.actions],
    )
    if predictor is not None:
        systems["predictor"] = predictor


def add_scheduler(builder, scenario: Scenario, human_events_port, executor, systems, seed):
    """The robots' scheduler of Ch. 6-7, commanding the task executor, if the scenario has one."""
    from hrc_drake.scheduling.systems import apply_scheduler_config

    scheduler = apply_scheduler_config(
        scenario.scheduler,
        builder,
        human_events=human_events_port,
        robot_events=executor.GetOutputPort("robot_events"),
        robot_commands_input=executor.GetInputPort("robot_commands"),
        scenario=scenario,
        seed=seed,
        forecast=systems["predictor"].GetOutputPort("forecast") if "predictor" in systems else None,
    )
    if scheduler is not None:
        systems["scheduler"] = scheduler


def add_motion(
    builder, scenario: Scenario, body, estimate_port, robot_capsules, follower, systems, overrides, seed
):
    """Swept volumes of the human (8.1) and the speed scaler, if the scenario has a motion model."""
    from hrc_drake.motion.config import NoMotionModel
    from hrc_drake.motion.systems import apply_motion_config

    if isinstance(scenario.motion_model, NoMotionModel):
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
        scenario.motion_model,
        builder,
        speed_scaling=scenario.speed_scaling,
        body_model=body,
        skeleton_estimate=estimate_port,
        robot_capsules=robot_capsules.get_output_port(),
        robot_capsules_ahead=ahead.get_output_port(),
        seed=seed,
    )
    overrides.append(scaler.GetOutputPort("speed_override"))
    systems["motion_predictor"] = predictor
    systems["speed_scaler"] = scaler


def add_proactive_planner(builder, scenario: Scenario, records, named_poses, estimate_port, human_events_port,
                          executor, systems, seed):
    """Proactive paths of thesis 8.2 for the scenario's robot action, if it has a planner: the
    robot arm's chain (its base pose), the nominal path from `start_pose` to the action's last
    pose, the table as the fixed obstacle; the paths go to the task executor."""
    from hrc_drake.motion.config import ProactivePlanner

    config = scenario.proactive_planner
    if not isinstance(config, ProactivePlanner):
        return
    # only now: the planner's modules import scikit-learn and the GPDM (0.5 s of a first run)
    from hrc_drake.motion.proactive import ProactivePlannerCore, nominal_path, table_box
    from hrc_drake.motion.systems import ProactivePlannerSystem
    from hrc_drake.robots.chain import SerialChain
    robot, action = next((r, a) for r in scenario.robots for a in r.actions if a.name == config.robot_action)
    agent = next(arm.agent for arm in robot.arms if arm.arm == action.arm)
    chain = SerialChain.from_model(records[robot.name], action.arm,
                                   base_pose=(robot.base.xyz, robot.base.rpy))
    nominal = nominal_path(named_poses[(robot.name, config.start_pose)],
                           named_poses[(robot.name, action.poses[-1])], config.waypoints)
    table = scenario.layout.table
    hands = {a.name: a.hand for a in scenario.operator.actions}
    core = ProactivePlannerCore(agent, action.name, config.human_actions, hands, nominal, chain,
                                [table_box(table.center, table.size, table.height)], config, rng=seed)
    planner = builder.AddSystem(ProactivePlannerSystem(core, config.rate))
    planner.set_name("proactive_planner")
    builder.Connect(estimate_port, planner.GetInputPort("skeleton_estimate"))
    builder.Connect(human_events_port, planner.GetInputPort("human_events"))
    builder.Connect(executor.GetOutputPort("robot_events"), planner.GetInputPort("robot_events"))
    builder.Connect(planner.GetOutputPort("proactive_paths"), executor.GetInputPort("proactive_paths"))
    systems["proactive_planner"] = planner
