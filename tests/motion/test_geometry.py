import numpy as np
import pytest

from hrc_drake.motion.geometry import (
    bounding_capsules,
    capsule_capsule_distance,
    point_capsule_distance,
    point_segment_distance,
    segment_segment_closest,
)


def _brute_segment_distance(p0, p1, q0, q1, samples=301):
    u = np.linspace(0.0, 1.0, samples)
    a = p0[:, None] + u[None, :, None] * (p1 - p0)[:, None]
    b = q0[:, None] + u[None, :, None] * (q1 - q0)[:, None]
    return np.linalg.norm(a[:, :, None] - b[:, None, :], axis=-1).min(axis=(1, 2))


def test_segment_distance_matches_brute_force():
    rng = np.random.default_rng(0)
    p0, p1, q0, q1 = rng.normal(size=(4, 40, 3))
    distance, s, t = segment_segment_closest(p0, p1, q0, q1)
    brute = _brute_segment_distance(p0, p1, q0, q1)
    # the analytic minimum is never above the sampled one, and within the sampling step of it
    assert np.all(distance <= brute + 1e-12)
    step = np.maximum(np.linalg.norm(p1 - p0, axis=1), np.linalg.norm(q1 - q0, axis=1)) / 300
    assert np.all(brute - distance <= step + 1e-9)
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    closest = np.linalg.norm(p0 + s[:, None] * (p1 - p0) - q0 - t[:, None] * (q1 - q0), axis=1)
    np.testing.assert_allclose(closest, distance)


def test_hand_computed_cases():
    # crossing segments one above the other: distance 1
    d, s, t = segment_segment_closest([-1, 0, 0], [1, 0, 0], [0, -1, 1], [0, 1, 1])
    assert d == pytest.approx(1.0) and s == pytest.approx(0.5) and t == pytest.approx(0.5)
    # parallel, overlapping: distance 2
    d, _, _ = segment_segment_closest([0, 0, 0], [2, 0, 0], [1, 2, 0], [3, 2, 0])
    assert d == pytest.approx(2.0)
    # collinear, disjoint: gap of 1
    d, _, _ = segment_segment_closest([0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0])
    assert d == pytest.approx(1.0)
    # degenerate: a point against a segment and two points
    d, _, _ = segment_segment_closest([0, 1, 0], [0, 1, 0], [-1, 0, 0], [1, 0, 0])
    assert d == pytest.approx(1.0)
    d, _, _ = segment_segment_closest([0, 0, 0], [0, 0, 0], [3, 4, 0], [3, 4, 0])
    assert d == pytest.approx(5.0)
    assert point_segment_distance([2.0, 1.0, 0.0], [0, 0, 0], [1, 0, 0]) == pytest.approx(np.sqrt(2))


def test_capsule_distance_matrix_against_brute_force():
    rng = np.random.default_rng(1)
    a0, a1 = rng.normal(size=(2, 5, 3))
    b0, b1 = rng.normal(size=(2, 7, 3)) + 2.0
    ra, rb = rng.uniform(0.05, 0.2, 5), rng.uniform(0.05, 0.2, 7)
    clearance = capsule_capsule_distance(a0, a1, ra, b0, b1, rb)
    assert clearance.shape == (5, 7)
    for i in range(5):
        brute = _brute_segment_distance(np.repeat(a0[i:i + 1], 7, 0), np.repeat(a1[i:i + 1], 7, 0), b0, b1)
        assert np.all(np.abs(clearance[i] - (brute - ra[i] - rb)) < 0.02)
    inside = point_capsule_distance(a0[:1], a0[:1], a1[:1], ra[:1])
    assert inside[0, 0] == pytest.approx(-ra[0])


def test_bad_input_is_a_clear_error():
    with pytest.raises(ValueError, match="NaN"):
        segment_segment_closest([np.nan, 0, 0], [1, 0, 0], [0, 0, 0], [0, 1, 0])
    with pytest.raises(ValueError, match="capsule set A"):
        capsule_capsule_distance(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros(3), np.zeros((1, 3)),
                                 np.zeros((1, 3)), np.zeros(1))


def test_bounding_capsule_holds_every_sample():
    rng = np.random.default_rng(2)
    starts = rng.normal(size=(50, 3, 3)) * [0.3, 0.1, 0.1]
    ends = starts + [1.0, 0.0, 0.0] + rng.normal(size=(50, 3, 3)) * 0.05
    radius = np.array([0.1, 0.05, 0.0])
    start, end, bound = bounding_capsules(starts, ends, radius, margin=0.01)
    for points in (starts, ends):
        d = point_segment_distance(points, start[None], end[None]) + radius
        assert np.all(d <= bound + 1e-9)
    # identical samples give back the capsule itself, inflated by the margin
    same = np.repeat(np.array([[[0.0, 0, 0]]]), 4, 0)
    s, e, r = bounding_capsules(same, same + [0, 0, 1.0], [0.2], margin=0.01)
    assert r[0] == pytest.approx(0.21)
    assert {tuple(np.round(s[0], 9)), tuple(np.round(e[0], 9))} == {(0.0, 0.0, 0.0), (0.0, 0.0, 1.0)}
