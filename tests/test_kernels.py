"""The compiled kernels against their numpy references (hrc_drake/kernels.py)."""

import numpy as np
import pytest

from hrc_drake import kernels
from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.motion.geometry import segment_segment_closest


def _random_capsules(rng, count):
    start = rng.uniform(-0.5, 0.5, size=(count, 3))
    end = start + rng.normal(scale=0.3, size=(count, 3))
    end[0] = start[0]  # a point-like capsule: the degenerate branch of Ericson 5.1.9
    radius = rng.uniform(0.01, 0.1, size=count)
    return start, end, radius


def test_capsule_clearances_equal_the_numpy_segment_distance_minus_radii():
    rng = np.random.default_rng(0)
    start_a, end_a, radius_a = _random_capsules(rng, 7)
    start_b, end_b, radius_b = _random_capsules(rng, 5)
    start_b[1], end_b[1] = start_a[2] + 0.1, end_a[2] + 0.1  # a parallel pair
    got = kernels.capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b)
    distance, _, _ = segment_segment_closest(start_a[:, None], end_a[:, None], start_b[None], end_b[None])
    expected = distance - radius_a[:, None] - radius_b[None, :]
    assert got.shape == (7, 5)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_capsule_clearances_accept_read_only_strided_and_integer_inputs():
    rng = np.random.default_rng(1)
    start, end, radius = _random_capsules(rng, 6)
    reference = kernels.capsule_clearances(start, end, radius, start, end, radius)
    wide = np.zeros((6, 6))
    wide[:, ::2] = start  # a strided view
    read_only = end.copy()
    read_only.flags.writeable = False
    got = kernels.capsule_clearances(wide[:, ::2], read_only, radius, start, end, radius)
    np.testing.assert_array_equal(got, reference)
    ones = kernels.capsule_clearances([[0, 0, 0]], [[1, 0, 0]], [0], [[0, 2, 0]], [[1, 2, 0]], [0])
    assert ones[0, 0] == pytest.approx(2.0)


def test_hidden_points_equal_occluded_or_outside_the_view_cone():
    camera = DepthCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0],
                              [([0.5, 0.0, 1.2], [0.2, 0.4, 0.3]), ([0.6, 0.5, 1.0], [0.1, 0.1, 0.6])],
                              margin=0.02)
    rng = np.random.default_rng(2)
    points = rng.uniform([-0.5, -1.0, 0.0], [1.5, 1.0, 2.2], size=(400, 3))
    capsules = _random_capsules(rng, 4)
    capsules = (capsules[0] + [0.6, 0.0, 1.2], capsules[1] + [0.6, 0.0, 1.2], capsules[2] * 2)
    for links in (None, capsules):
        expected = camera.is_occluded(points, links) | ~camera.in_view(points)
        got = camera.is_hidden(points, links)
        np.testing.assert_array_equal(got, expected)
        assert 0 < expected.sum() < len(points)  # both kinds of point are tested


def test_warm_up_compiles_every_kernel_and_returns_its_seconds():
    seconds = kernels.warm_up()
    assert 0.0 < seconds < 120.0
    assert kernels.warm_up() < 1.0  # the second call finds them compiled
