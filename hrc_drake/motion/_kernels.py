"""Compiled kernels (numba) of the human motion predictor (thesis 8.1, `motion.reactive`,
`motion.gp`): the forward-difference Jacobian of the skeleton and the damped Gauss-Newton steps
of `motion.reactive.tracking_inverse` (a 12-joint IK), the Monte Carlo rollouts of eq. (8.8) on
the GP of (8.7), and `motion.reactive._bounding_capsule`, the capsule around each swept point
set. In numpy each is 20-40 calls of 1-5 us whatever the size (DESIGN.md, performance rules);
here they are loops. Their numpy forms stay the reference the tests compare against
(tests/test_kernels.py). Compiled when first called, cached on disk (`hrc_drake.kernels`,
group "motion").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hrc_drake import kernels
from hrc_drake.human import _kernels as human_kernels
from hrc_drake.human._kernels import _skeleton_points
from hrc_drake.kernels import _arrays, _solve_pivoting


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


def bounding_capsule(points, offsets, stride: int = 1) -> tuple[np.ndarray, np.ndarray, float]:
    """One capsule around points (3, N) translated by every corner in offsets (C, 3), see
    `_bounding_capsule`: (start (3,), end (3,), radius)."""
    start, end, radius = _bounding_capsule(*_arrays(points, offsets), int(stride))
    return start, end, float(radius)


_BUCKET_KEYS = ("x_train", "x_train_sq", "alpha", "k_inv", "theta", "x_mean", "x_std", "y_mean", "y_std")


def gp_rollouts(history, noise, bucket) -> np.ndarray:
    """`_gp_rollouts` with the arrays `_BUCKET_KEYS` of a fitted `GPMotionModel` bucket."""
    return _gp_rollouts(*_arrays(history, noise, *(bucket[key] for key in _BUCKET_KEYS)))


def _rows(visible) -> np.ndarray:
    return np.flatnonzero(np.asarray(visible, dtype=bool)).astype(np.int64)


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


def _warm_up_steps() -> list:
    """Calls that compile (or load) every kernel here on tiny inputs, each on its own
    (`kernels.warm_up`)."""
    bucket = {"x_train": np.ones((1, 2, 3)), "x_train_sq": np.ones((1, 2)), "alpha": np.ones((1, 2, 3)),
              "k_inv": np.eye(2)[None], "theta": np.ones((1, 4)), "x_mean": np.zeros((1, 3)),
              "x_std": np.ones((1, 3)), "y_mean": np.zeros((1, 3)), "y_std": np.ones((1, 3))}
    dims, q, visible = np.ones(6), np.zeros(12), np.ones(8, dtype=bool)
    return [
        lambda: bounding_capsule(np.eye(3), np.zeros((1, 3))),
        lambda: gp_rollouts(np.zeros((1, 1, 3)), np.zeros((2, 1, 2, 3)), bucket),
        lambda: skeleton_jacobian(dims, q, visible, 1e-5),
        lambda: tracking_gauss_newton(dims, q - 1.0, q + 1.0, np.zeros(24), visible, q, 1, 1e-3, 1e-5),
    ]


kernels.register_group(globals(), kernels, human_kernels)
