"""Labelled reaches recorded from the synthetic operator, for learning L_GMM (thesis 3.1.2).

"We can monitor some operators during the execution of predefined sequences of tasks, collecting
p^R(t), p^L(t), h(t), z(t); knowing the intended goal locations, a population of samples Phi is
extracted." Here the operator is `hrc_drake.human.SyntheticOperator`, seen by a
`DepthCameraModel` (noisy points, gaze flag F); the gaze direction gets an extra angular noise
(a face-plane fit is far noisier than the joints).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hrc_drake.intention.features import (
    DEFAULT_MIN_SPEED,
    DEFAULT_SIGNIFICANCE,
    DEFAULT_WINDOW,
    skeleton_features,
    trajectory_velocities,
)
from hrc_drake.intention.layouts import GoalLayout
from hrc_drake.messages import HANDS, L_WRIST, R_WRIST


@dataclass
class Recording:
    """A measured run of the operator at the camera rate.

    times (T,); points (T, 8, 3) measured (NaN where hidden); gaze (T, 3) measured unit gaze;
    gaze_valid (T,) flag F; true_wrists (T, 2, 3); target (T, 2) index of the goal each hand
    (left, right) is going to, -1 when none; layout: the goals.
    """

    times: np.ndarray
    points: np.ndarray
    gaze: np.ndarray
    gaze_valid: np.ndarray
    true_wrists: np.ndarray
    target: np.ndarray
    layout: GoalLayout


def random_segments(rng: np.random.Generator):
    """Anthropometrics of a random adult (+/- ~10 % around the schema defaults)."""
    from hrc_drake.human.config import Segments

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
) -> Recording:
    """Record `n_reaches` single-goal actions of a synthetic operator in `layout`.

    pattern: goal indices in order (default: random, never the same goal twice in a row);
    hands: the hand per goal, left|right|both (default: layout.hands). Durations are uniform in
    duration_range. target_scatter (m): std of this operator's personal offset from each centre.
    """
    from hrc_drake.human.operator import OperatorTask

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
    return _record(layout, segments, tasks, names, labels, total, rng, noise_std, gaze_noise, rate)


def record_task_cycles(
    layout: GoalLayout,
    segments,
    n_cycles: int,
    rng: np.random.Generator,
    noise_std: float = 0.01,
    gaze_noise: float = 0.1,
    rate: float = 30.0,
    target_scatter: float = 0.0,
) -> Recording:
    """Record `n_cycles` of the scenario's operator pattern (layout.tasks, e.g. fill, foam, bring, tape).

    Each action reaches its targets with its hand(s) as in the cell (thesis 3.1.3); durations
    are normal (mean, std) truncated at `low`; the world never makes the operator wait.
    """
    from hrc_drake.human.operator import OperatorTask

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
    return _record(layout, segments, tasks, names, labels, total, rng, noise_std, gaze_noise, rate)


def _record(layout, segments, tasks, names, labels, total, rng, noise_std, gaze_noise, rate) -> Recording:
    import warnings

    from hrc_drake.human.body import BodyModel
    from hrc_drake.human.camera import DepthCameraModel
    from hrc_drake.human.operator import SyntheticOperator

    x, y, yaw = layout.operator_base
    body = BodyModel(segments)
    rest_q = body.rest_q((x, y), yaw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a goal slightly out of a short arm's reach is fine here
        operator = SyntheticOperator(body, tasks, names, rest_q, rng)
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


def training_samples(
    recording: Recording,
    window: int = DEFAULT_WINDOW,
    min_speed: float = DEFAULT_MIN_SPEED,
    with_gaze_flag: bool = False,
    significance: float = DEFAULT_SIGNIFICANCE,
    approach_only: bool = True,
):
    """Phi (M, 4) for the true goal of every moving, labelled hand sample (thesis 3.1.2).

    approach_only: keep only the samples of each reach from its start to its arrival at the goal
    (`reaches_of`); the dwell at a goal is no reach, and a wrist lingering there teaches the
    mixtures "close to a goal, any direction". With `with_gaze_flag` also the flag F (M,) of
    each sample: (phi, gaze_valid).
    """
    wrists = recording.points[:, [L_WRIST, R_WRIST]]
    velocity, moving = trajectory_velocities(recording.times, wrists, window, min_speed, significance)
    phi = skeleton_features(recording.points, velocity, moving, recording.gaze, recording.layout.centers)
    in_reach = np.ones(recording.target.shape, dtype=bool)
    if approach_only:
        in_reach[:] = False
        for reach in reaches_of(recording):
            in_reach[reach.start : reach.arrival + 1, reach.hand] = True
    rows, flags = [], []
    for h in range(2):
        labelled = (
            (recording.target[:, h] >= 0)
            & in_reach[:, h]
            & moving[:, h]
            & np.all(np.isfinite(wrists[:, h]), axis=1)
        )
        steps = np.nonzero(labelled)[0]
        rows.append(phi[steps, h, recording.target[steps, h], 0])
        flags.append(recording.gaze_valid[steps])
    samples = np.concatenate(rows)
    flag = np.concatenate(flags).astype(bool)
    finite = np.all(np.isfinite(samples), axis=1)
    if with_gaze_flag:
        return samples[finite], flag[finite]
    return samples[finite]


@dataclass(frozen=True)
class Reach:
    """One reach of a hand: from its start to its arrival at the goal (indices into a recording)."""

    hand: int
    goal: int
    start: int
    arrival: int


def reaches_of(recording: Recording, arrival_margin: float = 0.03, max_offset: float = 0.2) -> list[Reach]:
    """Runs of a constant target per hand, from the start of the run to the arrival at the goal.

    Arrival: the first sample whose true wrist is within `arrival_margin` of its closest approach
    to the centre (hands of two-handed actions stop beside the centre). Runs whose closest
    approach is farther than `max_offset` (goal out of reach) or that start at the goal are skipped.
    """
    out = []
    for h in range(2):
        target = recording.target[:, h]
        change = np.nonzero(np.diff(target) != 0)[0] + 1
        starts = np.concatenate([[0], change])
        ends = np.concatenate([change, [len(target)]])
        for s, e in zip(starts, ends, strict=True):
            goal = int(target[s])
            if goal < 0:
                continue
            dist = np.linalg.norm(recording.true_wrists[s:e, h] - recording.layout.centers[goal], axis=1)
            closest = float(dist.min())
            if closest > max_offset:
                continue
            arrival = int(np.nonzero(dist <= closest + arrival_margin)[0][0])
            if arrival < 3:
                continue  # already there
            out.append(Reach(h, goal, int(s), int(s + arrival)))
    return out
