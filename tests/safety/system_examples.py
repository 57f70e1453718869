"""Contract examples of the safety systems (see tests/contract.py): a two-link arm in the plane
z = 0.9 beside an operator standing near it (A) or far from it (B)."""

import numpy as np

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import Capsules, SkeletonEstimate
from hrc_drake.safety.config import Hybrid
from hrc_drake.safety.contacts import ContactAccountant
from hrc_drake.safety.limits import load_limits
from hrc_drake.safety.regions import RegionCapsules
from hrc_drake.safety.rules import SafetyRules
from hrc_drake.safety.systems import HumanRegions, RobotPointDynamics, SafetyController, SafetyMonitor
from tests.contract import SystemExample
from tests.safety.arms import two_link_arm, two_link_kinematics


def _setup():
    plant, _ = two_link_arm(height=0.9)
    kinematics = two_link_kinematics(plant)
    config = Hybrid(position_uncertainty="fixed")
    limits = load_limits()
    rules = SafetyRules(config, limits, RegionCapsules().regions,
                        (np.array([[1.0, 0.0, 0.9]]), np.array([0.6])))
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


def safety_monitor() -> SystemExample:
    plant, kinematics, _, limits, rules = _setup()
    _, _, near = _operator(1.6)
    _, _, far = _operator(4.0)
    accountant = ContactAccountant(rules, limits, kinematics.names, RegionCapsules().names)
    system = SafetyMonitor(accountant, RobotPointDynamics(plant, kinematics), 2, 1.0 / 30.0, "hybrid", "")
    moving = {"positions": [0.0, 0.3]}
    # the monitor has no output ports: its run is read with `summary` (tests/safety/test_systems.py)
    return SystemExample(system, {**moving, "human_capsules": near}, {**moving, "human_capsules": far},
                         duration=0.3, inputs_matter=False)


EXAMPLES = {SafetyController: safety_controller, SafetyMonitor: safety_monitor}
