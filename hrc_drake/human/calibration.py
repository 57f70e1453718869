"""The operator's body as a cell would calibrate it online: from the first seconds of what the
camera sees of them, nothing later (issue 56: the real-data figures judge the pipeline as
deployed). The segment lengths are the medians over those frames; the hip height follows from the
shoulders' height (the body model's thorax, at shoulder height, lies one torso above the hip), so
a person seated at a table gets a low hip (`Segments.hip_height`) instead of a standing body
leaning its torso down to reach their shoulders.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from hrc_drake.human.config import HIP_HEIGHT_RANGE, Segments
from hrc_drake.messages import L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST

#: how long the calibration looks (s): the operator's first seconds in view
CALIBRATION_SECONDS = 2.0
#: a calibrated hip lower than this share of the standing body's is a seated person
SEATED_BELOW = 0.8


@dataclass(frozen=True)
class Calibration:
    """A calibrated body: its segments, the frames it was measured on, whether it sits, and which
    lengths fell back on the default (not seen in those frames)."""

    segments: Segments
    frames: int
    seated: bool
    defaulted: tuple[str, ...] = ()


def _median_length(points: np.ndarray, pairs) -> float:
    lengths = [np.linalg.norm(points[:, a] - points[:, b], axis=1) for a, b in pairs]
    joined = np.concatenate(lengths)
    joined = joined[np.isfinite(joined)]
    return float(np.median(joined)) if joined.size else math.nan


def calibrate_body(points, rate: float, seconds: float = CALIBRATION_SECONDS,
                   default: Segments | None = None) -> Calibration:
    """The body from the first `seconds` of `points` ((T, 8, 3) m, z up, NaN where untracked, at
    `rate` Hz): upper arm, forearm and shoulder width as medians over those frames (both sides),
    torso and neck the default's (the camera sees no hip), the hip one torso below the shoulders'
    median height. A length not seen in those frames keeps the default's (named in `defaulted`)."""
    default = default or Segments()
    points = np.asarray(points, dtype=float)
    if points.ndim != 3 or points.shape[1:] != (8, 3):
        raise ValueError(f"calibrate_body: points must be (T, 8, 3), got {points.shape}")
    if not (math.isfinite(rate) and rate > 0 and math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"calibrate_body: rate and seconds must be positive, got {rate}, {seconds}")
    first = points[: max(1, int(round(seconds * rate)))]
    measured = {
        "upper_arm": _median_length(first, [(L_SHOULDER, L_ELBOW), (R_SHOULDER, R_ELBOW)]),
        "forearm": _median_length(first, [(L_ELBOW, L_WRIST), (R_ELBOW, R_WRIST)]),
        "shoulder_width": _median_length(first, [(L_SHOULDER, R_SHOULDER)]),
    }
    defaulted = tuple(name for name, value in measured.items() if not math.isfinite(value) or value <= 0)
    lengths = {name: (getattr(default, name) if name in defaulted else value)
               for name, value in measured.items()}
    shoulders = first[:, [L_SHOULDER, R_SHOULDER], 2]
    shoulders = shoulders[np.isfinite(shoulders)]
    standing_hip = replace(default, hip_height=0.0)
    from hrc_drake.human.body import BodyModel  # numba kernels: imported when used

    standing = BodyModel(standing_hip).hip_height
    if shoulders.size:
        hip = float(np.clip(np.median(shoulders) - default.torso, *HIP_HEIGHT_RANGE))
    else:
        hip, defaulted = standing, (*defaulted, "hip_height")
    segments = replace(default, **lengths, hip_height=hip)
    return Calibration(segments, len(first), hip < SEATED_BELOW * standing, defaulted)


#: the points a fit is scored on: the arms a camera measures (a recording's thorax and head may be
#: synthesised from them)
ARM_POINTS = (L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST)


def fit_errors(body, points, scored=ARM_POINTS) -> np.ndarray:
    """Per frame, the rms distance (m) between the recorded `scored` points ((T, 8, 3), NaN
    untracked) and the body model's after its tracking IK on every point seen (warm-started at the
    previous frame, as the cell's predictor fits it); NaN for a frame with fewer than three points
    seen or none of `scored`."""
    from hrc_drake.motion.reactive import tracking_inverse

    points = np.asarray(points, dtype=float)
    scored = np.asarray(scored, dtype=int)
    out, q = np.full(len(points), np.nan), None
    for k, frame in enumerate(points):
        seen = np.all(np.isfinite(frame), axis=1)
        if seen.sum() < 3 or not seen[scored].any():
            continue
        q = tracking_inverse(body, frame, q)
        keep = scored[seen[scored]]
        out[k] = float(np.sqrt(np.mean(np.sum((body.points(q)[keep] - frame[keep]) ** 2, axis=1))))
    return out
