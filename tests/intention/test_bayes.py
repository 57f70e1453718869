import numpy as np
import pytest
from scipy.special import logsumexp

from hrc_drake.intention.bayes import (
    FeedbackStateMachine,
    GoalIntentionEstimator,
    bayes_update,
    minimum_jerk_velocity,
)
from hrc_drake.intention.features import skeleton_features, trajectory_velocities
from hrc_drake.messages import HEAD, L_WRIST, R_WRIST
from tests.intention.intention_reaches import GOALS, straight_reach


def test_bayes_update_hand_computed():
    prior = np.array([[0.5, 0.25, 0.25]])
    lik = np.array([[1.0, 2.0, 4.0]])
    post = bayes_update(prior, np.log(lik))
    np.testing.assert_allclose(post, [[0.5 / 2.0, 0.5 / 2.0, 1.0 / 2.0]])
    switched = bayes_update(np.array([[1.0, 0.0]]), np.log([[1.0, 1.0]]), switch_probability=0.2)
    np.testing.assert_allclose(switched, [[0.9, 0.1]])


def test_bayes_update_keeps_inactive_rows_and_never_nans():
    prior = np.array([[0.2, 0.8], [0.6, 0.4]])
    post = bayes_update(prior, np.array([[0.0, -5.0], [np.nan, np.nan]]), 0.0, active=np.array([False, True]))
    np.testing.assert_allclose(post, prior)
    extreme = bayes_update(prior, np.array([[-1e300, 0.0], [-np.inf, np.inf]]))
    assert np.all(np.isfinite(extreme)) and np.allclose(extreme.sum(axis=1), 1.0)
    assert np.all(extreme > 0)


def test_minimum_jerk_nominal_velocity_from_rest_points_at_the_goal():
    v = minimum_jerk_velocity(np.zeros(3), np.zeros(3), np.array([1.0, 0, 0]), np.array(1.0), 0.1)
    assert v[0] > 0 and abs(v[1]) < 1e-12
    # with an initial velocity the nominal one starts from it and ends at rest
    v0 = np.array([0.0, 1.0, 0.0])
    goal = np.array([1.0, 0, 0])
    np.testing.assert_allclose(minimum_jerk_velocity(np.zeros(3), v0, goal, np.array(1.0), 0.0), v0)
    np.testing.assert_allclose(
        minimum_jerk_velocity(np.zeros(3), v0, goal, np.array(1.0), 1.0), 0, atol=1e-12
    )


def test_m1_angle_is_to_the_minimum_jerk_direction_from_the_reach_start():
    estimator = GoalIntentionEstimator(GOALS, method="M1", m1_sigma=0.5)
    start = np.array([0.9, 0.0, 0.9])
    points = np.zeros((8, 3)) + [1.0, 0.0, 1.3]
    points[L_WRIST] = [0.9, 0.3, 0.9]
    gaze = np.array([-1.0, 0.0, 0.0])
    k = 0
    for _ in range(10):  # both hands at rest: anchors at `start`
        points[R_WRIST] = start
        estimator.update(k / 30.0, points, gaze)
        k += 1
    # the right wrist then moves at 0.5 m/s straight towards goal 0
    direction = (GOALS[0] - start) / np.linalg.norm(GOALS[0] - start)
    anchor = start
    for step in range(1, 12):
        points[R_WRIST] = start + 0.5 * (step / 30.0) * direction
        log_lik, active = estimator.log_likelihood(k / 30.0, points, gaze, True)
        if not active[1]:
            anchor = points[R_WRIST].copy()  # the motion starts where the hand was last still
        k += 1
    assert active.tolist() == [False, True]
    # from rest the quintic's velocity is along C_i - p_s at every instant: delta^i is its angle
    expected = [-0.5 * (np.arccos(np.dot(direction, (g - anchor) / np.linalg.norm(g - anchor))) / 0.5) ** 2
                for g in GOALS]
    np.testing.assert_allclose(log_lik[1], expected, atol=1e-6)
    assert np.all(np.isnan(log_lik[0]))


def run(estimator, times, points, gaze, gaze_valid=True):
    history = []
    for t, p, g in zip(times, points, gaze, strict=True):
        history.append(estimator.update(t, p, g, gaze_valid).copy())
    return np.array(history)


@pytest.mark.parametrize("method", ["M1", "M2", "M3"])
def test_converges_to_the_true_goal_on_a_straight_reach(small_model, method):
    start = np.array([0.85, 0.15, 0.9])
    for goal_index in range(3):
        estimator = GoalIntentionEstimator(GOALS, small_model, method=method, rng=0)
        history = run(estimator, *straight_reach(start, GOALS[goal_index], noise=0.003, rng=goal_index))
        np.testing.assert_allclose(history.sum(axis=2), 1.0)
        assert history[-1, 1].argmax() == goal_index
        assert history[-1, 1, goal_index] > 0.8
        np.testing.assert_allclose(history[-1, 0], 1 / 3)  # the still left hand learns nothing


def test_gaze_switch_uses_gmm2d_when_flag_is_invalid(small_model):
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[1], noise=0.003, rng=5)
    wrong_gaze = np.tile(GOALS[0] - points[0, HEAD], (len(times), 1))  # always looking at goal 0
    invalid = run(GoalIntentionEstimator(GOALS, small_model, "M3"), times, points, wrong_gaze, False)
    m2 = run(GoalIntentionEstimator(GOALS, small_model, "M2"), times, points, wrong_gaze, True)
    np.testing.assert_allclose(invalid, m2)  # invalid flag -> exactly GMM2d
    valid = run(GoalIntentionEstimator(GOALS, small_model, "M3"), times, points, wrong_gaze, True)
    assert not np.allclose(valid, invalid)  # a valid flag makes the gaze count
    right = run(GoalIntentionEstimator(GOALS, small_model, "M3"), times, points, gaze, True)
    k = 8  # early in the reach the gaze at the goal helps more than a gaze elsewhere
    assert right[k, 1, 1] > valid[k, 1, 1]


def test_still_hand_nan_points_and_goal_at_wrist_do_not_break(small_model):
    estimator = GoalIntentionEstimator(GOALS, small_model, "M3")
    points = np.zeros((8, 3)) + [1.0, 0.0, 1.3]
    points[R_WRIST] = GOALS[2]  # wrist exactly at a goal, still
    for k in range(20):
        p = estimator.update(k / 30.0, points, np.array([-1.0, 0, 0]))
        assert np.all(np.isfinite(p))
    np.testing.assert_allclose(p, 1 / 3)
    nan_points = np.full((8, 3), np.nan)
    p = estimator.update(1.0, nan_points, np.array([np.nan] * 3), True)
    assert np.all(np.isfinite(p)) and np.allclose(p.sum(axis=1), 1.0)
    # moving wrist passing exactly through a goal centre
    times, pts, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[1], noise=0.0)
    history = run(GoalIntentionEstimator(GOALS, small_model, "M3"), times, pts, gaze)
    assert np.all(np.isfinite(history))


def test_uncertain_goal_centres_average_the_likelihood(small_model):
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[0], noise=0.003, rng=1)
    sampled = GoalIntentionEstimator(GOALS, small_model, "M3", goal_std=0.05, n_goal_samples=30, rng=1)
    k = 10
    run(sampled, times[:k], points[:k], gaze[:k])
    log_lik, active = sampled.log_likelihood(times[k], points[k], gaze[k], True)
    assert active[1] and not active[0]
    # eq. (3.12) by hand: the k-th draw of centres, features, mean of the GMM4d likelihoods
    rng = np.random.default_rng(1)
    for _ in range(k):
        rng.standard_normal((3, 30, 3))
    centres = GOALS[:, None, :] + 0.05 * rng.standard_normal((3, 30, 3))
    velocity, moving = trajectory_velocities(times[: k + 1], points[: k + 1][:, [L_WRIST, R_WRIST]])
    phi = skeleton_features(points[k], velocity[-1], moving[-1], gaze[k], centres)
    expected = logsumexp(small_model.gmm4d.log_density(phi[1]), axis=-1) - np.log(30)
    np.testing.assert_allclose(log_lik[1], expected, rtol=1e-9)
    exact = GoalIntentionEstimator(GOALS, small_model, "M3")
    run(exact, times[:k], points[:k], gaze[:k])
    assert not np.allclose(exact.log_likelihood(times[k], points[k], gaze[k], True)[0][1], log_lik[1])


def test_feedback_state_machine_of_fig_3_6():
    machine = FeedbackStateMachine(("G1", "G2", "G3", "G4"), 0.8, sequence=("G4", "G1"), hands=("left",))
    low = np.full((2, 4), 0.25)
    assert machine.step(low) == [] and machine.state == 1
    g1 = np.array([[0.9, 0.05, 0.03, 0.02]] * 2)
    assert machine.step(g1) == []  # waiting for goal 4 first
    g4 = np.array([[0.05, 0.03, 0.02, 0.9]] * 2)
    assert machine.step(g4) == [("left", "G4")] and machine.state == 2
    assert machine.step(g4) == []
    assert machine.step(g1) == [("left", "G1")] and machine.state == 1


def test_feedback_rising_edges_with_release():
    machine = FeedbackStateMachine(("A", "B"), 0.8)
    p = np.array([[0.85, 0.15], [0.5, 0.5]])
    assert machine.step(p) == [("left", "A")]
    assert machine.step(np.array([[0.79, 0.21], [0.5, 0.5]])) == []
    assert machine.step(p) == []  # not released below 0.5 yet
    assert machine.step(np.array([[0.3, 0.7], [0.1, 0.9]])) == [("right", "B")]
    assert machine.step(p) == [("left", "A")]
    with pytest.raises(ValueError, match="sequence"):
        FeedbackStateMachine(("A",), sequence=("Z",))


def test_bad_inputs_raise(small_model):
    with pytest.raises(ValueError, match="method"):
        GoalIntentionEstimator(GOALS, small_model, method="M4")
    with pytest.raises(ValueError, match="goal_centers"):
        GoalIntentionEstimator(np.zeros((3, 2)), small_model)
    with pytest.raises(ValueError, match=r"\(8, 3\)"):
        GoalIntentionEstimator(GOALS, small_model).update(0.0, np.zeros((7, 3)), np.ones(3))


def test_evidence_weight_tempers_the_likelihood(small_model):
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[2], noise=0.003, rng=2)
    full = GoalIntentionEstimator(GOALS, small_model, "M3", evidence_weight=1.0, restart_switch=0.0)
    half = GoalIntentionEstimator(GOALS, small_model, "M3", evidence_weight=0.5, restart_switch=0.0)
    for k in range(12):
        log_full, active = full.log_likelihood(times[k], points[k], gaze[k], True)
        log_half, _ = half.log_likelihood(times[k], points[k], gaze[k], True)
    assert active[1]
    np.testing.assert_allclose(log_half[1], 0.5 * log_full[1])
    with pytest.raises(ValueError, match="evidence_weight"):
        GoalIntentionEstimator(GOALS, small_model, "M3", evidence_weight=0.0)


def test_a_motion_after_a_pause_restarts_from_a_flatter_prior(small_model):
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[0], noise=0.0, rng=0)
    estimator = GoalIntentionEstimator(
        GOALS, small_model, "M2", switch_probability=0.0, restart_switch=0.6, restart_after=0.25
    )
    estimator.probabilities_[1] = [0.1, 0.1, 0.8]  # belief left over from the previous reach
    history = run(estimator, times, points, gaze)
    first = np.nonzero([active[1] for active in _activity(times, points, small_model)])[0][0]
    # the first update with motion mixes the prior with the uniform one: 0.4 P + 0.6 / 3
    prior = 0.4 * np.array([0.1, 0.1, 0.8]) + 0.2
    replay = GoalIntentionEstimator(GOALS, small_model, "M2")
    for k in range(first):
        replay.log_likelihood(times[k], points[k], gaze[k], True)
    log_lik, _ = replay.log_likelihood(times[first], points[first], gaze[first], True)
    expected = prior * np.exp(log_lik[1] - log_lik[1].max())
    np.testing.assert_allclose(history[first, 1], expected / expected.sum(), atol=1e-9)
    # the next updates (no pause) use switch_probability = 0: plain eq. (3.2)
    log_next, _ = replay.log_likelihood(times[first + 1], points[first + 1], gaze[first + 1], True)
    expected = history[first, 1] * np.exp(log_next[1] - log_next[1].max())
    np.testing.assert_allclose(history[first + 1, 1], expected / expected.sum(), atol=1e-9)  # 30-nat floor


def _activity(times, points, model):
    estimator = GoalIntentionEstimator(GOALS, model, "M2")
    gaze = np.array([1.0, 0, 0])
    return [estimator.log_likelihood(t, p, gaze, False)[1] for t, p in zip(times, points, strict=True)]
