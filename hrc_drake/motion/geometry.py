"""Vectorised distances between segments, capsules and points (no Drake).

A capsule is a segment [start, end] inflated by a radius. Everything broadcasts over leading
axes, so all robot-link x swept-volume pairs are one numpy expression.
"""

from __future__ import annotations

import numpy as np

from hrc_drake.kernels import capsule_clearances

_EPS = 1e-12


def _check_points(name: str, array) -> np.ndarray:
    array = np.asarray(array, dtype=float)
    if array.ndim < 1 or array.shape[-1] != 3:
        raise ValueError(f"{name}: expected an array of 3-d points (..., 3), got shape {array.shape}")
    if not np.isfinite(array).all():  # the method, not np.all: this check runs ~100 times a frame
        raise ValueError(f"{name}: contains NaN or inf")
    return array


def segment_segment_closest(p0, p1, q0, q1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest points of segments [p0, p1] and [q0, q1] (clamped least squares, Ericson 5.1.9).

    All inputs are (..., 3) and broadcast together. Returns (distance (...), s (...), t (...))
    with the closest points p0 + s (p1 - p0) and q0 + t (q1 - q0); degenerate (zero-length)
    segments are handled as points.
    """
    p0 = _check_points("p0", p0)
    p1 = _check_points("p1", p1)
    q0 = _check_points("q0", q0)
    q1 = _check_points("q1", q1)
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    b = np.einsum("...i,...i->...", d1, d2)
    c = np.einsum("...i,...i->...", d1, r)
    f = np.einsum("...i,...i->...", d2, r)
    a, b, c, e, f = np.broadcast_arrays(a, b, c, e, f)
    a_ok = a > _EPS
    e_ok = e > _EPS
    safe_a = np.where(a_ok, a, 1.0)
    safe_e = np.where(e_ok, e, 1.0)
    denom = a * e - b * b
    # Parallel segments (denom ~ 0): any s works; s = 0 then t is clamped below.
    skew = denom > _EPS * np.maximum(a * e, _EPS)
    s = np.where(skew, (b * f - c * e) / np.where(skew, denom, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    t = (b * s + f) / safe_e
    # Clamp t and recompute s for the clamped t.
    s_low = np.clip(-c / safe_a, 0.0, 1.0)
    s_high = np.clip((b - c) / safe_a, 0.0, 1.0)
    s = np.where(t < 0.0, s_low, np.where(t > 1.0, s_high, s))
    t = np.clip(t, 0.0, 1.0)
    # Degenerate cases: a point against a segment, or two points.
    s = np.where(a_ok & ~e_ok, np.clip(-c / safe_a, 0.0, 1.0), s)
    t = np.where(a_ok & ~e_ok, 0.0, t)
    t = np.where(~a_ok & e_ok, np.clip(f / safe_e, 0.0, 1.0), t)
    s = np.where(~a_ok, 0.0, s)
    t = np.where(~a_ok & ~e_ok, 0.0, t)
    closest_p = p0 + s[..., None] * d1
    closest_q = q0 + t[..., None] * d2
    distance = np.linalg.norm(closest_p - closest_q, axis=-1)
    return distance, s, t


def point_segment_distance(points, start, end) -> np.ndarray:
    """Distance of points (..., 3) to segments [start, end] (..., 3), broadcast together."""
    points = _check_points("points", points)
    start = _check_points("start", start)
    end = _check_points("end", end)
    direction = end - start
    length2 = np.einsum("...i,...i->...", direction, direction)
    u = np.einsum("...i,...i->...", points - start, direction) / np.where(length2 > _EPS, length2, 1.0)
    u = np.clip(np.where(length2 > _EPS, u, 0.0), 0.0, 1.0)
    return np.linalg.norm(points - (start + u[..., None] * direction), axis=-1)


def capsule_capsule_distance(start_a, end_a, radius_a, start_b, end_b, radius_b) -> np.ndarray:
    """Clearance between every capsule of set A (Ka) and every capsule of set B (Kb).

    start_a, end_a: (Ka, 3); radius_a: (Ka,); likewise for B. Returns (Ka, Kb): segment
    distance minus both radii (negative when the capsules overlap).
    """
    start_a = _check_points("start_a", start_a).reshape(-1, 3)
    end_a = _check_points("end_a", end_a).reshape(-1, 3)
    start_b = _check_points("start_b", start_b).reshape(-1, 3)
    end_b = _check_points("end_b", end_b).reshape(-1, 3)
    radius_a = np.asarray(radius_a, dtype=float).reshape(-1)
    radius_b = np.asarray(radius_b, dtype=float).reshape(-1)
    if not (len(start_a) == len(end_a) == len(radius_a)):
        raise ValueError(
            f"capsule set A: start {start_a.shape}, end {end_a.shape}, radius {radius_a.shape} disagree"
        )
    if not (len(start_b) == len(end_b) == len(radius_b)):
        raise ValueError(
            f"capsule set B: start {start_b.shape}, end {end_b.shape}, radius {radius_b.shape} disagree"
        )
    if (radius_a < 0).any() or (radius_b < 0).any():
        raise ValueError("capsule radii must be >= 0")
    # `segment_segment_closest` over all pairs as one compiled loop (equal to ~1e-15 m)
    return capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b)


def point_capsule_distance(points, start, end, radius) -> np.ndarray:
    """Signed distance of points (P, 3) to every capsule (K,): (P, K), negative inside."""
    points = _check_points("points", points).reshape(-1, 3)
    start = _check_points("start", start).reshape(-1, 3)
    end = _check_points("end", end).reshape(-1, 3)
    radius = np.asarray(radius, dtype=float).reshape(-1)
    if not (len(start) == len(end) == len(radius)):
        raise ValueError(f"capsules: start {start.shape}, end {end.shape}, radius {radius.shape} disagree")
    return point_segment_distance(points[:, None], start[None], end[None]) - radius[None, :]


def _fit_along_axis(centred, sq_norm, axis):
    """Tightest capsule around points (K, N, 3) (centred) whose segment lies on the given axis line.

    Returns (low (K,), high (K,), cover (K,)): the segment runs from low to high along the
    axis (through the centroid) and every point lies within `cover` of it.
    """
    along = np.einsum("kni,ki->kn", centred, axis)
    perpendicular2 = np.maximum(sq_norm - along**2, 0.0)
    cover = np.sqrt(perpendicular2.max(axis=1))
    slack = np.sqrt(np.maximum(cover[:, None] ** 2 - perpendicular2, 0.0))
    low = (along + slack).min(axis=1)
    high = (along - slack).max(axis=1)
    empty = low > high
    if np.any(empty):
        # The shortened segment is empty: the cloud fits a ball around the axis midpoint.
        middle = 0.5 * (low + high)
        ball = np.sqrt((sq_norm - 2.0 * middle[:, None] * along).max(axis=1) + middle**2)
        low = np.where(empty, middle, low)
        high = np.where(empty, middle, high)
        cover = np.where(empty, ball, cover)
    return low, high, cover


def bounding_capsules(starts, ends, radius, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One capsule per part bounding S sampled capsule instances of that part.

    starts, ends: (S, K, 3) segment end points of part k in sample s; radius: (K,) radii of
    the parts. Two axis lines through the centroid of the 2S end points are tried, the
    principal direction of the points and the mean segment direction; on each, the radius is
    the largest distance of an end point to the line and the segment is shortened as far as
    every end point stays within the radius; the smaller capsule (volume) is kept. The
    capsule is convex and holds every sampled end point, hence every sampled segment.
    Returns (start (K, 3), end (K, 3), radius (K,)) with radius = fit + part radius + margin.
    """
    starts = _check_points("starts", starts)
    ends = _check_points("ends", ends)
    if starts.ndim != 3 or starts.shape != ends.shape:
        raise ValueError(f"starts and ends must both be (S, K, 3); got {starts.shape} and {ends.shape}")
    radius = np.asarray(radius, dtype=float).reshape(-1)
    if radius.shape[0] != starts.shape[1]:
        raise ValueError(f"radius has {radius.shape[0]} entries for {starts.shape[1]} parts")
    cloud = np.concatenate([starts, ends], axis=0).transpose(1, 0, 2)  # (K, 2S, 3)
    centroid = cloud.mean(axis=1)
    centred = cloud - centroid[:, None]
    sq_norm = np.einsum("kni,kni->kn", centred, centred)
    scatter = np.swapaxes(centred, 1, 2) @ centred
    _, vectors = np.linalg.eigh(scatter)
    candidates = [vectors[:, :, -1]]
    mean_direction = (ends - starts).mean(axis=0)
    norm = np.linalg.norm(mean_direction, axis=1, keepdims=True)
    if np.all(norm > 1e-9):
        candidates.append(mean_direction / norm)
    best = None
    for axis in candidates:
        low, high, cover = _fit_along_axis(centred, sq_norm, axis)
        total = cover + radius + margin
        volume = np.pi * total**2 * (high - low) + 4.0 / 3.0 * np.pi * total**3
        if best is None:
            best = [axis, low, high, total, volume]
            continue
        better = volume < best[4]
        best = [np.where(better[:, None], axis, best[0]), np.where(better, low, best[1]),
                np.where(better, high, best[2]), np.where(better, total, best[3]),
                np.where(better, volume, best[4])]
    axis, low, high, total, _ = best
    return centroid + low[:, None] * axis, centroid + high[:, None] * axis, total
