"""Contract examples of the perception systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.messages import L_WRIST, SkeletonFrame
from hrc_drake.perception.config import KalmanTracker, ParticleFilterTracker
from hrc_drake.perception.systems import MeasurementAsEstimate, OcclusionTracker
from tests.contract import SystemExample

POSE = np.array([
    [0.0, 0.0, 1.40], [0.0, 0.0, 1.65], [0.0, 0.2, 1.40], [0.0, -0.2, 1.40],
    [0.0, 0.2, 1.10], [0.0, -0.2, 1.10], [0.27, 0.2, 1.10], [0.27, -0.2, 1.10],
])
CENTER, SIZE = [0.6, 0.2, 1.1], [0.5, 0.6, 0.6]


def _frame(shift: float, wrist_lost: bool) -> SkeletonFrame:
    points = POSE + [shift, 0.0, 0.0]
    tracked = np.ones(8, dtype=bool)
    if wrist_lost:
        points[L_WRIST] = np.nan
        tracked[L_WRIST] = False
    return SkeletonFrame(time=0.0, points=points, tracked=tracked)


def _is_hidden(points, capsules=None):
    return points[..., 0] > 0.15


def particle_filter_tracker() -> SystemExample:
    config = ParticleFilterTracker(particles=40)
    tracker = OcclusionTracker(config, _is_hidden, CENTER, SIZE, rate=30.0, seed=3)
    return SystemExample(tracker, {"skeleton_frame": _frame(0.0, False)},
                         {"skeleton_frame": _frame(0.3, True)}, duration=0.2)


def kalman_tracker() -> SystemExample:
    tracker = OcclusionTracker(KalmanTracker(), None, CENTER, SIZE, rate=30.0, seed=3)
    return SystemExample(tracker, {"skeleton_frame": _frame(0.0, False)},
                         {"skeleton_frame": _frame(0.3, True)}, duration=0.2)


def measurement_as_estimate() -> SystemExample:
    system = MeasurementAsEstimate(CENTER, SIZE, rate=30.0)
    return SystemExample(system, {"skeleton_frame": _frame(0.0, False)},
                         {"skeleton_frame": _frame(0.4, True)}, duration=0.2)


EXAMPLES = {OcclusionTracker: particle_filter_tracker, MeasurementAsEstimate: measurement_as_estimate}
#: More examples of one class (the contract test takes one per class; tests/perception use these).
MORE_EXAMPLES = {"kalman": kalman_tracker}
