"""Compiled kernels (numba) of the intention estimator (Ch. 3, `intention.features`,
`intention.bayes`): the least-squares wrist velocity of a window, the features Phi and GMM
densities of eq. (3.12) and the Bayes step (3.2); and of the action segmenter (Ch. 4,
`intention.segmentation`): max-product on the hidden chain of order 1 (App. C.0.1). Their numpy
forms stay the reference the tests compare against (tests/test_kernels.py,
tests/intention/test_segmentation_chain.py). Compiled when first called, cached on disk
(`hrc_drake.kernels`, group "intention").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hrc_drake import kernels
from hrc_drake.kernels import _arrays


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


@njit(cache=True)
def _chain_max_log_energy(unary, pair):
    """max over y of sum_k unary[k, y_k] + sum_{k >= 1} pair[y_k, y_k-1]: max-product on a chain
    (App. C.0.1, eq. (C.22)) in the log domain, forward messages only (the value, not the argmax)."""
    n_links, n_values = unary.shape
    best = unary[0].copy()
    step = np.empty(n_values)
    for k in range(1, n_links):
        for a in range(n_values):
            top = -np.inf
            for b in range(n_values):
                value = best[b] + pair[a, b]
                if value > top:
                    top = value
            step[a] = top + unary[k, a]
        best[:] = step
    top = -np.inf
    for a in range(n_values):
        if best[a] > top:
            top = best[a]
    return top


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


def bayes_rows(prior, log_likelihood, switch, active, floor: float) -> np.ndarray:
    """`_bayes_rows`: prior, log_likelihood (R, G), switch (R,) in [0, 1], active (R,) bool."""
    return _bayes_rows(*_arrays(prior, log_likelihood, switch), np.ascontiguousarray(active, dtype=np.bool_),
                       float(floor))


def chain_max_log_energy(unary, pair) -> float:
    """`_chain_max_log_energy`: unary (K, m) log potentials, pair (m, m) the log potential of
    (Y_k, Y_k-1); -inf when every assignment is impossible."""
    return float(_chain_max_log_energy(*_arrays(unary, pair)))


def _warm_up_steps() -> list:
    """Calls that compile (or load) every kernel here on tiny inputs, each on its own
    (`kernels.warm_up`)."""
    return [
        lambda: window_velocity(np.arange(3.0), np.zeros((3, 2, 3)), 0.1, 2, 3.0),
        lambda: bayes_rows(np.full((2, 2), 0.5), np.zeros((2, 2)), np.zeros(2), np.ones(2, dtype=bool),
                           -30.0),
        lambda: goal_log_likelihoods(np.zeros((2, 3)), np.ones((2, 3)), np.ones(2, dtype=bool), np.zeros(3),
                                     np.ones(3), np.ones((1, 1, 3)), np.array([0, 3]), np.eye(2)[None],
                                     np.zeros((1, 2)), np.zeros(1), 1.0, 1e-6),
        lambda: chain_max_log_energy(np.zeros((2, 2)), np.zeros((2, 2))),
    ]


kernels.register_group(globals())
