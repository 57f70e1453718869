"""Compiled kernels (numba) of the trackers and the skeleton particle filter (Ch. 9,
`perception.kalman`, `perception.particle_filter`): the Kalman time and measurement updates,
the RTS smoothed means of eq. (8.6), the particle filter's re-acquisition gate, its posterior
samples and its cloud summaries. Their numpy forms stay the reference the tests compare against
(tests/test_kernels.py, tests/perception/test_particle_filter.py). Compiled when first called,
cached on disk (`hrc_drake.kernels`, group "perception").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hrc_drake import kernels
from hrc_drake.kernels import _arrays, _solve_pivoting


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


def rts_means(a, w, means, covs) -> np.ndarray:
    """`_rts_means`: smoothed means (K, T, S) from filtered means (K, T, S) and covariances
    (K, T, S, S) of tracks sharing the chain matrices a, w (S, S)."""
    return _rts_means(*_arrays(a, w, means, covs))


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


def position_samples(x, p, rows, z) -> np.ndarray:
    """`_position_samples`: x (T, S), P (T, S, S), rows (R,) int, z (R, K, d) -> (R, K, d)."""
    return _position_samples(*_arrays(x, p), np.ascontiguousarray(rows, dtype=np.int64), *_arrays(z))


def cloud_summaries(particles, posterior_only, kf_x, kf_p, center, half) -> tuple[np.ndarray, np.ndarray]:
    """`_cloud_summaries`: particles (P, n, S), posterior_only (P,) bool, Kalman x (P, S) and P
    (P, S, S), the box's center and half size (3,)."""
    return _cloud_summaries(*_arrays(particles), np.ascontiguousarray(posterior_only, dtype=np.bool_),
                            *_arrays(kf_x, kf_p, center, half))


def _warm_up_steps() -> list:
    """Calls that compile (or load) every kernel here on tiny inputs, each on its own
    (`kernels.warm_up`)."""
    flags = np.zeros(1, dtype=bool)

    def state():  # each call its own, as kalman_update writes into them
        return np.zeros((1, 6)), np.eye(6)[None].copy()

    return [
        lambda: rts_means(np.eye(3), np.eye(3), np.zeros((2, 1, 3)), np.tile(np.eye(3), (2, 1, 1, 1))),
        lambda: kalman_predict(*state(), np.eye(6), np.eye(6), 1),
        lambda: kalman_update(*state(), flags.copy(), np.zeros((1, 3)), ~flags, np.eye(6), 1e-4, 1e6),
        lambda: kalman_gate(*state(), np.zeros((1, 3)), np.zeros(1, dtype=np.int64), 1e-4),
        lambda: position_samples(*state(), np.zeros(1, dtype=np.int64), np.zeros((1, 2, 3))),
        lambda: cloud_summaries(np.zeros((2, 3, 6)), np.array([True, False]), np.zeros((2, 6)),
                                np.tile(np.eye(6), (2, 1, 1)), np.zeros(3), np.ones(3)),
    ]


kernels.register_group(globals(), kernels)
