"""Compiled kernels (numba) for the per-frame geometry and the per-step models that numpy runs as
many calls on tiny arrays.

A camera frame tests 8 sight segments against a dozen boxes and robot capsules, the recorder
and the speed scaler take the clearance of ~15 x ~15 capsule pairs, the human motion predictor
(thesis 8.1) solves a 12-joint IK, rolls out T x M GP predictions and bounds six swept point
sets by capsules at every camera frame; in numpy each is 20-40 calls of 1-5 us whatever the
size (DESIGN.md, performance rules). The kernels below are the same algorithms written as loops:
the slab test and Ericson's clamped closest points of two segments (Real-Time Collision
Detection, 5.1.9) as `human.camera` and `motion.geometry` state them; the skeleton forward
kinematics of `human.body`, its forward-difference Jacobian and the damped Gauss-Newton steps of
`motion.reactive.tracking_inverse`; the Monte Carlo rollouts of eq. (8.8) on the GP of (8.7);
the RTS smoothed means of (8.6); the closest points of the safety controller's robot-body pairs;
`motion.reactive._bounding_capsule`; one lockstep step of
the Monte Carlo scheduler's trials (Algorithm 4, `scheduling.montecarlo`); the intention
estimator's wrist velocity window, the features and GMM densities of eq. (3.12) and its Bayes
step (3.2); the Kalman time and measurement updates of the trackers, the particle filter's
gate, posterior samples and cloud summaries (Ch. 9); and one level of the waiting-time tree
(Algorithm 1, a direct convolution). Their numpy forms stay the reference the tests compare
against (tests/test_kernels.py, tests/scheduling/test_scheduler.py,
tests/prediction/test_waiting.py, tests/perception/test_particle_filter.py).

Compiled on first use and cached on disk (`cache=True`: next to this file, or numba's user
cache when that is not writable); `warm_up()` compiles or loads every kernel, and
`tools/bench_cell.py` reports how long that takes, fresh and cached. Small products and
reductions are written as loops: numba's ndarray.min/max, np.linalg.solve and slice
assignments each take it a second or more to compile.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
from numba import njit

_EPS = 1e-12
_FLOAT64 = np.dtype(np.float64)


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


@njit(cache=True)
def _pair_closest_parameters(start_a, end_a, start_b, end_b, index_a, index_b):
    """(N, 2) closest-point parameters (s, t) of the segment pairs (index_a[n], index_b[n]) of sets
    A and B: the points start + s (end - start) of each (`_closest_on_segments`)."""
    out = np.empty((index_a.shape[0], 2))
    for n in range(index_a.shape[0]):
        i, j = index_a[n], index_b[n]
        d1x, d1y, d1z = end_a[i, 0] - start_a[i, 0], end_a[i, 1] - start_a[i, 1], end_a[i, 2] - start_a[i, 2]
        d2x, d2y, d2z = end_b[j, 0] - start_b[j, 0], end_b[j, 1] - start_b[j, 1], end_b[j, 2] - start_b[j, 2]
        rx, ry, rz = (start_a[i, 0] - start_b[j, 0], start_a[i, 1] - start_b[j, 1],
                      start_a[i, 2] - start_b[j, 2])
        s, t = _closest_on_segments(d1x * d1x + d1y * d1y + d1z * d1z, d1x * d2x + d1y * d2y + d1z * d2z,
                                    d1x * rx + d1y * ry + d1z * rz, d2x * d2x + d2y * d2y + d2z * d2z,
                                    d2x * rx + d2y * ry + d2z * rz)
        out[n, 0], out[n, 1] = s, t
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


@njit(cache=True)
def _skeleton_jacobian(dims, q, rows, step, model, jacobian):
    """The points `rows` at q stacked (3V,) into model and their forward-difference Jacobian
    (3V, 12) with step `step` into jacobian."""
    base = np.empty((8, 3))
    shifted = np.empty((8, 3))
    _skeleton_points(dims, q, base)
    for i in range(rows.shape[0]):
        for c in range(3):
            model[3 * i + c] = base[rows[i], c]
    moved = q.copy()
    for j in range(12):
        moved[j] = q[j] + step
        _skeleton_points(dims, moved, shifted)
        moved[j] = q[j]
        for i in range(rows.shape[0]):
            for c in range(3):
                jacobian[3 * i + c, j] = (shifted[rows[i], c] - base[rows[i], c]) / step


@njit(cache=True)
def _solve_pivoting(matrix, rhs):
    """matrix^-1 rhs (S x S by S x R) by Gaussian elimination with partial pivoting, as LAPACK's
    getrf/getrs order it (written out: numba's np.linalg.solve takes seconds to compile)."""
    size = matrix.shape[0]
    a = matrix.copy()
    b = rhs.copy()
    for col in range(size):
        pivot = col
        for row in range(col + 1, size):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if pivot != col:
            for c in range(size):
                a[col, c], a[pivot, c] = a[pivot, c], a[col, c]
            for c in range(b.shape[1]):
                b[col, c], b[pivot, c] = b[pivot, c], b[col, c]
        for row in range(col + 1, size):
            factor = a[row, col] / a[col, col]
            for c in range(col + 1, size):
                a[row, c] -= factor * a[col, c]
            for c in range(b.shape[1]):
                b[row, c] -= factor * b[col, c]
    for row in range(size - 1, -1, -1):
        for c in range(b.shape[1]):
            total = b[row, c]
            for k in range(row + 1, size):
                total -= a[row, k] * b[k, c]
            b[row, c] = total / a[row, row]
    return b


@njit(cache=True)
def _tracking_gauss_newton(dims, q_lower, q_upper, target, rows, q0, iterations, regularization, step):
    """Damped Gauss-Newton on sum ||FK_i(q) - p_i||^2 + r^2 ||q - q0||^2 over the points `rows`
    (target (3V,)), clipped to the joint limits after each step; returns q and the rms point
    residual sqrt(3 mean(residual^2)) at it."""
    n = 3 * rows.shape[0]
    model = np.empty(n)
    jacobian = np.empty((n, 12))
    damping = regularization * regularization
    gradient = np.empty(12)
    normal = np.empty((12, 12))
    q = q0.copy()
    for _ in range(iterations):
        _skeleton_jacobian(dims, q, rows, step, model, jacobian)
        for a in range(12):
            gradient[a] = -damping * (q[a] - q0[a])
            for r in range(n):
                gradient[a] += jacobian[r, a] * (target[r] - model[r])
            for b in range(a + 1):
                total = 0.0
                for r in range(n):
                    total += jacobian[r, a] * jacobian[r, b]
                normal[a, b] = total
                normal[b, a] = total
            normal[a, a] += damping
        step_q = _solve_pivoting(normal, gradient.reshape((12, 1)))[:, 0]
        for a in range(12):
            q[a] = min(max(q[a] + step_q[a], q_lower[a]), q_upper[a])
    final = np.empty((8, 3))
    _skeleton_points(dims, q, final)
    square = 0.0
    for i in range(rows.shape[0]):
        for c in range(3):
            square += (final[rows[i], c] - target[3 * i + c]) ** 2
    return q, math.sqrt(square / n * 3.0)


@njit(cache=True)
def _bounding_capsule(points, offsets, stride):
    """`motion.reactive._bounding_capsule` (its numpy form, the reference) as loops: one capsule
    around points (3, N) translated by every corner of offsets (C, 3); (start (3,), end (3,), radius)."""
    n = points.shape[1]
    mean = np.zeros(3)
    for p in range(n):
        for c in range(3):
            mean[c] += points[c, p]
    mean /= n
    scatter = np.zeros((3, 3))
    for p in range(n):
        for a in range(3):
            for b in range(a + 1):
                scatter[a, b] += (points[a, p] - mean[a]) * (points[b, p] - mean[b])
    for a in range(3):
        for b in range(a):
            scatter[b, a] = scatter[a, b]
    _, vectors = np.linalg.eigh(scatter)  # columns: principal directions
    rel = np.zeros((3, n))  # the points in those directions (small products written out: no BLAS)
    for c in range(3):
        for p in range(n):
            for a in range(3):
                rel[c, p] += vectors[a, c] * (points[a, p] - mean[a])
    middle = np.empty(3)
    for c in range(3):
        low, high = rel[c, 0], rel[c, 0]
        for p in range(1, n):  # loops: numba's ndarray.min/max take seconds to compile
            low, high = min(low, rel[c, p]), max(high, rel[c, p])
        middle[c] = 0.5 * (high + low)
        for p in range(n):
            rel[c, p] -= middle[c]
    # the axis: the direction whose capsule around every `stride`-th point is smallest
    best, best_k = np.inf, 0
    for k in range(3):
        cover2 = 0.0
        for p in range(0, n, stride):
            total = rel[0, p] ** 2 + rel[1, p] ** 2 + rel[2, p] ** 2
            cover2 = max(cover2, total - rel[k, p] ** 2)
        top, bottom = -np.inf, np.inf
        for p in range(0, n, stride):
            total = rel[0, p] ** 2 + rel[1, p] ** 2 + rel[2, p] ** 2
            slack = math.sqrt(max(cover2 - (total - rel[k, p] ** 2), 0.0))
            top = max(top, rel[k, p] - slack)
            bottom = min(bottom, rel[k, p] + slack)
        volume = cover2 * max(top - bottom, 0.0) + 4.0 / 3.0 * cover2**1.5
        if volume < best:
            best, best_k = volume, k
    k = best_k
    i, j = (1, 2) if k == 0 else ((0, 2) if k == 1 else (0, 1))
    corners = offsets.shape[0]
    shift = np.zeros((corners, 3))
    for c in range(corners):
        for d in range(3):
            for a in range(3):
                shift[c, d] += offsets[c, a] * vectors[a, d]
    radius2 = 0.0
    for c in range(corners):
        for p in range(n):
            radius2 = max(radius2, (rel[i, p] + shift[c, i]) ** 2 + (rel[j, p] + shift[c, j]) ** 2)
    low, high = np.inf, -np.inf
    for c in range(corners):
        for p in range(n):
            across2 = (rel[i, p] + shift[c, i]) ** 2 + (rel[j, p] + shift[c, j]) ** 2
            slack = math.sqrt(max(radius2 - across2, 0.0))
            along = rel[k, p] + shift[c, k]
            low = min(low, along + slack)
            high = max(high, along - slack)
    radius = math.sqrt(radius2)
    if low > high:  # rounding: the points fit a ball around the middle of the axis
        low = high = 0.5 * (low + high)
        far2 = 0.0
        for c in range(corners):
            for p in range(n):
                along = rel[k, p] + shift[c, k]
                across2 = (rel[i, p] + shift[c, i]) ** 2 + (rel[j, p] + shift[c, j]) ** 2
                far2 = max(far2, (along - low) ** 2 + across2)
        radius = math.sqrt(far2)
    base = mean.copy()
    for a in range(3):
        for d in range(3):
            base[a] += vectors[a, d] * middle[d]
    return base + low * vectors[:, k], base + high * vectors[:, k], radius


@njit(cache=True)
def _gp_step(state, x_train, x_train_sq, alpha, k_inv, theta, x_mean, x_std):
    """Predictive mean (T, d_out) and variance (T,) (E.6) of the standardised outputs of one
    group's GP for the states (T, P, d_out), newest last: the input is phi_{k-1}, ..., phi_{k-P}
    standardised, the kernel is (8.7) without its white-noise term."""
    trials, order, width = state.shape
    d_in = order * width
    xs = np.empty((trials, d_in))
    xs_sq = np.zeros(trials)
    for t in range(trials):
        for p in range(order):
            for c in range(width):
                f = p * width + c
                value = (state[t, order - 1 - p, c] - x_mean[f]) / x_std[f]
                xs[t, f] = value
                xs_sq[t] += value * value
    k_x = xs @ x_train.T  # (T, N) dot products, then (8.7) in place
    scale = -0.5 * theta[1]
    for t in range(trials):
        for n in range(k_x.shape[1]):
            dot = k_x[t, n]
            sq = max(xs_sq[t] + x_train_sq[n] - 2.0 * dot, 0.0)
            k_x[t, n] = theta[0] * dot + theta[2] * math.exp(scale * sq)
    mean = k_x @ alpha
    weighted = k_x @ k_inv
    var = np.empty(trials)
    for t in range(trials):
        explained = 0.0
        for n in range(k_x.shape[1]):
            explained += weighted[t, n] * k_x[t, n]
        var[t] = max(theta[0] * xs_sq[t] + theta[2] + theta[3] - explained, 0.0)
    return mean, var


@njit(cache=True)
def _gp_rollouts(history, noise, x_train, x_train_sq, alpha, k_inv, theta, x_mean, x_std, y_mean, y_std):
    """Monte Carlo rollouts of eq. (8.8) for the groups of one GP bucket: history (G, P, d_out)
    the shared past states, newest last; noise (M, G, T, d_out) standard normal draws; returns the
    sampled states (M, G, T, d_out). The first step's prediction is made once (every trial has
    the same past), as `GPMotionModel._rollouts_numpy` does."""
    steps, groups, trials, width = noise.shape
    order = history.shape[1]
    out = np.empty((steps, groups, trials, width))
    # element loops rather than slice assignments: each of those costs numba a compilation
    for g in range(groups):
        state = np.empty((trials, order, width))
        for t in range(trials):
            for p in range(order):
                for c in range(width):
                    state[t, p, c] = history[g, p, c]
        for step in range(steps):
            rows = 1 if step == 0 else trials  # every trial starts from the same past: one prediction
            mean, var = _gp_step(state[:rows], x_train[g], x_train_sq[g], alpha[g], k_inv[g], theta[g],
                                 x_mean[g], x_std[g])
            for t in range(trials):
                row = t if rows > 1 else 0
                spread = math.sqrt(var[row])
                for p in range(order - 1):
                    for c in range(width):
                        state[t, p, c] = state[t, p + 1, c]
                for c in range(width):
                    value = (mean[row, c] + spread * noise[step, g, t, c]) * y_std[g, c] + y_mean[g, c]
                    state[t, order - 1, c] = value
                    out[step, g, t, c] = value
    return out


@njit(cache=True)
def _trial_step(m, arcs, fired, unc, controllable, is_wait_end, pools, count, fire_at, en_prev, t,
                alive, keys, group, key_bonus, horizon, now, quantum, dt, chosen, column):
    """One lockstep step of `scheduling.montecarlo.simulate_trials` (the trials of Algorithm 4)
    for every trial n, in place: fire fired[n] (when >= 0) chosen by the previous step, enable
    (eq. 6.1), clock the newly enabled uncontrollable transitions from the delay pools (a robot's
    wait ends on the next t_w tick), then choose the next firing (the enabled controllable one
    with the largest key, unless an uncontrollable clock is due now; else the earliest clock) and
    advance the time to it, at most to the horizon. Writes dt, chosen and column (chosen, or -1
    once the trial has reached the horizon); returns whether any trial is still running.
    arcs: the net's arcs by transition (`petri_arcs`): only the places a transition touches are read."""
    pre_start, pre_place, pre_weight, inc_start, inc_place, inc_delta = arcs
    n_trials = m.shape[0]
    n_tr = pre_start.shape[0] - 1
    depth = pools.shape[2]
    any_alive = False
    for n in range(n_trials):
        j = fired[n]
        if j >= 0:  # finished trials fire too: what happens to them is never read
            for a in range(inc_start[j], inc_start[j + 1]):
                m[n, inc_place[a]] += inc_delta[a]
            fire_at[n, j] = np.inf
            en_prev[n, j] = False
        j_unc, t_unc = 0, np.inf
        j_ctrl, best_key, any_ctrl = 0, -np.inf, False
        for j in range(n_tr):
            enabled = True
            for a in range(pre_start[j], pre_start[j + 1]):
                if pre_weight[a] > m[n, pre_place[a]]:
                    enabled = False
                    break
            if enabled and unc[j] and not en_prev[n, j]:
                delay = pools[n, j, count[n, j] % depth]
                if quantum > 0 and is_wait_end[j]:
                    delay = quantum - (now + t[n]) % quantum
                    if delay < 1e-9 * quantum:
                        delay = quantum
                fire_at[n, j] = t[n] + delay
                count[n, j] += 1
            if not enabled:
                fire_at[n, j] = np.inf
            en_prev[n, j] = enabled and unc[j]
            if fire_at[n, j] < t_unc:  # the first earliest clock, as np.argmin
                j_unc, t_unc = j, fire_at[n, j]
            key = -1.0
            if enabled and controllable[j]:
                any_ctrl = True
                key = keys[group[n], j] + key_bonus[j]
            if key > best_key:  # the first largest key, as np.argmax
                j_ctrl, best_key = j, key
        # events due now fire first, so robots freed at the same instant decide together
        has_ctrl = any_ctrl and alive[n] and t_unc > t[n]
        advance = alive[n] and not has_ctrl
        t_next = min(t_unc, horizon) if advance else t[n]
        dt[n] = t_next - t[n]
        t[n] = t_next
        alive[n] = alive[n] and not (advance and t_unc > horizon)
        any_alive = any_alive or alive[n]
        chosen[n] = j_ctrl if has_ctrl else j_unc
        column[n] = chosen[n] if alive[n] else -1
    return any_alive


@njit(cache=True, inline="always")
def _propagate_covariance(a, w, p, a_p, out):
    """The Kalman time update of a covariance: a_p = A P, out = a_p A^T + W (out may be p itself:
    a_p is complete before out is written)."""
    size = a.shape[0]
    for i in range(size):
        for j in range(size):
            total = 0.0
            for m in range(size):
                total += a[i, m] * p[m, j]
            a_p[i, j] = total
    for i in range(size):
        for j in range(size):
            total = 0.0
            for m in range(size):
                total += a_p[i, m] * a[j, m]
            out[i, j] = total + w[i, j]


@njit(cache=True)
def _rts_means(a, w, means, covs):
    """Smoothed means phi_{k|K} (K, T, S) of the Rauch-Tung-Striebel smoother, eq. (8.6), from the
    filtered means (K, T, S) and covariances (K, T, S, S) of T tracks sharing the chain (A, W):
    J_k = V_{k|k} A^T V_{k+1|k}^-1, phi_{k|K} = phi_{k|k} + J_k (phi_{k+1|K} - A phi_{k|k}). The
    gains need only the filtered covariances, so the smoothed ones are not formed."""
    steps, tracks, size = means.shape
    smoothed = means.copy()
    a_p = np.empty((size, size))  # A V_k|k
    p_pred = np.empty((size, size))  # V_k+1|k = A V_k|k A^T + W
    for k in range(steps - 2, -1, -1):
        for t in range(tracks):
            _propagate_covariance(a, w, covs[k, t], a_p, p_pred)
            gain_t = _solve_pivoting(p_pred, a_p)  # J^T = V_{k+1|k}^-1 A V_k|k (both symmetric)
            for i in range(size):
                innovation = 0.0
                for j in range(size):
                    x_pred = 0.0
                    for m in range(size):
                        x_pred += a[j, m] * means[k, t, m]
                    innovation += gain_t[j, i] * (smoothed[k + 1, t, j] - x_pred)
                smoothed[k, t, i] = means[k, t, i] + innovation
    return smoothed


@njit(cache=True)
def _window_velocity(times, positions, min_speed, min_samples, significance, velocity, moving):
    """`intention.features.least_squares_velocity` of one window: times (K,), positions (K, P, 3)
    (NaN rows skipped); writes velocity (P, 3) and moving (P,)."""
    n_samples, n_points = positions.shape[0], positions.shape[1]
    for p in range(n_points):
        count, t_sum = 0.0, 0.0
        x_sum = np.zeros(3)
        valid = np.zeros(n_samples, dtype=np.bool_)
        for k in range(n_samples):
            x0, x1, x2 = positions[k, p, 0], positions[k, p, 1], positions[k, p, 2]
            if math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2):
                valid[k] = True
                count += 1.0
                t_sum += times[k]
                x_sum[0] += x0
                x_sum[1] += x1
                x_sum[2] += x2
        safe_count = max(count, 1.0)
        t_mean = t_sum / safe_count
        sxx, total = 0.0, 0.0
        sxy = np.zeros(3)
        for k in range(n_samples):
            if valid[k]:
                dt = times[k] - t_mean
                sxx += dt * dt
                for c in range(3):
                    centred = positions[k, p, c] - x_sum[c] / safe_count
                    sxy[c] += dt * centred
                    total += centred * centred
        known = count >= max(2, min_samples) and sxx > 1e-12
        safe_sxx = sxx if known else 1.0
        speed2 = 0.0
        for c in range(3):
            velocity[p, c] = sxy[c] / safe_sxx if known else 0.0
            speed2 += velocity[p, c] * velocity[p, c]
        is_moving = known and speed2 >= min_speed * min_speed
        if significance > 0:
            residual = max(total - speed2 * safe_sxx, 0.0)
            dof = max(3.0 * (count - 2.0), 1.0)
            is_moving = is_moving and speed2 * safe_sxx * dof >= significance * significance * residual
        moving[p] = is_moving


@njit(cache=True, inline="always")
def _angle(u0, u1, u2, v0, v1, v2):
    """`intention.features.angle_between` of two vectors: atan2(|u x v|, u.v)."""
    c0 = u1 * v2 - u2 * v1
    c1 = u2 * v0 - u0 * v2
    c2 = u0 * v1 - u1 * v0
    return math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), u0 * v0 + u1 * v1 + u2 * v2)


@njit(cache=True, inline="always")
def _shifted_exp_sum(values):
    """(top, sum of exp(v - top)) over values, top the largest one (0 when that is not finite):
    the two parts of a stable log-sum-exp."""
    top = -np.inf
    for v in values:
        if v > top:
            top = v
    if not math.isfinite(top):
        top = 0.0
    total = 0.0
    for v in values:
        total += math.exp(v - top)
    return top, total


@njit(cache=True)
def _gmm_log_density(x, precision_chol, mean_proj, log_norm):
    """`intention.likelihood.GaussianMixtureDensity.log_density` of one sample x (D,)."""
    n_components, d = mean_proj.shape
    log_comp = np.empty(n_components)
    for k in range(n_components):
        quadratic = 0.0
        for e in range(d):
            y = -mean_proj[k, e]
            for i in range(d):
                y += x[i] * precision_chol[k, i, e]
            quadratic += y * y
        log_comp[k] = log_norm[k] - 0.5 * quadratic
    top, total = _shifted_exp_sum(log_comp)
    return top + math.log(total)


@njit(cache=True)
def _goal_log_likelihoods(wrists, velocity, moving, head, gaze, centers, columns, precision_chol, mean_proj,
                          log_norm, neutral, at_goal):
    """log L (2, G) of eq. (3.12): for each hand and goal, log of the mean over the Np sampled
    centres (G, Np, 3) of the GMM density of Phi (`intention.features.goal_features`) restricted
    to `columns` (all four for GMM4d, Psi's for GMM2d)."""
    n_goals, n_samples = centers.shape[0], centers.shape[1]
    out = np.empty((2, n_goals))
    wrist_angle = np.empty(2)
    distance = np.empty(2)
    phi = np.empty(4)
    x = np.empty(columns.shape[0])
    per_sample = np.empty(n_samples)
    for g in range(n_goals):
        for h in range(2):
            for n in range(n_samples):
                for w in range(2):
                    t0 = centers[g, n, 0] - wrists[w, 0]
                    t1 = centers[g, n, 1] - wrists[w, 1]
                    t2 = centers[g, n, 2] - wrists[w, 2]
                    distance[w] = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
                    angle = _angle(velocity[w, 0], velocity[w, 1], velocity[w, 2], t0, t1, t2)
                    if distance[w] < at_goal:
                        angle = 0.0
                    wrist_angle[w] = angle if moving[w] else neutral
                head_angle = _angle(gaze[0], gaze[1], gaze[2], centers[g, n, 0] - head[0],
                                    centers[g, n, 1] - head[1], centers[g, n, 2] - head[2])
                if not math.isfinite(head_angle):
                    head_angle = neutral
                phi[0], phi[1], phi[2], phi[3] = wrist_angle[h], wrist_angle[1 - h], head_angle, distance[h]
                for c in range(columns.shape[0]):
                    x[c] = phi[columns[c]]
                per_sample[n] = _gmm_log_density(x, precision_chol, mean_proj, log_norm)
            top, total = _shifted_exp_sum(per_sample)
            out[h, g] = top + math.log(total / n_samples)
    return out


@njit(cache=True)
def _kalman_predict(x, p, a, w, steps):
    """`perception.kalman.KalmanFilter.predict`: x <- A x, P <- (A P) A^T + W of every track,
    `steps` times; returns new arrays (x (T, S), P (T, S, S))."""
    n_tracks, size = x.shape
    x = x.copy()
    p = p.copy()
    state = np.empty(size)
    ap = np.empty((size, size))
    for _ in range(steps):
        for t in range(n_tracks):
            for i in range(size):
                total = 0.0
                for j in range(size):
                    total += x[t, j] * a[i, j]
                state[i] = total
            for i in range(size):
                x[t, i] = state[i]
            _propagate_covariance(a, w, p[t], ap, p[t])
    return x, p


@njit(cache=True)
def _kalman_update(x, p, initialized, y, mask, initial_cov, r2, max_measurement):
    """`perception.kalman.KalmanFilter.update` in place: a track's first valid measurement y
    (T, d) sets its position (derivatives 0, covariance initial_cov); later ones the update with
    C = [I 0], R = r2 I: K = P C^T S^-1, S = C P C^T + R, x += K (y - C x), P <- sym(P - K C P).
    A row is valid with mask True, finite and every |component| <= max_measurement."""
    n_tracks, size = x.shape
    d = y.shape[1]
    s = np.empty((d, d))
    pct_t = np.empty((d, size))
    innovation = np.empty(d)
    for t in range(n_tracks):
        valid = mask[t]
        for c in range(d):
            valid = valid and abs(y[t, c]) <= max_measurement  # False for NaN too
        if not valid:
            continue
        if not initialized[t]:
            for i in range(size):
                x[t, i] = y[t, i] if i < d else 0.0
                for j in range(size):
                    p[t, i, j] = initial_cov[i, j]
            initialized[t] = True
            continue
        for i in range(d):
            for j in range(d):
                s[i, j] = p[t, i, j] + (r2 if i == j else 0.0)
            for j in range(size):
                pct_t[i, j] = p[t, j, i]
        gain_t = _solve_pivoting(s, pct_t)  # (d, S) = S^-1 C P
        for c in range(d):
            innovation[c] = y[t, c] - x[t, c]
        for i in range(size):
            total = 0.0
            for c in range(d):
                total += gain_t[c, i] * innovation[c]
            x[t, i] += total
        for i in range(size):
            for j in range(size):
                total = 0.0
                for c in range(d):
                    total += gain_t[c, i] * pct_t[c, j]
                ap = p[t, i, j] - total
                if j < i:  # the symmetric part: 0.5 (P + P^T) of the updated P
                    p[t, i, j] = 0.5 * (ap + p[t, j, i])
                    p[t, j, i] = p[t, i, j]
                else:
                    p[t, i, j] = ap
    return initialized


@njit(cache=True)
def _kalman_gate(x, p, y, rows, r2):
    """(R,) squared Mahalanobis distances nu^T S^-1 nu of the innovations nu = y - C x of tracks
    `rows`, S = C P C^T + r2 I (the particle filter's re-acquisition gate)."""
    d = y.shape[1]
    out = np.empty(rows.shape[0])
    s = np.empty((d, d))
    nu = np.empty((d, 1))
    for r in range(rows.shape[0]):
        t = rows[r]
        for i in range(d):
            nu[i, 0] = y[t, i] - x[t, i]
            for j in range(d):
                s[i, j] = p[t, i, j] + (r2 if i == j else 0.0)
        solved = _solve_pivoting(s, nu)
        total = 0.0
        for i in range(d):
            total += nu[i, 0] * solved[i, 0]
        out[r] = total
    return out


@njit(cache=True)
def _merged_end_mass(starts, parent_idx, child_action, probs, parents_mass, duration_pmfs, supports):
    """One level of Algorithm 1's tree (`prediction.waiting`): the children, sorted by group and
    starting at `starts`, merged (sum of p_arc * parent's end-time pmf per group), then each
    group's start-time pmf convolved with its action's duration pmf (direct sum over the pmf's
    support, truncated at the grid's end). Returns (groups, G)."""
    n_groups, n_rows = starts.shape[0], parent_idx.shape[0]
    n_bins = parents_mass.shape[1]
    out = np.zeros((n_groups, n_bins))
    weighted = np.empty(n_bins)
    for g in range(n_groups):
        stop = starts[g + 1] if g + 1 < n_groups else n_rows
        for t in range(n_bins):
            weighted[t] = 0.0
        for r in range(starts[g], stop):
            parent = parent_idx[r]
            arc = probs[parent, child_action[r]]
            for t in range(n_bins):
                weighted[t] += arc * parents_mass[parent, t]
        action = child_action[starts[g]]
        support = supports[action]
        for t in range(n_bins):
            total = 0.0
            for k in range(min(support, t + 1)):
                total += weighted[t - k] * duration_pmfs[action, k]
            out[g, t] = total
    return out


@njit(cache=True)
def _position_samples(x, p, rows, z):
    """Samples m + L z (R, K, d) of the position marginals N(m, P_pp) of tracks `rows`, from
    standard normal draws z (R, K, d); L the lower Cholesky factor of P_pp (d x d)."""
    n_rows, n_samples, d = z.shape
    out = np.empty((n_rows, n_samples, d))
    chol = np.zeros((d, d))
    for r in range(n_rows):
        t = rows[r]
        for i in range(d):  # Cholesky-Banachiewicz, row by row
            for j in range(i + 1):
                total = p[t, i, j]
                for k in range(j):
                    total -= chol[i, k] * chol[j, k]
                if i == j:
                    if not total > 0.0:
                        raise ValueError("a position covariance is not positive definite")
                    chol[i, j] = math.sqrt(total)
                else:
                    chol[i, j] = total / chol[j, j]
        for n in range(n_samples):
            for i in range(d):
                total = x[t, i]
                for k in range(i + 1):
                    total += chol[i, k] * z[r, n, k]
                out[r, n, i] = total
    return out


@njit(cache=True)
def _bayes_rows(prior, log_likelihood, switch, active, floor):
    """`intention.bayes.bayes_update` of rows (R, G): the prior mixed with the uniform one by each
    row's switch probability, times exp(log L - best) floored at `floor`, normalised; a row that
    is not active or has no finite likelihood keeps its prior."""
    n_rows, n_goals = prior.shape
    out = np.empty((n_rows, n_goals))
    for r in range(n_rows):
        best = -np.inf
        for g in range(n_goals):
            value = log_likelihood[r, g]
            if math.isfinite(value) and value > best:
                best = value
        if not (active[r] and math.isfinite(best)):
            for g in range(n_goals):
                out[r, g] = prior[r, g]
            continue
        total = 0.0
        for g in range(n_goals):
            value = log_likelihood[r, g]
            relative = max(value - best, floor) if math.isfinite(value) else floor
            out[r, g] = ((1.0 - switch[r]) * prior[r, g] + switch[r] / n_goals) * math.exp(relative)
            total += out[r, g]
        total = max(total, 1e-300)
        for g in range(n_goals):
            out[r, g] /= total
    return out


@njit(cache=True, inline="always")
def _normal_cdf(x):
    """Phi(x), the standard normal CDF (scipy.special.ndtr), from erfc."""
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


@njit(cache=True)
def _cloud_summaries(particles, posterior_only, kf_x, kf_p, center, half):
    """Per point of the skeleton particle filter: (spread (P,), fraction in the box (P,)), see
    `perception.particle_filter.SkeletonParticleFilter.spread` and `.fraction_in_box`: from
    the positions particles[:, :, :3] of a cloud, or from the Kalman posterior (kf_x, kf_p)
    of a point flagged posterior_only (the product of the per-axis marginal probabilities)."""
    n_points, n_particles = particles.shape[0], particles.shape[1]
    spread = np.empty(n_points)
    fraction = np.empty(n_points)
    for i in range(n_points):
        if posterior_only[i]:
            trace, inside = 0.0, 1.0
            for a in range(3):
                trace += kf_p[i, a, a]
                std = math.sqrt(kf_p[i, a, a])
                low = (center[a] - half[a] - kf_x[i, a]) / std
                high = (center[a] + half[a] - kf_x[i, a]) / std
                # the tail on the far side of the mean: no cancellation of two values near 1
                if low > 0:
                    axis = _normal_cdf(-low) - _normal_cdf(-high)
                else:
                    axis = _normal_cdf(high) - _normal_cdf(low)
                inside *= min(max(axis, 0.0), 1.0)
            spread[i] = math.sqrt(trace / 3.0)
            fraction[i] = inside
            continue
        variance, count = 0.0, 0
        for a in range(3):
            total = 0.0
            for n in range(n_particles):
                total += particles[i, n, a]
            mean = total / n_particles
            squares = 0.0
            for n in range(n_particles):
                deviation = particles[i, n, a] - mean
                squares += deviation * deviation
            variance += squares / n_particles
        for n in range(n_particles):
            if (abs(particles[i, n, 0] - center[0]) <= half[0] and abs(particles[i, n, 1] - center[1])
                    <= half[1] and abs(particles[i, n, 2] - center[2]) <= half[2]):
                count += 1
        spread[i] = math.sqrt(variance / 3.0)
        fraction[i] = count / n_particles
    return spread, fraction


def _arrays(*arrays):
    """The arrays as writeable C-ordered float64 (copies only where needed): one compiled
    specialisation per kernel (numba compiles another for read-only or strided arrays)."""
    # flags.carray: C-contiguous, aligned and writeable in one test (this runs ~1e5 times a minute)
    return tuple([a if type(a) is np.ndarray and a.dtype is _FLOAT64 and a.flags.carray
                  else np.array(a, dtype=np.float64, order="C") for a in arrays])


def capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b) -> np.ndarray:
    """(Ka, Kb) clearance of every capsule pair of sets A and B: segment distance minus both radii."""
    return _capsule_clearances(*_arrays(start_a, end_a, radius_a, start_b, end_b, radius_b))


def pair_closest_parameters(start_a, end_a, start_b, end_b, index_a, index_b) -> np.ndarray:
    """(N, 2) closest-point parameters (s, t) of the segment pairs (index_a, index_b) of sets A
    (Ka, 3) and B (Kb, 3) (`motion.geometry.segment_segment_closest` is the reference)."""
    index_a = np.ascontiguousarray(index_a, dtype=np.int64)
    index_b = np.ascontiguousarray(index_b, dtype=np.int64)
    return _pair_closest_parameters(*_arrays(start_a, end_a, start_b, end_b), index_a, index_b)


def hidden_points(origin, axis, cos_limit: float, points, box_lower, box_upper, cap_start, cap_end,
                  cap_radius) -> np.ndarray:
    """(N,) True where the camera cannot see the point (see `_hidden_points`): origin, axis (3,),
    points (N, 3), boxes (B, 3) lower and upper corners, capsules (K, 3) ends and (K,) radii."""
    return _hidden_points(*_arrays(origin, axis), float(cos_limit),
                          *_arrays(points, box_lower, box_upper, cap_start, cap_end, cap_radius))


def bounding_capsule(points, offsets, stride: int = 1) -> tuple[np.ndarray, np.ndarray, float]:
    """One capsule around points (3, N) translated by every corner in offsets (C, 3), see
    `_bounding_capsule`: (start (3,), end (3,), radius)."""
    start, end, radius = _bounding_capsule(*_arrays(points, offsets), int(stride))
    return start, end, float(radius)


#: the arrays of a fitted `GPMotionModel` bucket that `_gp_rollouts` takes, in its order
_BUCKET_KEYS = ("x_train", "x_train_sq", "alpha", "k_inv", "theta", "x_mean", "x_std", "y_mean", "y_std")


def gp_rollouts(history, noise, bucket) -> np.ndarray:
    """`_gp_rollouts` with the arrays `_BUCKET_KEYS` of a fitted `GPMotionModel` bucket."""
    return _gp_rollouts(*_arrays(history, noise, *(bucket[key] for key in _BUCKET_KEYS)))


def petri_arcs(pre, incidence) -> tuple[np.ndarray, ...]:
    """The arcs of a net with pre (P, T) and incidence (P, T), by transition, for `trial_step`:
    (pre_start (T+1,), pre_place, pre_weight) of the input arcs Pre^ij > 0 and (inc_start,
    inc_place, inc_delta) of the nonzero incidence entries, as int64 arrays in CSR form."""
    out = []
    for matrix in (np.asarray(pre), np.asarray(incidence)):
        transition, place = np.nonzero(matrix.T)
        start = np.searchsorted(transition, np.arange(matrix.shape[1] + 1)).astype(np.int64)
        out += [start, place.astype(np.int64), matrix.T[transition, place].astype(np.int64)]
    return tuple(out)


def trial_step(m, arcs, fired, unc, controllable, is_wait_end, pools, count, fire_at, en_prev, t, alive,
               keys, group, key_bonus, horizon: float, now: float, quantum: float, dt, chosen,
               column) -> bool:
    """`_trial_step` on the caller's arrays, changed in place (no copies: the caller passes C-ordered
    int64 m (N, P), fired, count, group, chosen, column; bool unc, controllable, is_wait_end,
    en_prev, alive; float64 pools, fire_at, t, keys, key_bonus, dt; arcs from `petri_arcs`)."""
    return _trial_step(m, arcs, fired, unc, controllable, is_wait_end, pools, count, fire_at, en_prev, t,
                       alive, keys, group, key_bonus, horizon, now, quantum, dt, chosen, column)


def rts_means(a, w, means, covs) -> np.ndarray:
    """`_rts_means`: smoothed means (K, T, S) from filtered means (K, T, S) and covariances
    (K, T, S, S) of tracks sharing the chain matrices a, w (S, S)."""
    return _rts_means(*_arrays(a, w, means, covs))


def window_velocity(times, positions, min_speed: float, min_samples: int,
                    significance: float) -> tuple[np.ndarray, np.ndarray]:
    """`_window_velocity`: (velocity (P, 3), moving (P,)) of one window times (K,), positions (K, P, 3)."""
    times, positions = _arrays(times, positions)
    velocity = np.empty((positions.shape[1], 3))
    moving = np.empty(positions.shape[1], dtype=np.bool_)
    _window_velocity(times, positions, float(min_speed), int(min_samples), float(significance), velocity,
                     moving)
    return velocity, moving


def goal_log_likelihoods(wrists, velocity, moving, head, gaze, centers, columns, precision_chol, mean_proj,
                         log_norm, neutral: float, at_goal: float) -> np.ndarray:
    """`_goal_log_likelihoods`: wrists, velocity (2, 3), moving (2,), head, gaze (3,), centers
    (G, Np, 3), the Phi columns the density reads, and the density's precomputed arrays (those of
    `intention.likelihood.GaussianMixtureDensity`: precision Cholesky factors (K, D, D), projected
    means (K, D), log normalisers (K,))."""
    return _goal_log_likelihoods(
        *_arrays(wrists, velocity), np.ascontiguousarray(moving, dtype=np.bool_),
        *_arrays(head, gaze, centers),
        np.ascontiguousarray(columns, dtype=np.int64), *_arrays(precision_chol, mean_proj, log_norm),
        float(neutral), float(at_goal))


def kalman_predict(x, p, a, w, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """`_kalman_predict`: new (x (T, S), P (T, S, S)) after `steps` time updates with A, W (S, S)."""
    return _kalman_predict(*_arrays(x, p, a, w), int(steps))


def kalman_update(x, p, initialized, y, mask, initial_cov, r2: float, max_measurement: float) -> None:
    """`_kalman_update` on the caller's x (T, S), P (T, S, S) and initialized (T,) bool, in place
    (C-ordered float64 and bool arrays, as `KalmanFilter` keeps them); y (T, d), mask (T,) bool."""
    _kalman_update(x, p, initialized, *_arrays(y), np.ascontiguousarray(mask, dtype=np.bool_),
                   *_arrays(initial_cov), float(r2), float(max_measurement))


def kalman_gate(x, p, y, rows, r2: float) -> np.ndarray:
    """`_kalman_gate`: (R,) nu^T S^-1 nu of tracks `rows` (int array) for measurements y (T, d)."""
    return _kalman_gate(*_arrays(x, p, y), np.ascontiguousarray(rows, dtype=np.int64), float(r2))


def merged_end_mass(starts, parent_idx, child_action, probs, parents_mass, duration_pmfs,
                    supports) -> np.ndarray:
    """`_merged_end_mass`: int arrays starts, parent_idx, child_action, supports; float probs (P, m),
    parents_mass (P, G), duration_pmfs (m, G)."""
    ints = (np.ascontiguousarray(a, dtype=np.int64) for a in (starts, parent_idx, child_action))
    return _merged_end_mass(*ints, *_arrays(probs, parents_mass, duration_pmfs),
                            np.ascontiguousarray(supports, dtype=np.int64))


def position_samples(x, p, rows, z) -> np.ndarray:
    """`_position_samples`: x (T, S), P (T, S, S), rows (R,) int, z (R, K, d) -> (R, K, d)."""
    return _position_samples(*_arrays(x, p), np.ascontiguousarray(rows, dtype=np.int64), *_arrays(z))


def bayes_rows(prior, log_likelihood, switch, active, floor: float) -> np.ndarray:
    """`_bayes_rows`: prior, log_likelihood (R, G), switch (R,) in [0, 1], active (R,) bool."""
    return _bayes_rows(*_arrays(prior, log_likelihood, switch), np.ascontiguousarray(active, dtype=np.bool_),
                       float(floor))


def cloud_summaries(particles, posterior_only, kf_x, kf_p, center, half) -> tuple[np.ndarray, np.ndarray]:
    """`_cloud_summaries`: particles (P, n, S), posterior_only (P,) bool, Kalman x (P, S) and P
    (P, S, S), the box's center and half size (3,)."""
    return _cloud_summaries(*_arrays(particles), np.ascontiguousarray(posterior_only, dtype=np.bool_),
                            *_arrays(kf_x, kf_p, center, half))


def _rows(visible) -> np.ndarray:
    return np.flatnonzero(np.asarray(visible, dtype=bool)).astype(np.int64)


def skeleton_points(dims, q) -> np.ndarray:
    """The 8 skeletal points (8, 3) of the body with dims (see `_skeleton_points`) at q (12,)."""
    out = np.empty((8, 3))
    _skeleton_points(*_arrays(dims, q), out)
    return out


def skeleton_jacobian(dims, q, visible, step: float) -> tuple[np.ndarray, np.ndarray]:
    """The visible points (3V,) at q and their forward-difference Jacobian (3V, 12)."""
    rows = _rows(visible)
    model, jacobian = np.empty(3 * len(rows)), np.empty((3 * len(rows), 12))
    _skeleton_jacobian(*_arrays(dims, q), rows, float(step), model, jacobian)
    return model, jacobian


def tracking_gauss_newton(dims, q_lower, q_upper, target, visible, q0, iterations: int,
                          regularization: float, step: float) -> tuple[np.ndarray, float]:
    """`_tracking_gauss_newton` over the visible points; target (3V,) their measured positions."""
    return _tracking_gauss_newton(*_arrays(dims, q_lower, q_upper, target), _rows(visible),
                                  *_arrays(q0), int(iterations), float(regularization), float(step))


def uncached_kernels() -> list[str]:
    """Names of the kernels with no compiled form in numba's disk cache yet (a first run)."""
    from numba.core.dispatcher import Dispatcher

    missing = []
    for name, value in globals().items():
        if not isinstance(value, Dispatcher) or value.targetoptions.get("inline") == "always":
            continue  # an inlined helper is compiled into its callers, never cached alone
        try:
            index = value._cache._cache_file._index_path
        except AttributeError:  # another numba's cache layout: say nothing rather than guess
            return []
        if not os.path.exists(index):
            missing.append(name)
    return missing


def warm_up(progress=None) -> float:
    """Compile (or load from the disk cache) every kernel; returns the seconds it took. With
    `progress` (a stream), say once that a first run compiles, and how long it took."""
    started = time.perf_counter()
    missing = uncached_kernels() if progress is not None else []
    if missing:
        print(f"compiling {len(missing)} numba kernels (the first run on this machine only; cached on "
              "disk afterwards) ...", file=progress, flush=True)
    one = np.zeros((1, 3))
    capsule_clearances(one, one + 1.0, np.ones(1), one, one + 1.0, np.ones(1))
    pair_closest_parameters(one, one + 1.0, one, one + 1.0, np.zeros(1, dtype=np.int64),
                            np.zeros(1, dtype=np.int64))
    hidden_points(np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.5, one + 1.0, one, one, one, one, np.ones(1))
    bounding_capsule(np.eye(3), np.zeros((1, 3)))
    rts_means(np.eye(3), np.eye(3), np.zeros((2, 1, 3)), np.tile(np.eye(3), (2, 1, 1, 1)))
    bucket = {"x_train": np.ones((1, 2, 3)), "x_train_sq": np.ones((1, 2)), "alpha": np.ones((1, 2, 3)),
              "k_inv": np.eye(2)[None], "theta": np.ones((1, 4)), "x_mean": np.zeros((1, 3)),
              "x_std": np.ones((1, 3)), "y_mean": np.zeros((1, 3)), "y_std": np.ones((1, 3))}
    gp_rollouts(np.zeros((1, 1, 3)), np.zeros((2, 1, 2, 3)), bucket)
    ints, flags, reals = np.zeros(1, dtype=np.int64), np.ones(1, dtype=bool), np.zeros(1)
    marking, arcs = np.ones((1, 1), dtype=np.int64), petri_arcs(np.ones((1, 1)), np.zeros((1, 1)))
    trial_step(marking, arcs, ints - 1, flags, ~flags, ~flags, np.ones((1, 1, 1)), marking - 1,
               np.full((1, 1), np.inf), np.zeros((1, 1), dtype=bool), reals.copy(), flags.copy(),
               np.zeros((1, 1)), ints, reals, 1.0, 0.0, 0.0, reals.copy(), ints.copy(), ints.copy())
    dims, q, visible = np.ones(6), np.zeros(12), np.ones(8, dtype=bool)
    skeleton_jacobian(dims, q, visible, 1e-5)
    window_velocity(np.arange(3.0), np.zeros((3, 2, 3)), 0.1, 2, 3.0)
    bayes_rows(np.full((2, 2), 0.5), np.zeros((2, 2)), np.zeros(2), np.ones(2, dtype=bool), -30.0)
    merged_end_mass(np.zeros(1), np.zeros(1), np.zeros(1), np.ones((1, 1)), np.ones((1, 2)), np.ones((1, 2)),
                    np.ones(1))
    x, p, flags = np.zeros((1, 6)), np.eye(6)[None].copy(), np.zeros(1, dtype=bool)
    x, p = kalman_predict(x, p, np.eye(6), np.eye(6), 1)
    kalman_update(x, p, flags, np.zeros((1, 3)), ~flags, np.eye(6), 1e-4, 1e6)
    kalman_gate(x, p, np.zeros((1, 3)), np.zeros(1, dtype=np.int64), 1e-4)
    position_samples(x, p, np.zeros(1, dtype=np.int64), np.zeros((1, 2, 3)))
    cloud_summaries(np.zeros((2, 3, 6)), np.array([True, False]), np.zeros((2, 6)),
                    np.tile(np.eye(6), (2, 1, 1)), np.zeros(3), np.ones(3))
    goal_log_likelihoods(np.zeros((2, 3)), np.ones((2, 3)), np.ones(2, dtype=bool), np.zeros(3), np.ones(3),
                         np.ones((1, 1, 3)), np.array([0, 3]), np.eye(2)[None], np.zeros((1, 2)), np.zeros(1),
                         1.0, 1e-6)
    tracking_gauss_newton(dims, q - 1.0, q + 1.0, skeleton_points(dims, q).ravel(), visible, q, 1, 1e-3, 1e-5)
    took = time.perf_counter() - started
    if missing:
        print(f"compiled in {took:.0f} s", file=progress, flush=True)
    return took
