import numpy as np
import pytest

from hrc_drake.messages import SweptVolumes
from hrc_drake.motion.speed import SeparationRule, SpeedScalerCore, minimum_distance


def _robot_at(x):
    """One vertical robot link capsule (radius 0.05) at x."""
    return (np.array([[x, 0.0, 0.8]]), np.array([[x, 0.0, 1.2]]), np.array([0.05]))


HUMAN = SweptVolumes(time=0.0, names=("torso",), start=np.array([[0.0, 0.0, 0.8]]),
                     end=np.array([[0.0, 0.0, 1.3]]), radius=np.array([0.2]), horizon=0.5)


def test_override_is_one_far_zero_inside_clearance_monotone_between():
    rule = SeparationRule(clearance=0.1, reaction_time=0.1, stopping_time=0.3, robot_speed=1.0)
    assert rule.full_speed_distance == pytest.approx(0.1 + 1.0 * (0.1 + 0.15))
    distances = np.linspace(-0.2, 1.0, 241)
    override = rule.override(distances)
    assert np.all(override[distances >= rule.full_speed_distance] == 1.0)
    assert np.all(override[distances <= 0.1] == 0.0)
    assert np.all(np.diff(override) >= 0.0)
    assert rule.override(0.1 + 0.125) == pytest.approx(0.5)
    assert rule.override(np.inf) == 1.0
    with pytest.raises(ValueError, match="NaN"):
        rule.override(np.nan)
    with pytest.raises(ValueError, match="robot_speed"):
        SeparationRule(robot_speed=0.0)


def test_human_speed_moves_the_stop_distance():
    rule = SeparationRule(clearance=0.1, reaction_time=0.1, stopping_time=0.3, human_speed=1.6)
    assert rule.stop_distance == pytest.approx(0.1 + 1.6 * 0.4)
    assert rule.override(0.7) == 0.0


def test_scaler_core_uses_capsule_clearance():
    core = SpeedScalerCore({"clearance": 0.1, "reaction_time": 0.1, "stopping_time": 0.3, "robot_speed": 1.0})
    override, distance = core.step(_robot_at(1.0), HUMAN)
    assert distance == pytest.approx(1.0 - 0.2 - 0.05)
    assert override == 1.0
    override, distance = core.step(_robot_at(0.3), HUMAN)
    assert distance == pytest.approx(0.05) and override == 0.0
    override, _ = core.step(_robot_at(0.5), HUMAN)
    assert 0.0 < override < 1.0
    # no swept volumes (no human seen yet): free to move
    assert minimum_distance(_robot_at(0.3), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)) == np.inf


def test_approach_speed_rule_lets_a_retreating_robot_move():
    rule = SeparationRule(clearance=0.1, reaction_time=0.1, stopping_time=0.3, robot_speed=1.0)
    # approaching at the nominal speed: the plain rule
    assert rule.override(0.225, approach_speed=1.0) == pytest.approx(rule.override(0.225))
    assert rule.override(0.225) == pytest.approx(0.5)
    # approaching at half the speed: twice the override at the same clearance (clipped at 1)
    assert rule.override(0.1 + 0.0625, approach_speed=0.5) == pytest.approx(0.5)
    # moving away or parallel: full speed, even inside the clearance
    np.testing.assert_allclose(rule.override([0.05, 0.3], approach_speed=[-0.2, 0.0]), [1.0, 1.0])
    core = SpeedScalerCore({"clearance": 0.1, "reaction_time": 0.1, "stopping_time": 0.3, "robot_speed": 1.0})
    # the link sits 0.05 m from the human: stopped when heading in, free when heading out
    stopped, distance = core.step(_robot_at(0.3), HUMAN, _robot_at(0.25), lookahead=0.1)
    assert distance == pytest.approx(0.05) and stopped == 0.0
    free, _ = core.step(_robot_at(0.3), HUMAN, _robot_at(0.35), lookahead=0.1)
    assert free == 1.0
    # 0.225 m clearance, closing at 0.5 m/s: override (0.225 - 0.1) / (0.5 * 0.25) = 1
    closing, _ = core.step(_robot_at(0.475), HUMAN, _robot_at(0.425), lookahead=0.1)
    assert closing == pytest.approx(1.0)


def test_each_capsule_gets_its_own_approach_speed():
    core = SpeedScalerCore({"clearance": 0.1, "reaction_time": 0.1, "stopping_time": 0.3, "robot_speed": 1.0})
    # the nearest link (0.05 m) retreats, a second link 0.2 m away closes in at 1 m/s
    now = tuple(np.concatenate(pair) for pair in zip(_robot_at(0.3), _robot_at(-0.45), strict=True))
    ahead = tuple(np.concatenate(pair) for pair in zip(_robot_at(0.35), _robot_at(-0.35), strict=True))
    override, distance = core.step(now, HUMAN, ahead, lookahead=0.1)
    assert distance == pytest.approx(0.05)
    # the second link rules: clearance 0.45 - 0.25 = 0.2 -> (0.2 - 0.1) / (1.0 * 0.25) = 0.4
    assert override == pytest.approx(0.4)
    with pytest.raises(ValueError, match="ahead"):
        core.step(now, HUMAN, _robot_at(0.3), lookahead=0.1)
