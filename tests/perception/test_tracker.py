"""SkeletonTracker core (kinds particle_filter | kalman | none) and the 9.1.3 slow-down rule."""

import numpy as np
import pytest

from hrc_drake.messages import L_WRIST, SkeletonEstimate, SkeletonFrame
from hrc_drake.perception.tracker import UNKNOWN_SPREAD, SkeletonTracker, speed_override

POSE = np.array([
    [0.0, 0.0, 1.40], [0.0, 0.0, 1.65], [0.0, 0.2, 1.40], [0.0, -0.2, 1.40],
    [0.0, 0.2, 1.10], [0.0, -0.2, 1.10], [0.27, 0.2, 1.10], [0.27, -0.2, 1.10],
])
# Robot workspace in front of the operator; the left wrist sits just outside it.
WS_CENTER, WS_SIZE = np.array([0.6, 0.2, 1.1]), np.array([0.5, 0.6, 0.6])


def frame(t, points, tracked=None):
    tracked = np.all(np.isfinite(points), axis=1) if tracked is None else tracked
    return SkeletonFrame(time=t, points=points, tracked=tracked)


def run(kind, n_seen=15, n_hidden=30, params=None):
    tracker = SkeletonTracker(kind, params or {"particles": 200}, is_hidden=lambda p: p[..., 0] > 0.15,
                              workspace_center=WS_CENTER, workspace_size=WS_SIZE)
    ests = []
    for k in range(n_seen + n_hidden):
        pts = POSE.copy()
        if k >= n_seen:
            pts[L_WRIST] = np.nan
        ests.append(tracker.update(frame(k / 30.0, pts)))
    return tracker, ests


def test_speed_override_rule():
    est = SkeletonEstimate(workspace_fraction=np.array([0, 0, 0, 0, 0, 0, 0.09, 0]))
    assert speed_override(est) == 1.0
    est = SkeletonEstimate(workspace_fraction=np.array([0, 0, 0, 0, 0, 0, 0.1, 0]))
    assert speed_override(est) == 0.3
    assert speed_override(est, threshold=0.5, slow=0.2) == 1.0
    with pytest.raises(ValueError):
        speed_override(est, threshold=0.0)


@pytest.mark.parametrize("kind", ["particle_filter", "kalman", "none"])
def test_outputs_never_nan_and_have_port_shapes(kind):
    _, ests = run(kind)
    for est in ests:
        assert est.points.shape == (8, 3) and np.all(np.isfinite(est.points))
        assert np.all(np.isfinite(est.spread)) and np.all(np.isfinite(est.workspace_fraction))
        assert est.tracked.dtype == bool
    assert not ests[-1].tracked[L_WRIST] and ests[0].tracked.all()
    if kind != "none":
        assert ests[-1].particles.shape == (8, 50 if kind == "kalman" else 50, 3)


def test_kalman_ellipsoid_grows_into_workspace_but_particles_stay_out():
    # Occluded wrist: the KF ellipsoid grows (open loop) and reaches the workspace; the PF
    # keeps the wrist on the crown around the seen elbow, so the robot need not slow down.
    _, kf = run("kalman", n_hidden=90)
    _, pf = run("particle_filter", n_hidden=90)
    assert kf[-1].spread[L_WRIST] > kf[14].spread[L_WRIST] * 5
    assert speed_override(kf[14]) == 1.0
    # Once it reaches the workspace, an ever larger ellipsoid keeps the robot slow.
    slow = [speed_override(e) == 0.3 for e in kf[15:]]
    first = slow.index(True)
    assert all(slow[first:])
    assert all(speed_override(e) == 1.0 for e in pf)
    # hidden: no particle in the workspace; seen (the first 15 frames), the Kalman posterior's
    # tail 8 standard deviations away (0.08 m at ~1 cm), far below the rule's 10 %
    assert max(e.workspace_fraction[L_WRIST] for e in pf[15:]) == 0.0
    assert max(e.workspace_fraction[L_WRIST] for e in pf[:15]) < 1e-9


def test_none_holds_the_last_seen_position():
    _, ests = run("none")
    np.testing.assert_allclose(ests[-1].points[L_WRIST], POSE[L_WRIST])


def test_point_never_seen_is_conservative_not_nan():
    tracker = SkeletonTracker("particle_filter", {"particles": 100}, is_hidden=None,
                              workspace_center=WS_CENTER, workspace_size=WS_SIZE)
    pts = POSE.copy()
    pts[L_WRIST] = np.nan
    est = tracker.update(frame(0.0, pts))
    assert est.spread[L_WRIST] == UNKNOWN_SPREAD and est.workspace_fraction[L_WRIST] == 1.0
    assert np.all(np.isfinite(est.points))


def test_same_frame_twice_and_time_reset():
    tracker, ests = run("particle_filter", n_seen=5, n_hidden=0)
    again = tracker.update(frame(4 / 30.0, POSE))
    assert again is ests[-1]
    tracker.update(frame(0.0, POSE))  # time went back: a new run, calibration restarts
    assert not tracker.particle_filter.calibrated


def test_same_seed_same_estimates():
    a = run("particle_filter")[1][-1]
    b = run("particle_filter")[1][-1]
    np.testing.assert_array_equal(a.points, b.points)


def test_bad_configuration_raises():
    with pytest.raises(ValueError, match="kind"):
        SkeletonTracker("ukf")
    with pytest.raises(ValueError, match="unknown tracker parameter"):
        SkeletonTracker("kalman", {"particels": 10})
    with pytest.raises(ValueError, match="positive integer"):
        SkeletonTracker("particle_filter", {"particles": 10.5})
    with pytest.raises(ValueError, match="points"):
        SkeletonTracker("kalman").update(SkeletonFrame(points=np.zeros((7, 3))))
