"""Compiled kernels (numba) for the per-frame geometry that numpy runs as many calls on tiny arrays.

A camera frame tests 8 sight segments against a dozen boxes and robot capsules, the recorder
and the speed scaler take the clearance of ~15 x ~15 capsule pairs; in numpy each is 20-40 calls
of 1-5 us whatever the size (DESIGN.md, performance rules). The kernels below are the same
algorithms written as loops over the pairs: the slab test and Ericson's clamped closest points of
two segments (Real-Time Collision Detection, 5.1.9), as `human.camera` and `motion.geometry`
state them, whose numpy forms stay the reference the tests compare against.

Compiled on first use and cached on disk (`cache=True`: next to this file, or numba's user
cache when that is not writable); `warm_up()` compiles or loads every kernel, and
`tools/bench_cell.py` reports how long that takes, fresh and cached.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

_EPS = 1e-12


@njit(cache=True, inline="always")
def _closest_on_segments(a, b, c, e, f):
    """Closest-point parameters (s, t) of segments p1 + s d1, p2 + t d2 from a = d1.d1, b = d1.d2,
    c = d1.r, e = d2.d2, f = d2.r, r = p1 - p2 (Ericson 5.1.9; a zero-length segment is a point)."""
    if a <= _EPS and e <= _EPS:
        return 0.0, 0.0
    if a <= _EPS:
        return 0.0, min(max(f / e, 0.0), 1.0)
    if e <= _EPS:
        return min(max(-c / a, 0.0), 1.0), 0.0
    denom = a * e - b * b
    s = 0.0
    if denom > _EPS * max(a * e, _EPS):  # not parallel: else any s, take 0
        s = min(max((b * f - c * e) / denom, 0.0), 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        return min(max(-c / a, 0.0), 1.0), 0.0
    if t > 1.0:
        return min(max((b - c) / a, 0.0), 1.0), 1.0
    return s, t


@njit(cache=True, inline="always")
def _segment_distance(p, q, u, v):
    """Distance between segments p -> q and u -> v (each a (3,) array)."""
    d1x, d1y, d1z = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    d2x, d2y, d2z = v[0] - u[0], v[1] - u[1], v[2] - u[2]
    rx, ry, rz = p[0] - u[0], p[1] - u[1], p[2] - u[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    s, t = _closest_on_segments(a, b, c, e, f)
    gx = rx + s * d1x - t * d2x
    gy = ry + s * d1y - t * d2y
    gz = rz + s * d1z - t * d2z
    return math.sqrt(gx * gx + gy * gy + gz * gz)


@njit(cache=True)
def _segment_pair_distances(start_a, end_a, start_b, end_b):
    """(Ka, Kb) distances between every segment of set A (Ka, 3) and every one of set B (Kb, 3)."""
    out = np.empty((start_a.shape[0], start_b.shape[0]))
    for i in range(start_a.shape[0]):
        for j in range(start_b.shape[0]):
            out[i, j] = _segment_distance(start_a[i], end_a[i], start_b[j], end_b[j])
    return out


@njit(cache=True)
def _capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b):
    out = _segment_pair_distances(start_a, end_a, start_b, end_b)
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            out[i, j] -= radius_a[i] + radius_b[j]
    return out


@njit(cache=True, inline="always")
def _sight_hits_box(origin, point, lower, upper):
    """Slab test: does the segment origin -> point cross the box (the point on its surface does not)?"""
    t_enter, t_exit = -np.inf, np.inf
    for i in range(3):
        d = point[i] - origin[i]
        if d == 0.0:
            d = 1e-300  # parallel to the slab: (-huge, huge) inside it, empty outside
        t1 = (lower[i] - origin[i]) / d
        t2 = (upper[i] - origin[i]) / d
        t_enter = max(t_enter, min(t1, t2))
        t_exit = min(t_exit, max(t1, t2))
    return t_exit > max(t_enter, 0.0) and t_enter < 1.0 - 1e-9


@njit(cache=True)
def _hidden_points(origin, axis, cos_limit, points, box_lower, box_upper, cap_start, cap_end, cap_radius):
    """(N,) True where the camera at `origin` cannot see the point (Ch. 9 analytic camera): not
    finite, outside the view cone (cos to `axis` below cos_limit), behind a box (slab test), or its
    sight segment passes closer than a capsule's radius to the capsule's segment. For each point
    the tests run in that order and stop at the first that hides it; a capsule is first tested by
    its bounding sphere against the sight segment."""
    n = points.shape[0]
    hidden = np.zeros(n, dtype=np.bool_)
    k = cap_start.shape[0]
    centre = np.empty((k, 3))
    bound2 = np.empty(k)
    for j in range(k):
        half2 = 0.0
        for i in range(3):
            centre[j, i] = 0.5 * (cap_start[j, i] + cap_end[j, i])
            half2 += (cap_end[j, i] - cap_start[j, i]) ** 2
        bound2[j] = (0.5 * math.sqrt(half2) + cap_radius[j]) ** 2
    for p in range(n):
        point = points[p]
        rx, ry, rz = point[0] - origin[0], point[1] - origin[1], point[2] - origin[2]
        if not (math.isfinite(rx) and math.isfinite(ry) and math.isfinite(rz)):
            hidden[p] = True
            continue
        length2 = rx * rx + ry * ry + rz * rz
        cos = (rx * axis[0] + ry * axis[1] + rz * axis[2]) / max(math.sqrt(length2), _EPS)
        if not cos >= cos_limit:
            hidden[p] = True
            continue
        for b in range(box_lower.shape[0]):
            if _sight_hits_box(origin, point, box_lower[b], box_upper[b]):
                hidden[p] = True
                break
        if hidden[p]:
            continue
        for j in range(k):
            # nearest point of the sight segment to the capsule's centre, against its bounding sphere
            cx, cy, cz = centre[j, 0] - origin[0], centre[j, 1] - origin[1], centre[j, 2] - origin[2]
            along = rx * cx + ry * cy + rz * cz
            t = min(max(along / max(length2, _EPS), 0.0), 1.0)
            gap2 = cx * cx + cy * cy + cz * cz - 2.0 * t * along + t * t * length2
            if gap2 < bound2[j]:
                if _segment_distance(origin, point, cap_start[j], cap_end[j]) < cap_radius[j]:
                    hidden[p] = True
                    break
    return hidden


def _arrays(*arrays):
    """The arrays as writeable C-ordered float64 (copies only where needed): one compiled
    specialisation per kernel (numba compiles another for read-only or strided arrays)."""
    return tuple(
        a if type(a) is np.ndarray and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable
        else np.array(a, dtype=np.float64, order="C")
        for a in arrays
    )


def capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b) -> np.ndarray:
    """(Ka, Kb) clearance of every capsule pair of sets A and B: segment distance minus both radii."""
    return _capsule_clearances(*_arrays(start_a, end_a, radius_a, start_b, end_b, radius_b))


def hidden_points(origin, axis, cos_limit: float, points, box_lower, box_upper, cap_start, cap_end,
                  cap_radius) -> np.ndarray:
    """(N,) True where the camera cannot see the point (see `_hidden_points`): origin, axis (3,),
    points (N, 3), boxes (B, 3) lower and upper corners, capsules (K, 3) ends and (K,) radii."""
    return _hidden_points(*_arrays(origin, axis), float(cos_limit),
                          *_arrays(points, box_lower, box_upper, cap_start, cap_end, cap_radius))


def warm_up() -> float:
    """Compile (or load from the disk cache) every kernel; returns the seconds it took."""
    started = time.perf_counter()
    one = np.zeros((1, 3))
    capsule_clearances(one, one + 1.0, np.ones(1), one, one + 1.0, np.ones(1))
    hidden_points(np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.5, one + 1.0, one, one, one, one, np.ones(1))
    return time.perf_counter() - started
