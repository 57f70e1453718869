"""Table 3.1 and Fig. 3.9 figures from probability traces (thesis 3.1.3).

False positive (for goal g): the probability of g rose above the threshold while the hand was
going to another goal. True negative (the thesis' name for a missed goal): the hand went to g
but the probability of g never rose above the threshold before arrival. Both are percentages of
the number of reaches to g. A rise counts only if the probability had fallen below `release`
since it was last above the threshold (the re-arming of the feedback machine), so a belief
that stays high from the previous reach and wobbles around 0.8 is not a new rise. Distance
before recognition: path length of the true wrist from the instant g is recognised to the
arrival at g (Fig. 3.9).
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
    """Per reach: hand, goal, recognised (bool), distance before recognition (m), goals falsely risen."""
    rising = rises(probabilities, threshold, release)  # (T, 2, G), over the whole recording
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
        out.append(
            {
                "hand": reach.hand,
                "goal": reach.goal,
                "recognised": recognised,
                "distance": distance,
                "false_goals": false_goals,
            }
        )
    return out


def table_3_1(outcomes: list[dict], goal: int) -> dict:
    """% false positives and % true negatives for `goal` (Table 3.1), and its recognition distances."""
    to_goal = [o for o in outcomes if o["goal"] == goal]
    n = len(to_goal)
    false_positives = sum(goal in o["false_goals"] for o in outcomes if o["goal"] != goal)
    missed = sum(not o["recognised"] for o in to_goal)
    distances = np.array([o["distance"] for o in to_goal if o["recognised"]])
    return {
        "reaches": n,
        "false_positives_pct": 100.0 * false_positives / n if n else float("nan"),
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
    `recordings` of validation operators (never the benchmark's). Returns (w, {w: errors}).
    """
    from dataclasses import replace

    if not recordings:
        raise ValueError("choose_evidence_weight: no validation recordings")
    scores = {}
    for weight in weights:
        tempered = replace(model, evidence_weight=float(weight))
        per_method = []
        for method in methods:
            outcomes = []
            for k, recording in enumerate(recordings):
                estimator = GoalIntentionEstimator(recording.layout.centers, tempered, method, rng=k)
                outcomes.extend(reach_outcomes(recording, run_estimator(estimator, recording)))
            per_method.append(errors_per_reach(outcomes))
        scores[float(weight)] = float(np.mean(per_method))
    best = min(scores, key=lambda w: (scores[w], -w))
    return best, scores
