"""Labelled reaches of an operator, for learning and evaluating L_GMM (thesis 3.1.2-3.1.3).

The value types of intention data: a `GoalLayout` (named goal spheres and the cell around
them), a `Recording` (a measured run of an operator with the goal each hand is going to) and the
samples Phi extracted from it (`training_samples`, `reaches_of`). Plain numpy; the synthetic
generators that fill them from a scenario live in `hrc_drake.cell.intention_data`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hrc_drake.intention.features import (
    DEFAULT_MIN_SPEED,
    DEFAULT_SIGNIFICANCE,
    DEFAULT_WINDOW,
    skeleton_features,
    trajectory_velocities,
)
from hrc_drake.messages import L_WRIST, R_WRIST


@dataclass(frozen=True)
class LayoutTask:
    """An operator action of a scenario: `hand` (left|right|both) reaches `targets` (n, 3) in order.

    labels (n,): index of the goal of each target (-1: a place that is no goal, e.g. a buffer);
    duration: (mean, std, low) of the whole action's normal duration (s).
    """

    name: str
    targets: np.ndarray
    labels: tuple[int, ...]
    hand: str
    duration: tuple[float, float, float]


@dataclass(frozen=True)
class GoalLayout:
    """Named goal spheres, which hand usually reaches each (left|right), and the cell around them.

    operator_base: (x, y, yaw) of the operator; camera_position / camera_target: the depth
    camera; tasks / pattern: the scenario's operator actions and their cyclic order (empty for
    the built-in tables, whose reaches are single goals in random order).
    """

    name: str
    goal_names: tuple[str, ...]
    centers: np.ndarray  # (G, 3)
    hands: tuple[str, ...]
    radius: float = 0.05
    operator_base: tuple[float, float, float] = (1.05, 0.0, float(np.pi))
    camera_position: tuple[float, float, float] = (-0.1, 0.0, 1.35)
    camera_target: tuple[float, float, float] = (1.05, 0.0, 1.2)
    tasks: tuple[LayoutTask, ...] = field(default_factory=tuple)
    pattern: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self):
        centers = np.asarray(self.centers, dtype=float)
        if centers.shape != (len(self.goal_names), 3) or len(self.hands) != len(self.goal_names):
            raise ValueError(
                f"GoalLayout {self.name!r}: {len(self.goal_names)} names, {len(self.hands)} hands and "
                f"centres of shape {centers.shape} do not match"
            )
        if not np.all(np.isfinite(centers)):
            raise ValueError(f"GoalLayout {self.name!r}: goal centres contain NaN or inf")
        object.__setattr__(self, "centers", centers)
        known = {t.name for t in self.tasks}
        unknown = [p for p in self.pattern if p not in known]
        if unknown:
            raise ValueError(f"GoalLayout {self.name!r}: pattern names unknown tasks {unknown}")

    def index(self, goal_name: str) -> int:
        """Index of a goal by name (ValueError naming the known goals)."""
        if goal_name not in self.goal_names:
            raise ValueError(f"GoalLayout {self.name!r}: no goal {goal_name!r}; goals: {self.goal_names}")
        return self.goal_names.index(goal_name)


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
