"""STOMP (Kalakrishnan et al. 2011) and the proactive cost of thesis eqs. (8.31)-(8.32)."""

import dataclasses
import time

import numpy as np
import pytest

from hrc_drake.motion.geometry import point_capsule_distance
from hrc_drake.motion.stomp import (
    Box,
    ProactiveCost,
    acceleration_matrix,
    capsule_box_penetration,
    plan_proactive_path,
    repulsive_potential,
    segment_box_signed_distance,
    stomp,
)

N = 40
S = np.linspace(0.0, 1.0, N + 1)
STRAIGHT = np.stack([S, np.zeros_like(S)], axis=-1)  # 2-joint path (0, 0) -> (1, 0)


def tracking_cost(target):
    """Per-waypoint ||theta_i - target_i||^2: the optimum is the target's interior."""
    return lambda Q: np.square(Q - target[1:-1]).sum(-1)


def bump_cost():
    """A Gaussian bump centred below the straight path (strength growing towards the middle) plus
    springs: x to the straight path, y to 0. Returns (cost, per-waypoint optimum (N-1, 2))."""
    strength = np.exp(-0.5 * ((S[1:-1] - 0.5) / 0.15) ** 2)
    centre, sigma, wy, wx = -0.08, 0.1, 2.0, 20.0

    def cost(Q):
        x, y = Q[..., 0], Q[..., 1]
        return wx * (x - S[1:-1]) ** 2 + strength * np.exp(-0.5 * ((y - centre) / sigma) ** 2) + wy * y**2

    y = np.linspace(-0.5, 0.5, 100001)  # the cost separates per waypoint: brute force each
    best = [y[np.argmin(a * np.exp(-0.5 * ((y - centre) / sigma) ** 2) + wy * y**2)] for a in strength]
    return cost, np.stack([S[1:-1], best], axis=-1)


def test_stomp_reaches_the_tracking_optimum():
    target = np.stack([S, 0.8 * np.sin(np.pi * S)], axis=-1)
    cost = tracking_cost(target)
    result = stomp(STRAIGHT, cost, rng=0, max_iterations=200, noise_std=0.2, noise_decay=0.97, tol=1e-4,
                   patience=20)
    assert result.costs[0] == pytest.approx(cost(STRAIGHT[1:-1]).sum())
    assert result.best_cost < 1e-3 * result.costs[0]
    assert np.abs(result.path - target).max() < 0.01


def test_stomp_bends_around_a_bump_to_the_known_optimum():
    cost, optimum = bump_cost()
    result = stomp(STRAIGHT, cost, rng=0, max_iterations=300, noise_std=0.1, tol=1e-5, patience=30)
    optimal = cost(optimum).sum()
    assert result.costs[0] > 4.0 * optimal  # the straight path runs over the bump
    assert result.best_cost == pytest.approx(cost(result.path[1:-1]).sum())
    assert result.best_cost < 1.01 * optimal
    assert np.abs(result.path[1:-1] - optimum).max() < 0.03
    assert result.best_cost == result.costs.min()


def test_stomp_respects_joint_limits_and_fixed_end_points():
    target = np.stack([S, 0.8 * np.sin(np.pi * S)], axis=-1)  # unconstrained optimum: y up to 0.8
    lower, upper = np.array([-0.2, -0.1]), np.array([1.2, 0.5])
    seen = []

    def cost(Q):
        seen.append((Q.min(axis=(0, 1)), Q.max(axis=(0, 1))))
        return tracking_cost(target)(Q)

    start = STRAIGHT + np.array([0.0, 0.02])
    result = stomp(start, cost, (lower, upper), rng=1, max_iterations=150, noise_std=0.3, noise_decay=0.97)
    assert np.all(np.array([s[0] for s in seen]) >= lower) and np.all(np.array([s[1] for s in seen]) <= upper)
    np.testing.assert_array_equal(result.path[[0, -1]], start[[0, -1]])
    assert np.all(result.path[1:-1] <= upper) and np.all(result.path[1:-1] >= lower)
    np.testing.assert_allclose(result.path[1:-1], np.clip(target, lower, upper)[1:-1], atol=0.03)
    assert result.path[:, 1].max() == pytest.approx(0.5, abs=1e-3)  # pressed against the limit


def test_stomp_is_deterministic_per_seed():
    cost, _ = bump_cost()
    a = stomp(STRAIGHT, cost, rng=7, max_iterations=20)
    b = stomp(STRAIGHT, cost, rng=np.random.default_rng(7), max_iterations=20)
    c = stomp(STRAIGHT, cost, rng=8, max_iterations=20)
    np.testing.assert_array_equal(a.path, b.path)
    np.testing.assert_array_equal(a.costs, b.costs)
    assert not np.array_equal(a.path, c.path)


def test_result_is_frozen_and_records_history():
    cost, _ = bump_cost()
    result = stomp(STRAIGHT, cost, rng=0, max_iterations=5, tol=0.0)
    assert result.iterations == 5 and len(result.costs) == 6 and not result.converged
    assert result.path.shape == STRAIGHT.shape
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.best_cost = 0.0
    with pytest.raises(ValueError):
        result.path[1, 1] = 3.0


def test_stomp_stops_when_converged():
    result = stomp(STRAIGHT, lambda Q: np.zeros(Q.shape[:2]), rng=0, max_iterations=100, patience=5)
    assert result.converged and result.iterations == 5 and result.best_cost == 0.0


def test_control_cost_is_half_the_squared_accelerations_and_smooths():
    bent = STRAIGHT + np.array([0.0, 1.0]) * 0.3 * np.sin(np.pi * S)[:, None]
    acc = bent[:-2] - 2 * bent[1:-1] + bent[2:]
    boundary = np.r_[bent[0, 1], np.zeros(N - 3), bent[-1, 1]]
    np.testing.assert_allclose(acceleration_matrix(N - 1) @ bent[1:-1, 1] + boundary, acc[:, 1], atol=1e-15)
    result = stomp(bent, lambda Q: np.zeros(Q.shape[:2]), rng=0, control_cost_weight=3.0,
                   max_iterations=100, noise_std=0.1, tol=0.0)
    assert result.costs[0] == pytest.approx(3.0 * 0.5 * np.square(acc).sum())
    assert result.best_cost < 0.5 * result.costs[0]  # towards the straight line (zero acceleration)
    assert np.abs(result.path[:, 1]).max() < 0.6 * 0.3


# ----------------------------------------------------------------------------- eq. (8.32) terms


def rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_penetration_depth_of_capsules_placed_at_known_depths():
    rng = np.random.default_rng(0)
    R, centre, half = rotation(rng), np.array([0.3, -0.2, 0.5]), np.array([0.2, 0.3, 0.1])
    box = Box(centre, half, R)

    def world(p):  # box-frame points -> world
        return np.asarray(p) @ R.T + centre

    r = 0.05
    cases = [  # (start, end) in the box frame, expected penetration depth
        (((-0.1, 0.0, 0.13), (0.1, 0.0, 0.13)), 0.02),  # lying 2 cm into the top face's skin
        (((0.0, 0.1, 0.16), (0.0, 0.1, 0.5)), 0.0),  # 1 cm above the reach of its radius
        (((0.05, 0.0, 0.07), (0.05, 0.0, 0.4)), r + 0.03),  # poking 3 cm into the top face
        (((-0.1, 0.0, 0.0), (0.1, 0.0, 0.01)), r + 0.1),  # deep inside: 10 cm from the top face
        (((0.23, 0.33, 0.0), (0.23, 0.33, 0.01)), r - 0.03 * np.sqrt(2)),  # beside a vertical edge
        (((0.22, 0.32, 0.12), (0.4, 0.5, 0.3)), r - np.sqrt(3) * 0.02),  # nearest to a corner
    ]
    starts = np.array([world(c[0][0]) for c in cases])
    ends = np.array([world(c[0][1]) for c in cases])
    depth = capsule_box_penetration(starts, ends, np.full(len(cases), r), [box])[:, 0]
    np.testing.assert_allclose(depth, [c[1] for c in cases], atol=1e-12)


def brute_signed_distance(starts, ends, box, samples=4001):
    s = np.linspace(0.0, 1.0, samples)[:, None, None]
    p = (starts + s * (ends - starts) - box.centre) @ box.rotation
    q = np.abs(p) - box.half_extents
    return (np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)).min(axis=0)


def test_segment_box_distance_against_dense_sampling():
    rng = np.random.default_rng(1)
    boxes = [Box(rng.normal(size=3) * 0.3, rng.uniform(0.05, 0.4, 3), rotation(rng)) for _ in range(3)]
    starts = rng.normal(size=(500, 3)) * 0.5
    ends = starts + rng.normal(size=(500, 3)) * 0.4
    sd = segment_box_signed_distance(starts.reshape(50, 10, 3), ends.reshape(50, 10, 3), boxes)
    sd = sd.reshape(500, 3)
    brute = np.stack([brute_signed_distance(starts, ends, b) for b in boxes], axis=-1)
    assert np.all(sd <= brute + 1e-12) and np.all(brute - sd < 2e-4)  # exact min below samples
    assert (sd < 0).mean() > 0.05  # inside cases covered
    radii = rng.uniform(0.0, 0.3, 500)
    depth = capsule_box_penetration(starts, ends, radii, boxes)  # pruned path, same answer
    np.testing.assert_allclose(depth, np.maximum(radii[:, None] - sd, 0.0), atol=1e-12)


def test_repulsive_potential_against_a_loop():
    rng = np.random.default_rng(2)
    cloud, gamma = rng.uniform(-0.5, 0.5, (700, 3)), rng.uniform(0.0, 1.0, 700)
    points = rng.uniform(-0.6, 0.6, (4, 5, 2, 3))
    points[0, 0, 0] = cloud[3]  # a coincident pair
    loop = np.zeros(points.shape[:-1])
    for index in np.ndindex(points.shape[:-1]):
        for p, g in zip(cloud, gamma, strict=True):
            loop[index] += g * np.exp(-7.0 * np.linalg.norm(p - points[index]))
    np.testing.assert_allclose(repulsive_potential(points, cloud, gamma, 7.0), loop, rtol=1e-7)
    np.testing.assert_allclose(repulsive_potential(points, cloud, gamma, 7.0, chunk=1), loop, rtol=1e-7)
    single = repulsive_potential(points, cloud, gamma, 7.0, dtype=np.float32)
    np.testing.assert_allclose(single, loop, rtol=1e-5)
    cut = repulsive_potential(points, cloud, gamma, 7.0, cutoff=0.6)
    assert np.all(cut <= loop + 1e-12) and np.all(loop - cut <= gamma.sum() * np.exp(-7.0 * 0.6))


def point_robot(Q):
    """Fake kinematics of a 3-joint 'robot': one capsule from q to q + (0.1, 0, 0), radius 0.05."""
    starts = Q[..., None, :]
    return starts, starts + np.array([0.1, 0.0, 0.0]), np.array([0.05])


def test_proactive_cost_terms_against_brute_force():
    rng = np.random.default_rng(3)
    nominal = np.linspace([0.0, 0.0, 0.0], [1.0, 0.5, 0.2], 9)
    cloud, gamma = rng.uniform(0.0, 1.0, (50, 3)), rng.uniform(0.1, 1.0, 50)
    box = Box((0.5, 0.25, -0.1), (0.3, 0.3, 0.12))

    def points(Q):  # two control points: q and q + (0, 0, 0.2)
        return np.stack([Q, Q + np.array([0.0, 0.0, 0.2])], axis=-2)

    cost = ProactiveCost(point_robot, points, nominal, cloud, gamma, [box], lambda1=0.3, lambda2=2.0,
                         alpha=4.0)
    Q = nominal[1:-1] + rng.normal(size=(5, 7, 3)) * 0.1
    j_ob, j_rep, j_diff = cost.terms(Q)
    for k, i in np.ndindex(5, 7):
        q = Q[k, i]
        sd = brute_signed_distance(q[None], (q + [0.1, 0.0, 0.0])[None], box, 20001)[0]
        assert j_ob[k, i] == pytest.approx(max(0.0, 0.05 - sd), abs=1e-5)
        rep = sum(g * np.exp(-4.0 * np.linalg.norm(p - t))
                  for t in points(q) for p, g in zip(cloud, gamma, strict=True))
        assert j_rep[k, i] == pytest.approx(rep, rel=1e-9)
        assert j_diff[k, i] == pytest.approx(np.linalg.norm(nominal[i + 1] - q), rel=1e-12)
    assert np.any(j_ob > 0) and np.any(j_ob == 0)
    np.testing.assert_allclose(cost(Q), j_ob + 0.3 * j_rep + 2.0 * j_diff, rtol=1e-12)
    assert cost.total(nominal) == pytest.approx(cost(nominal[1:-1]).sum())
    with pytest.raises(ValueError, match="paths must be"):
        cost(Q[:, :3])


# ----------------------------------------------------------------------------- YuMi example


def voxel_cloud(a, b, radius, low, high, bins=25):
    """A synthetic GPDM-like cloud: centres of a bins^3 grid within `radius` of segment a-b, gamma
    falling off with the distance from it (Gaussian, std radius/2)."""
    axes = [np.linspace(lo, hi, bins) for lo, hi in zip(low, high, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    d = point_capsule_distance(grid, np.array(a), np.array(b), 0.0)[:, 0]
    keep = d < radius
    return grid[keep], np.exp(-0.5 * (d[keep] / (radius / 2)) ** 2)


def test_yumi_proactive_path_avoids_the_cloud():
    from hrc_drake.robots.chain import SerialChain

    chain = SerialChain.from_model("yumi", "left")
    qa = np.array([-0.858, -0.681, 2.086, 0.062, 4.18, 0.645, -1.942])
    qb = np.array([-0.922, -0.442, 1.624, 0.778, 4.382, 0.894, -0.897])
    nominal = qa + np.linspace(0.0, 1.0, 43)[:, None] * (qb - qa)  # tool from y = 0.47 to y = 0.03 m
    # a forearm's sweep from the front, 10 cm thick, across the middle of the tool path
    cloud, gamma = voxel_cloud((0.85, 0.22, 0.3), (0.5, 0.22, 0.3), 0.1, (0.35, 0.05, 0.15),
                               (0.95, 0.4, 0.45))
    assert 2000 < len(cloud) < 5000
    table, fixture = Box((0.5, 0.0, -0.05), (0.6, 0.8, 0.05)), Box((0.4, 0.3, 0.05), (0.06, 0.06, 0.05))
    boxes = [table, fixture]
    cost = ProactiveCost(chain.capsules, lambda Q: chain.points(Q, ("elbow", "tool")), nominal, cloud, gamma,
                         boxes, lambda1=0.05, lambda2=1.0, alpha=10.0)

    def clearance(path):  # smallest capsule-cloud distance along the path
        starts, ends, radii = chain.capsules(path)
        return min(point_capsule_distance(cloud, s, e, radii).min()
                   for s, e in zip(starts, ends, strict=True))

    settings = dict(n_rollouts=8, max_iterations=30, noise_std=0.4)
    plan_proactive_path(nominal, cost, chain.joint_limits, 0, **settings)  # warm-up
    t0 = time.perf_counter()
    result = plan_proactive_path(nominal, cost, chain.joint_limits, 0, **settings)
    elapsed = time.perf_counter() - t0
    print(f"\nYuMi proactive path: {len(cloud)} cloud points, {settings}: {elapsed:.3f} s per path, "
          f"J {cost.total(nominal):.1f} -> {result.best_cost:.1f}, "
          f"clearance {clearance(nominal):.3f} -> {clearance(result.path):.3f} m")
    assert result.best_cost == pytest.approx(cost.total(result.path))
    assert result.best_cost < 0.5 * cost.total(nominal)
    assert clearance(result.path) > clearance(nominal) + 0.02
    assert cost.terms(result.path[1:-1])[0].sum() == 0.0  # no box penetrated
    lower, upper = chain.joint_limits
    assert np.all(result.path >= lower) and np.all(result.path <= upper)
    np.testing.assert_array_equal(result.path[[0, -1]], nominal[[0, -1]])
