"""Table 3.1 and Fig. 3.9 figures from probability traces (thesis 3.1.3).

A reach (`dataset.reaches_of`) runs from the start of a hand's motion to its arrival at its goal.
False positive (for goal g), counted two ways, both as percentages of the reaches to g:
  rising edge (`rises`): the probability of g reached the threshold during a reach to another
    goal, having fallen below `release` since it last did (the re-arming of the feedback
    machine), so a belief that stays high from the previous reach and wobbles around the
    threshold is not a new rise; at most one per wrong goal and reach;
  crossing (`threshold_crossings`): every upward crossing of the threshold by g during a reach
    to another goal (below it at the previous sample, at or above it now), so a belief that
    oscillates around the threshold counts each time: the thesis' "number of times for which the
    probability of a certain goal has risen beyond the threshold" read literally.
True negative (the thesis' name for a missed goal): the hand went to g but the probability of g
never reached the threshold before arrival. Distance before recognition: path length of the true
wrist from the instant g is recognised to the arrival at g (Fig. 3.9).
"""

from __future__ import annotations

import numpy as np

from hrc_drake.intention.bayes import GoalIntentionEstimator
from hrc_drake.intention.dataset import Recording, reaches_of


def run_estimator(estimator: GoalIntentionEstimator, recording: Recording) -> np.ndarray:
    """Probabilities (T, 2, G) after each frame of the recording."""
    estimator.reset()
    out = np.empty((len(recording.times), 2, estimator.n_goals))
    for k, t in enumerate(recording.times):
        out[k] = estimator.update(t, recording.points[k], recording.gaze[k], bool(recording.gaze_valid[k]))
    return out


def likelihood_trace(estimator: GoalIntentionEstimator, recording: Recording):
    """log L (T, 2, G) and the hands with evidence (T, 2) of each frame (the likelihood half of
    `GoalIntentionEstimator.update`, with the estimator's own evidence weight w)."""
    estimator.reset()
    n = len(recording.times)
    log_lik = np.empty((n, 2, estimator.n_goals))
    active = np.empty((n, 2), dtype=bool)
    for k, t in enumerate(recording.times):
        log_lik[k], active[k] = estimator.log_likelihood(
            t, recording.points[k], recording.gaze[k], bool(recording.gaze_valid[k])
        )
    return log_lik, active


def replay_posteriors(estimator: GoalIntentionEstimator, times, log_likelihood, active, weight: float = 1.0):
    """Probabilities (T, 2, G) of eq. (3.2) over a likelihood trace, the likelihoods raised to `weight`.

    With a trace of w = 1 this equals `run_estimator` of an estimator of evidence_weight `weight`
    (L^w is w log L), at the cost of the Bayes step only; the switch and restart settings are
    the estimator's.
    """
    estimator.reset()
    out = np.empty(np.shape(log_likelihood))
    for k, t in enumerate(times):
        out[k] = estimator.posterior_step(t, weight * log_likelihood[k], active[k])
    return out


def threshold_crossings(probabilities: np.ndarray, threshold: float = 0.8) -> np.ndarray:
    """Upward crossings (T, ...) bool: p[k] >= threshold > p[k - 1]; before the first sample p is
    taken to be below the threshold (the uniform prior is).

    probabilities: (T, ...) along time.
    """
    p = np.asarray(probabilities, dtype=float)
    above = p >= threshold
    before = np.concatenate([np.zeros((1,) + p.shape[1:], dtype=bool), above[:-1]])
    return above & ~before


def rises(probabilities: np.ndarray, threshold: float = 0.8, release: float = 0.5) -> np.ndarray:
    """Rising edges (T, ...) bool: p reaches `threshold`, having been below `release` since it last did.

    probabilities: (T, ...) along time; the first sample rises if it is above the threshold.
    """
    probabilities = np.asarray(probabilities, dtype=float)
    armed = np.ones(probabilities.shape[1:], dtype=bool)
    out = np.zeros(probabilities.shape, dtype=bool)
    for k, p in enumerate(probabilities):
        out[k] = armed & (p >= threshold)
        armed = (armed & ~out[k]) | (p < release)
    return out


def reach_outcomes(
    recording: Recording, probabilities: np.ndarray, threshold: float = 0.8, release: float = 0.5
) -> list[dict]:
    """Per reach: hand, goal, recognised (bool), distance before recognition (m), the wrong goals
    that rose (`false_goals`, each once) and one entry per upward crossing of a wrong goal
    (`false_crossings`, repeated as often as it crossed)."""
    rising = rises(probabilities, threshold, release)  # (T, 2, G), over the whole recording
    crossing = threshold_crossings(probabilities, threshold)
    out = []
    for reach in reaches_of(recording):
        p = probabilities[reach.start : reach.arrival + 1, reach.hand]  # (n, G)
        hits = np.nonzero(p[:, reach.goal] >= threshold)[0]
        recognised = len(hits) > 0
        distance = np.nan
        if recognised:
            path = recording.true_wrists[reach.start + hits[0] : reach.arrival + 1, reach.hand]
            distance = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
        crossed = rising[reach.start : reach.arrival + 1, reach.hand]
        false_goals = sorted({int(g) for g in np.nonzero(crossed.any(axis=0))[0] if g != reach.goal})
        crossings = crossing[reach.start : reach.arrival + 1, reach.hand].sum(axis=0)  # (G,)
        false_crossings = [g for g in range(len(crossings)) if g != reach.goal for _ in range(crossings[g])]
        out.append(
            {
                "hand": reach.hand,
                "goal": reach.goal,
                "recognised": recognised,
                "distance": distance,
                "false_goals": false_goals,
                "false_crossings": false_crossings,
            }
        )
    return out


def table_3_1(outcomes: list[dict], goal: int) -> dict:
    """% false positives (rising edges and crossings) and % true negatives for `goal` (Table 3.1),
    and its recognition distances."""
    to_goal = [o for o in outcomes if o["goal"] == goal]
    n = len(to_goal)
    others = [o for o in outcomes if o["goal"] != goal]
    false_positives = sum(goal in o["false_goals"] for o in others)
    crossings = sum(o["false_crossings"].count(goal) for o in others)
    missed = sum(not o["recognised"] for o in to_goal)
    distances = np.array([o["distance"] for o in to_goal if o["recognised"]])
    return {
        "reaches": n,
        "false_positives_pct": 100.0 * false_positives / n if n else float("nan"),
        "false_positive_crossings_pct": 100.0 * crossings / n if n else float("nan"),
        "true_negatives_pct": 100.0 * missed / n if n else float("nan"),
        "distance_median": float(np.median(distances)) if len(distances) else float("nan"),
        "distances": distances,
    }


def errors_per_reach(outcomes: list[dict]) -> float:
    """False positives plus missed goals per reach, over all goals (the sum of Table 3.1's rows)."""
    if not outcomes:
        return float("nan")
    errors = sum(len(o["false_goals"]) + (not o["recognised"]) for o in outcomes)
    return errors / len(outcomes)


def choose_evidence_weight(model, recordings, weights=(1.0, 0.7, 0.5, 0.35, 0.25), methods=("M2", "M3")):
    """The exponent w of the likelihoods (L^w in eq. 3.2) with the fewest errors per reach.

    Errors (false positives + missed goals, `errors_per_reach`) are averaged over `methods` on
    `recordings` of validation operators (never the benchmark's); the grid `weights` is extended
    downwards until the minimum is bracketed (`bracketed_minimum`). Returns (w, {w: errors}).
    """
    from dataclasses import replace

    if not recordings:
        raise ValueError("choose_evidence_weight: no validation recordings")

    def error(weight):
        tempered = replace(model, evidence_weight=float(weight))
        per_method = []
        for method in methods:
            outcomes = []
            for k, recording in enumerate(recordings):
                estimator = GoalIntentionEstimator(recording.layout.centers, tempered, method, rng=k)
                outcomes.extend(reach_outcomes(recording, run_estimator(estimator, recording)))
            per_method.append(errors_per_reach(outcomes))
        return float(np.mean(per_method))

    best, scores, _ = bracketed_minimum(error, weights)
    return best, scores


def all_goals(outcomes: list[dict]) -> dict:
    """Table 3.1's figures pooled over every goal: false positives (rising edges, crossings) and
    missed goals as % of all reaches."""
    n = len(outcomes)
    if not n:
        nan = float("nan")
        return {"reaches": 0, "fp_pct": nan, "fp_crossings_pct": nan, "tn_pct": nan}
    return {
        "reaches": n,
        "fp_pct": 100.0 * sum(len(o["false_goals"]) for o in outcomes) / n,
        "fp_crossings_pct": 100.0 * sum(len(o["false_crossings"]) for o in outcomes) / n,
        "tn_pct": 100.0 * sum(not o["recognised"] for o in outcomes) / n,
    }


def bracketed_minimum(error, weights, shrink: float = 0.7, smallest: float = 0.01, upper: float = 1.0):
    """Minimise error(w) over a grid of w in (0, upper] extended until the minimum is bracketed.

    Starts from `weights`; while no grid value below the best w has a strictly larger error, adds
    shrink * (the smallest w) down to `smallest`. The best w is the one of least error, ties to
    the largest w (the least tempering). Returns (w, {w: error} by decreasing w, interior):
    interior is True when some grid w on each side of the best has a strictly larger error; a
    best w at `upper` (eq. 3.2 tempered as L^w needs w <= 1) or at the floor is not interior.
    """
    scores = {}
    grid = sorted({float(w) for w in weights if 0.0 < w <= upper}, reverse=True)
    if not grid:
        raise ValueError(f"bracketed_minimum: no weight in (0, {upper}] in {weights}")
    for w in grid:
        scores[w] = float(error(w))

    def best():
        return min(scores, key=lambda w: (scores[w], -w))

    while True:
        w_best = best()
        below = [w for w in scores if w < w_best]
        if any(scores[w] > scores[w_best] for w in below):
            break
        lowest = min(scores)
        if lowest * shrink < smallest:
            break
        w_new = round(lowest * shrink, 4)
        scores[w_new] = float(error(w_new))
    w_best = best()
    interior = any(scores[w] > scores[w_best] for w in scores if w < w_best) and any(
        scores[w] > scores[w_best] for w in scores if w > w_best
    )
    return w_best, dict(sorted(scores.items(), reverse=True)), interior
