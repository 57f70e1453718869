"""Property tests of the recursive Bayes goal estimator and the feedback machine on arbitrary
hand/gaze streams (Hypothesis): NaN, inf, huge values, lost wrists, jumps, time going backwards."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hrc_drake.intention.bayes import FeedbackStateMachine, GoalIntentionEstimator, bayes_update
from hrc_drake.intention.likelihood import default_model
from hrc_drake.messages import HANDS, HEAD, L_WRIST, R_WRIST
from tests.intention.intention_reaches import GOALS

MODEL = default_model()
BODY = np.array([1.0, 0.0, 1.3])
START = np.array([[0.9, 0.3, 0.9], [0.9, -0.1, 0.9]])  # left, right wrist at rest

corruption = st.one_of(
    st.just(None), st.just(None), st.just(None),
    st.just("lost"),  # NaN row
    st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3),  # a jump
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=3, max_size=3),  # NaN, inf, huge
)
time_step = st.one_of(
    st.just(1.0 / 30.0), st.just(1.0 / 30.0),
    st.just(0.0), st.floats(-1.0, 0.0), st.floats(0.0, 2.0),
    st.sampled_from([math.nan, math.inf, -math.inf, 1e12]),
)
gaze = st.one_of(st.just("goal"), st.just("goal"), st.just((0.0, 0.0, 0.0)),
                 st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=3, max_size=3))
messy = st.tuples(time_step, corruption, corruption, gaze, st.booleans())
clean = st.tuples(st.just(1.0 / 30.0), st.none(), st.none(), st.just("goal"), st.booleans())
frame = st.one_of(clean, clean, messy)  # enough clean runs for the wrist velocity window to fill
# Each hand moves from rest towards a goal (index) at a speed (m/s), or stays still (speed 0).
motion = st.tuples(st.integers(0, len(GOALS) - 1), st.sampled_from([0.0, 0.3, 0.6, 1.5]))


def build_stream(draws, motions):
    """(time, points (8, 3), gaze (3,), gaze_valid) per frame."""
    clock, k, out = 0.0, 0, []
    for step, left, right, g, g_valid in draws:
        t = clock + step if math.isfinite(step) else step
        if math.isfinite(step):
            clock = t
        k += 1
        points = np.tile(BODY, (8, 1))
        points[HEAD] = BODY + [0.0, 0.0, 0.3]
        for hand, (row, corrupt) in enumerate(((L_WRIST, left), (R_WRIST, right))):
            goal, speed = motions[hand]
            direction = GOALS[goal] - START[hand]
            reach = min(1.0, speed * k / 30.0 / np.linalg.norm(direction))
            points[row] = START[hand] + reach * direction
            with np.errstate(over="ignore", invalid="ignore"):
                if corrupt == "lost":
                    points[row] = np.nan
                elif corrupt is not None:
                    points[row] = points[row] + np.array(corrupt)
        if g == "goal":
            direction = GOALS[motions[1][0]] - points[HEAD]
            g = direction / np.linalg.norm(direction)
        out.append((t, points, np.array(g, dtype=float), g_valid))
    return out


def run_estimator(stream, method, samples, switch, seed=0):
    estimator = GoalIntentionEstimator(GOALS, MODEL, method=method, goal_std=0.05, n_goal_samples=samples,
                                       switch_probability=switch, rng=seed)
    out = []
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for t, points, g, g_valid in stream:
            before = estimator.predict_proba()
            probs = estimator.update(t, points, g, g_valid)
            out.append((before, probs.copy(), estimator.last_active_.copy()))
            np.testing.assert_array_equal(estimator.predict_proba(), probs)
    return out


@settings(max_examples=100, deadline=None)
@given(draws=st.lists(frame, min_size=20, max_size=60), motions=st.tuples(motion, motion),
       method=st.sampled_from(["M1", "M2", "M3"]), samples=st.sampled_from([0, 4]),
       switch=st.sampled_from([0.0, 0.02]))
def test_any_stream_gives_distributions_and_lost_hands_keep_theirs(draws, motions, method, samples, switch):
    stream = build_stream(draws, motions)
    out = run_estimator(stream, method, samples, switch)
    for (t, points, _, _), (before, probs, active) in zip(stream, out, strict=True):
        assert probs.shape == (2, len(GOALS))
        assert np.all(np.isfinite(probs)) and np.all((probs >= 0) & (probs <= 1))
        np.testing.assert_allclose(probs.sum(axis=1), 1.0, atol=1e-9)
        if switch > 0:  # mixed with the uniform prior before every update: never exactly 0
            assert np.all(probs > 0)
        wrists_known = np.all(np.isfinite(points[[L_WRIST, R_WRIST]]), axis=1)
        assert not np.any(active & ~wrists_known)
        if not math.isfinite(t):
            assert not active.any()
        # a still or lost wrist keeps its hand's probabilities (documented)
        np.testing.assert_array_equal(probs[~active], before[~active])
    again = run_estimator(stream, method, samples, switch)
    for a, b in zip(out, again, strict=True):
        np.testing.assert_array_equal(a[1], b[1])


@settings(max_examples=40, deadline=None)
@given(draws=st.lists(frame, min_size=20, max_size=60), motions=st.tuples(motion, motion),
       method=st.sampled_from(["M1", "M3"]), cut=st.integers(0, 60))
def test_a_clone_continues_like_the_original_and_leaves_it_alone(draws, motions, method, cut):
    stream = build_stream(draws, motions)
    estimator = GoalIntentionEstimator(GOALS, MODEL, method=method, goal_std=0.05, n_goal_samples=4, rng=1)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for t, points, g, g_valid in stream[:cut]:
            estimator.update(t, points, g, g_valid)
        copy = estimator.clone()  # copy-on-write state of the Drake system
        from_copy = [copy.update(*f).copy() for f in stream[cut:]]
        from_original = [estimator.update(*f).copy() for f in stream[cut:]]
    for a, b in zip(from_copy, from_original, strict=True):
        np.testing.assert_array_equal(a, b)


log_lik = st.floats(allow_nan=True, allow_infinity=True)


@settings(max_examples=200, deadline=None)
@given(n_goals=st.integers(1, 5), data=st.data(), switch=st.floats(0.0, 1.0), shift=st.floats(-1e3, 1e3))
def test_bayes_update_is_a_distribution_and_ignores_a_likelihood_constant(n_goals, data, switch, shift):
    raw = np.array(data.draw(st.lists(st.floats(0.0, 1.0), min_size=2 * n_goals, max_size=2 * n_goals)))
    prior = raw.reshape(2, n_goals) + 1e-3
    prior /= prior.sum(axis=1, keepdims=True)
    ll = np.array(data.draw(st.lists(log_lik, min_size=2 * n_goals, max_size=2 * n_goals)))
    ll = ll.reshape(2, n_goals)
    active = np.array(data.draw(st.lists(st.booleans(), min_size=2, max_size=2)))
    with np.errstate(over="ignore", invalid="ignore"):
        post = bayes_update(prior, ll, switch, active)
    assert np.all(np.isfinite(post)) and np.all((post >= 0) & (post <= 1))
    np.testing.assert_allclose(post.sum(axis=1), 1.0, atol=1e-9)
    assert np.all(post > 0)
    keep = ~active | ~np.any(np.isfinite(ll), axis=1)  # inactive rows, rows without evidence
    np.testing.assert_array_equal(post[keep], prior[keep])
    moderate = np.where(np.isfinite(ll), np.clip(ll, -1e3, 1e3), ll)
    with np.errstate(over="ignore", invalid="ignore"):
        np.testing.assert_allclose(bayes_update(prior, moderate + shift, switch, active),
                                   bayes_update(prior, moderate, switch, active), rtol=1e-6, atol=1e-12)


probability_rows = st.lists(st.one_of(st.floats(0.0, 1.0), st.just(math.nan)), min_size=6, max_size=6)


@settings(max_examples=150, deadline=None)
@given(rows=st.lists(probability_rows, max_size=40), threshold=st.sampled_from([0.6, 0.8, 1.0]),
       release=st.sampled_from([0.0, 0.3, 0.5]), sequence=st.sampled_from([None, ("G3", "G1"), ("G2",)]),
       hands=st.sampled_from([HANDS, ("right",)]))
def test_feedback_machine_emits_only_crossings_and_rearms_below_release(rows, threshold, release, sequence,
                                                                         hands):
    names = ("G1", "G2", "G3")
    machine = FeedbackStateMachine(names, threshold=threshold, sequence=sequence, hands=hands,
                                   release=release)
    history = np.zeros((0, 2, 3))  # the probabilities of the earlier steps
    last_emit = np.full((2, 3), -1)  # step of each pair's last crossing of the threshold
    state = 0
    for row in rows:
        probs = np.array(row).reshape(2, 3)
        out = machine.step(probs)
        for hand, goal in out:
            assert hand in hands and probs[HANDS.index(hand), names.index(goal)] >= threshold
        if sequence is not None:  # Fig. 3.6: at most one, the goal the state waits for, in order
            state = max(state, 1)
            want = sequence[state - 1]
            assert len(out) <= 1 and all(goal == want for _, goal in out)
            crossed = any(probs[HANDS.index(h), names.index(want)] >= threshold for h in hands)
            assert bool(out) == crossed
            if out:
                state = state % len(sequence) + 1
            assert machine.state == state
        else:  # each (hand, goal) once per rise: again only after a step below `release`
            for r, c in np.ndindex(2, 3):
                p = probs[r, c]
                rearmed = last_emit[r, c] < 0 or any(
                    x < release for x in history[last_emit[r, c] + 1:, r, c])
                should = p >= threshold and rearmed
                assert ((HANDS[r], names[c]) in out) == (should and HANDS[r] in hands)
                if should:
                    last_emit[r, c] = len(history)
            assert len(set(out)) == len(out)
        history = np.concatenate([history, probs[None]])
