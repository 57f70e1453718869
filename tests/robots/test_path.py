import copy

import numpy as np
import pytest

from hrc_drake.robots.path import JointPathFollower, min_jerk_profile


def run(follower, dt, steps, override=1.0):
    qs = []
    for _ in range(steps):
        qs.append(follower.step(dt, override).copy())
    return np.array(qs)


def test_min_jerk_profile_ends():
    assert min_jerk_profile(0.0) == pytest.approx(0.0)
    assert min_jerk_profile(1.0) == pytest.approx(1.0)
    assert min_jerk_profile(0.5) == pytest.approx(0.5)


def test_reaches_waypoints_within_velocity_limits():
    v_max = np.array([1.0, 2.0])
    follower = JointPathFollower(np.zeros(3), [np.array([0, 2])], [v_max], velocity_fraction=1.0)
    follower.request(0, 1, np.array([[1.0, 1.0], [0.0, -1.0]]), np.array([0.0, 0.0]))
    dt = 0.001
    qs = run(follower, dt, 6000)
    speeds = np.abs(np.diff(qs, axis=0)) / dt
    assert np.all(speeds[:, 0] <= v_max[0] * 1.001)
    assert np.all(speeds[:, 2] <= v_max[1] * 1.001)
    assert np.all(qs[:, 1] == 0.0)
    np.testing.assert_allclose(qs[-1], [0.0, 0.0, -1.0], atol=1e-12)
    assert follower.done_seq == [1]
    # The first segment is limited by joint 0: 1.875 * 1 rad / (1 rad/s).
    np.testing.assert_allclose(qs[round(1.875 / dt) - 1][[0, 2]], [1.0, 1.0], atol=1e-9)
    assert abs(qs[round(1.7 / dt)][0] - 1.0) > 1e-3


def test_speed_override_scales_time_and_zero_stops():
    def duration(override):
        f = JointPathFollower(np.zeros(1), [np.array([0])], [np.array([1.0])])
        f.request(0, 7, np.array([[1.0]]), np.array([0.5]))
        steps = 0
        while f.done_seq[0] != 7:
            f.step(0.01, override)
            steps += 1
            assert steps < 10000
        return steps * 0.01

    assert duration(0.5) == pytest.approx(2 * duration(1.0), rel=0.02)
    f = JointPathFollower(np.zeros(1), [np.array([0])], [np.array([1.0])])
    f.request(0, 1, np.array([[1.0]]), np.array([0.0]))
    f.step(0.5, 1.0)
    q = f.q.copy()
    run(f, 0.1, 20, override=0.0)
    np.testing.assert_array_equal(f.q, q)
    run(f, 0.1, 20, override=float("nan"))
    np.testing.assert_array_equal(f.q, q)


def test_bad_requests_are_refused():
    with pytest.raises(ValueError, match="velocity_fraction"):
        JointPathFollower(np.zeros(1), [np.array([0])], [np.array([1.0])], velocity_fraction=0.0)
    with pytest.raises(ValueError, match="positive velocity limit"):
        JointPathFollower(np.zeros(1), [np.array([0])], [np.array([0.0])])
    f = JointPathFollower(np.zeros(2), [np.array([0, 1])], [np.ones(2)])
    with pytest.raises(ValueError, match="expected 2"):
        f.request(0, 1, np.zeros((1, 3)), np.zeros(1))


def test_positions_ahead_match_stepping():
    follower = JointPathFollower(np.zeros(2), [np.array([0, 1])], [np.ones(2)])
    follower.request(0, 1, np.array([[1.0, -0.5], [0.2, 0.3]]), np.array([0.3, 0.0]))
    for _ in range(40):
        follower.step(0.1, 0.7)
        q = follower.q.copy()
        probe = copy.deepcopy(follower)
        probe.step(0.04, 0.7)
        np.testing.assert_allclose(follower.positions_ahead(0.04, 0.7), probe.q, atol=1e-12)
        np.testing.assert_array_equal(follower.q, q)
    np.testing.assert_allclose(follower.positions_ahead(100.0, 1.0), [0.2, 0.3])


def test_blended_path_is_one_smooth_move_within_the_velocity_limits():
    from hrc_drake.robots.path import ArmPath, BlendedArmPath

    v_max = np.array([1.0, 2.0])
    angles = np.linspace(0.0, np.pi, 43)
    waypoints = np.stack([np.cos(angles), np.sin(angles)], axis=1) - [1.0, 0.0]
    blended = BlendedArmPath(np.zeros(2), waypoints[1:], np.full(42, 0.5), v_max, 0.8)
    stop_and_go = ArmPath(np.zeros(2), waypoints[1:], np.zeros(42), v_max, 0.8)
    assert blended.move_times.sum() < 0.8 * stop_and_go.move_times.sum()
    dt = 0.002
    T = blended.move_times[0]
    times = np.arange(0.0, T + 0.5 + dt, dt)
    q = np.array([blended.position_at(0, t) for t in times])
    speeds = np.abs(np.diff(q, axis=0)) / dt
    assert np.all(speeds <= 0.8 * v_max * 1.01)
    np.testing.assert_allclose(q[-1], waypoints[-1])
    np.testing.assert_allclose(q[0], [0.0, 0.0])
    # it passes through the waypoints (the polyline), not a chord of them
    gaps = np.min(np.linalg.norm(q[:, None, :] - waypoints[None, 1:-1, :], axis=2), axis=0)
    assert gaps.max() < 0.01
    # the velocity matches the positions' derivative
    t = 0.37 * T
    np.testing.assert_allclose(blended.velocity_at(0, t),
                               (blended.position_at(0, t + 1e-6) - blended.position_at(0, t - 1e-6)) / 2e-6,
                               rtol=1e-3, atol=1e-6)
    # progress runs through the move, then the last dwell only
    segment, phase, finished = blended.progress_after(0, 0.0, T + 0.4)
    assert (segment, finished) == (0, False)
    assert blended.progress_after(0, 0.0, T + 0.51)[2]


def test_a_path_goes_back_over_its_waypoints_no_further_than_its_start():
    """A retreat (negative time): back through the dwell at the first waypoint into the first move;
    never before the start. Moves of 1.875 s (1 rad at 1 rad/s, the min-jerk peak), a 0.5 s dwell."""
    from hrc_drake.robots.path import ArmPath

    path = ArmPath(np.zeros(1), np.array([[1.0], [2.0]]), np.array([0.5, 0.0]), np.array([1.0]), 1.0)
    segment, phase, finished = path.progress_after(1, 0.3, -1.0)  # 0.3 of move 2, the dwell, 0.2 of move 1
    assert (segment, finished) == (0, False) and phase == pytest.approx(1.875 - 0.2)
    u = (1.875 - 0.2) / 1.875
    np.testing.assert_allclose(path.position_at(segment, phase), [u**3 * (10 - 15 * u + 6 * u * u)])
    assert path.progress_after(0, 0.4, -5.0)[:2] == (0, 0.0)
    assert path.progress_after(1, 0.3, 0.0)[:2] == (1, 0.3)
