"""Contract examples of the safety systems (see tests/contract.py): a two-link arm in the plane
z = 0.9 beside an operator standing near it (A) or far from it (B)."""

import numpy as np

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import Capsules, SkeletonEstimate
from hrc_drake.safety.config import Hybrid
from hrc_drake.safety.judge import Judge, declared_mode, standard_values
from hrc_drake.safety.limits import load_limits
from hrc_drake.safety.regions import RegionCapsules
from hrc_drake.safety.rules import SafetyRules
from hrc_drake.safety.systems import (
    ContactSensing,
    HumanRegions,
    RobotPointDynamics,
    SafetyController,
    SafetyMonitor,
    arm_masses,
)
from tests.contract import SystemExample
from tests.safety.arms import two_link_arm, two_link_kinematics

#: the hybrid mode's collaborative zone: a sphere around the elbow (centres (1, 3), radii (1,))
ZONES = (np.array([[1.0, 0.0, 0.9]]), np.array([0.6]))


def _setup():
    plant, _ = two_link_arm(height=0.9)
    kinematics = two_link_kinematics(plant)
    config = Hybrid(position_uncertainty="fixed")
    limits = load_limits()
    rules = SafetyRules(config, limits, RegionCapsules().regions, ZONES)
    return plant, kinematics, config, limits, rules


def _operator(x: float):
    body = BodyModel()
    q = body.rest_q((x, 0.0), np.pi)
    return body, body.points(q), Capsules(*body.capsules(q))


def safety_controller() -> SystemExample:
    plant, kinematics, config, _, rules = _setup()
    body, near, _ = _operator(1.6)
    _, far, _ = _operator(4.0)
    system = SafetyController(rules, RobotPointDynamics(plant, kinematics), HumanRegions(body, config), 2)
    moving = {"positions": [0.0, 0.3], "velocities_full": [1.5, 0.0], "requested_override": [1.0]}
    return SystemExample(system, {**moving, "skeleton_estimate": SkeletonEstimate(points=near)},
                         {**moving, "skeleton_estimate": SkeletonEstimate(points=far)}, duration=0.3)


def monitor_judge(plant, kinematics, config) -> Judge:
    """The standard judge of the two-link cell (T_r 0.1 s, a stop at 5 m/s^2) in `config`'s mode."""
    cutter = RegionCapsules()
    return Judge(standard_values(0.1, 5.0), declared_mode(config, ZONES), kinematics.names, cutter.names,
                 cutter.regions, arm_masses(plant, kinematics.capsule_bodies))


def safety_monitor() -> SystemExample:
    plant, kinematics, config, _, _ = _setup()
    _, near_points, near = _operator(1.6)
    _, far_points, far = _operator(4.0)
    judge = monitor_judge(plant, kinematics, config)
    system = SafetyMonitor((judge,), RobotPointDynamics(plant, kinematics), 2, 1.0 / 30.0, "hybrid")
    moving = {"positions": [0.0, 0.3], "protective_stop": [0.0]}
    # the monitor has no output ports: its run is read with `summary` (tests/safety/test_systems.py)
    return SystemExample(
        system, {**moving, "human_capsules": near, "skeleton_estimate": SkeletonEstimate(points=near_points)},
        {**moving, "human_capsules": far, "skeleton_estimate": SkeletonEstimate(points=far_points)},
        duration=0.3, inputs_matter=False)


def contact_sensing() -> SystemExample:
    """The arm's link 2 along x at height 0.9, a body capsule upright across it (1 cm of overlap) or
    clear of it."""
    plant, kinematics, _, _, _ = _setup()
    system = ContactSensing(RobotPointDynamics(plant, kinematics), 2, 1.0 / 30.0)
    touching = Capsules(np.array([[1.4, 0.09, 0.5]]), np.array([[1.4, 0.09, 1.3]]), np.array([0.05]))
    clear = Capsules(np.array([[1.4, 0.3, 0.5]]), np.array([[1.4, 0.3, 1.3]]), np.array([0.05]))
    return SystemExample(system, {"positions": [0.0, 0.0], "human_capsules": touching},
                         {"positions": [0.0, 0.0], "human_capsules": clear}, duration=0.3)


EXAMPLES = {SafetyController: safety_controller, SafetyMonitor: safety_monitor,
            ContactSensing: contact_sensing}
