"""Contract examples of the intention systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.intention.config import GmmBayesIntention, GoalRegionActionDetector
from hrc_drake.intention.systems import ActionDetector, IntentionEstimator
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


EXAMPLES = {IntentionEstimator: intention_estimator, ActionDetector: action_detector}
