import numpy as np
import pytest

from hrc_drake.intention.features import (
    NEUTRAL_ANGLE,
    WristVelocityEstimator,
    angle_between,
    goal_features,
    least_squares_velocity,
    trajectory_velocities,
)


def test_angle_between_hand_made_vectors():
    assert angle_between([1, 0, 0], [0, 2, 0]) == pytest.approx(np.pi / 2)
    assert angle_between([1, 0, 0], [-3, 0, 0]) == pytest.approx(np.pi)
    assert angle_between([1, 1, 0], [1, 0, 0]) == pytest.approx(np.pi / 4)
    assert angle_between([1, 0, 0], [1, 1e-9, 0]) == pytest.approx(1e-9, abs=1e-12)


def test_least_squares_velocity_of_a_line_and_skipped_nan():
    times = np.arange(6) / 30.0
    positions = np.zeros((6, 2, 3))
    positions[:, 0, 0] = 0.5 * times  # 0.5 m/s along x
    positions[:, 1] = [1.0, 2.0, 3.0]  # still
    positions[2, 0] = np.nan
    velocity, moving = least_squares_velocity(times, positions, min_speed=0.1)
    # too few valid samples: unknown, not moving
    few = positions.copy()
    few[:4] = np.nan
    assert not least_squares_velocity(times, few, min_speed=0.1)[1][0]
    np.testing.assert_allclose(velocity[0], [0.5, 0, 0], atol=1e-12)
    np.testing.assert_allclose(velocity[1], 0.0, atol=1e-12)
    assert moving.tolist() == [True, False]


def test_online_and_batch_velocities_agree():
    rng = np.random.default_rng(3)
    times = np.arange(40) / 30.0
    wrists = np.cumsum(rng.normal(0, 0.01, (40, 2, 3)), axis=0)
    wrists[7, 1] = np.nan
    batch_v, batch_m = trajectory_velocities(times, wrists, window=5, min_speed=0.05)
    online = WristVelocityEstimator(window=5, min_speed=0.05)
    for k in range(40):
        v, m = online.update(times[k], wrists[k])
        np.testing.assert_allclose(v, batch_v[k], atol=1e-12)
        assert m.tolist() == batch_m[k].tolist()


def test_feature_angles_on_hand_made_geometry():
    wrists = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])  # left, right
    velocities = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    head = np.array([0.0, 0.0, 1.0])
    gaze = np.array([0.0, 0.0, -1.0])  # looking straight down
    goals = np.array([[2.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    phi = goal_features(wrists, velocities, np.array([True, True]), head, gaze, goals)[:, :, 0]
    assert phi.shape == (2, 2, 4)
    # right hand moves along +x: goal 0 straight ahead, goal 1 at 90 deg
    np.testing.assert_allclose(phi[1, :, 0], [0.0, np.pi / 2], atol=1e-12)
    # left hand moves along +y: goal 0 (direction +x) 90 deg, goal 1 (direction (1,1)) 45 deg
    np.testing.assert_allclose(phi[0, :, 0], [np.pi / 2, np.pi / 4], atol=1e-12)
    # delta_W2 is the other hand's delta_W1
    np.testing.assert_allclose(phi[1, :, 1], phi[0, :, 0])
    np.testing.assert_allclose(phi[0, :, 1], phi[1, :, 0])
    # head at (0,0,1) looking down; goal 0 at (2,0,0): angle atan2(2, 1)
    np.testing.assert_allclose(phi[:, 0, 2], np.arctan2(2.0, 1.0))
    np.testing.assert_allclose(phi[1, :, 3], [1.0, 1.0])
    np.testing.assert_allclose(phi[0, :, 3], [2.0, np.sqrt(2.0)])


def test_still_hand_and_goal_at_the_wrist_are_finite():
    wrists = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    velocities = np.zeros((2, 3))
    goals = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # goal 0 exactly at the right wrist
    phi = goal_features(
        wrists, velocities, np.array([False, True]), np.zeros(3), np.array([1.0, 0, 0]), goals
    )
    assert np.all(np.isfinite(phi))
    assert np.all(phi[0, :, 0, 0] == NEUTRAL_ANGLE)  # still left hand
    assert phi[1, 0, 0, 0] == 0.0 and phi[1, 0, 0, 3] == 0.0  # right wrist at goal 0


def test_sampled_goal_centres_broadcast():
    samples = np.zeros((3, 7, 3))
    samples[..., 0] = np.arange(1, 8)
    phi = goal_features(
        np.zeros((2, 3)),
        np.array([[1.0, 0, 0]] * 2),
        np.array([True, True]),
        np.zeros(3),
        np.array([1.0, 0, 0]),
        samples,
    )
    assert phi.shape == (2, 3, 7, 4)
    np.testing.assert_allclose(phi[0, 0, :, 3], np.arange(1, 8))


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ValueError, match="goal centres"):
        goal_features(
            np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2, bool), np.zeros(3), np.ones(3), np.zeros((2, 2))
        )
    with pytest.raises(ValueError, match="window"):
        WristVelocityEstimator(window=1)
    with pytest.raises(ValueError, match=r"\(2, 3\)"):
        WristVelocityEstimator().update(0.0, np.zeros(3))


def test_a_still_wrist_seen_with_camera_noise_is_not_moving():
    rng = np.random.default_rng(7)
    times = np.arange(300) / 30.0
    still = np.array([0.8, 0.1, 0.9]) + 0.02 * rng.standard_normal((300, 1, 3))
    # the slope of 8 noisy samples often exceeds 0.15 m/s: speed alone calls it motion
    speed_only = trajectory_velocities(times, np.repeat(still, 2, axis=1), 8, 0.15, significance=0.0)[1]
    tested = trajectory_velocities(times, np.repeat(still, 2, axis=1), 8, 0.15, significance=3.5)[1]
    assert speed_only[10:, 0].mean() > 0.2
    assert tested[10:, 0].mean() < 0.03
    # a steady 0.6 m/s motion (a reach's speed) seen with the same noise is motion
    line = still + 0.6 * times[:, None, None] * np.array([1.0, 0.0, 0.0])
    moving = trajectory_velocities(times, np.repeat(line, 2, axis=1), 8, 0.15, significance=3.5)[1]
    assert moving[10:, 0].mean() > 0.9


def test_significance_test_by_hand():
    # x = 0.3 t plus residuals +e, -e, -e, +e: slope 0.3 (the residuals are orthogonal to t)
    times = np.arange(4) / 10.0
    e = 0.002
    positions = np.zeros((4, 1, 3))
    positions[:, 0, 0] = 0.3 * times + e * np.array([1, -1, -1, 1])
    velocity, _ = least_squares_velocity(times, positions, min_speed=0.0, significance=0.0)
    np.testing.assert_allclose(velocity[0], [0.3, 0, 0], atol=1e-12)
    # s^2 = RSS / (3 (K - 2)) = 4 e^2 / 6; standard error sqrt(s^2 / sum (t - t_mean)^2) = sqrt(s^2 / 0.05)
    standard_error = np.sqrt(4 * e * e / 6 / 0.05)
    ratio = 0.3 / standard_error
    assert least_squares_velocity(times, positions, 0.0, significance=0.99 * ratio)[1][0]
    assert not least_squares_velocity(times, positions, 0.0, significance=1.01 * ratio)[1][0]
