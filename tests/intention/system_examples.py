"""Contract examples of the intention systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.intention.config import GmmBayesIntention, GoalRegionActionDetector, SegmenterActionDetector
from hrc_drake.intention.segmentation import GeneticSettings, Segmenter
from hrc_drake.intention.systems import ActionDetector, ActionSegmenterSystem, IntentionEstimator
from hrc_drake.messages import SkeletonEstimate
from tests.contract import SystemExample
from tests.intention.intention_reaches import GOALS, straight_reach


def _estimate(goal, k: int) -> SkeletonEstimate:
    _, points, gaze = straight_reach([0.85, 0.15, 0.9], goal, duration=0.9, noise=0.0, rng=0)
    return SkeletonEstimate(time=0.0, points=points[k], gaze=gaze[k], gaze_valid=True)


def intention_estimator() -> SystemExample:
    """Evidence needs a moving wrist, which a fixed input cannot give: with fixed inputs the belief
    stays uniform whatever the pose (inputs_matter=False). Two contexts fed different moving
    reaches, interleaved, are checked in tests/intention/test_systems.py
    (test_two_contexts_fed_different_reaches_stay_independent)."""
    system = IntentionEstimator(GmmBayesIntention(n_goal_samples=5, goal_std=0.02), ["A", "B", "C"], GOALS,
                                seed=4)
    return SystemExample(system, {"skeleton_estimate": _estimate(GOALS[0], 10)},
                         {"skeleton_estimate": _estimate(GOALS[2], 20)}, duration=0.3, inputs_matter=False)


def _wrists_at(left, right) -> SkeletonEstimate:
    points = np.zeros((8, 3))
    points[6], points[7] = left, right
    return SkeletonEstimate(time=0.0, points=points, spread=np.zeros(8))


def action_detector() -> SystemExample:
    """A: the left wrist in goal A's region (begins "a"); B: the right wrist in goal C's."""
    away = [0.0, 0.0, 2.0]
    system = ActionDetector(GoalRegionActionDetector(min_dwell=0.1), ["A", "B", "C"], GOALS,
                            [0.05, 0.05, 0.05], actions=["a", "b", "c"])
    return SystemExample(system, {"skeleton_estimate": _wrists_at(GOALS[0], away)},
                         {"skeleton_estimate": _wrists_at(away, GOALS[2])}, duration=0.5)


def reaching_library(rng, frames: int = 12) -> list:
    """[(action, frames)]: action "a" with the left wrist at goal A, "b" ... B, "c" ... C."""
    away = np.array([0.0, 0.0, 2.0])
    library = []
    for _ in range(3):
        for action, goal in zip("abc", GOALS, strict=True):
            points = np.tile(np.linspace(0.0, 1.0, 8)[:, None] * [0.1, 0.2, 0.3], (frames, 1, 1))
            points[:, 6], points[:, 7] = goal, away
            library.append((action, points + rng.normal(0.0, 0.01, points.shape)))
    return library


def small_segmenter(config: SegmenterActionDetector, seed: int = 0) -> Segmenter:
    genetic = GeneticSettings(population=config.population, generations=config.generations)
    segmenter = Segmenter(int(round(config.window * config.rate)), batch_windows=config.batch_windows,
                          centres=GOALS, genetic=genetic, seed=seed,
                          observation_potential=config.observation_potential)
    return segmenter.fit(reaching_library(np.random.default_rng(seed)), [("a", "b"), ("b", "c")],
                         n_cycles=4, n_sequences=10, seed=seed)


SMALL_SEGMENTER = SegmenterActionDetector(window=0.2, batch_windows=3, population=6, generations=3, rate=10.0)


def action_segmenter() -> SystemExample:
    """Constant inputs make one action that never closes (a segment is held until one of another
    action closes), so the event logs stay empty either way (inputs_matter=False); the events of
    two different streams are checked in tests/intention/test_systems.py."""
    points_a = np.tile(np.linspace(0.0, 1.0, 8)[:, None] * [0.1, 0.2, 0.3], (1, 1))
    points_b = points_a.copy()
    points_a[6], points_b[6] = GOALS[0], GOALS[2]
    system = ActionSegmenterSystem(SMALL_SEGMENTER, small_segmenter(SMALL_SEGMENTER))
    return SystemExample(system, {"skeleton_estimate": SkeletonEstimate(time=0.0, points=points_a)},
                         {"skeleton_estimate": SkeletonEstimate(time=0.0, points=points_b)}, duration=2.0,
                         inputs_matter=False)


EXAMPLES = {IntentionEstimator: intention_estimator, ActionDetector: action_detector,
            ActionSegmenterSystem: action_segmenter}
