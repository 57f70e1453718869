"""False-positive counting (rising edges vs crossings), the likelihood replay and the w sweep."""

import numpy as np
import pytest

from hrc_drake.intention.bayes import GoalIntentionEstimator
from hrc_drake.intention.dataset import GoalLayout, Recording, reaches_of
from hrc_drake.intention.evaluation import (
    all_goals,
    bracketed_minimum,
    likelihood_trace,
    reach_outcomes,
    replay_posteriors,
    rises,
    run_estimator,
    table_3_1,
    threshold_crossings,
)
from tests.intention.intention_reaches import GOALS, straight_reach


def test_threshold_crossings_count_every_upward_pass_and_rises_only_rearmed_ones():
    p = np.array([0.2, 0.85, 0.7, 0.9, 0.75, 0.85, 0.4, 0.81, 0.95, 0.1])
    assert np.nonzero(threshold_crossings(p, 0.8))[0].tolist() == [1, 3, 5, 7]
    # the rising edge needs a fall below the release 0.5 (at index 6) before it counts again
    assert np.nonzero(rises(p, 0.8, 0.5))[0].tolist() == [1, 7]
    # above the threshold from the first sample: one crossing there (the prior was below)
    assert threshold_crossings(np.array([0.9, 0.9, 0.7]), 0.8).tolist() == [True, False, False]


def _two_reach_recording():
    """Left wrist: goal 0 -> goal 1 in frames 0-19, then back to goal 0 in frames 20-39."""
    centers = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
    layout = GoalLayout("hand_made", ("A", "B"), centers, ("left", "left"))
    n = 40
    s = np.linspace(0.0, 1.0, 20)[:, None]
    wrists = np.zeros((n, 2, 3))
    wrists[:20, 0] = centers[0] + s * (centers[1] - centers[0])
    wrists[20:, 0] = centers[1] + s * (centers[0] - centers[1])
    wrists[:, 1] = [0.5, 0.5, 0.5]
    target = np.full((n, 2), -1)
    target[:20, 0], target[20:, 0] = 1, 0
    points = np.zeros((n, 8, 3))
    return Recording(np.arange(n) / 30.0, points, np.zeros((n, 3)), np.ones(n, bool), wrists, target, layout)


def test_reach_outcomes_count_edges_and_crossings_of_wrong_goals_on_hand_made_posteriors():
    recording = _two_reach_recording()
    assert [(r.goal, r.start, r.arrival) for r in reaches_of(recording)] == [(1, 0, 19), (0, 20, 39)]
    p_a = np.full(40, 0.5)
    # reach to B: A oscillates around 0.8 without falling below 0.5 -> 1 rising edge, 3 crossings
    p_a[3:12] = [0.85, 0.7, 0.9, 0.75, 0.85, 0.6, 0.55, 0.6, 0.5]
    p_a[12:20] = 0.1  # B = 0.9 from frame 12: recognised
    # reach to A: B stays high from the last reach (neither an edge nor a crossing), falls below
    # the release, crosses once more (an edge and a crossing), then A wins
    p_a[20:24] = 0.1
    p_a[24:27] = 0.6
    p_a[27:30] = 0.15
    p_a[30:] = 0.9
    probabilities = np.zeros((40, 2, 2))
    probabilities[:, 0, 0], probabilities[:, 0, 1] = p_a, 1.0 - p_a
    probabilities[:, 1] = 0.5
    outcomes = reach_outcomes(recording, probabilities)
    assert [o["false_goals"] for o in outcomes] == [[0], [1]]
    assert [o["false_crossings"] for o in outcomes] == [[0, 0, 0], [1]]
    assert all(o["recognised"] for o in outcomes)
    row_a = table_3_1(outcomes, 0)  # 1 reach to A; the reach to B raised A once, crossed it 3 times
    assert row_a["false_positives_pct"] == 100.0 and row_a["false_positive_crossings_pct"] == 300.0
    pooled = all_goals(outcomes)
    assert pooled["fp_pct"] == 100.0 and pooled["fp_crossings_pct"] == 200.0 and pooled["tn_pct"] == 0.0


@pytest.mark.parametrize("method", ["M2", "M3"])
def test_replaying_a_likelihood_trace_with_w_equals_the_estimator_of_that_w(small_model, method):
    times, points, gaze = straight_reach([0.9, 0.15, 0.9], GOALS[0], duration=1.0, noise=0.005, rng=3)
    layout = GoalLayout("reach", ("G1", "G2", "G3"), GOALS, ("right",) * 3)
    n = len(times)
    recording = Recording(times, points, gaze, np.ones(n, bool), np.zeros((n, 2, 3)), np.full((n, 2), -1),
                          layout)
    untempered = GoalIntentionEstimator(GOALS, small_model, method, evidence_weight=1.0)
    log_lik, active = likelihood_trace(untempered, recording)
    for w, switch in ((0.3, 0.02), (1.0, 0.0)):
        options = {"switch_probability": switch, "restart_switch": 0.5 if switch else 0.0}
        tempered = GoalIntentionEstimator(GOALS, small_model, method, evidence_weight=w, **options)
        direct = run_estimator(tempered, recording)
        replayed = replay_posteriors(GoalIntentionEstimator(GOALS, small_model, method, **options), times,
                                     log_lik, active, w)
        np.testing.assert_allclose(replayed, direct, rtol=0, atol=1e-12)


def test_bracketed_minimum_extends_the_grid_until_the_error_rises_below_the_best():
    calls = []

    def error(w):
        calls.append(w)
        return (np.log(w) - np.log(0.08)) ** 2

    w, scores, interior = bracketed_minimum(error, (1.0, 0.5, 0.25))
    assert interior and 0.05 < w < 0.12
    assert min(scores) < w < max(scores) and list(scores) == sorted(scores, reverse=True)
    assert scores[min(scores)] > scores[w]
    assert len(calls) == len(scores)  # each w evaluated once


def test_bracketed_minimum_reports_a_best_w_on_the_edge_and_breaks_ties_to_the_larger_w():
    w, _, interior = bracketed_minimum(lambda w: w, (1.0, 0.5), smallest=0.1)  # falls to the floor
    assert not interior and w < 0.15
    w, _, interior = bracketed_minimum(lambda w: -w, (1.0, 0.5))  # best at w = 1, the upper bound
    assert w == 1.0 and not interior
    w, scores, interior = bracketed_minimum(lambda w: 0.0 if 0.3 <= w <= 0.5 else 1.0, (1.0, 0.7, 0.5, 0.35))
    assert w == 0.5 and interior and min(scores) < 0.3
