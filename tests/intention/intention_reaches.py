"""Hand-made reaches for the intention tests (no operator, no Drake)."""

from __future__ import annotations

import numpy as np

from hrc_drake.intention.features import trajectory_velocities
from hrc_drake.messages import HEAD, L_WRIST, R_WRIST

GOALS = np.array([[0.6, -0.4, 0.8], [0.55, 0.0, 0.85], [0.6, 0.4, 0.8]])
RATE = 30.0


def straight_reach(start, goal, duration=0.9, rate=RATE, noise=0.0, rng=None, other_wrist=(0.9, 0.2, 0.9)):
    """A minimum-jerk right-wrist reach, the left wrist still, the head looking at the goal.

    Returns times (T,), points (T, 8, 3), gaze (T, 3).
    """
    rng = np.random.default_rng(rng)
    times = np.arange(0.0, duration + 1e-9, 1.0 / rate)
    s = np.clip(times / duration, 0.0, 1.0)[:, None]
    profile = s**3 * (10 - 15 * s + 6 * s**2)
    start = np.asarray(start, float)
    goal = np.asarray(goal, float)
    points = np.zeros((len(times), 8, 3))
    points[:] = np.array([1.0, 0.0, 1.3])
    points[:, HEAD] = [1.0, 0.0, 1.6]
    points[:, R_WRIST] = start + (goal - start) * profile
    points[:, L_WRIST] = other_wrist
    points = points + noise * rng.standard_normal(points.shape)
    gaze = goal - points[:, HEAD]
    gaze /= np.linalg.norm(gaze, axis=1, keepdims=True)
    return times, points, gaze


def reach_samples(n_reaches=60, seed=0):
    """Phi rows for the true goal of random straight reaches (the training recipe of 3.1.2)."""
    from hrc_drake.intention.features import skeleton_features

    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n_reaches):
        goal = GOALS[rng.integers(len(GOALS))] + rng.normal(0, 0.03, 3)
        start = np.array([0.85, 0.15, 0.9]) + rng.normal(0, 0.08, 3)
        times, points, gaze = straight_reach(start, goal, rng.uniform(0.7, 1.2), noise=0.005, rng=rng)
        wrists = points[:, [L_WRIST, R_WRIST]]
        velocity, moving = trajectory_velocities(times, wrists)
        phi = skeleton_features(points, velocity, moving, gaze, goal[None])  # (T, 2, 1, 1, 4)
        right = phi[:, 1, 0, 0]
        rows.append(right[moving[:, 1]])
    return np.concatenate(rows)
