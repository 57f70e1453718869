"""Belief regions of the trackers (perception.regions, SkeletonTracker.region_contains; 9.1.3)."""

import numpy as np
import pytest

from hrc_drake.messages import L_WRIST
from hrc_drake.perception.regions import (
    ball_union_volume,
    ball_volume,
    ellipsoid_threshold,
    ellipsoid_volume,
    in_ball_union,
    in_ellipsoid,
)
from tests.perception.test_tracker import POSE, run


def test_ellipsoid_threshold_is_the_chi2_quantile():
    assert ellipsoid_threshold(0.95) == pytest.approx(7.8147, abs=1e-4)
    with pytest.raises(ValueError):
        ellipsoid_threshold(1.0)


def test_in_ellipsoid_along_and_across_the_long_axis():
    cov = np.diag([0.2**2, 0.01**2, 0.01**2])  # long along x
    radius = np.sqrt(ellipsoid_threshold(0.95))  # ~2.80 standard deviations
    mean = np.zeros(3)
    points = np.array([
        [0.2 * radius * 0.99, 0.0, 0.0],  # just inside along x
        [0.2 * radius * 1.01, 0.0, 0.0],  # just outside along x
        [0.0, 0.01 * radius * 1.01, 0.0],  # the same distance in sigmas along y: outside
        [0.0, 0.05, 0.0],  # 5 cm across: far outside (a sphere of the x spread would hold it)
    ])
    got = in_ellipsoid(np.tile(mean, (4, 1)), np.tile(cov, (4, 1, 1)), points)
    assert got.tolist() == [True, False, False, False]


def test_in_ellipsoid_rotated_covariance():
    angle = np.pi / 4
    rot = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    cov = rot @ np.diag([0.1**2, 0.01**2, 0.01**2]) @ rot.T
    along, across = rot[:, 0] * 0.2, rot[:, 1] * 0.05
    assert in_ellipsoid(np.zeros(3), cov, along)[0]
    assert not in_ellipsoid(np.zeros(3), cov, across)[0]


def test_ellipsoid_volume_of_a_sphere():
    sigma = 0.1
    expected = 4 / 3 * np.pi * (sigma * np.sqrt(ellipsoid_threshold(0.95))) ** 3
    assert ellipsoid_volume(np.eye(3) * sigma**2)[0] == pytest.approx(expected)


def test_in_ball_union_per_point():
    cloud = np.array([[[0.0, 0, 0], [0.1, 0, 0]], [[1.0, 1, 1], [1.0, 1, 1]]])
    points = np.array([[0.05, 0.0, 0.015], [1.0, 1.0, 1.03]])
    assert in_ball_union(cloud, points, radius=0.02).tolist() == [False, False]
    assert in_ball_union(cloud, points + [[0.04, 0, 0], [0, 0, -0.02]], radius=0.02).tolist() == [True, True]


def test_ball_union_volume_disjoint_overlapping_and_one():
    r = 0.02
    one = ball_volume(r)
    assert ball_union_volume(np.zeros((5, 3)), r) == pytest.approx(one)  # repeats count once
    apart = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    assert ball_union_volume(apart, r, samples=200_000) == pytest.approx(2 * one, rel=0.05)
    # Two balls a radius apart overlap: their union is 2 V - lens, lens = 5/12 pi r^3 at d = r.
    close = np.array([[0.0, 0, 0], [r, 0, 0]])
    lens = 5 / 12 * np.pi * r**3
    assert ball_union_volume(close, r, samples=200_000) == pytest.approx(2 * one - lens, rel=0.03)
    assert ball_union_volume(close, r, seed=3) == ball_union_volume(close, r, seed=3)


@pytest.mark.parametrize("kind", ["particle_filter", "kalman", "none"])
def test_tracker_region_holds_the_still_hidden_wrist_and_not_a_far_point(kind):
    # A few hidden frames: the particles, resampled every frame, collapse onto a few clumps
    # of the crown later, and may then miss even a still wrist (what the benchmark measures).
    tracker, ests = run(kind, n_hidden=3)
    assert not ests[-1].tracked[L_WRIST]
    which = np.zeros(8, dtype=bool)
    which[L_WRIST] = True
    inside, volume = tracker.region_contains(POSE, which)
    assert inside[L_WRIST] and np.isfinite(volume[L_WRIST]) and volume[L_WRIST] > 0
    assert not inside[~which].any() and np.all(np.isnan(volume[~which]))
    far = POSE.copy()
    far[L_WRIST] += [0.0, 0.0, -0.5]  # half a metre below: beyond the forearm's reach
    inside, _ = tracker.region_contains(far, which)
    assert not inside[L_WRIST]


def test_hold_region_is_a_ball_around_the_last_seen_point():
    tracker, _ = run("none", n_hidden=5)
    moved = POSE.copy()
    moved[L_WRIST] += [0.0, 0.03, 0.0]  # the wrist moved 3 cm while hidden
    inside, volume = tracker.region_contains(moved, radius=0.02)
    assert not inside[L_WRIST] and inside[0]
    assert volume[L_WRIST] == pytest.approx(ball_volume(0.02))
    assert tracker.region_contains(moved, radius=0.05)[0][L_WRIST]


def test_kalman_region_grows_in_the_open_loop():
    tracker_short, _ = run("kalman", n_hidden=2)
    tracker_long, _ = run("kalman", n_hidden=30)
    short = tracker_short.region_contains(POSE)[1][L_WRIST]
    long = tracker_long.region_contains(POSE)[1][L_WRIST]
    assert long > 10 * short


def test_never_seen_point_has_no_region():
    from hrc_drake.perception.tracker import SkeletonTracker

    tracker = SkeletonTracker("kalman")
    inside, volume = tracker.region_contains(POSE)
    assert not inside.any() and np.all(np.isnan(volume))
