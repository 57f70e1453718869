"""Minimum-jerk reaching profile."""

import numpy as np
import pytest

from hrc_drake.human.trajectories import minimum_jerk, minimum_jerk_acceleration


def test_boundary_conditions():
    p0, p1, T = np.array([0.0, 1.0, -1.0]), np.array([1.0, 3.0, 0.5]), 1.5
    pos, vel = minimum_jerk(p0, p1, T, np.array([0.0, T]))
    acc = minimum_jerk_acceleration(p0, p1, T, np.array([0.0, T]))
    np.testing.assert_allclose(pos, [p0, p1])
    np.testing.assert_allclose(vel, 0.0, atol=1e-12)
    np.testing.assert_allclose(acc, 0.0, atol=1e-12)


def test_midpoint_and_peak_velocity():
    pos, vel = minimum_jerk(0.0, 2.0, 4.0, 2.0)
    assert pos == pytest.approx(1.0)
    assert vel == pytest.approx(1.875 * 2.0 / 4.0)  # peak speed of min-jerk: 15/8 of the mean


def test_shapes_clamping_and_derivative():
    t = np.linspace(-0.5, 2.5, 301)
    p0, p1 = np.zeros(2), np.array([1.0, -2.0])
    pos, vel = minimum_jerk(p0, p1, 2.0, t)
    assert pos.shape == vel.shape == (301, 2)
    np.testing.assert_allclose(pos[t <= 0], 0.0)
    np.testing.assert_allclose(pos[t >= 2], np.tile(p1, (np.sum(t >= 2), 1)))
    np.testing.assert_allclose(vel[(t < 0) | (t > 2)], 0.0)
    numeric = np.gradient(pos, t, axis=0)
    np.testing.assert_allclose(vel[1:-1], numeric[1:-1], atol=2e-3)
    acc = minimum_jerk_acceleration(p0, p1, 2.0, t)
    np.testing.assert_allclose(acc[1:-1], np.gradient(vel, t, axis=0)[1:-1], atol=5e-2)


def test_errors():
    with pytest.raises(ValueError, match="duration"):
        minimum_jerk(0.0, 1.0, 0.0, 0.5)
    with pytest.raises(ValueError, match="same shape"):
        minimum_jerk(np.zeros(2), np.zeros(3), 1.0, 0.5)
    with pytest.raises(ValueError, match="NaN"):
        minimum_jerk(0.0, 1.0, 1.0, np.nan)
