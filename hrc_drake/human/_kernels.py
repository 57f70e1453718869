"""Compiled kernels (numba) of `human.camera` and `human.body`: the analytic camera's visibility
test of every skeletal point (the view cone, then the slab test against the boxes, then the
sight segment against the capsules, Real-Time Collision Detection 5.1.9 as `motion.geometry`
states it) and the skeleton forward kinematics of `BodyModel` (thesis Fig. 8.2, Fig. 9.1). Their
numpy forms (`Camera.is_occluded`, `BodyModel._points_single`) are the reference the tests
compare against (tests/test_kernels.py). Compiled when first called, cached on disk
(`hrc_drake.kernels`, group "human").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hrc_drake import kernels
from hrc_drake.kernels import _EPS, _arrays, _segment_distance


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


@njit(cache=True, inline="always")
def _to_world(cy, sy, cl, sl, x, y, hz, px, py, pz, out, row):
    """out[row] = hip + R_z(yaw) R_y(lean) p, the torso-to-world map of `human.body`."""
    lx = cl * px + sl * pz
    out[row, 0] = x + cy * lx - sy * py
    out[row, 1] = y + sy * lx + cy * py
    out[row, 2] = hz + (-sl * px + cl * pz)  # in `_points_single`'s order: the same rounding


@njit(cache=True)
def _skeleton_points(dims, q, out):
    """The 8 skeletal points (Fig. 9.1 order) of `human.body.BodyModel` at q (12,) into out (8, 3),
    as `BodyModel._points_single` computes them; dims = (hip height, torso, neck, half shoulder
    width, upper arm, forearm)."""
    hz, torso, neck, half, upper, fore = dims[0], dims[1], dims[2], dims[3], dims[4], dims[5]
    x, y = q[0], q[1]
    cy, sy, cl, sl = math.cos(q[2]), math.sin(q[2]), math.cos(q[3]), math.sin(q[3])
    _to_world(cy, sy, cl, sl, x, y, hz, 0.0, 0.0, torso, out, 0)
    _to_world(cy, sy, cl, sl, x, y, hz, 0.0, 0.0, torso + neck, out, 1)
    _to_world(cy, sy, cl, sl, x, y, hz, 0.0, half, torso, out, 2)
    _to_world(cy, sy, cl, sl, x, y, hz, 0.0, -half, torso, out, 3)
    for arm in range(2):
        m = 1.0 - 2.0 * arm
        base = 4 + 4 * arm
        cf, sf = math.cos(q[base]), math.sin(q[base])
        ca, sa = math.cos(q[base + 1]), math.sin(q[base + 1])
        cr, sr = math.cos(q[base + 2]), math.sin(q[base + 2])
        ce, se = math.cos(q[base + 3]), math.sin(q[base + 3])
        msa = m * sa
        ux, uy, uz = sf * ca, msa, -cf * ca  # upper arm direction (torso frame)
        vx, vy, vz = cr * se, m * sr * se, -ce  # forearm direction in the upper-arm frame
        wy = ca * vy - msa * vz
        wz = msa * vy + ca * vz
        fx, fy, fz = cf * vx - sf * wz, wy, sf * vx + cf * wz
        ex, ey, ez = upper * ux, m * half + upper * uy, torso + upper * uz
        _to_world(cy, sy, cl, sl, x, y, hz, ex, ey, ez, out, 4 + arm)
        _to_world(cy, sy, cl, sl, x, y, hz, ex + fore * fx, ey + fore * fy, ez + fore * fz, out, 6 + arm)


def hidden_points(origin, axis, cos_limit: float, points, box_lower, box_upper, cap_start, cap_end,
                  cap_radius) -> np.ndarray:
    """(N,) True where the camera cannot see the point (see `_hidden_points`): origin, axis (3,),
    points (N, 3), boxes (B, 3) lower and upper corners, capsules (K, 3) ends and (K,) radii."""
    return _hidden_points(*_arrays(origin, axis), float(cos_limit),
                          *_arrays(points, box_lower, box_upper, cap_start, cap_end, cap_radius))


def skeleton_points(dims, q) -> np.ndarray:
    """The 8 skeletal points (8, 3) of the body with dims (see `_skeleton_points`) at q (12,)."""
    out = np.empty((8, 3))
    _skeleton_points(*_arrays(dims, q), out)
    return out


def _warm_up_steps() -> list:
    """Calls that compile (or load) every kernel here on tiny inputs, each on its own
    (`kernels.warm_up`)."""
    one = np.zeros((1, 3))
    return [lambda: hidden_points(np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.5, one + 1.0, one, one, one, one,
                                  np.ones(1)),
            lambda: skeleton_points(np.ones(6), np.zeros(12))]


kernels.register_group(globals(), kernels)
