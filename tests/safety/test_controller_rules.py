"""The safety controller's rules (`safety.rules.SafetyRules`) on scripted scenes: a robot link
above the operator's right hand (moved here from the tests of the contact accountant, which the
ISO/TS 15066 judge replaced: tests/safety/test_judge.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hrc_drake.safety.config import Hybrid, PowerForceLimiting, SpeedSeparationMonitoring
from hrc_drake.safety.limits import load_limits
from hrc_drake.safety.regions import FixedBox, RegionCapsules
from hrc_drake.safety.rules import SafetyRules, decelerated_override

LIMITS = load_limits()
CUTTER = RegionCapsules()
INDEX = {name: k for k, name in enumerate(CUTTER.names)}
ROBOT_MASS = 3.0


def body(hand_height: float = 1.0):
    """Body capsules far from the robot, but for the right forearm, horizontal along +y at x = 0,
    its hand from the wrist at y = 0.05 + 0.6 / 1.37 = 0.49 to y = 0.65."""
    start = np.array([[2.0, 0.0, 1.0], [2.0, 0.0, 1.6], [2.0, 0.2, 1.4], [2.0, -0.2, 1.4], [2.0, 0.3, 1.2],
                      [0.0, 0.05, hand_height]])
    end = np.array([[2.0, 0.0, 1.4], [2.0, 0.0, 1.72], [2.0, 0.3, 1.2], [2.0, -0.3, 1.2], [2.0, 0.4, 1.0],
                    [0.0, 0.65, hand_height]])
    radius = np.array([0.15, 0.11, 0.06, 0.06, 0.05, 0.05])
    return CUTTER.cut(start, end, radius)


def robot_at(z: float):
    """One vertical robot capsule above the hand at y = 0.58 (clear of the lower arm), its lower end
    at height z."""
    start = np.array([[0.0, 0.58, z]])
    end = np.array([[0.0, 0.58, z + 0.2]])
    return start, end, np.array([0.03])


def test_the_stopping_model_limits_the_fall_of_the_override():
    # a point at 1 m/s braking at 5 m/s^2 loses at most 5 x 0.02 = 0.1 m/s in one 20 ms period
    assert decelerated_override(1.0, 0.0, 0.02, 1.0, 5.0) == pytest.approx(0.9)
    # speeding up, too, by at most a dt: 0.5 m/s + 0.1 m/s (not a leap to 0.8 m/s in one period)
    assert decelerated_override(0.5, 0.8, 0.02, 1.0, 5.0) == pytest.approx(0.6)
    assert decelerated_override(0.5, 0.55, 0.02, 1.0, 5.0) == 0.55
    assert decelerated_override(1.0, 0.0, 0.02, 0.0, 5.0) == 0.0  # nothing moves: stop at once
    # a path still accelerating (its fastest point at 2 m/s by the next period at full speed): the
    # override falls so that the point's real speed, 1 m/s now, is 0.9 m/s then: 0.9 / 2
    assert decelerated_override(1.0, 0.0, 0.02, 1.0, 5.0, next_fastest=2.0) == pytest.approx(0.45)


def test_the_controller_rules_keep_the_hand_within_its_pfl_speed():
    rules = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions)
    regions = body()
    z_d = np.full(len(CUTTER), 0.03)
    velocity = np.array([[0.0, 0.0, -2.0]])
    override, binding = rules.override(robot_at(1.15), (velocity, velocity), regions, z_d,
                                       lambda k, p, u: np.full(len(k), ROBOT_MASS))
    pairs, n, rule, _ = binding
    assert rule == "pfl" and CUTTER.regions[pairs.r[n]] in ("hand_fingers", "lower_arm_wrist")
    v_hand = 280.0 / math.sqrt(1.0 / (1.0 / 0.6 + 1.0 / ROBOT_MASS) * 75e3)
    assert override * 2.0 <= v_hand + 1e-9
    # under SSM the same approach stops: 0.15 m is inside S_p(0) of the hand
    ssm = SafetyRules(SpeedSeparationMonitoring(), LIMITS, CUTTER.regions)
    assert ssm.override(robot_at(1.15), (velocity, velocity), regions, z_d)[0] == 0.0
    # moving away is never limited
    assert ssm.override(robot_at(1.15), (-velocity, -velocity), regions, z_d)[0] == 1.0


def test_a_pfl_pair_skipped_for_its_bound_does_not_stop_the_robot():
    # the hand near and approached fast (PFL: a speed limit, not a stop), the torso far (SSM):
    # the override is the hand's PFL speed over the approach, never the SSM's 0 of the hand
    rules = SafetyRules(Hybrid(), LIMITS, CUTTER.regions, (np.array([[0.0, 0.5, 1.0]]), np.array([0.5])))
    z_d = np.full(len(CUTTER), 0.03)
    velocity = np.array([[0.0, 0.0, -2.0]])
    override, binding = rules.override(robot_at(1.15), (velocity, velocity), body(), z_d,
                                       lambda k, p, u: np.full(len(k), ROBOT_MASS))
    pairs, n, rule, _ = binding
    assert rule == "pfl" and 0.3 < override < 1.0
    v_hand = 280.0 / math.sqrt(1.0 / (1.0 / 0.6 + 1.0 / ROBOT_MASS) * 75e3)
    assert override == pytest.approx(v_hand / 2.0, rel=1e-6)


def test_the_override_is_the_smallest_pair_s_when_a_pfl_pair_is_skipped():
    # the hand (PFL) 5 cm under the robot, the chest (SSM) 0.45 m below it: the chest's SSM
    # override is below the hand's PFL bound, so the hand is not evaluated; the override is the
    # chest's, not the hand's SSM stop
    rules = SafetyRules(Hybrid(), LIMITS, CUTTER.regions, (np.array([[0.0, 0.5, 1.0]]), np.array([0.5])))
    start, end, radius = (np.full((len(CUTTER), 3), 9.0), np.full((len(CUTTER), 3), 9.0),
                          np.full(len(CUTTER), 0.05))
    hand, chest = INDEX["right_hand"], INDEX["chest"]
    start[hand], end[hand] = [0.0, 0.5, 1.0], [0.0, 0.7, 1.0]
    start[chest], end[chest] = [0.0, 0.58, 0.4], [0.0, 0.58, 0.6]
    z_d = np.full(len(CUTTER), 0.03)
    velocity = np.array([[0.0, 0.0, -2.0]])
    robot = robot_at(1.13)
    override, (pairs, n, rule, _) = rules.override(robot, (velocity, velocity), (start, end, radius), z_d,
                                                   lambda k, p, u: np.full(len(k), ROBOT_MASS))
    ssm_only = SafetyRules(SpeedSeparationMonitoring(), LIMITS, CUTTER.regions)
    chest_only = (start.copy(), end.copy(), radius)
    chest_only[0][hand] = chest_only[1][hand] = 9.0
    expected, _ = ssm_only.override(robot, (velocity, velocity), chest_only, z_d)
    assert 0.0 < expected < 1.0
    assert rule == "ssm" and CUTTER.regions[pairs.r[n]] == "chest"
    assert override == pytest.approx(expected)


def test_a_pair_judged_clamped_stays_clamped_for_the_hold_time():
    """A hand resting on a table under the robot is clamped (here SSM: stop). When the estimate's
    noise lifts it off the table in the next period, the pair stays clamped for `clamp_hold`, then
    it is free again (PFL's transient speed)."""
    table = FixedBox((0.0, 0.5, 0.9), (1.0, 1.0, 0.1))  # top at z = 0.95: the hand (r 0.05) rests on it
    config = PowerForceLimiting(clamp_hold=0.5, clamped_approach="ssm")
    rules = SafetyRules(config, LIMITS, CUTTER.regions, fixed_boxes=(table,))
    z_d = np.full(len(CUTTER), 0.03)
    velocity = np.array([[0.0, 0.0, -0.3]])
    mass = lambda k, p, u: np.full(len(k), ROBOT_MASS)  # noqa: E731
    until = np.full((1, len(CUTTER)), -np.inf)
    # lifted: 8 cm of noise puts it 0.08 m clear of the table, beyond its Z_d and the clamp margin
    resting, lifted = body(1.0), body(1.08)
    assert rules.override(robot_at(1.2), (velocity, velocity), resting, z_d, mass, 0.0, until, 0.0)[0] == 0.0
    assert np.isfinite(until).any()
    robot = robot_at(1.28)
    held, (_, _, rule, _) = rules.override(robot, (velocity, velocity), lifted, z_d, mass, 0.0, until, 0.1)
    assert held == 0.0 and rule == "ssm"
    free, (_, _, rule, _) = rules.override(robot, (velocity, velocity), lifted, z_d, mass, 0.0, until, 0.7)
    assert free > 0.0 and rule == "pfl"
    # without the memory, the lifted estimate is free at once
    assert rules.override(robot_at(1.28), (velocity, velocity), lifted, z_d, mass)[0] > 0.0


def test_a_hand_the_estimate_puts_clear_of_the_table_but_within_its_z_d_counts_as_clamped():
    """The estimate puts the hand 4 cm over the table (top 0.95 m, the hand's axis at 1.04 m, radius
    0.05): beyond the 2 cm clamp margin, but within it plus Z_d 3 cm the hand may rest on the table
    (falsify_pcb_ic: a hand the controller took for free was pressed onto the table at 12.7x its
    quasi-static limit). Clamped: the compression budget, not the free contact's transient speed.
    With Z_d 0 the same estimate is free (PFL)."""
    table = FixedBox((0.0, 0.5, 0.9), (1.0, 1.0, 0.1))
    rules = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions, fixed_boxes=(table,))
    velocity = np.array([[0.0, 0.0, -2.0]])
    mass = lambda k, p, u: np.full(len(k), ROBOT_MASS)  # noqa: E731
    robot = robot_at(1.24)
    for compiled in (True, False):
        judged = rules if compiled else SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions,
                                                    fixed_boxes=(table,), compiled=False)
        uncertain = judged.override(robot, (velocity, velocity), body(1.04), np.full(len(CUTTER), 0.03), mass)
        exact = judged.override(robot, (velocity, velocity), body(1.04), np.zeros(len(CUTTER)), mass)
        assert uncertain[1][2] == "clamped" and exact[1][2] == "pfl"
        assert uncertain[0] < exact[0]


def test_a_lost_hand_may_lie_under_a_robot_that_sweeps_over_the_table():
    """A lost right wrist: its forearm and hand are a reachable set around the elbow. A robot
    capsule sweeping 3 cm over the table inside that set might press the hand onto the table, so
    the pair is clamped (SSM: stop); the same set of a seen hand placed exactly (Z_d 0: an
    uncertain one this near the table is clamped whatever the push), unclamped, is free under PFL
    (the sweep is slower than the hand's PFL speed). Without `lost_parts_clamped` (the default) the
    lost hand counts as free."""
    table = FixedBox((0.0, 0.5, 0.9), (1.0, 1.0, 0.1))  # top at z = 0.95
    rules = SafetyRules(PowerForceLimiting(lost_parts_clamped=True), LIMITS, CUTTER.regions,
                        fixed_boxes=(table,))
    start, end = np.full((len(CUTTER), 3), 9.0), np.full((len(CUTTER), 3), 9.0)
    radius = np.full(len(CUTTER), 0.05)
    lost = [INDEX["right_lower_arm"], INDEX["right_hand"]]
    start[lost] = end[lost] = [0.0, 0.6, 1.2]  # a sphere around the elbow
    radius[lost] = 0.05 + 0.45
    robot = (np.array([[0.0, 0.2, 1.01]]), np.array([[0.0, 0.3, 1.01]]), np.array([0.03]))
    velocity = np.array([[0.0, 0.5, 0.0]])  # sideways, toward the operator
    z_d = np.full(len(CUTTER), 0.03)
    mass = lambda k, p, u: np.full(len(k), ROBOT_MASS)  # noqa: E731
    lost_radius = np.full(len(CUTTER), np.nan)
    assert rules.override(robot, (velocity, velocity), (start, end, radius), 0.0 * z_d, mass,
                          lost_radius=lost_radius)[0] == 1.0
    assert rules.override(robot, (velocity, velocity), (start, end, radius), z_d, mass,
                          lost_radius=lost_radius)[0] < 1.0
    lost_radius[lost] = 0.05
    override, (pairs, n, rule, _) = rules.override(robot, (velocity, velocity), (start, end, radius), z_d,
                                                   mass, lost_radius=lost_radius)
    assert override == 0.0 and rule == "clamped"  # inside the set: no room for a compression budget
    # 20 cm above the table the robot cannot press it there: free again
    high = (robot[0] + [0.0, 0.0, 0.2], robot[1] + [0.0, 0.0, 0.2], robot[2])
    assert rules.override(high, (velocity, velocity), (start, end, radius), z_d, mass,
                          lost_radius=lost_radius)[0] == 1.0
    off = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions, fixed_boxes=(table,))
    assert off.override(robot, (velocity, velocity), (start, end, radius), z_d, mass,
                        lost_radius=lost_radius)[0] == 1.0
    # a robot at rest on its path (its first mm/s) is not yet approaching a lost hand
    creep = velocity * 0.002
    assert rules.override(robot, (creep, creep), (start, end, radius), z_d, mass,
                          lost_radius=lost_radius)[0] == 1.0


def test_a_robot_passing_sideways_may_approach_a_body_the_estimate_places_within_z_d():
    from hrc_drake.safety.rules import PairGeometry, approach_within

    # the robot point at the origin, the region's axis point 0.4 m along x, Z_d 0.04 m: the body
    # may lie anywhere in a cone of half-angle asin(0.1) around x
    def pair(velocity, z_d):
        one = np.zeros(1, dtype=np.int64)
        geometry = PairGeometry(one, one, np.array([0.36]), np.zeros((1, 3)), np.array([[0.4, 0.0, 0.0]]),
                                np.array([[1.0, 0.0, 0.0]]), np.array([velocity], dtype=float),
                                np.array([float(np.dot(velocity, [1.0, 0.0, 0.0]))]), np.zeros(1))
        return float(approach_within(geometry, np.array([z_d]))[0])

    # sideways at 0.3 m/s: 0.3 sin(theta) = 0.03 m/s toward the body (the estimate says 0)
    assert pair([0.0, 0.3, 0.0], 0.04) == pytest.approx(0.03, rel=1e-9)
    # straight at it: the speed itself; straight away: still away, 0.3 cos(pi - theta)
    assert pair([0.3, 0.0, 0.0], 0.04) == pytest.approx(0.3)
    assert pair([-0.3, 0.0, 0.0], 0.04) == pytest.approx(-0.3 * np.sqrt(1 - 0.01), rel=1e-9)
    # Z_d beyond the distance: the body may be on any side, every motion approaches it
    assert pair([0.0, 0.0, 0.3], 0.5) == pytest.approx(0.3)
    # Z_d 0: the estimate's own direction
    assert pair([0.1, 0.3, 0.0], 0.0) == pytest.approx(0.1)


def test_a_robot_point_moving_straight_at_the_body_approaches_at_its_speed_not_nan():
    from hrc_drake.safety.rules import PairGeometry, approach_within

    # a velocity whose dot product with its own unit vector rounds one float step above its norm
    velocity = np.array([-1.2654214710460525, -0.6232744625373522, 0.0413259793472436])
    speed = np.linalg.norm(velocity)
    direction = velocity / speed
    assert np.dot(velocity, direction) / speed > 1.0  # the rounding this test is about
    one = np.zeros(1, dtype=np.int64)
    approach = np.array([np.dot(velocity, direction)])
    pairs = PairGeometry(one, one, np.array([0.3]), np.zeros((1, 3)), 0.4 * direction[None],
                         direction[None], velocity[None], approach, np.zeros(1))
    assert approach_within(pairs, np.array([0.02]))[0] == pytest.approx(speed)


def test_head_and_torso_take_the_body_speed_and_the_limbs_the_human_speed():
    rules = SafetyRules(Hybrid(), load_limits(), RegionCapsules().regions)
    assert rules.separation.human_speed == 0.0  # ISO 13855's rule for hands and arms
    assert rules.body_separation.human_speed == 1.6  # the whole body's approach
    # body_speed 0: as human_speed
    same = SafetyRules(Hybrid(human_speed=1.8, body_speed=0.0), load_limits(), RegionCapsules().regions)
    assert same.body_separation.human_speed == 1.8 and same.separation.human_speed == 1.8


def test_after_a_contact_the_robot_approaches_a_hand_no_faster_than_it_stops_within_its_compression():
    """The compression budget (`override(..., budget=True)`, PFL after a sensed contact): the robot
    2 m/s straight down onto the hand 7 cm below, Z_d 3 cm, Z_r 1 cm. It must stop, after T_r +
    P = 0.1 + 1/30 s and braking at 5 m/s^2, within the 4 cm left plus the hand's quasi-static
    compression 140 N / 75 N/mm = 1.867 mm: s 2 (0.1 + 1/30) + s^2 2 x 2 / (2 x 5) <= 0.031867."""
    rules = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions)
    z_d = np.full(len(CUTTER), 0.03)
    velocity = np.array([[0.0, 0.0, -2.0]])
    mass = lambda k, p, u: np.full(len(k), ROBOT_MASS)  # noqa: E731
    room = 0.07 - 0.03 - 0.01 + 140.0 / 75e3
    a, b = 2.0 * 2.0 / (2 * 5.0), 2.0 * (0.1 + 1.0 / 30.0)
    expected = (math.sqrt(b * b + 4 * a * room) - b) / (2 * a)  # 0.1034
    override, (pairs, n, rule, _) = rules.override(robot_at(1.15), (velocity, velocity), body(), z_d, mass,
                                                   budget=True)
    assert rule == "pfl" and CUTTER.regions[pairs.r[n]] == "hand_fingers"
    assert override == pytest.approx(expected, rel=1e-9)
    # without the budget: eq. (A.6)'s transient speed, 7x faster
    assert rules.override(robot_at(1.15), (velocity, velocity), body(), z_d, mass)[0] > 6.5 * expected
    # at the edge: the hand's nearest possible point less its compression -> a stop; moving away is free
    edge = 1.0 + 0.05 + 0.03 + 0.03 + 0.01 - 140.0 / 75e3
    def budgeted(z, v):
        return rules.override(robot_at(z), (v, v), body(), z_d, mass, budget=True)[0]

    assert budgeted(edge - 1e-6, velocity) == 0.0
    assert budgeted(edge + 1e-4, velocity) > 0.0
    assert budgeted(edge - 0.02, -velocity) == 1.0
    # the numpy reference decides the same
    reference = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions, compiled=False)
    assert reference.override(robot_at(1.15), (velocity, velocity), body(), z_d, mass,
                              budget=True)[0] == pytest.approx(expected, rel=1e-9)


def test_a_clamped_hand_is_approached_no_faster_than_the_robot_stops_within_its_compression():
    """A hand resting on the table (top at 0.95 m; the hand's axis at 1.0 m, radius 0.05), the robot
    capsule (radius 0.03) 2 m/s straight down onto it, its lower end at 1.2 m: D = 0.12 m, Z_d
    3 cm, Z_r 1 cm. `clamped_approach: compression_budget` (the default): it stops, after T_r + P
    and braking at 5 m/s^2, within the room left plus the hand's quasi-static compression 140 N /
    75 N/mm: s 2 (0.1 + 1/30) + s^2 2 x 2 / 10 <= 0.12 - 0.03 - 0.01 + 0.0018667 (s 0.2285). SSM (the
    other choice) holds it: the hand's S_p at rest is already 0.27 + C + Z_d + Z_r > D."""
    table = FixedBox((0.0, 0.5, 0.9), (1.0, 1.0, 0.1))
    rules = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions, fixed_boxes=(table,))
    z_d = np.full(len(CUTTER), 0.03)
    velocity = np.array([[0.0, 0.0, -2.0]])
    mass = lambda k, p, u: np.full(len(k), ROBOT_MASS)  # noqa: E731
    room = 0.12 - 0.03 - 0.01 + 140.0 / 75e3
    a, b = 2.0 * 2.0 / (2 * 5.0), 2.0 * (0.1 + 1.0 / 30.0)
    expected = (math.sqrt(b * b + 4 * a * room) - b) / (2 * a)
    assert 0.0 < expected < 1.0
    override, (pairs, n, rule, _) = rules.override(robot_at(1.2), (velocity, velocity), body(), z_d, mass)
    assert rule == "clamped" and CUTTER.regions[pairs.r[n]] == "hand_fingers"
    assert override == pytest.approx(expected, rel=1e-9)
    ssm = SafetyRules(PowerForceLimiting(clamped_approach="ssm"), LIMITS, CUTTER.regions,
                      fixed_boxes=(table,))
    assert ssm.override(robot_at(1.2), (velocity, velocity), body(), z_d, mass)[0] == 0.0
    # the edge: the hand's nearest possible point less its compression -> a stop; moving away is free
    edge = 1.05 + 0.03 + 0.03 + 0.01 - 140.0 / 75e3

    def budgeted(z, v, compiled=True):
        judged = rules if compiled else SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions,
                                                    fixed_boxes=(table,), compiled=False)
        return judged.override(robot_at(z), (v, v), body(), z_d, mass)[0]

    assert budgeted(edge - 1e-6, velocity) == 0.0
    assert budgeted(edge + 1e-4, velocity) > 0.0
    assert budgeted(edge - 0.02, -velocity) == 1.0
    # the numpy reference decides the same
    assert budgeted(1.2, velocity, compiled=False) == pytest.approx(expected, rel=1e-9)
    assert budgeted(edge - 1e-6, velocity, compiled=False) == 0.0


def test_the_controller_takes_the_judges_effective_mass_never_less_than_the_standards_m_over_2():
    """The judge's m_R is max(the plant's along u, M/2) + m_L (ISO/TS 15066 eq. A.5); a controller that
    took the plant's lower mass (the YuMi's gripper: 1.31 kg against M/2 = 3.17 kg) would allow a
    transient speed the judge finds over the limit. Arm mass M = 6.34 kg, payload 0.2 kg."""
    rules = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions, arm_masses=np.array([6.34]),
                        payloads=np.array([0.2]))
    velocity = np.array([[0.0, 0.0, -2.0]])
    robot = robot_at(1.15)
    pairs, n = rules.override(robot, (velocity, velocity), body(), np.full(len(CUTTER), 0.03),
                              lambda k, p, u: np.full(len(k), 1.31))[1][:2]
    light = rules.robot_masses(pairs, lambda k, p, u: np.full(len(k), 1.31))
    heavy = rules.robot_masses(pairs, lambda k, p, u: np.full(len(k), 5.0))
    assert light == pytest.approx(np.full(len(pairs.k), 3.17 + 0.2))
    assert heavy == pytest.approx(np.full(len(pairs.k), 5.0 + 0.2))


def test_a_lost_hand_under_a_robot_coming_down_onto_its_reachable_set_counts_as_clamped():
    """Default config (no `lost_parts_clamped`): a lost wrist's reachable set (0.5 m around the
    elbow) reaches the table; a gripper coming down onto the set may press the hidden hand onto
    the table, so the pair is clamped (the set tested as a ball its size), compiled and numpy. An
    adversarial review found the first version of the judge's clamping test leaving every
    reachable set free here (override 1.0)."""
    table = FixedBox((0.0, 0.5, 0.9), (1.0, 1.0, 0.1))  # top at z = 0.95
    start, end = np.full((len(CUTTER), 3), 9.0), np.full((len(CUTTER), 3), 9.0)
    radius = np.full(len(CUTTER), 0.05)
    lost = [INDEX["right_lower_arm"], INDEX["right_hand"]]
    start[lost] = end[lost] = [0.0, 0.6, 1.2]
    radius[lost] = 0.05 + 0.45
    lost_radius = np.full(len(CUTTER), np.nan)
    lost_radius[lost] = 0.05
    robot = (np.array([[0.0, 0.6, 1.70]]), np.array([[0.0, 0.6, 1.75]]), np.array([0.03]))
    down = np.array([[0.0, 0.0, -0.5]])
    mass = lambda k, p, u: np.full(len(k), ROBOT_MASS)  # noqa: E731
    for compiled in (True, False):
        rules = SafetyRules(PowerForceLimiting(), LIMITS, CUTTER.regions, fixed_boxes=(table,),
                            compiled=compiled)
        override, (_, _, rule, _) = rules.override(robot, (down, down), (start, end, radius),
                                                   np.full(len(CUTTER), 0.03), mass, lost_radius=lost_radius)
        assert rule == "clamped" and override < 1.0
