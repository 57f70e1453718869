"""Contract examples of the intention systems (see tests/contract.py)."""

from hrc_drake.intention.config import GmmBayesIntention
from hrc_drake.intention.systems import IntentionEstimator
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


EXAMPLES = {IntentionEstimator: intention_estimator}
