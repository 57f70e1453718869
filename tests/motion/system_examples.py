"""Contract examples of the motion systems (see tests/contract.py)."""

import numpy as np

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import (
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    Capsules,
    EventLog,
    HumanEvent,
    RobotEvent,
    SkeletonEstimate,
    SweptVolumes,
)
from hrc_drake.motion.config import GPMotionModel, ProactivePlanner, SeparationSpeedScaling
from hrc_drake.motion.proactive import ProactivePlannerCore, nominal_path
from hrc_drake.motion.systems import HumanMotionPredictor, ProactivePlannerSystem, SpeedScaler
from hrc_drake.robots.chain import SerialChain
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


def _reach(y: float, seed: int) -> np.ndarray:
    """Right-arm points (20, 3, 3) of a reach toward the robot at lateral y."""
    s = np.linspace(0.0, 1.0, 20)[:, None]
    wrist = np.array([0.9, y, 0.3]) + s * np.array([-0.4, 0.0, 0.0])
    shoulder = np.broadcast_to([1.25, y, 0.55], wrist.shape)
    arm = np.stack([shoulder, 0.5 * (shoulder + wrist), wrist], axis=1)
    return arm + np.random.default_rng(seed).normal(0.0, 0.005, arm.shape)


def proactive_planner() -> SystemExample:
    qa = np.array([-0.858, -0.681, 2.086, 0.062, 4.18, 0.645, -1.942])
    qb = np.array([-0.922, -0.442, 1.624, 0.778, 4.382, 0.894, -0.897])
    settings = ProactivePlanner(replan_period=100.0, grid=8, latent_dim=2, gpdm_iterations=10, iterations=8,
                                 lambda1=20.0)
    core = ProactivePlannerCore("yumi_left", "r1", ["a1", "a2"], {"a1": "right", "a2": "right"},
                                nominal_path(qa, qb, 9), SerialChain.from_model("yumi", "left"),
                                settings=settings, rng=0)
    core.databases = {"a1": tuple(_reach(0.22, k) for k in range(3)),
                      "a2": tuple(_reach(-0.3, k) for k in range(3, 6))}
    points = np.full((8, 3), np.nan)
    points[[R_SHOULDER, R_ELBOW, R_WRIST]] = _reach(0.22, 9)[0]
    robot = EventLog((RobotEvent(0.0, "yumi_left", "r1", "begin", 1),))

    def inputs(action):
        return {"skeleton_estimate": SkeletonEstimate(time=0.0, points=points),
                "human_events": EventLog((HumanEvent(0.0, action, "begin", 1),)), "robot_events": robot}

    return SystemExample(ProactivePlannerSystem(core, rate=10.0), inputs("a1"), inputs("a2"), duration=0.25)


EXAMPLES = {HumanMotionPredictor: human_motion_predictor, SpeedScaler: speed_scaler,
            ProactivePlannerSystem: proactive_planner}
