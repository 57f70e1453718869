import numpy as np
import pytest

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import R_WRIST, SweptVolumes
from hrc_drake.motion.geometry import point_segment_distance
from hrc_drake.motion.reactive import (
    JointStateEstimator,
    ReactiveMotionPredictor,
    SweptVolumeBuilder,
    excursions_from_rollouts,
    ik_joint_std,
    joint_limit_vector,
    tracking_inverse,
    worst_case_excursions,
)


def test_excursions_hand_computed():
    q_now = np.array([0.0, 1.0])
    rollouts = np.array([
        [[0.1, 1.0], [0.3, 0.8]],   # trial 1: joint 0 up 0.3; joint 1 down 0.2
        [[-0.2, 1.1], [0.1, 1.4]],  # trial 2: joint 0 up 0.1 down 0.2; joint 1 up 0.4
    ])
    plus, minus = excursions_from_rollouts(q_now, rollouts)  # means (8.9)-(8.10)
    np.testing.assert_allclose(plus, [0.2, 0.2])
    np.testing.assert_allclose(minus, [0.1, 0.1])
    plus, minus = excursions_from_rollouts(q_now, rollouts, percentile=100)
    np.testing.assert_allclose(plus, [0.3, 0.4])
    np.testing.assert_allclose(minus, [0.2, 0.2])
    with pytest.raises(ValueError, match="percentile"):
        excursions_from_rollouts(q_now, rollouts, percentile=120)


def test_worst_case_hand_computed():
    # from rest, a = 2, v_max = 1, horizon 1: 0.5 s accelerating (0.25) + 0.5 s at v_max (0.5)
    plus, minus = worst_case_excursions(np.array([0.0, 1.0, -1.0]), 1.0, 1.0, 2.0)
    np.testing.assert_allclose(plus, [0.75, 1.0, 0.0])
    # moving at -1: decelerate 1 s to 0 -> displacement -1 + 1 = 0, never positive within 1 s
    np.testing.assert_allclose(minus, [0.75, 0.0, 1.0])


def test_kalman_and_rts_on_constant_acceleration():
    dt = 0.05
    estimator = JointStateEstimator(n_dof=2, dt=dt, process_std=1.0, measurement_std=0.01, window=40)
    rng = np.random.default_rng(0)
    t = np.arange(80) * dt
    truth = np.stack([0.5 * 0.8 * t**2, 0.3 * t], -1)  # q'' = 0.8, and a constant velocity 0.3
    filtered = np.array([estimator.step(q + rng.normal(0, 0.002, 2)) for q in truth])
    np.testing.assert_allclose(filtered[-1, :, 1], [0.8 * t[-1], 0.3], atol=0.1)
    np.testing.assert_allclose(filtered[-1, :, 2], [0.8, 0.0], atol=0.5)
    smoothed = estimator.smoothed_window()
    assert smoothed.shape == (40, 2, 3)
    np.testing.assert_allclose(smoothed[-1], filtered[-1])  # the last smoothed state is the filtered one
    window_truth = truth[-40:]
    err_filtered = np.abs(filtered[-40:-1, :, 0] - window_truth[:-1]).mean()
    err_smoothed = np.abs(smoothed[:-1, :, 0] - window_truth[:-1]).mean()
    assert err_smoothed < err_filtered


@pytest.fixture(scope="module")
def body():
    return BodyModel()


def test_swept_volumes_hold_the_body_over_the_joint_box(body):
    builder = SweptVolumeBuilder(body, levels=3)
    q = body.rest_q((1.0, 0.2), np.pi)
    q[8] = 0.8
    rng = np.random.default_rng(4)
    for delta in (0.0, 0.1, 0.4):
        start, end, radius = builder.build(q, np.full(12, delta), np.full(12, delta))
        samples = np.clip(q + rng.uniform(-delta, delta, (3000, 12)), body.q_lower, body.q_upper)
        s, e, r = body.capsules(samples)
        reach = np.maximum(point_segment_distance(s, start, end), point_segment_distance(e, start, end)) + r
        assert np.all(reach <= radius + 1e-9)
    # zero excursions give back the body capsules themselves
    s0, e0, r0 = body.capsules(q)
    start, end, radius = builder.build(q, np.zeros(12), np.zeros(12))
    np.testing.assert_allclose(radius, r0, atol=1e-9)
    assert np.allclose(np.sort(np.stack([start, end], 1), axis=1), np.sort(np.stack([s0, e0], 1), axis=1))


def test_bigger_excursions_give_bigger_volumes(body):
    builder = SweptVolumeBuilder(body)
    q = body.rest_q()
    _, _, small = builder.build(q, np.full(12, 0.05), np.full(12, 0.05))
    _, _, large = builder.build(q, np.full(12, 0.3), np.full(12, 0.3))
    assert np.all(large > small)


def _inside_union(body, start, end, radius, samples) -> float:
    """Largest excess of a body-capsule ball (points on the segments, body radius) over the
    nearest swept capsule, for joint samples (n, 12): <= 0 when every one lies inside a capsule."""
    s, e, r = body.capsules(samples)
    worst = -np.inf
    for t in (0.0, 0.3, 0.5, 1.0):
        points = s + t * (e - s)  # (n, 6, 3)
        clearance = point_segment_distance(points[:, :, None], start, end) - radius  # (n, 6, K)
        worst = max(worst, float((clearance.min(axis=2) + r).max()))
    return worst


def _box_samples(body, q, delta_plus, delta_minus, n, rng):
    """Joint samples in the box, a third of the coordinates on its faces, and every joint's
    mid-cell values (where a grid alone misses the arcs)."""
    low = np.maximum(q - delta_minus, body.q_lower)
    high = np.maximum(np.minimum(q + delta_plus, body.q_upper), low)
    u = rng.uniform(size=(n, 12))
    u = np.where(rng.uniform(size=u.shape) < 0.3, np.round(u), u)
    u[: n // 4] = rng.choice([0.0, 0.25, 0.5, 0.75, 1.0, 1.0 / 6, 0.5 - 1.0 / 6], size=(n // 4, 12))
    return low + u * (high - low)


def test_tight_swept_volumes_are_conservative_on_dense_joint_samples(body):
    """Every body capsule instance on the joint box, arcs between the grid values included, lies
    in the union of the returned capsules: worst-case boxes from rest and moving, GP-sized and
    lopsided boxes, boxes clipped at the joint limits, and spans over 90 degrees."""
    rng = np.random.default_rng(7)
    predictor = ReactiveMotionPredictor(body, "worst_case", dt=0.05, horizon=0.3)
    rest = body.rest_q((1.4, 0.0), np.pi)
    moving = rng.normal(0.0, 1.0, 12)
    cases = [(rest, *worst_case_excursions(np.zeros(12), 0.3, predictor.v_max, predictor.a_max)),
             (rest, *worst_case_excursions(moving, 0.5, predictor.v_max, predictor.a_max)),
             (rest, np.full(12, 0.03), np.full(12, 0.01)),
             (rest, rng.uniform(0.0, 0.6, 12) * (rng.uniform(size=12) < 0.6), np.zeros(12))]
    near_limits = body.q_upper.copy()
    near_limits[:3] = [0.5, -0.3, 1.0]
    near_limits[3:] -= 0.05
    cases.append((near_limits, np.full(12, 0.4), np.full(12, 0.4)))
    wide = rest.copy()
    wide[[4, 8]] = 1.2
    cases.append((wide, np.full(12, 1.3), np.full(12, 1.3)))  # shoulders sweep ~150 degrees
    for levels in (2, 3):
        builder = SweptVolumeBuilder(body, levels=levels)
        for q, plus, minus in cases:
            start, end, radius = builder.build(q, plus, minus)
            assert start.shape == end.shape == (6, 3) and radius.shape == (6,)
            samples = _box_samples(body, q, plus, minus, 4000, rng)
            assert _inside_union(body, start, end, radius, samples) <= 1e-9


def test_worst_case_frontier_from_rest_is_tight(body):
    """From rest with the worst case of [107] over 0.3 s, the volumes reach ahead of the shoulder
    at most about arm + torso lean + base motion + forearm radius (1.06 m with the default
    segments), a few cm beyond the farthest sampled pose (0.98 m). The single-capsule
    builder with arc and translation inflation reached 1.36 m (x = 0.04 for a body at x = 1.4)."""
    predictor = ReactiveMotionPredictor(body, "worst_case", dt=0.05, horizon=0.3)
    q = body.rest_q((1.4, 0.0), np.pi)  # facing -x: "ahead" is -x
    plus, minus = worst_case_excursions(np.zeros(12), predictor.horizon, predictor.v_max, predictor.a_max)
    start, end, radius = predictor.builder.build(q, plus, minus)
    ahead = 1.4 - float(np.minimum(start[:, 0] - radius, end[:, 0] - radius).min())
    arm = body.upper_arm + body.forearm + body.hand_length
    lean = body.torso * np.sin(plus[3])
    bound = arm + lean + plus[0] + body.capsule_radius[4]
    assert ahead <= bound + 0.01
    assert ahead < 0.8 * 1.36
    # and not below what the body reaches: the farthest of dense samples of the box
    samples = _box_samples(body, q, plus, minus, 20000, np.random.default_rng(1))
    s, e, r = body.capsules(samples)
    reached = 1.4 - float(np.minimum(s[..., 0] - r, e[..., 0] - r).min())
    assert reached <= ahead <= reached + 0.1
    # the forearm capsules are far thinner than before (radius 1.17 m)
    assert np.all(radius[4:] < 0.9)


def test_small_excursions_give_capsules_close_to_the_body(body):
    """Excursions of 0.02 (rad, m): each capsule is thinner than its body capsule grown by the
    farthest any of its points can move, sum of lever x excursion over the joints that move it."""
    builder = SweptVolumeBuilder(body)
    q = body.rest_q((1.0, 0.2), np.pi)
    delta = 0.02
    start, end, radius = builder.build(q, np.full(12, delta), np.full(12, delta))
    s0, e0, r0 = body.capsules(q)
    arm = body.upper_arm + body.forearm + body.hand_length
    from_hip = body.torso + 0.5 * body.shoulder_width + arm
    base = np.hypot(delta, delta)
    moves = np.array([body.torso, body.torso + body.neck + 0.06, 0.5 * body.shoulder_width + body.torso,
                      0.5 * body.shoulder_width + body.torso, from_hip, from_hip]) * 2 * delta + base
    moves[2:4] += body.upper_arm * 2 * delta  # shoulder flexion, abduction
    moves[4:] += arm * 2 * delta + (body.forearm + body.hand_length) * 2 * delta
    assert np.all(radius > r0) and np.all(radius <= r0 + moves)
    assert np.all(radius - r0 < 0.07)


def test_builder_rejects_a_body_with_other_kinematics(body):
    class Mirrored(BodyModel):
        def capsules(self, q):
            start, end, radius = super().capsules(q)
            return start * [1.0, -1.0, 1.0], end * [1.0, -1.0, 1.0], radius

    with pytest.raises(ValueError, match="kinematics"):
        SweptVolumeBuilder(Mirrored())


def test_constant_velocity_joint_excursions(body):
    """A joint moving at constant speed v: Delta+ ~ v * horizon, Delta- ~ 0 once the GP is trained."""
    dt, velocity = 0.05, 0.4
    predictor = ReactiveMotionPredictor(body, "gp_c", order=2, dt=dt, horizon=0.5, n_trials=40, rng=0)
    worst = ReactiveMotionPredictor(body, "worst_case", dt=dt, horizon=0.5, rng=0)
    q = body.rest_q((1.0, 0.0), np.pi)
    for k in range(120):
        q_k = q.copy()
        # right shoulder flexion sweeps back and forth at constant speed (triangle wave)
        phase = (k * dt * velocity) % 1.2
        q_k[8] = 0.2 + (phase if phase < 0.6 else 1.2 - phase)
        plus, minus = predictor.update_q(q_k)
        w_plus, w_minus = worst.update_q(q_k)
    assert predictor.model_ready
    rising = (k * dt * velocity) % 1.2 < 0.6
    moving = plus[8] if rising else minus[8]
    assert moving == pytest.approx(velocity * 0.5, abs=0.08)
    # the worst case of [107] is far more conservative than the GP on the still joints
    still = [0, 1, 4, 5, 6, 7]
    assert np.all(w_plus[still] > plus[still])
    assert w_plus[8] > plus[8] and w_minus[8] > minus[8]


def test_update_from_points_gives_swept_volumes(body):
    predictor = ReactiveMotionPredictor(body, "worst_case", dt=0.05, horizon=0.3, rng=0)
    q = body.rest_q((1.0, 0.0), np.pi)
    out = predictor.update(0.0, body.points(q))
    assert isinstance(out, SweptVolumes)
    assert out.names == body.CAPSULE_NAMES and out.start.shape == (6, 3) and out.horizon == pytest.approx(0.3)
    np.testing.assert_allclose(body.points(predictor.q_), body.points(q), atol=1e-3)
    with pytest.raises(ValueError, match="unknown kind"):
        ReactiveMotionPredictor(body, "gp_z")


def test_ik_joint_std_follows_the_geometry(body):
    q = body.rest_q((1.0, 0.0), np.pi)
    q[[7, 11]] = [0.05, 1.5]  # left elbow almost straight, right elbow bent
    std = ik_joint_std(body, q, 0.01)
    # shoulder rotation is nearly unobservable with a straight elbow, well observed with a bent one
    assert std[6] > 5 * std[10]
    # twice the point noise, twice the joint noise (linear propagation) away from the cap
    np.testing.assert_allclose(ik_joint_std(body, q, 0.02)[[0, 1, 3, 11]], 2 * std[[0, 1, 3, 11]], rtol=0.02)
    # without the right wrist the right elbow flexion is not measured at all: std at the cap
    visible = np.ones(8, dtype=bool)
    visible[R_WRIST] = False
    assert ik_joint_std(body, q, 0.01, visible, cap=1.0)[11] == pytest.approx(1.0, rel=0.05)
    with pytest.raises(ValueError, match="point_std"):
        ik_joint_std(body, q, 0.0)


def test_noisier_joint_is_smoothed_more():
    """Two joints, same truth (rest), measurement noise 0.01 vs 0.1: the filter trusts the first more."""
    rng = np.random.default_rng(3)
    estimator = JointStateEstimator(n_dof=2, dt=0.05, process_std=3.0, measurement_std=[0.01, 0.1])
    velocities = []
    for _ in range(200):
        phi = estimator.step(rng.normal(0.0, [0.01, 0.1]))
        velocities.append(phi[:, 1])
    rms = np.sqrt(np.mean(np.square(velocities[50:]), axis=0))
    # ten times the noise, far less than ten times the velocity jitter (the gain is lower)
    assert rms[1] < 5 * rms[0]
    # a per-step std overrides the constructor's
    estimator.step(np.array([0.0, 5.0]), measurement_std=[0.01, 1e3])
    assert abs(estimator.filter.x_[1, 0] * 3.0) < 0.1
    with pytest.raises(ValueError, match="measurement_std"):
        estimator.step(np.zeros(2), measurement_std=[0.01, -1.0])


def test_gp_waits_for_min_samples_and_stays_within_the_worst_case_when_capped(body):
    dt = 0.05
    predictor = ReactiveMotionPredictor(body, "gp_c", order=2, dt=dt, horizon=0.5, n_trials=20,
                                        min_samples=40, rng=1, cap_by_worst_case=True)
    rng = np.random.default_rng(2)
    q = body.rest_q((1.0, 0.0), np.pi)
    ready_at = None
    for k in range(80):
        q_k = q + rng.normal(0.0, 0.05, 12)  # jittery IK: the GP learns noise
        q_k[8] += 0.6 * np.sin(2.0 * k * dt)
        plus, minus = predictor.update_q(q_k)
        bound_plus, bound_minus = worst_case_excursions(predictor.phi_[:, 1], predictor.horizon,
                                                        predictor.v_max, predictor.a_max)
        assert np.all(plus <= bound_plus + 1e-12) and np.all(minus <= bound_minus + 1e-12)
        if not predictor.model_ready:
            np.testing.assert_allclose(plus, bound_plus)  # fallback: the worst case of [107]
        elif ready_at is None:
            ready_at = k
    assert predictor.model_.n_samples_ >= 40
    # refreshes every 10 steps; 40 samples after 4 refreshes (the first needs P + 1 states)
    assert ready_at is not None and 35 <= ready_at <= 50
    assert np.all(plus[:8] < bound_plus[:8])


def test_tracking_inverse_matches_the_full_solve_and_falls_back(body):
    rng = np.random.default_rng(5)
    q = body.rest_q((1.0, 0.1), np.pi)
    q[[4, 7, 8, 11]] = [0.6, 0.9, 0.3, 1.2]
    points = body.points(q) + rng.normal(0.0, 0.01, (8, 3))
    full = body.inverse(points, q0=q)
    warm = tracking_inverse(body, points, q + 0.02)
    np.testing.assert_allclose(body.points(warm), body.points(full), atol=2e-3)
    # without a previous pose, or from a far one, it is the full solve
    np.testing.assert_allclose(tracking_inverse(body, points, None), body.inverse(points), atol=1e-9)
    far = q.copy()
    far[[4, 8]] += 2.0
    np.testing.assert_allclose(body.points(tracking_inverse(body, points, far)), body.points(full), atol=0.02)
    with pytest.raises(ValueError, match="shape"):
        tracking_inverse(body, points[:7], q)


def test_per_joint_human_limits_reach_the_right_joints(body):
    speeds = {"base": 1.0, "yaw": 2.0, "torso": 3.0, "shoulder": 4.0, "shoulder_rotation": 5.0, "elbow": 6.0}
    np.testing.assert_array_equal(joint_limit_vector(speeds), [1, 1, 2, 3, 4, 4, 5, 6, 4, 4, 5, 6])
    with pytest.raises(ValueError, match="missing"):
        joint_limit_vector({"base": 1.0})
    predictor = ReactiveMotionPredictor(body, "worst_case", speed_limits=speeds, accel_limits=speeds)
    plus, _ = predictor.update_q(body.rest_q((1.0, 0.0), np.pi))
    # from rest, t_sat = v / a = 1 s > horizon 0.5 s: every excursion is a * T^2 / 2
    np.testing.assert_allclose(plus, 0.5 * joint_limit_vector(speeds) * 0.5**2)
    with pytest.raises(ValueError, match="speed_limits"):
        ReactiveMotionPredictor(body, "worst_case", speed_limits=np.zeros(12))


def test_motion_config_sets_per_joint_limits_and_options(body):
    from hrc_drake.motion.config import GPMotionModel
    from hrc_drake.motion.systems import predictor_kwargs

    config = GPMotionModel(elbow_speed=7.0, torso_accel=9.0, training_states="filtered",
                           cap_by_worst_case=True, hyperparameter_every=4)
    predictor = ReactiveMotionPredictor(body, rng=0, **predictor_kwargs(config))
    assert predictor.v_max[7] == predictor.v_max[11] == 7.0
    assert predictor.a_max[3] == 9.0 and predictor.v_max[4] == config.shoulder_speed
    assert predictor.training_states == "filtered" and predictor.cap_by_worst_case
    assert predictor.model_.hyperparameter_every == 4
    from hrc_drake.errors import ConfigError
    with pytest.raises(ConfigError, match="training_states"):
        GPMotionModel(training_states="raw").validate("motion_model")
    with pytest.raises(ConfigError, match="hyperparameter_every"):
        GPMotionModel(hyperparameter_every=0).validate("motion_model")
    with pytest.raises(ConfigError, match="elbow_speed"):
        GPMotionModel(elbow_speed=0.0).validate("motion_model")


def test_filtered_training_states_are_the_kalman_filtered_ones(body):
    predictor = ReactiveMotionPredictor(body, "gp_c", order=2, training_states="filtered", rng=0)
    rng = np.random.default_rng(0)
    q = body.rest_q((1.0, 0.0), np.pi)
    for _ in range(12):
        predictor.update_q(q + rng.normal(0.0, 0.05, 12))
    np.testing.assert_allclose(predictor._states(3)[-1], predictor.phi_)
    smoothed = ReactiveMotionPredictor(body, "gp_c", order=2, rng=0)
    for _ in range(12):
        smoothed.update_q(q + rng.normal(0.0, 0.05, 12))
    # the smoother changes every state but the newest
    assert not np.allclose(smoothed._states(3)[0], smoothed.estimator.filtered_window(3)[0])


def test_scalar_linspace_is_numpys_bit_for_bit():
    from hrc_drake.motion.reactive import _linspace

    rng = np.random.default_rng(8)
    for _ in range(500):
        low = rng.normal()
        high = low + abs(rng.normal()) * rng.choice([0.0, 1e-9, 1.0, 3.0])
        num = int(rng.integers(2, 12))
        np.testing.assert_array_equal(_linspace(low, high, num), np.linspace(low, high, num))
