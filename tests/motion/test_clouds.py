import copy
import itertools

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from hrc_drake.motion.clouds import (
    GridBox,
    InteractionModel,
    ProbabilityCloud,
    cloud_error,
    hull_distance,
    occupancy,
    pca_box,
    probability_cloud,
    repulsive_potential,
    swept_hulls,
    weighted_union,
)
from hrc_drake.motion.geometry import point_segment_distance

# ------------------------------------------------------------------------------------------
# P_RH, eqs. (8.20)-(8.23)
# ------------------------------------------------------------------------------------------


def _worked_model() -> InteractionModel:
    # R: 0 on [0, 6), 1 from 6.  A: None on [0, 2), 1 on [2, 5), None on [5, 7), 0 from 7.
    model = InteractionModel(2, 2, window=10.0)
    model.set_robot(0.0, 0)
    model.set_human(2.0, 1)
    model.set_human(5.0, None)
    model.set_robot(6.0, 1)
    model.set_human(7.0, 0)
    return model


def test_p_rh_hand_worked_window():
    model = _worked_model()
    # window [2, 12]: robot 0 for 4 s, 3 of them with human 1; robot 1 for 6 s, 5 with human 0
    np.testing.assert_allclose(model.matrix(12.0), [[0.0, 3 / 4], [5 / 6, 0.0]])
    # window [4, 14] cuts the robot-0 and human-1 segments: 2 s and 1 s of them remain
    np.testing.assert_allclose(model.matrix(14.0), [[0.0, 1 / 2], [7 / 8, 0.0]])
    joint, robot_time = model.integrals(14.0)
    np.testing.assert_allclose(joint, [[0.0, 1.0], [7.0, 0.0]])
    np.testing.assert_allclose(robot_time, [2.0, 8.0])


def test_p_rh_undefined_rows_and_none_segments():
    model = _worked_model()
    assert np.all(np.isnan(InteractionModel(2, 3, 5.0).matrix(0.0)))
    # window [10, 20]: robot action 0 never occurs -> row NaN (1/0 in M, eq. 8.23)
    p = model.matrix(20.0)
    assert np.all(np.isnan(p[0])) and model.defined_rows(20.0).tolist() == [False, True]
    np.testing.assert_allclose(p[1], [1.0, 0.0])
    # robot idle (None) and the human doing nothing of A_S: the row sums to < 1
    model.set_robot(20.0, None)
    model.set_human(21.0, None)
    model.set_robot(22.0, 0)
    model.set_human(24.0, 1)
    # window [16, 26]: robot 0 on [22, 26] (4 s): human None on [22, 24), 1 on [24, 26]
    np.testing.assert_allclose(model.matrix(26.0)[0], [0.0, 0.5])
    # robot 1 on [16, 20) (4 s), human 0 all along
    np.testing.assert_allclose(model.matrix(26.0)[1], [1.0, 0.0])


def test_p_rh_matches_time_stepping_and_forgets_old_history():
    rng = np.random.default_rng(3)
    m, n, window, dt = 3, 4, 7.5, 0.05
    model = InteractionModel(m, n, window)
    robot, human = np.full(2000, -1), np.full(2000, -1)  # reference signals on the dt grid
    for t in np.arange(0.0, 100.0, 0.5):  # change times on a 0.5 s grid: midpoints are exact
        k = int(round(t / dt))
        if rng.random() < 0.4:
            j = int(rng.integers(-1, m))
            model.set_robot(t, None if j < 0 else j)
            robot[k:] = j
        if rng.random() < 0.4:
            i = int(rng.integers(-1, n))
            model.set_human(t, None if i < 0 else i)
            human[k:] = i
        if t > 0 and rng.random() < 0.3:
            steps = np.arange(max(0, k - 150), k)  # the window [t - 7.5, t] in dt steps
            joint = np.zeros((m, n))
            for r_value, h_value in zip(robot[steps], human[steps], strict=True):
                if r_value >= 0 and h_value >= 0:
                    joint[r_value, h_value] += dt
            total = np.bincount(robot[steps][robot[steps] >= 0], minlength=m) * dt
            expected = np.where(total[:, None] > 0, joint / np.where(total > 0, total, 1)[:, None], np.nan)
            np.testing.assert_allclose(model.matrix(t), expected, atol=1e-9)
    assert len(model._times["robot"]) <= 16 and len(model._times["human"]) <= 16


def test_p_rh_copy_is_independent():
    model = _worked_model()
    twin = model.copy()
    twin.set_robot(8.0, 0)
    assert model.matrix(12.0)[1, 0] == pytest.approx(5 / 6)
    assert twin.matrix(12.0)[0, 0] == pytest.approx(4 / 8)


def test_p_rh_bad_inputs():
    model = _worked_model()
    with pytest.raises(ValueError, match="times must not decrease"):
        model.set_robot(6.5, 0)
    with pytest.raises(ValueError, match="times must not decrease"):
        model.matrix(3.0)
    for bad in (2, -1, 1.0, True, "0"):
        with pytest.raises(ValueError, match="robot action"):
            model.set_robot(9.0, bad)
    with pytest.raises(ValueError, match="human action"):
        model.set_human(9.0, 5)
    with pytest.raises(ValueError, match="finite"):
        model.set_human(np.nan, 0)
    for args in ((0, 2, 1.0), (2, 0, 1.0), (2, 2, 0.0), (2, 2, np.inf), (1.5, 2, 1.0)):
        with pytest.raises(ValueError):
            InteractionModel(*args)


# ------------------------------------------------------------------------------------------
# Hull distance and occupancy, eqs. (8.27)-(8.28)
# ------------------------------------------------------------------------------------------


def _brute_hull_distance(x, vertices):
    """Exact by enumeration: project x on the affine span of every vertex subset, keep convex ones."""
    best = np.inf
    for size in range(1, 5):
        for subset in itertools.combinations(range(4), size):
            p = vertices[list(subset)]
            span = (p[1:] - p[0]).T
            coefficients = np.linalg.lstsq(span, x - p[0], rcond=None)[0] if size > 1 else np.zeros(0)
            if size > 1 and (coefficients.min() < -1e-12 or coefficients.sum() > 1 + 1e-12):
                continue
            best = min(best, np.linalg.norm(x - p[0] - span @ coefficients))
    return best


def _hulls(rng):
    plane = rng.normal(size=(4, 2)) @ rng.normal(size=(2, 3))  # coplanar through 0
    line = np.outer(rng.normal(size=4), rng.normal(size=3))
    point = rng.normal(size=3)
    yield from (rng.normal(size=(4, 3)) for _ in range(6))
    yield plane + rng.normal(size=3)
    yield line + rng.normal(size=3)
    yield np.tile(point, (4, 1))
    yield np.array([point, point, point + 1.0, point + [1.0, 0.0, 0.0]])  # two coincident pairs
    yield np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, 0.0]])  # one inside the triangle
    yield np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 1e-14]])  # nearly flat


def test_hull_distance_matches_brute_force_incl_degenerate_hulls():
    rng = np.random.default_rng(0)
    for vertices in _hulls(rng):
        x = vertices.mean(axis=0) + rng.normal(scale=0.8, size=(60, 3))
        x[:10] = vertices[rng.integers(0, 4, 10)] + rng.normal(scale=0.05, size=(10, 3))
        distance = hull_distance(x, vertices)
        brute = [_brute_hull_distance(point, vertices) for point in x]
        np.testing.assert_allclose(distance, brute, atol=1e-9)
        # and never above the distance to dense samples of the hull
        samples = rng.dirichlet(np.ones(4), size=4000) @ vertices
        sampled = np.linalg.norm(x[:, None] - samples[None], axis=-1).min(axis=1)
        assert np.all(distance <= sampled + 1e-12)


def test_hull_distance_zero_exactly_inside_solid_hull():
    rng = np.random.default_rng(1)
    vertices = rng.normal(size=(4, 3))
    hull = ConvexHull(vertices)
    x = rng.dirichlet(np.ones(4), size=500) @ vertices + rng.normal(scale=0.1, size=(500, 3))
    inside = np.all(x @ hull.equations[:, :3].T + hull.equations[:, 3] <= 0, axis=1)
    assert inside.any() and not inside.all()
    distance = hull_distance(x, vertices)
    assert np.all(distance[inside] == 0.0) and np.all(distance[~inside] > 0.0)
    # broadcasting over a batch of hulls
    batch = np.stack([vertices, vertices + 5.0])
    np.testing.assert_allclose(hull_distance(x[:3, None], batch), np.stack(
        [hull_distance(x[:3], vertices), hull_distance(x[:3], vertices + 5.0)], axis=1))


def _arm(shoulder=(0.0, 0.0, 0.0), elbow=(0.3, 0.0, 0.0), wrist=(0.55, 0.0, 0.0)):
    return np.array([shoulder, elbow, wrist], dtype=float)


def _trajectories(rng):
    base = _arm((0, 0, 1.4), (0.25, 0.1, 1.2), (0.5, 0.1, 1.3))
    yield base + np.cumsum(rng.normal(scale=0.04, size=(6, 3, 3)), axis=0)  # general motion
    yield np.stack([base] * 4)  # static: each hull is a segment (two coincident pairs)
    yield np.stack([base + s * (base[2] - base[0]) for s in (0.0, 0.1, 0.3)])  # along the arm: collinear
    yield np.stack([base + [0.0, 0.0, s] for s in (0.0, 0.05, 0.2)])  # translation: coplanar hulls
    yield np.stack([_arm(), _arm(wrist=(0.3, 0.0, 0.0)), _arm((0.3, 0, 0), (0.3, 0, 0), (0.3, 0, 0))])


def test_occupancy_matches_full_grid_brute_force():
    rng = np.random.default_rng(2)
    radius = 0.05
    for trajectory in _trajectories(rng):
        box = pca_box(trajectory, radius, 14)
        occupied = occupancy(trajectory, radius, box)
        nodes = box.nodes()
        hulls = swept_hulls(trajectory)
        distance = hull_distance(nodes[None, :, None], hulls[:, None]).min(axis=-1)  # (L-1, g)
        clear = np.abs(distance - radius) > 1e-9
        assert np.array_equal(occupied[clear], (distance <= radius)[clear])
        assert occupied.any()


def test_box_holds_every_swept_volume():
    rng = np.random.default_rng(4)
    trajectory = next(_trajectories(rng))
    radius = 0.07
    cloud = probability_cloud(trajectory, radius, grid=9, threshold=-1.0)
    assert len(cloud) == 9**3
    local = cloud.box.to_box(trajectory.reshape(-1, 3))
    assert np.all(np.abs(local) <= 0.5 * cloud.box.extents - radius + 1e-12)
    np.testing.assert_allclose(cloud.box.cell_size, cloud.box.extents / 9)
    assert len(probability_cloud(trajectory, radius).box.nodes()) == 15625  # G = 25 of the thesis


STRAIGHT_VOLUME = np.pi * 0.05**2 * 0.55 + 4 / 3 * np.pi * 0.05**3
# arm and forearm at 90 degrees: two cylinders - a quarter Steinmetz solid + 5/4 of a sphere
BENT_VOLUME = np.pi * 0.05**2 * 0.55 + 5 / 4 * 4 / 3 * np.pi * 0.05**3 - 4 / 3 * 0.05**3


def test_bent_volume_by_monte_carlo():
    arm, radius = _arm(wrist=(0.3, 0.25, 0.0)), 0.05
    rng = np.random.default_rng(5)
    low, high = np.array([-radius] * 3), np.array([0.3 + radius, 0.25 + radius, radius])
    p = low + rng.random((400_000, 3)) * (high - low)
    inside = (point_segment_distance(p, arm[0], arm[1]) <= radius) | (
        point_segment_distance(p, arm[1], arm[2]) <= radius)
    assert inside.mean() * np.prod(high - low) == pytest.approx(BENT_VOLUME, rel=0.01)


@pytest.mark.parametrize(
    "arm, volume", [(_arm(), STRAIGHT_VOLUME), (_arm(wrist=(0.3, 0.25, 0.0)), BENT_VOLUME)])
def test_static_arm_cloud_integrates_to_the_swept_volume(arm, volume):
    radius = 0.05
    errors = {}
    for grid in (10, 25, 60):
        cloud = probability_cloud(np.stack([arm] * 5), radius, grid)
        assert np.all(cloud.gamma == 1.0)  # every step sweeps the same set
        errors[grid] = abs(cloud.occupied_volume() - volume)
        # grid error: at most the shell within half a cell diagonal of the surface
        area = 2 * np.pi * radius * 0.55 + 4 * np.pi * radius**2
        assert errors[grid] <= area * np.linalg.norm(cloud.box.cell_size)
    assert errors[60] < errors[10] and errors[60] < 0.01 * volume


def test_half_time_at_two_places_gives_half_occupancy():
    radius, poses = 0.08, 5
    place_a = _arm((0, 0, 0), (0, 0, -0.3), (0.25, 0, -0.3))
    place_b = place_a + [1.5, 0.0, 0.0]
    trajectory = np.stack([place_a] * poses + [place_b] * poses)
    cloud = probability_cloud(trajectory, radius, grid=30)
    # 4 static steps at each place + the transition step A -> B, which covers A and B too
    steps = 2 * poses - 1
    assert cloud.gamma.max() == pytest.approx(poses / steps)
    for place in (place_a, place_b):
        near = np.linalg.norm(cloud.points - place[1], axis=1) < radius / 2
        assert near.any()
        np.testing.assert_allclose(cloud.gamma[near], poses / steps)
    between = np.linalg.norm(cloud.points - [0.75, 0.0, -0.15], axis=1) < radius / 2
    assert between.any()
    np.testing.assert_allclose(cloud.gamma[between], 1 / steps)
    assert set(np.round(cloud.gamma * steps, 9)) <= {1.0, float(poses)}


def test_cloud_error_bounded_by_half_cell_diagonal():
    rng = np.random.default_rng(6)
    trajectory = next(_trajectories(rng))
    cloud = probability_cloud(trajectory, 0.05, grid=8)
    error = cloud_error(trajectory, cloud)
    assert error.shape == (6, 3)
    assert np.all(error <= 0.5 * np.linalg.norm(cloud.box.cell_size) + 1e-12)
    nodes = cloud.box.nodes()
    brute = np.linalg.norm(trajectory[..., None, :] - nodes, axis=-1).min(axis=-1)
    np.testing.assert_allclose(error, brute, atol=1e-12)
    np.testing.assert_allclose(cloud_error(trajectory, cloud.box), error)
    assert cloud_error(trajectory, probability_cloud(trajectory, 0.05, grid=24)).mean() < error.mean()


def test_cloud_bad_inputs():
    arm = np.stack([_arm()] * 3)
    for bad in (arm[:1], arm[..., :2], np.zeros((3, 4, 3)), np.where(arm == 0, np.nan, arm)):
        with pytest.raises(ValueError, match="trajectory"):
            probability_cloud(bad, 0.05)
    for radius in (0.0, -0.1, np.nan):
        with pytest.raises(ValueError, match="radius"):
            probability_cloud(arm, radius)
    for grid in (0, 2.5, True):
        with pytest.raises(ValueError, match="grid"):
            probability_cloud(arm, 0.05, grid)
    with pytest.raises(ValueError, match="orthonormal"):
        GridBox(np.zeros(3), 2 * np.eye(3), np.ones(3), 4)
    with pytest.raises(ValueError, match="gamma"):
        ProbabilityCloud(np.zeros((2, 3)), [0.5, -0.1])
    with pytest.raises(ValueError, match="points but"):
        ProbabilityCloud(np.zeros((2, 3)), [0.5])
    with pytest.raises(ValueError, match="box"):
        cloud_error(arm, ProbabilityCloud(np.zeros((0, 3)), []))


def test_cloud_is_an_immutable_value():
    cloud = probability_cloud(np.stack([_arm()] * 3), 0.05, grid=6)
    assert copy.deepcopy(cloud) is cloud and copy.deepcopy(cloud.box) is cloud.box
    with pytest.raises(ValueError):
        cloud.gamma[0] = 3.0
    with pytest.raises(AttributeError):
        cloud.gamma = np.zeros(1)


# ------------------------------------------------------------------------------------------
# Weighted union (8.29)-(8.30) and the repulsive potential (8.32)
# ------------------------------------------------------------------------------------------


def _small_clouds():
    first = ProbabilityCloud([[0, 0, 0], [1, 0, 0]], [0.5, 1.0])
    second = ProbabilityCloud([[0, 2, 0]], [0.8])
    third = ProbabilityCloud([[5, 5, 5]], [1.0])
    return first, second, third


def test_weighted_union():
    first, second, third = _small_clouds()
    union = weighted_union([first, second, third], [0.25, 0.5, 0.0])
    np.testing.assert_allclose(union.points, [[0, 0, 0], [1, 0, 0], [0, 2, 0]])
    np.testing.assert_allclose(union.gamma, [0.125, 0.25, 0.4])
    assert len(weighted_union([first, second, third], [np.nan, 1.0, 0.0])) == 1
    assert len(weighted_union([first], [0.0])) == 0
    # with the P_RH row of a robot action (the undefined row drops every cloud)
    model = _worked_model()
    row = model.matrix(12.0)[0]  # [0, 3/4]
    np.testing.assert_allclose(weighted_union([first, second], row).gamma, [0.6])
    assert len(weighted_union([first, second], model.matrix(20.0)[0])) == 0
    # the grid box survives only when every kept cloud shares it
    arm_cloud = probability_cloud(np.stack([_arm()] * 2), 0.05, grid=5)
    assert weighted_union([arm_cloud, first], [0.5, 0.0]).box is arm_cloud.box
    assert weighted_union([arm_cloud, first], [0.5, 0.1]).box is None


def test_weighted_union_bad_inputs():
    first, second, _ = _small_clouds()
    with pytest.raises(ValueError, match="2 clouds but 3 weights"):
        weighted_union([first, second], [0.1, 0.2, 0.3])
    for weights in ([0.5, -0.1], [np.inf, 0.1]):
        with pytest.raises(ValueError, match="weights"):
            weighted_union([first, second], weights)
    with pytest.raises(ValueError, match="ProbabilityCloud"):
        weighted_union([first, "cloud"], [0.1, 0.2])


def test_repulsive_potential_matches_a_loop():
    rng = np.random.default_rng(7)
    cloud = ProbabilityCloud(rng.normal(size=(5000, 3)), rng.random(5000))
    queries = rng.normal(size=(2, 150, 3))  # 300 queries: more than one chunk
    alpha = 3.0
    value = repulsive_potential(cloud, queries, alpha)
    assert value.shape == (2, 150)
    expected = np.zeros((2, 150))
    for a, b in np.ndindex(2, 150):
        for point, gamma in zip(cloud.points[::50], cloud.gamma[::50], strict=True):
            expected[a, b] += gamma * np.exp(-alpha * np.linalg.norm(point - queries[a, b]))
    thin = ProbabilityCloud(cloud.points[::50], cloud.gamma[::50])
    np.testing.assert_allclose(repulsive_potential(thin, queries, alpha), expected, rtol=1e-12)
    full = np.exp(-alpha * np.linalg.norm(queries[..., None, :] - cloud.points, axis=-1)) @ cloud.gamma
    np.testing.assert_allclose(value, full, rtol=1e-12)
    # J_Rep of one waypoint: the caller sums over its points T
    assert repulsive_potential(cloud, queries[0], alpha).sum() == pytest.approx(value[0].sum())
    assert repulsive_potential(cloud, [0.0, 0.0, 0.0], 0.0) == pytest.approx(cloud.gamma.sum())
    empty = ProbabilityCloud(np.zeros((0, 3)), [])
    assert np.all(repulsive_potential(empty, queries, alpha) == 0.0)


def test_repulsive_potential_bad_inputs():
    cloud = _small_clouds()[0]
    for alpha in (-1.0, np.nan):
        with pytest.raises(ValueError, match="alpha"):
            repulsive_potential(cloud, [0.0, 0.0, 0.0], alpha)
    with pytest.raises(ValueError, match="query_points"):
        repulsive_potential(cloud, [0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="ProbabilityCloud"):
        repulsive_potential(np.zeros((3, 3)), [0.0, 0.0, 0.0], 1.0)
