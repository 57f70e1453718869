"""Body model (thesis Fig. 8.2 / 9.1): forward kinematics, inverse kinematics, capsules, gaze."""

import numpy as np
import pytest

from hrc_drake.human.body import ARM_DOFS, CAPSULE_NAMES, HIP_FRACTION, JOINT_NAMES, N_DOF, BodyModel
from hrc_drake.human.config import Segments
from hrc_drake.messages import (
    HEAD,
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    THORAX,
)

SEG = Segments(torso=0.5, neck=0.25, shoulder_width=0.4, upper_arm=0.3, forearm=0.27)
# a range where the arm angles are identifiable (elbow bent, abduction below 90 deg)
LOW = np.array([-1, -1, -3, -0.2, -0.5, -0.3, -1.2, 0.3, -0.5, -0.3, -1.2, 0.3])
HIGH = np.array([1, 1, 3, 1.0, 2.5, 1.4, 1.2, 2.4, 2.5, 1.4, 1.2, 2.4])


@pytest.fixture(scope="module")
def body():
    return BodyModel(SEG)


def test_constants():
    assert N_DOF == 12 and len(JOINT_NAMES) == 12
    assert JOINT_NAMES[3] == "torso_flexion"
    assert ARM_DOFS == {"left": slice(4, 8), "right": slice(8, 12)}
    assert len(CAPSULE_NAMES) == 6


def test_rest_pose_is_sensible(body):
    q = body.rest_q((0.0, 0.0), 0.0)
    assert q.shape == (12,)
    p = body.points(q)
    hip = HIP_FRACTION * (0.5 + 0.25 + 0.75)
    np.testing.assert_allclose(p[THORAX], [0, 0, hip + 0.5], atol=1e-12)
    np.testing.assert_allclose(p[HEAD], [0, 0, hip + 0.75], atol=1e-12)
    # left is +y when facing +x
    np.testing.assert_allclose(p[L_SHOULDER], [0, 0.2, hip + 0.5], atol=1e-12)
    np.testing.assert_allclose(p[R_SHOULDER], [0, -0.2, hip + 0.5], atol=1e-12)
    assert p[L_WRIST, 2] < p[L_ELBOW, 2] < p[L_SHOULDER, 2]
    assert p[R_WRIST, 2] < p[R_ELBOW, 2] < p[R_SHOULDER, 2]
    mirror = np.array([1.0, -1.0, 1.0])
    for left, right in ((L_SHOULDER, R_SHOULDER), (L_ELBOW, R_ELBOW), (L_WRIST, R_WRIST)):
        np.testing.assert_allclose(p[left] * mirror, p[right], atol=1e-12)


def test_hand_computed_poses(body):
    q = np.zeros(12)
    q[4] = np.pi / 2  # left arm straight forward
    q[9] = np.pi / 2  # right arm straight sideways (outwards = -y)
    p = body.points(q)
    np.testing.assert_allclose(p[L_WRIST], p[L_SHOULDER] + [0.57, 0, 0], atol=1e-12)
    np.testing.assert_allclose(p[R_WRIST], p[R_SHOULDER] + [0, -0.57, 0], atol=1e-12)
    # elbow flexion 90 deg with the arm down: forearm forward; external rotation 90 deg turns it out
    q = np.zeros(12)
    q[7] = np.pi / 2
    q[10] = np.pi / 2
    q[11] = np.pi / 2
    p = body.points(q)
    np.testing.assert_allclose(p[L_WRIST] - p[L_ELBOW], [0.27, 0, 0], atol=1e-12)
    np.testing.assert_allclose(p[R_WRIST] - p[R_ELBOW], [0, -0.27, 0], atol=1e-12)
    # lean forward 30 deg around the hip, facing +y (yaw 90 deg), standing at (1, 2)
    q = body.rest_q((1.0, 2.0), np.pi / 2)
    q[3] = np.pi / 6
    p = body.points(q)
    hip = np.array([1.0, 2.0, body.hip_height])
    np.testing.assert_allclose(p[THORAX], hip + 0.5 * np.array([0, 0.5, np.sqrt(3) / 2]), atol=1e-12)
    np.testing.assert_allclose(p[L_SHOULDER] - p[THORAX], [-0.2, 0, 0], atol=1e-12)


def test_batched_fk_matches_loop_and_keeps_lengths(body):
    rng = np.random.default_rng(3)
    q = rng.uniform(body.q_lower, body.q_upper, size=(2, 5, 12))
    q[..., :2] = rng.uniform(-2, 2, size=(2, 5, 2))
    p = body.points(q)
    assert p.shape == (2, 5, 8, 3)
    for i in range(2):
        for j in range(5):
            np.testing.assert_allclose(p[i, j], body.points(q[i, j]), atol=1e-12)
    bone = lambda a, b: np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1)  # noqa: E731
    np.testing.assert_allclose(bone(L_SHOULDER, L_ELBOW), 0.3)
    np.testing.assert_allclose(bone(R_ELBOW, R_WRIST), 0.27)
    np.testing.assert_allclose(bone(L_SHOULDER, R_SHOULDER), 0.4)
    np.testing.assert_allclose(bone(THORAX, HEAD), 0.25)


def test_ik_round_trip(body):
    rng = np.random.default_rng(0)
    for q_true in rng.uniform(LOW, HIGH, size=(25, 12)):
        q = body.inverse(body.points(q_true))
        np.testing.assert_allclose(q, q_true, atol=1e-3)


def test_ik_with_missing_points_and_noise(body):
    rng = np.random.default_rng(1)
    for q_true in rng.uniform(LOW, HIGH, size=(10, 12)):
        pts = body.points(q_true)
        pts[[HEAD, L_WRIST]] = np.nan
        q = body.inverse(pts, q0=q_true + rng.normal(0, 0.05, 12))
        visible = [THORAX, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, R_WRIST]
        np.testing.assert_allclose(body.points(q)[visible], pts[visible], atol=1e-3)
    noisy = body.points(q_true) + rng.normal(0, 0.01, (8, 3))
    q = body.inverse(noisy)
    assert np.all(q >= body.q_lower) and np.all(q <= body.q_upper)
    assert np.sqrt(np.mean((body.points(q) - noisy) ** 2)) < 0.015


def test_ik_respects_joint_limits(body):
    q_out = body.rest_q((0, 0), 0)
    q_out[7] = -0.5  # hyper-extended elbow, outside the limits
    q = body.inverse(body.points(q_out))
    assert np.all(q >= body.q_lower - 1e-12) and np.all(q <= body.q_upper + 1e-12)
    assert q[7] < 0.05  # the closest feasible pose has a straight elbow


def test_ik_errors(body):
    pts = body.points(body.rest_q())
    pts[2:] = np.nan
    with pytest.raises(ValueError, match="at least 3"):
        body.inverse(pts)
    with pytest.raises(ValueError, match=r"\(8, 3\)"):
        body.inverse(np.zeros((7, 3)))
    with pytest.raises(ValueError, match="NaN"):
        body.points(np.full(12, np.nan))
    with pytest.raises(ValueError, match="size 12"):
        body.points(np.zeros(11))
    with pytest.raises(ValueError, match="forearm"):
        BodyModel(Segments(forearm=-0.1))


def test_capsules(body):
    q = np.stack([body.rest_q(), body.rest_q((1, 1), 1.0)])
    start, end, radius = body.capsules(q)
    assert start.shape == end.shape == (2, 6, 3) and radius.shape == (6,)
    p = body.points(q)
    np.testing.assert_allclose(end[:, 0], p[:, THORAX])
    np.testing.assert_allclose(start[:, 2], p[:, L_SHOULDER])
    np.testing.assert_allclose(end[:, 2], p[:, L_ELBOW])
    forearm = np.linalg.norm(end[:, 5] - start[:, 5], axis=-1)
    np.testing.assert_allclose(forearm, 0.27 + body.hand_length)
    assert np.all(radius > 0)


def test_gaze(body):
    q = body.rest_q((0, 0), np.pi / 2)
    np.testing.assert_allclose(body.gaze(q), [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(body.gaze(q, [np.pi / 2, 0]), [-1, 0, 0], atol=1e-12)
    g = body.gaze(q, [0.0, np.pi / 4])
    np.testing.assert_allclose(g, [0, np.sqrt(0.5), -np.sqrt(0.5)], atol=1e-12)
    assert body.gaze(np.zeros((4, 12))).shape == (4, 3)
