"""Body regions cut from the body capsules, and clamping against the scene."""

from __future__ import annotations

import numpy as np
import pytest

from hrc_drake.human.body import HAND_FRACTION, BodyModel
from hrc_drake.safety.regions import (
    FixedBox,
    RegionCapsules,
    clamped,
    lost_capsules,
    reach_bounded,
    surface_clearances,
)

TABLE = FixedBox((0.45, 0.0, 0.73), (0.9, 1.6, 0.04))  # top surface at z = 0.75


def test_regions_tile_each_body_capsule():
    body = BodyModel()
    start, end, radius = body.capsules(body.rest_q())
    cutter = RegionCapsules(HAND_FRACTION)
    r_start, r_end, r_radius = cutter.cut(start, end, radius)
    assert len(r_radius) == len(cutter.names) == 10
    index = {name: k for k, name in enumerate(cutter.names)}
    # the right forearm capsule: lower arm elbow -> wrist, then the hand beyond
    wrist = body.points(body.rest_q())[7]
    assert np.allclose(r_start[index["right_lower_arm"]], start[5])
    assert np.allclose(r_end[index["right_lower_arm"]], wrist, atol=1e-9)
    assert np.allclose(r_start[index["right_hand"]], wrist, atol=1e-9)
    assert np.allclose(r_end[index["right_hand"]], end[5])
    assert np.allclose(r_end[index["abdomen"]], r_start[index["chest"]])
    # and each side on its own capsules: the left forearm (4), the left upper arm (2)
    left_wrist = body.points(body.rest_q())[6]
    assert np.allclose(r_start[index["left_lower_arm"]], start[4])
    assert np.allclose(r_start[index["left_hand"]], left_wrist, atol=1e-9)
    assert np.allclose(r_end[index["left_hand"]], end[4])
    assert np.allclose(r_end[index["left_upper_arm"]], end[2])
    assert np.allclose(r_end[index["right_upper_arm"]], end[3])
    assert cutter.regions[index["right_hand"]] == "hand_fingers"
    assert cutter.regions[index["face"]] == "face"


def _reach_bounded(uncertainty, q=None):
    body = BodyModel()
    points = body.points(body.rest_q() if q is None else q)
    start, end, radius = body.capsules_from_points(points)
    bounded = reach_bounded(start, end, radius, uncertainty, 0.3, body.upper_arm,
                            body.forearm + body.hand_length)
    return body, points, (start, end, radius), bounded


def test_uncertainty_from_the_spread_of_the_points():
    cutter = RegionCapsules()
    uncertainty = np.full(8, 0.03)
    uncertainty[0] = 0.05  # the thorax
    _, _, placed, (start, end, radius, per_capsule) = _reach_bounded(uncertainty)
    z_d = cutter.region_uncertainty(per_capsule)
    index = {name: k for k, name in enumerate(cutter.names)}
    assert z_d[index["right_hand"]] == pytest.approx(0.03)
    assert z_d[index["chest"]] == pytest.approx(0.05)
    assert z_d[index["face"]] == pytest.approx(0.05)  # thorax and head place it
    uncertainty[1] = 0.2  # the head's own point
    _, _, _, (_, _, _, per_capsule) = _reach_bounded(uncertainty)
    z_d = cutter.region_uncertainty(per_capsule)
    assert z_d[index["face"]] == pytest.approx(0.2) and z_d[index["chest"]] == pytest.approx(0.05)
    assert np.array_equal(start, placed[0]) and np.array_equal(end, placed[1])
    assert np.array_equal(radius, placed[2])


def test_a_lost_wrist_is_anywhere_its_elbow_lets_it_reach():
    uncertainty = np.full(8, 0.03)
    uncertainty[7] = np.inf  # the right wrist is lost (a Kalman prediction drifts away)
    body, points, placed, (start, end, radius, per_capsule) = _reach_bounded(uncertainty)
    reach = body.forearm + body.hand_length
    # right forearm (capsule 5): a sphere around the elbow, with the elbow's uncertainty
    assert np.allclose(start[5], points[5]) and np.allclose(end[5], points[5])
    assert radius[5] == pytest.approx(placed[2][5] + reach)
    assert per_capsule[5] == pytest.approx(0.03)
    # the fingertips anywhere on that reach lie inside it
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(200, 3))
    tips = points[5] + reach * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    assert np.all(np.linalg.norm(tips - points[5], axis=1) <= radius[5] - placed[2][5] + 1e-12)
    # the other arm and the upper arm keep their capsules
    for capsule in (0, 1, 2, 3, 4):
        assert np.array_equal(start[capsule], placed[0][capsule])
        assert radius[capsule] == placed[2][capsule]


def test_a_lost_elbow_bounds_the_whole_arm_by_the_shoulder_and_a_lost_shoulder_grows_uncapped():
    uncertainty = np.full(8, 0.02)
    uncertainty[[4, 6]] = [0.5, np.inf]  # the left elbow and wrist are lost
    body, points, placed, (start, end, radius, per_capsule) = _reach_bounded(uncertainty)
    for capsule in (2, 4):  # left upper arm and forearm: spheres around the shoulder
        assert np.allclose(start[capsule], points[2]) and np.allclose(end[capsule], points[2])
        assert per_capsule[capsule] == pytest.approx(0.02)
    assert radius[2] == pytest.approx(placed[2][2] + body.upper_arm)
    assert radius[4] == pytest.approx(placed[2][4] + body.upper_arm + body.forearm + body.hand_length)
    # the shoulder unmeasured for 5 s at 2.0 m/s: the arm's spheres keep their reach around its
    # last position, with its 10 m growth (no cap at 0.3 m; issue 51, item 5)
    uncertainty[2] = 10.0
    _, _, _, (start, _, radius, per_capsule) = _reach_bounded(uncertainty)
    assert per_capsule[2] == per_capsule[4] == pytest.approx(10.0)
    assert np.allclose(start[4], points[2])
    assert radius[4] == pytest.approx(placed[2][4] + body.upper_arm + body.forearm + body.hand_length)


def test_a_lost_thorax_grows_without_a_cap():
    uncertainty = np.full(8, 0.02)
    uncertainty[0] = 20.0  # the thorax unmeasured for 10 s at 2.0 m/s
    _, _, placed, (start, end, radius, per_capsule) = _reach_bounded(uncertainty)
    assert per_capsule[0] == pytest.approx(20.0)
    assert np.array_equal(radius, placed[2])


def test_a_lost_hand_near_the_table_counts_as_clamped():
    uncertainty = np.full(8, 0.03)
    uncertainty[7] = np.inf
    body = BodyModel()
    points = body.points(body.rest_q())
    points = points + np.array([0.0, 0.0, TABLE.center[2] + 0.3 - points[5][2]])  # elbow 0.3 m above
    start, end, radius = body.capsules_from_points(points)
    start, end, radius, _ = reach_bounded(start, end, radius, uncertainty, 0.3, body.upper_arm,
                                          body.forearm + body.hand_length)
    down = np.array([[0.0, 0.0, -1.0]])
    assert clamped(start[5:6], down, radius[5:6], (TABLE,))[0]


def test_a_hand_pressed_onto_the_table_is_clamped():
    hand = np.array([[0.5, 0.0, 0.78]])  # 3 cm above the top, radius 0.05: resting on it
    down = np.array([[0.0, 0.0, -1.0]])
    assert clamped(hand, down, np.array([0.05]), (TABLE,))[0]
    # pushed sideways or up it can recoil
    assert not clamped(hand, np.array([[1.0, 0.0, 0.0]]), np.array([0.05]), (TABLE,))[0]
    assert not clamped(hand, -down, np.array([0.05]), (TABLE,))[0]
    # well above the table it is free
    assert not clamped(np.array([[0.5, 0.0, 1.0]]), down, np.array([0.05]), (TABLE,))[0]
    # beyond the table's edge it is free
    assert not clamped(np.array([[1.2, 0.0, 0.78]]), down, np.array([0.05]), (TABLE,))[0]
    # no fixed surface: never clamped
    assert not clamped(hand, down, np.array([0.05]), ())[0]


def test_a_hand_pushed_against_a_fixture_side_is_clamped():
    fixture = FixedBox((0.6, 0.0, 0.85), (0.1, 0.3, 0.2))
    hand = np.array([[0.5, 0.0, 0.85]])  # 5 cm from the fixture's face at x = 0.55
    toward = np.array([[1.0, 0.0, 0.0]])
    assert clamped(hand, toward, np.array([0.04]), (TABLE, fixture))[0]
    assert not clamped(hand, -toward, np.array([0.04]), (TABLE, fixture))[0]


def test_the_pair_closest_points_kernel_matches_the_numpy_reference():
    from hrc_drake.kernels import pair_closest_parameters
    from hrc_drake.motion.geometry import segment_segment_closest

    rng = np.random.default_rng(5)
    a0, a1 = rng.normal(size=(7, 3)), rng.normal(size=(7, 3))
    b0, b1 = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    b1[2] = b0[2]  # a point
    a1[3] = a0[3] + 1e-3 * (b1[1] - b0[1])  # nearly parallel to b[1]
    k, r = np.meshgrid(np.arange(7), np.arange(5), indexing="ij")
    k, r = k.ravel(), r.ravel()
    _, s, t = segment_segment_closest(a0[k], a1[k], b0[r], b1[r])
    st = pair_closest_parameters(a0, a1, b0, b1, k, r)
    # the same closest points (the parameters of a point-like or parallel pair may differ)
    assert np.allclose(a0[k] + st[:, :1] * (a1[k] - a0[k]), a0[k] + s[:, None] * (a1[k] - a0[k]), atol=1e-9)
    assert np.allclose(b0[r] + st[:, 1:] * (b1[r] - b0[r]), b0[r] + t[:, None] * (b1[r] - b0[r]), atol=1e-9)


def test_surface_clearances_bound_the_capsule_s_clearance_from_below():
    rng = np.random.default_rng(5)
    start = rng.uniform([-0.5, -0.5, 0.8], [0.5, 0.5, 1.3], size=(40, 3))
    end = start + rng.normal(scale=0.2, size=(40, 3))
    radius = rng.uniform(0.02, 0.06, size=40)
    bound = surface_clearances(start, end, radius, (TABLE,))
    t = np.linspace(0.0, 1.0, 2001)
    points = start[:, None] + t[None, :, None] * (end - start)[:, None]
    lower = np.subtract(TABLE.center, np.multiply(TABLE.size, 0.5))
    upper = np.add(TABLE.center, np.multiply(TABLE.size, 0.5))
    outside = np.maximum(lower - points, 0.0) + np.maximum(points - upper, 0.0)
    fine = np.linalg.norm(outside, axis=2).min(axis=1) - radius
    spacing = np.linalg.norm(end - start, axis=1) / 16
    assert np.all(bound <= fine + 1e-12)
    assert np.all(bound >= fine - 0.5 * spacing - 1e-12)
    assert np.all(np.isinf(surface_clearances(start, end, radius, ())))


def test_only_a_lost_arm_point_s_capsules_are_reachable_sets():
    uncertainty = np.full(8, 0.03)
    assert not lost_capsules(uncertainty, 0.3).any()
    uncertainty[7] = np.inf  # right wrist: the right forearm
    assert lost_capsules(uncertainty, 0.3).tolist() == [False, False, False, False, False, True]
    uncertainty[4] = 0.5  # left elbow: the whole left arm
    assert lost_capsules(uncertainty, 0.3).tolist() == [False, False, True, False, True, True]


def test_a_lost_right_elbow_bounds_the_right_arm_by_the_right_shoulder():
    uncertainty = np.full(8, 0.02)
    uncertainty[3] = 0.04  # the right shoulder, placed
    uncertainty[[5, 7]] = np.inf  # the right elbow and wrist are lost
    body, points, placed, (start, end, radius, per_capsule) = _reach_bounded(uncertainty)
    for capsule in (3, 5):  # right upper arm and forearm: spheres around the right shoulder
        assert np.allclose(start[capsule], points[3]) and np.allclose(end[capsule], points[3])
        assert per_capsule[capsule] == pytest.approx(0.04)
    for capsule in (2, 4):  # the left arm keeps its capsules
        assert np.array_equal(start[capsule], placed[0][capsule]) and radius[capsule] == placed[2][capsule]


def test_a_hand_on_the_table_pushed_down_and_aside_is_clamped_as_the_judge_holds_it():
    """Regression (issue 52, torch_clock_fuzzy under PFL, seed 7): the gripper pushed a hand 6 cm
    over the table mostly sideways and 10-20 degrees down; a ray along the push never met the
    table, so the controller held the hand free, and the judge, whose ball moved 2 cm along the
    push comes nearer the table within its radius, found it clamped at 1.5x its quasi-static
    limit. The controller's test is now the judge's."""
    hand = np.array([[0.5, 0.0, 0.79]])  # 4 cm over the top, radius 0.05
    down_aside = np.array([[0.0, -np.cos(np.radians(15)), -np.sin(np.radians(15))]])
    assert clamped(hand, down_aside, np.array([0.05]), (TABLE,))[0]
    # along the table it slides; up, it recoils
    assert not clamped(hand, np.array([[0.0, -1.0, 0.0]]), np.array([0.05]), (TABLE,))[0]
    assert not clamped(hand, np.array([[0.0, -0.97, 0.26]]), np.array([0.05]), (TABLE,))[0]
    # an estimate inside the table: clamped whatever the push
    assert clamped(np.array([[0.5, 0.0, 0.74]]), np.array([[0.0, -1.0, 0.0]]), np.array([0.05]), (TABLE,))[0]


def test_the_controllers_clamping_test_holds_every_part_the_judge_finds_clamped():
    """Over random parts near the table and a fixture and random pushes, with the estimate the
    truth (Z_d 0), wherever the judge finds a part clamped against a fixed surface, so does the
    controller's test (`regions.clamped`; the kernel agrees with it in test_compiled_rules). With
    an estimate off by Z_d the push direction can tilt the other way: not covered (issue 52's
    closing note)."""
    from hrc_drake.safety.config import PowerForceLimiting
    from hrc_drake.safety.judge import Judge, declared_mode, standard_values

    fixture = FixedBox((0.6, 0.0, 0.85), (0.1, 0.3, 0.2))
    boxes = (TABLE, fixture)
    values = standard_values(reaction_time=0.1, deceleration=5.0)
    mode = declared_mode(PowerForceLimiting(), None)
    judge = Judge(values, mode, ("tool",), ("right_hand",), ("hand_fingers",), (6.0,), None, boxes)
    far = (np.array([[-5.0, 0.0, 1.0]]), np.array([[-5.0, 0.0, 1.0]]), np.array([0.03]))
    rng = np.random.default_rng(52)
    n = 4000
    points = np.column_stack([rng.uniform(0.3, 0.7, n), rng.uniform(-0.3, 0.3, n),
                              rng.uniform(0.70, 0.95, n)])
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    radius = rng.uniform(0.03, 0.06, n)
    by_judge = np.array([judge.clamped_against(0, radius[i], points[i], directions[i], far)
                         == "a fixed surface" for i in range(n)])
    by_controller = clamped(points, directions, radius, boxes, 0.02)
    assert by_judge.sum() > 200  # the cases exist
    assert not np.any(by_judge & ~by_controller), np.nonzero(by_judge & ~by_controller)[0][:5]


def test_under_estimate_error_the_controller_clamps_every_contact_the_judge_finds_clamped():
    """Issue 52's gap: the judge tests the true hand, the controller its estimate, off by up to
    Z_d (3 cm). Over random hand-robot contacts near the table and a fixture, with the estimate's
    end points moved up to Z_d, every contact the judge finds clamped against a fixed surface the
    controller holds clamped (`SafetyRules.clamped` with `near_surfaces`). Without the near test,
    the push test alone (the judge's on the estimate, its radius grown by Z_d) misses some: the
    estimate's push tilts away from the surface the true push comes nearer."""
    from hrc_drake.safety.config import PowerForceLimiting
    from hrc_drake.safety.judge import Judge, declared_mode, standard_values
    from hrc_drake.safety.limits import load_limits
    from hrc_drake.safety.rules import SafetyRules, clamping_radius, pair_geometry

    fixture = FixedBox((0.6, 0.0, 0.85), (0.1, 0.3, 0.2))
    boxes = (TABLE, fixture)
    values = standard_values(reaction_time=0.1, deceleration=5.0)
    judge = Judge(values, declared_mode(PowerForceLimiting(), None), ("tool",), ("right_hand",),
                  ("hand_fingers",), (6.0,), None, boxes)
    rules = SafetyRules(PowerForceLimiting(), load_limits(), ("hand_fingers",), None, boxes)
    rng = np.random.default_rng(520)
    z_d = np.array([0.03])
    still = (np.zeros((1, 3)), np.zeros((1, 3)))
    judged = missed = missed_by_push_alone = 0
    for _ in range(3000):
        centre = np.array([rng.uniform(0.3, 0.7), rng.uniform(-0.3, 0.3), rng.uniform(0.76, 0.9)])
        axis = rng.normal(size=3)
        axis *= rng.uniform(0.0, 0.05) / np.linalg.norm(axis)
        radius = np.array([rng.uniform(0.03, 0.05)])
        truth = (centre[None] - axis, centre[None] + axis, radius)
        push = rng.normal(size=3)
        push /= np.linalg.norm(push)
        tool_radius = 0.04
        at = centre - push * (radius[0] + tool_radius - 0.002)  # 2 mm deep: a contact
        across = np.cross(push, rng.normal(size=3))
        across *= rng.uniform(0.0, 0.08) / np.linalg.norm(across)
        robot = ((at - across)[None], (at + across)[None], np.array([tool_radius]))
        k = r = np.zeros(1, dtype=np.int64)
        true_pair = pair_geometry(robot, still, truth, k, r, np.zeros(1))
        if judge.clamped_against(0, radius[0], true_pair.body_point[0], true_pair.direction[0],
                                 robot) != "a fixed surface":
            continue
        judged += 1
        error = rng.normal(size=(2, 3))
        error *= (z_d[0] * rng.uniform(0.5, 1.0, (2, 1)) ** (1 / 3)) / np.linalg.norm(error, axis=1)[:, None]
        estimate = (truth[0] + error[:1], truth[1] + error[1:], radius)
        pair = pair_geometry(robot, still, estimate, k, r, np.zeros(1))
        grown = clamping_radius(radius, z_d)
        near = rules.near_pairs(pair, estimate, z_d, np.zeros((1, 1)), robot)
        missed += not rules.clamped(pair, grown, near=near)[0]
        missed_by_push_alone += not rules.clamped(pair, grown)[0]
    assert judged > 300  # the cases exist
    assert missed_by_push_alone > 0  # the near test is what closes the gap
    assert missed == 0


def test_a_hand_pushed_against_a_cart_is_clamped_as_the_judge_holds_it():
    """The audit's crushed hand: a gripper pushes a hand toward a cart (another robot capsule). The
    controller's test is the judge's (`Judge.clamped_against`) on the robot's capsules: over random
    hands between a pushing capsule and two others, every hand the judge finds clamped against a
    capsule the controller holds clamped, and one pushed away from the cart is free."""
    from hrc_drake.safety.config import PowerForceLimiting
    from hrc_drake.safety.judge import Judge, declared_mode, standard_values
    from hrc_drake.safety.regions import clamped_by_capsules

    hand = np.array([[0.0, 0.0, 1.0]])
    cart = (np.array([[0.0, 0.1, 0.8], [0.0, 0.0, 1.0]]), np.array([[0.0, 0.1, 1.2], [0.0, 0.0, 1.0]]),
            np.array([0.05, 0.04]))  # capsule 0: the cart's post 10 cm beside the hand; 1: the gripper
    toward = np.array([[0.0, 1.0, 0.0]])
    assert clamped_by_capsules(hand, toward, np.array([0.05]), np.array([1]), cart)[0]
    assert not clamped_by_capsules(hand, -toward, np.array([0.05]), np.array([1]), cart)[0]
    # the capsule that pushes does not clamp against itself
    assert not clamped_by_capsules(hand, toward, np.array([0.05]), np.array([0]), cart)[0]

    values = standard_values(reaction_time=0.1, deceleration=5.0)
    judge = Judge(values, declared_mode(PowerForceLimiting(), None), ("gripper", "cart", "link"),
                  ("right_hand",), ("hand_fingers",), (6.0, 20.0, 6.0), None, ())
    rng = np.random.default_rng(521)
    n = 3000
    points = rng.uniform(-0.15, 0.15, (n, 3)) + [0.0, 0.0, 1.0]
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    radius = rng.uniform(0.03, 0.06, n)
    robot = (np.array([[0.5, 0.0, 1.0], [0.0, 0.1, 0.8], [-0.1, -0.1, 1.0]]),
             np.array([[0.6, 0.0, 1.0], [0.0, 0.1, 1.2], [-0.1, 0.1, 1.0]]), np.array([0.04, 0.05, 0.03]))
    by_controller = clamped_by_capsules(points, directions, radius, np.zeros(n, dtype=int), robot)
    by_judge = np.array([judge.clamped_against(0, radius[i], points[i], directions[i], robot) != ""
                         for i in range(n)])
    assert by_judge.sum() > 200
    np.testing.assert_array_equal(by_controller, by_judge)


def test_under_estimate_error_the_controller_clamps_every_hand_the_judge_finds_clamped_against_a_cart():
    """As for fixed surfaces, with the estimate off by up to Z_d (3 cm): over random hands at a
    cart's post pushed by a gripper, every contact the judge finds clamped against the post the
    controller holds clamped (`SafetyRules.near_pairs`: an uncertain part within Z_d + the margin of
    a capsule apart from the pushing one), where the push test alone misses some."""
    from hrc_drake.safety.config import PowerForceLimiting
    from hrc_drake.safety.judge import Judge, declared_mode, standard_values
    from hrc_drake.safety.limits import load_limits
    from hrc_drake.safety.rules import SafetyRules, clamping_radius, pair_geometry

    values = standard_values(reaction_time=0.1, deceleration=5.0)
    judge = Judge(values, declared_mode(PowerForceLimiting(), None), ("gripper", "cart"), ("right_hand",),
                  ("hand_fingers",), (6.0, 20.0), None, ())
    rules = SafetyRules(PowerForceLimiting(), load_limits(), ("hand_fingers",), None, (),
                        capsule_robots=[0, 1])  # the gripper's robot and the cart
    rng = np.random.default_rng(522)
    z_d = np.array([0.03])
    still = (np.zeros((2, 3)), np.zeros((2, 3)))
    post = (np.array([0.0, 0.0, 0.6]), np.array([0.0, 0.0, 1.4]), 0.06)
    judged = missed = missed_by_push_alone = 0
    for _ in range(4000):
        radius = np.array([rng.uniform(0.03, 0.05)])
        side = np.append(rng.normal(size=2), 0.0)
        side /= np.linalg.norm(side)
        centre = [0.0, 0.0, rng.uniform(0.8, 1.2)] + side * (post[2] + radius[0] + rng.uniform(-0.005, 0.04))
        axis = rng.normal(size=3)
        axis *= rng.uniform(0.0, 0.05) / np.linalg.norm(axis)
        truth = (centre[None] - axis, centre[None] + axis, radius)
        push = rng.normal(size=3)
        push /= np.linalg.norm(push)
        at = centre - push * (radius[0] + 0.04 - 0.002)  # the gripper 2 mm deep: a contact
        across = np.cross(push, rng.normal(size=3))
        across *= rng.uniform(0.0, 0.08) / np.linalg.norm(across)
        robot = (np.array([at - across, post[0]]), np.array([at + across, post[1]]),
                 np.array([0.04, post[2]]))
        k = r = np.zeros(1, dtype=np.int64)
        true_pair = pair_geometry(robot, still, truth, k, r, np.zeros(1))
        if judge.clamped_against(0, radius[0], true_pair.body_point[0], true_pair.direction[0], robot) == "":
            continue
        judged += 1
        error = rng.normal(size=(2, 3))
        error *= (z_d[0] * rng.uniform(0.5, 1.0, (2, 1)) ** (1 / 3)) / np.linalg.norm(error, axis=1)[:, None]
        estimate = (truth[0] + error[:1], truth[1] + error[1:], radius)
        distance, _, _ = rules.screen(robot, still, estimate, z_d)
        pair = pair_geometry(robot, still, estimate, k, r, distance[k, r])
        grown = clamping_radius(radius, z_d)
        near = rules.near_pairs(pair, estimate, z_d, distance, robot)
        missed += not rules.clamped(pair, grown, near=near, robot=robot)[0]
        missed_by_push_alone += not rules.clamped(pair, grown, robot=robot)[0]
    assert judged > 300
    assert missed_by_push_alone > 0
    assert missed == 0


def test_under_estimate_error_the_controller_clamps_a_part_pinched_in_the_robot_s_elbow():
    """The elbow's pinch (IRB 140 links 2 and 3, joined, at 20-160 degrees): a part pushed by one
    link against the other. Every part the judge finds clamped on the truth, the controller holds
    clamped on an estimate off by up to Z_d (3 cm) (`SafetyRules._pushed_toward` for joined
    links, found by an adversarial review: the push test alone missed 14 % of the hands)."""
    from hrc_drake.kernels import capsule_clearances
    from hrc_drake.safety.config import PowerForceLimiting
    from hrc_drake.safety.judge import Judge, declared_mode, standard_values
    from hrc_drake.safety.limits import load_limits
    from hrc_drake.safety.rules import SafetyRules, clamping_radius, pair_geometry

    values = standard_values(reaction_time=0.1, deceleration=5.0)
    judge = Judge(values, declared_mode(PowerForceLimiting(), None), ("link2", "link3"),
                  ("right_hand",), ("hand_fingers",), (6.0, 6.0), None, ())
    rules = SafetyRules(PowerForceLimiting(), load_limits(), ("hand_fingers",), None, (),
                        capsule_robots=[0, 0], joined_capsules=np.ones((2, 2), dtype=bool))
    rng = np.random.default_rng(523)
    z_d = np.array([0.03])
    still = (np.zeros((2, 3)), np.zeros((2, 3)))
    one = np.zeros(1, dtype=np.int64)
    judged = missed = missed_by_push_alone = clamped_free = free = 0
    for _ in range(8000):
        angle = np.radians(rng.uniform(20.0, 160.0))
        second = 0.239 * np.array([np.sin(angle), 0.0, np.cos(angle)])
        robot = (np.zeros((2, 3)), np.array([[0.0, 0.0, 0.36], second]), np.array([0.11, 0.085]))
        k = int(rng.integers(2))  # the pushing link
        along = robot[1][k] / np.linalg.norm(robot[1][k])
        out = rng.normal(size=3)
        out -= (out @ along) * along
        out /= np.linalg.norm(out)
        centre = robot[1][k] * rng.uniform() + out * (robot[2][k] + 0.05 - rng.uniform(0.0, 0.01))
        axis = rng.normal(size=3)
        axis *= 0.05 / np.linalg.norm(axis)
        truth = (centre[None] - axis, centre[None] + axis, np.array([0.05]))
        error = rng.normal(size=(2, 3))
        error *= (z_d[0] * rng.uniform(0.0, 1.0, (2, 1)) ** (1 / 3)) / np.linalg.norm(error, axis=1)[:, None]
        estimate = (truth[0] + error[:1], truth[1] + error[1:], truth[2])
        true_pair = pair_geometry(robot, still, truth, one + k, one, np.zeros(1))
        against = judge.clamped_against(k, 0.05, true_pair.body_point[0], true_pair.direction[0], robot)
        by_judge = against != ""
        distance = capsule_clearances(*robot, *estimate)
        pair = pair_geometry(robot, still, estimate, one + k, one, distance[[k], [0]])
        grown = clamping_radius(estimate[2], z_d)
        held = rules.clamped(pair, grown, near=rules.near_pairs(pair, estimate, z_d, distance, robot),
                             robot=robot)[0]
        judged += by_judge
        missed += by_judge and not held
        missed_by_push_alone += by_judge and not rules.clamped(pair, grown, robot=robot)[0]
        if not by_judge and distance[1 - k, 0] < z_d[0] + 0.02:  # free, but near the other link
            free += 1
            clamped_free += held
    assert judged > 150
    assert missed_by_push_alone > 0
    assert missed == 0
    assert clamped_free < 0.8 * free  # not every part near both links: the push's direction counts


def test_an_uncertain_part_is_near_the_table_within_its_radius_plus_z_d_plus_the_margin():
    """By hand: the table's top at z = 0.75, a hand of radius 0.05 with Z_d = 0.03 and the 2 cm
    margin is near it while its (level, 0.1 m long) axis is under 0.75 + 0.05 + 0.03 + 0.02 = 0.85 m,
    plus half the spacing of the 17 points the axis is sampled at (0.1 / 16 / 2 = 3.1 mm: a lower
    bound on the distance keeps the test a superset); an exact estimate (Z_d 0) is never near (the
    push test alone decides)."""
    from hrc_drake.safety.regions import near_surfaces

    def near(height, z_d):
        start, end = np.array([[0.4, 0.0, height]]), np.array([[0.5, 0.0, height]])
        return near_surfaces(start, end, np.array([0.05]), np.array([z_d]), (TABLE,))[0]

    assert near(0.849, 0.03) and near(0.853, 0.03) and not near(0.854, 0.03)
    assert not near(0.80, 0.0)
