"""Synthetic skeleton sequences for tests and benchmarks of the trackers (no Drake, no cell).

A standing operator (fixed thorax, head, shoulders) moves a wrist between goals along
minimum-jerk paths; the elbow follows by two-link inverse kinematics (elbow down). Positions
are (T, 8, 3) in the order of `messages.SKELETON_POINTS`.
"""

from __future__ import annotations

import numpy as np

from hrc_drake.messages import HEAD, L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST, THORAX


def minimum_jerk_path(p0, p1, s) -> np.ndarray:
    """Positions (len(s), 3) of the minimum-jerk path p0 -> p1 at normalized times s in [0, 1]."""
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    return np.asarray(p0, float) + blend[:, None] * (np.asarray(p1, float) - np.asarray(p0, float))


def elbow_from_wrist(shoulder, wrist, upper_arm: float, forearm: float, down=(0.0, 0.0, -1.0)) -> np.ndarray:
    """Elbow positions (..., 3) of a two-link arm reaching `wrist` (..., 3), elbow towards `down`."""
    shoulder = np.asarray(shoulder, dtype=float)
    wrist = np.asarray(wrist, dtype=float)
    offset = wrist - shoulder
    dist = np.linalg.norm(offset, axis=-1, keepdims=True)
    dist = np.clip(dist, abs(upper_arm - forearm) + 1e-6, upper_arm + forearm - 1e-9)
    axis = offset / np.maximum(np.linalg.norm(offset, axis=-1, keepdims=True), 1e-12)
    along = (upper_arm**2 - forearm**2 + dist**2) / (2 * dist)
    radius = np.sqrt(np.clip(upper_arm**2 - along**2, 0.0, None))
    down = np.broadcast_to(np.asarray(down, dtype=float), offset.shape)
    perp = down - np.sum(down * axis, axis=-1, keepdims=True) * axis
    perp /= np.maximum(np.linalg.norm(perp, axis=-1, keepdims=True), 1e-12)
    return shoulder + along * axis + radius * perp


def reaching_sequence(goals, durations, rate: float = 30.0, hand: str = "right", thorax=(1.0, 0.0, 1.4),
                      torso_dir=(1.0, 0.0, 0.0), shoulder_width: float = 0.4, neck: float = 0.25,
                      upper_arm: float = 0.3, forearm: float = 0.27, dwell: float = 0.5):
    """True skeleton (T, 8, 3) and times (T,) of a wrist visiting `goals` in order.

    goals: (G, 3) wrist targets, the first one is the start; durations: (G - 1,) move times (s);
    the wrist dwells `dwell` s at each goal. torso_dir: the direction the chest faces (the
    operator's left is z x torso_dir). The other arm hangs still.
    """
    goals = np.asarray(goals, dtype=float)
    if goals.ndim != 2 or goals.shape[1] != 3 or len(goals) < 2:
        raise ValueError(f"reaching_sequence: goals must be (G >= 2, 3), got {goals.shape}")
    if len(durations) != len(goals) - 1:
        raise ValueError("reaching_sequence: need one duration per move (len(goals) - 1)")
    dt = 1.0 / rate
    segments = []
    for g in range(len(goals) - 1):
        n_move = max(int(round(durations[g] / dt)), 1)
        segments.append(minimum_jerk_path(goals[g], goals[g + 1], np.arange(n_move) / n_move))
        segments.append(np.repeat(goals[g + 1][None], max(int(round(dwell / dt)), 1), axis=0))
    wrist = np.concatenate([np.repeat(goals[:1], max(int(round(dwell / dt)), 1), axis=0)] + segments)
    t_count = len(wrist)
    thorax = np.asarray(thorax, dtype=float)
    face = np.asarray(torso_dir, dtype=float) / np.linalg.norm(torso_dir)
    left_dir = np.cross([0.0, 0.0, 1.0], face)
    left_dir /= np.linalg.norm(left_dir)
    pts = np.empty((t_count, 8, 3))
    pts[:, THORAX] = thorax
    pts[:, HEAD] = thorax + [0.0, 0.0, neck]
    pts[:, L_SHOULDER] = thorax + 0.5 * shoulder_width * left_dir
    pts[:, R_SHOULDER] = thorax - 0.5 * shoulder_width * left_dir
    moving_shoulder, moving_elbow, moving_wrist = (
        (R_SHOULDER, R_ELBOW, R_WRIST) if hand == "right" else (L_SHOULDER, L_ELBOW, L_WRIST))
    still_shoulder, still_elbow, still_wrist = (
        (L_SHOULDER, L_ELBOW, L_WRIST) if hand == "right" else (R_SHOULDER, R_ELBOW, R_WRIST))
    pts[:, moving_wrist] = wrist
    # Elbow pointing down and slightly outwards, as a relaxed arm does.
    outward = -left_dir if hand == "right" else left_dir
    pts[:, moving_elbow] = elbow_from_wrist(pts[:, moving_shoulder], wrist, upper_arm, forearm,
                                            down=np.array([0.0, 0.0, -1.0]) + 0.5 * outward)
    pts[:, still_elbow] = pts[:, still_shoulder] + [0.0, 0.0, -upper_arm]
    pts[:, still_wrist] = pts[:, still_elbow] + forearm * (0.6 * face + [0.0, 0.0, -0.8])
    return np.arange(t_count) * dt, pts
