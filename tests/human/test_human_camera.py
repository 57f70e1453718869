"""Depth camera: box occlusion (slab test), capsule occlusion, view cone, noise, gaze flag."""

import numpy as np
import pytest

from hrc_drake.human.camera import DepthCameraModel, segment_segment_distance, segments_hit_boxes
from hrc_drake.human.config import Occluder
from hrc_drake.messages import HEAD


@pytest.fixture()
def camera():
    # camera at 2 m height looking down the -x axis; a 20 cm box at x = 1
    return DepthCameraModel([2.0, 0.0, 1.0], [0.0, 0.0, 1.0], [([1.0, 0.0, 1.0], [0.2, 0.2, 0.2])],
                            noise_std=0.01, rate=30.0)


def test_box_hides_what_is_behind(camera):
    pts = np.array([
        [0.5, 0.0, 1.0],   # behind the box
        [1.5, 0.0, 1.0],   # between camera and box
        [0.5, 0.5, 1.0],   # behind, but off to the side
        [0.5, 0.0, 1.25],  # line of sight passes over the box (z at x=1 is 1.125 > 1.1)
        [0.5, 0.0, 1.15],  # line of sight at x=1.1 has z = 1.0833 < 1.1: clips the top
    ])
    np.testing.assert_array_equal(camera.is_hidden(pts), [True, False, False, False, True])


def test_margin_grows_the_box():
    pts = np.array([[0.5, 0.0, 1.25]])
    box = [([1, 0, 1], [0.2, 0.2, 0.2])]
    assert not DepthCameraModel([2, 0, 1], [0, 0, 1], box).is_hidden(pts)[0]
    assert DepthCameraModel([2, 0, 1], [0, 0, 1], box, margin=0.05).is_hidden(pts)[0]


def test_schema_occluders_accepted():
    cam = DepthCameraModel([2, 0, 1], [0, 0, 1], [Occluder("box", [1, 0, 1], [0.2, 0.2, 0.2])])
    assert cam.is_hidden(np.array([0.5, 0.0, 1.0]))


def test_slab_test_matches_sampling():
    rng = np.random.default_rng(0)
    origin = np.array([2.0, 0.3, 1.4])
    pts = rng.uniform([-0.5, -1, 0.2], [1.5, 1, 1.8], size=(400, 3))
    lower = np.array([[0.8, -0.2, 0.8], [0.2, 0.3, 0.5]])
    upper = np.array([[1.0, 0.2, 1.2], [0.6, 0.6, 1.0]])
    hit = segments_hit_boxes(origin, pts, lower, upper)
    s = np.linspace(0, 1, 2001)[:, None, None]
    samples = origin + s * (pts - origin)  # (S, N, 3)
    inside = np.all((samples[:, :, None] > lower) & (samples[:, :, None] < upper), axis=-1).any(axis=0)
    assert hit.shape == (400, 2)
    assert np.all(hit[inside])  # every segment seen inside a box is reported
    assert inside.sum() > 20
    fine = np.linspace(0, 1, 400001)[:, None]
    for n, b in np.argwhere(hit & ~inside):  # grazing hits the coarse sampling missed
        samples = origin + fine * (pts[n] - origin)
        assert np.all((samples > lower[b]) & (samples < upper[b]), axis=1).any()


def test_capsule_occlusion():
    camera = DepthCameraModel([2.0, 0.0, 1.0], [0.0, 0.0, 1.0], [])
    pts = np.array([[0.0, 0.0, 0.2], [0.0, 0.0, 0.9], [1.7, 0.0, 0.8]])
    # lines of sight cross the plane x = 1.5 at z = 0.8, 0.975 and (never: the last point is in front)
    low_bar = (np.array([[1.5, -0.3, 0.6]]), np.array([[1.5, 0.3, 0.6]]), np.array([0.05]))
    np.testing.assert_array_equal(camera.is_occluded(pts, low_bar), [False, False, False])
    bar = (np.array([[1.5, -0.3, 0.8]]), np.array([[1.5, 0.3, 0.8]]), np.array([0.05]))
    np.testing.assert_array_equal(camera.is_occluded(pts, bar), [True, False, False])
    thick = (bar[0], bar[1], np.array([0.19]))  # axis 0.175 from the 2nd sight line, 0.2 from the 3rd point
    np.testing.assert_array_equal(camera.is_occluded(pts, thick), [True, True, False])
    empty = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
    assert not camera.is_occluded(pts, empty).any()


def test_segment_distance_hand_cases():
    d = segment_segment_distance(np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.5, 1, -1]),
                                 np.array([0.5, 1, 1]))
    assert d == pytest.approx(1.0)
    d = segment_segment_distance(np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([2.0, 0, 0]),
                                 np.array([3.0, 0, 0]))  # collinear, disjoint
    assert d == pytest.approx(1.0)
    d = segment_segment_distance(np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.2, 0.5, 0]),
                                 np.array([0.8, 0.5, 0]))  # parallel
    assert d == pytest.approx(0.5)
    d = segment_segment_distance(np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([3.0, 4, 0]),
                                 np.array([3.0, 4, 0]))  # degenerate: point
    assert d == pytest.approx(np.hypot(2, 4))


def test_view_cone(camera):
    pts = np.array([[3.0, 0.0, 1.0], [1.9, 0.5, 1.0], [1.0, 0.5, 1.0]])  # behind, 79 deg off, 27 deg off
    np.testing.assert_array_equal(camera.in_view(pts), [False, False, True])
    np.testing.assert_array_equal(camera.is_hidden(pts), [True, True, False])


def test_vectorised_shape(camera):
    pts = np.random.default_rng(0).normal([0.5, 0, 1], 0.3, size=(8, 500, 3))
    caps = (np.zeros((3, 3)), np.ones((3, 3)), np.full(3, 0.05))
    hidden = camera.is_hidden(pts, caps)
    assert hidden.shape == (8, 500) and hidden.dtype == bool
    np.testing.assert_array_equal(hidden[3], camera.is_hidden(pts[3], caps))


def test_measure(camera):
    rng = np.random.default_rng(0)
    pts = np.tile([0.3, 0.4, 1.0], (8, 1)) + 0.01 * np.arange(8)[:, None]
    pts[0] = [0.5, 0.0, 1.0]  # behind the box
    frame = camera.measure(1.5, pts, np.array([1.0, 0.0, 0.0]), rng)
    assert frame.time == 1.5
    assert not frame.tracked[0] and np.all(np.isnan(frame.points[0]))
    assert frame.tracked[1:].all() and np.all(np.abs(frame.points[1:] - pts[1:]) < 0.06)
    assert frame.gaze_valid  # facing +x, the camera is at +x
    frame = camera.measure(1.5, pts, np.array([-1.0, 0.0, 0.0]), rng)
    assert not frame.gaze_valid
    hidden_head = pts.copy()
    hidden_head[HEAD] = [0.5, 0.0, 1.0]
    assert not camera.measure(0.0, hidden_head, np.array([1.0, 0.0, 0.0]), rng).gaze_valid
    errors = np.array([camera.measure(0, pts, [1, 0, 0], rng).points[1:] - pts[1:] for _ in range(300)])
    assert np.std(errors) == pytest.approx(0.01, rel=0.1)


def test_bad_input(camera):
    with pytest.raises(ValueError, match="position"):
        DepthCameraModel([0, 0], [1, 0, 0], [])
    with pytest.raises(ValueError, match="differ"):
        DepthCameraModel([0, 0, 0], [0, 0, 0], [])
    with pytest.raises(ValueError, match=r"occluders\[0\].size"):
        DepthCameraModel([0, 0, 0], [1, 0, 0], [([0, 0, 0], [1, 1])])
    with pytest.raises(ValueError, match=r"\(8, 3\)"):
        camera.measure(0, np.zeros((7, 3)), [1, 0, 0], np.random.default_rng())


def test_is_hidden_is_occluded_or_out_of_view_on_random_points_and_capsules():
    rng = np.random.default_rng(7)
    boxes = [([0.6, 0.1, 1.0], [0.2, 0.3, 0.4]), ([0.9, -0.4, 1.2], [0.1, 0.1, 0.6])]
    camera = DepthCameraModel([0.0, 0.0, 2.0], [1.2, 0.0, 1.0], boxes)
    for _ in range(20):
        pts = rng.uniform([-0.5, -1.5, 0.0], [2.5, 1.5, 2.5], (400, 3))
        pts[rng.random(400) < 0.02] = np.nan
        start = rng.uniform([0.2, -0.6, 0.8], [1.2, 0.6, 1.6], (6, 3))
        caps = (start, start + rng.normal(0.0, 0.2, (6, 3)), rng.uniform(0.02, 0.1, 6))
        expected = camera.is_occluded(pts, caps) | ~camera.in_view(pts)
        assert 0 < expected.sum() < len(pts)
        np.testing.assert_array_equal(camera.is_hidden(pts, caps), expected)
        np.testing.assert_array_equal(camera.is_hidden(pts), camera.is_occluded(pts) | ~camera.in_view(pts))


def test_the_all_pairs_capsule_test_agrees_with_the_bounding_sphere_one():
    rng = np.random.default_rng(11)
    camera = DepthCameraModel([0.0, 0.0, 2.0], [1.2, 0.0, 1.0])
    blocked = 0
    for _ in range(50):
        pts = rng.uniform([-0.5, -1.0, 0.0], [2.0, 1.0, 2.0], (8, 3))
        start = rng.uniform([0.2, -0.6, 0.8], [1.2, 0.6, 1.6], (14, 3))
        end, radius = start + rng.normal(0.0, 0.2, (14, 3)), rng.uniform(0.02, 0.1, 14)
        few = camera._sight_blocked_by_capsules(pts, start, end, radius)  # 112 pairs: all at once
        many = camera._sight_blocked_by_capsules(np.repeat(pts, 40, axis=0), start, end, radius)
        np.testing.assert_array_equal(np.repeat(few, 40), many)  # 4480 pairs: the sphere test
        blocked += few.sum()
    assert 0 < blocked < 400


def test_gaze_visible_is_the_angle_to_the_camera_below_the_limit():
    camera = DepthCameraModel([2.0, 0.0, 1.5], [0.0, 0.0, 1.0], [], gaze_valid_angle=0.8)
    rng = np.random.default_rng(4)
    answers = []
    for _ in range(300):
        head, gaze = rng.normal(scale=0.5, size=3) + [0.0, 0.0, 1.6], rng.normal(size=3)
        to_camera = camera.position - head
        angle = np.arccos(np.clip(to_camera @ gaze / np.linalg.norm(to_camera) / np.linalg.norm(gaze), -1, 1))
        if abs(angle - 0.8) > 1e-9:
            answers.append(camera.gaze_visible(head, gaze))
            assert answers[-1] == (angle <= 0.8)
    assert 0 < sum(answers) < len(answers)
    assert not camera.gaze_visible([0.0, 0.0, 1.6], [0.0, 0.0, 0.0])  # no gaze direction
    assert not camera.gaze_visible([np.nan, 0.0, 1.6], [1.0, 0.0, 0.0])
