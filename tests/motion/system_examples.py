"""Contract examples of the motion systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import Capsules, SkeletonEstimate, SweptVolumes
from hrc_drake.motion.config import GPMotionModel, SeparationSpeedScaling
from hrc_drake.motion.systems import HumanMotionPredictor, SpeedScaler
from tests.contract import SystemExample


def _estimate(body, x: float, arm: float) -> SkeletonEstimate:
    q = body.rest_q((x, 0.0), np.pi)
    q[8] = arm
    return SkeletonEstimate(time=0.0, points=body.points(q))


def human_motion_predictor() -> SystemExample:
    body = BodyModel()
    config = GPMotionModel(variant="C", order=2, horizon=0.3, n_trials=10, min_samples=4, refresh_period=0.2)
    system = HumanMotionPredictor(body, config, seed=2)
    return SystemExample(system, {"skeleton_estimate": _estimate(body, 1.2, 0.3)},
                         {"skeleton_estimate": _estimate(body, 0.9, 0.9)}, duration=0.6)


def _capsules(x: float) -> Capsules:
    return Capsules(np.array([[x, 0.0, 0.8]]), np.array([[x, 0.0, 1.3]]), np.array([0.05]))


def speed_scaler() -> SystemExample:
    human = SweptVolumes(time=0.0, names=("torso",), start=np.array([[0.5, 0.0, 0.8]]),
                         end=np.array([[0.5, 0.0, 1.3]]), radius=np.array([0.2]), horizon=0.3)
    system = SpeedScaler(SeparationSpeedScaling(clearance=0.1, reaction_time=0.1, stopping_time=0.3))
    return SystemExample(
        system,
        {"swept_volumes": human, "robot_capsules": _capsules(0.0), "robot_capsules_ahead": _capsules(0.05)},
        {"swept_volumes": human, "robot_capsules": _capsules(-0.1), "robot_capsules_ahead": _capsules(-0.15)},
        duration=0.2,
    )


EXAMPLES = {HumanMotionPredictor: human_motion_predictor, SpeedScaler: speed_scaler}
