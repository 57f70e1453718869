"""Synthetic intention data of a cell: goal layouts and labelled operator recordings (thesis 3.1).

Generators for training and benchmarking the goal estimator (`tools/train_intention.py`,
`tools/bench_intention.py`), built from a loaded scenario (`load_scenario`), so the goals,
operator, camera and operator actions are the scenario's own, checked once by the loader.
They fill the value types of `hrc_drake.intention.dataset` with runs of the synthetic operator
(`hrc_drake.human`), seen by a `DepthCameraModel`.

`box_usb_layout(path)` is the box-with-USB-pen cell of Fig. 3.4 (diagrams/box_usb.yaml: goals
1-5 = home, foam feeders 1 and 2, collaborative station, feeder of boxes and pens);
`second_layout()` is a cell no shipped model was trained on; `random_layout` samples goals in
the operator's reach. The built-in tables' operator stands at `OPERATOR_BASE` facing -x (yaw
pi): their left is -y.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from hrc_drake.cell.scenario import HAND_ABOVE_BUFFER, load_scenario
from hrc_drake.cell.schema import Scenario
from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.human.config import Segments
from hrc_drake.human.operator import OperatorTask, SyntheticOperator
from hrc_drake.intention.dataset import GoalLayout, LayoutTask, Recording
from hrc_drake.messages import HANDS, L_WRIST, R_WRIST

OPERATOR_BASE = (1.05, 0.0)
OPERATOR_YAW = np.pi


def _operator_frame(forward: float, left: float, height: float) -> list[float]:
    """World point `forward` m ahead of the operator's hips, `left` m to its left, at `height`."""
    c, s = np.cos(OPERATOR_YAW), np.sin(OPERATOR_YAW)
    return [OPERATOR_BASE[0] + c * forward - s * left, OPERATOR_BASE[1] + s * forward + c * left, height]


#: An unseen second cell: goals on a shelf-like arc, higher and wider than the box cell.
_SECOND = (
    ("S1", _operator_frame(0.40, 0.35, 1.05), "left"),
    ("S2", _operator_frame(0.50, 0.05, 1.10), "left"),
    ("S3", _operator_frame(0.30, -0.10, 0.95), "right"),
    ("S4", _operator_frame(0.45, -0.40, 1.00), "right"),
    ("S5", _operator_frame(0.25, 0.35, 0.90), "left"),
)


def _from_table(name: str, table) -> GoalLayout:
    return GoalLayout(
        name, tuple(t[0] for t in table), np.array([t[1] for t in table]), tuple(t[2] for t in table)
    )


def layout_from_scenario(scenario: Scenario, name: str = "scenario") -> GoalLayout:
    """Goals, operator base, camera and operator actions of a loaded scenario.

    The usual hand of a goal is the side of the goal as seen by the operator; a buffer reached
    by an operator action is a target `HAND_ABOVE_BUFFER` above the buffer's base, labelled -1.
    """
    goals = scenario.layout.goals
    if not goals:
        raise ValueError(f"{name}: layout.goals is empty; the intention data needs goals")
    names = tuple(g.name for g in goals)
    centers = np.array([g.center for g in goals], dtype=float)
    radius = float(np.mean([g.radius for g in goals]))
    op = scenario.operator
    xyz = np.asarray(op.base.xyz, dtype=float)
    yaw = float(op.base.rpy[2])
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    side = (centers[:, :2] - xyz[:2]) @ left
    hands = tuple("left" if s >= -0.05 else "right" for s in side)
    camera = scenario.layout.camera
    places = {g: (centers[k], k) for k, g in enumerate(names)}
    for b in scenario.layout.buffers:
        places.setdefault(b.name, (np.asarray(b.position, dtype=float) + HAND_ABOVE_BUFFER, -1))
    tasks = []
    for action in op.actions:
        targets = [places[g] for g in action.goals]
        d = action.duration
        tasks.append(
            LayoutTask(
                action.name,
                np.array([t[0] for t in targets]),
                tuple(int(t[1]) for t in targets),
                action.hand,
                (float(d.mean), float(d.std), float(d.low)),
            )
        )
    return GoalLayout(
        name, names, centers, hands, radius, (float(xyz[0]), float(xyz[1]), yaw),
        tuple(float(v) for v in camera.position), tuple(float(v) for v in camera.target),
        tuple(tasks), tuple(op.pattern),
    )


def box_usb_layout(scenario_path: str | Path) -> GoalLayout:
    """Goals 1-5 of thesis 3.1.3 (goal 1 = g1_home, goal 4 = g4_station) of diagrams/box_usb.yaml.

    The scenario is read and checked by `load_scenario` (ScenarioError on any problem).
    """
    path = Path(scenario_path)
    return layout_from_scenario(load_scenario(path), path.stem)


def second_layout() -> GoalLayout:
    """A layout no shipped model was trained on (benchmark of layout independence)."""
    return _from_table("shelf_arc", _SECOND)


def random_layout(rng: np.random.Generator, n_goals: int = 5, min_spacing: float = 0.25) -> GoalLayout:
    """Goals sampled in the operator's reach (forward 0.25-0.6 m, +/-0.5 m sideways, 0.8-1.1 m high)."""
    centers: list[list[float]] = []
    hands = []
    for _ in range(2000):
        forward, left, height = rng.uniform(0.25, 0.6), rng.uniform(-0.5, 0.5), rng.uniform(0.8, 1.1)
        point = np.array(_operator_frame(forward, left, height))
        if all(np.linalg.norm(point - c) >= min_spacing for c in centers):
            centers.append(point.tolist())
            hands.append("left" if left >= 0 else "right")
            if len(centers) == n_goals:
                break
    if len(centers) < n_goals:
        raise ValueError(f"random_layout: cannot place {n_goals} goals {min_spacing} m apart")
    return GoalLayout("random", tuple(f"R{i + 1}" for i in range(n_goals)), np.array(centers), tuple(hands))


def random_segments(rng: np.random.Generator):
    """Anthropometrics of a random adult (+/- ~10 % around the schema defaults)."""
    scale = rng.uniform(0.9, 1.1)
    return Segments(
        torso=0.50 * scale * rng.uniform(0.95, 1.05),
        neck=0.25 * scale,
        shoulder_width=0.40 * scale * rng.uniform(0.93, 1.07),
        upper_arm=0.30 * scale * rng.uniform(0.95, 1.05),
        forearm=0.27 * scale * rng.uniform(0.95, 1.05),
    )


def _noisy_gaze(gaze: np.ndarray, std: float, rng: np.random.Generator) -> np.ndarray:
    noisy = gaze + std * rng.standard_normal(3)
    return noisy / max(np.linalg.norm(noisy), 1e-9)


def _scattered(point: np.ndarray, scatter: float, rng: np.random.Generator) -> np.ndarray:
    """Where this operator really puts the hand for a goal: the centre plus a personal offset."""
    return np.asarray(point, dtype=float) + (scatter * rng.standard_normal(3) if scatter > 0 else 0.0)


def record_reaches(
    layout: GoalLayout,
    segments,
    n_reaches: int,
    rng: np.random.Generator,
    noise_std: float = 0.01,
    gaze_noise: float = 0.1,
    rate: float = 30.0,
    duration_range: tuple[float, float] = (1.2, 2.2),
    pattern: list[int] | None = None,
    hands: tuple[str, ...] | None = None,
    target_scatter: float = 0.0,
    behaviour=None,
    robot_points=(),
) -> Recording:
    """Record `n_reaches` single-goal actions of a synthetic operator in `layout`.

    pattern: goal indices in order (default: random, never the same goal twice in a row);
    hands: the hand per goal, left|right|both (default: layout.hands). Durations are uniform in
    duration_range. target_scatter (m): std of this operator's personal offset from each centre.
    behaviour: the operator's `IdealBehaviour` (None, the default) or `RealisticBehaviour`, whose
    glances and aborted reaches go to the layout's goals and robot_points (3,).
    """
    n_goals = len(layout.goal_names)
    hands = tuple(hands or layout.hands)
    if len(hands) != n_goals:
        raise ValueError(f"record_reaches: {len(hands)} hands for {n_goals} goals")
    if pattern is None:
        pattern = [int(rng.integers(n_goals))]
        while len(pattern) < n_reaches:
            step = int(rng.integers(1, n_goals))
            pattern.append((pattern[-1] + step) % n_goals)
    low, high = duration_range
    tasks, labels = {}, {}
    for i in range(n_goals):
        target = _scattered(layout.centers[i], target_scatter, rng)
        tasks[f"reach_{i}"] = OperatorTask(
            f"reach_{i}", [target], hands[i], lambda r, lo=low, hi=high: float(r.uniform(lo, hi))
        )
        labels[tuple(np.round(target, 6))] = i
    names = [f"reach_{i}" for i in pattern]
    total = high * len(names)
    return _record(layout, segments, tasks, names, labels, total, rng, noise_std, gaze_noise, rate,
                   behaviour, robot_points)


def record_task_cycles(
    layout: GoalLayout,
    segments,
    n_cycles: int,
    rng: np.random.Generator,
    noise_std: float = 0.01,
    gaze_noise: float = 0.1,
    rate: float = 30.0,
    target_scatter: float = 0.0,
    behaviour=None,
    robot_points=(),
) -> Recording:
    """Record `n_cycles` of the scenario's operator pattern (layout.tasks, e.g. fill, foam, bring, tape).

    Each action reaches its targets with its hand(s) as in the cell (thesis 3.1.3); durations
    are normal (mean, std) truncated at `low`; the world never makes the operator wait.
    behaviour, robot_points: as in `record_reaches`.
    """
    if not layout.tasks or not layout.pattern:
        raise ValueError(f"record_task_cycles: layout {layout.name!r} has no operator tasks")
    tasks, labels = {}, {}
    longest = 0.0
    for task in layout.tasks:
        targets = [_scattered(t, target_scatter, rng) for t in task.targets]
        mean, std, low = task.duration
        floor = max(low, 0.3)

        def sampler(r, mean=mean, std=std, low=floor):
            return float(max(r.normal(mean, std), low))

        tasks[task.name] = OperatorTask(task.name, targets, task.hand, sampler)
        for target, label in zip(targets, task.labels, strict=True):
            if label >= 0:
                labels[tuple(np.round(target, 6))] = label
        longest = max(longest, mean + 4 * std)
    names = list(layout.pattern) * int(n_cycles)
    total = longest * len(names)
    return _record(layout, segments, tasks, names, labels, total, rng, noise_std, gaze_noise, rate,
                   behaviour, robot_points)


def _record(layout, segments, tasks, names, labels, total, rng, noise_std, gaze_noise, rate, behaviour=None,
            robot_points=()) -> Recording:
    x, y, yaw = layout.operator_base
    body = BodyModel(segments)
    rest_q = body.rest_q((x, y), yaw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a goal slightly out of a short arm's reach is fine here
        operator = SyntheticOperator(body, tasks, names, rest_q, rng, behaviour=behaviour,
                                     other_goals=list(layout.centers), robot_points=robot_points)
    camera = DepthCameraModel(layout.camera_position, layout.camera_target, noise_std=noise_std, rate=rate)
    times = np.arange(0.0, total, 1.0 / rate)
    count = len(times)
    points = np.empty((count, 8, 3))
    gaze = np.empty((count, 3))
    gaze_valid = np.empty(count, dtype=bool)
    true_wrists = np.empty((count, 2, 3))
    target = np.full((count, 2), -1)
    finished = 0
    for k, t in enumerate(times):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            events = operator.update(t)
        finished += sum(e.kind == "end" for e in events)
        true_points = operator.points(t)
        frame = camera.measure(t, true_points, _noisy_gaze(operator.gaze(t), gaze_noise, rng), rng)
        points[k], gaze[k], gaze_valid[k] = frame.points, frame.gaze, frame.gaze_valid
        true_wrists[k] = true_points[[L_WRIST, R_WRIST]]
        for h, hand in enumerate(HANDS):
            goal = operator.current_goal(hand)
            if goal is not None:
                target[k, h] = labels.get(tuple(np.round(goal, 6)), -1)
        if finished >= len(names):
            count = k + 1
            break
    return Recording(
        times[:count],
        points[:count],
        gaze[:count],
        gaze_valid[:count],
        true_wrists[:count],
        target[:count],
        layout,
    )


