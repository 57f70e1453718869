"""Chain-of-integrators motion model, a vectorised Kalman filter and an RTS smoother.

The model of one tracked quantity (a skeletal point in Ch. 9, a joint in Ch. 8.1) is a chain
of integrators, eq. (9.1)-(9.3) and (8.3):

    U_{k+1} = A U_k + w_k,  w_k ~ N(0, W)        y_k = C U_k + e_k,  e_k ~ N(0, E)

The state stacks `order` blocks of `dim` components, position first:
U = [u, u', u'', ...] (order 4 = position .. jerk, the model of Ch. 9; order 3 = position ..
acceleration, the three-integrator model of Ch. 8.1, eq. 8.3, in position-first order).
Block (i, j >= i) of A is dt^(j-i) / (j-i)! I. W is diagonal, each block holding the first
truncated Taylor term: block j gets sigma_j^2 dt^(n-j) / (n-j)! I with n = order, i.e.
sigma^2 dt^4/24, dt^3/6, dt^2/2, dt for the jerk chain (eq. 9.3, last block sigma^2 dt I).

`KalmanFilter` runs many independent tracks at once: means (T, S) and covariances (T, S, S),
S = order * dim. A missing measurement (mask False, or a row with NaN, inf or a component
beyond MAX_MEASUREMENT) leaves the track open loop, as the KF baseline of 9.1.3 does under
occlusion.
"""

from __future__ import annotations

from functools import lru_cache
from math import factorial

import numpy as np

from hrc_drake.messages import shallow_copy
from hrc_drake.perception import _kernels


class ChainOfIntegrators:
    """Discrete chain of integrators, eq. (9.1)-(9.3) (and eq. 8.3 with order 3).

    order: number of state blocks (4: position, velocity, acceleration, jerk).
    dt: sampling time (s).
    sigma: process standard deviation, a scalar for every block or one value per block
        (position first), the tunable sigma_u, sigma_u', ... of eq. (9.3).
    dim: components per block (3 for a Cartesian point, 1 for a joint).

    Attributes: A (S, S) transition, W (S, S) process covariance, C (dim, S) output matrix
    of eq. (9.5), with S = order * dim; A_block, W_block the (order, order) scalar patterns.
    """

    def __init__(self, order: int = 4, dt: float = 1.0 / 30.0, sigma=1.0, dim: int = 3):
        if int(order) != order or order < 1:
            raise ValueError(f"ChainOfIntegrators: order must be a positive integer, got {order!r}")
        if not np.isfinite(dt) or dt <= 0:
            raise ValueError(f"ChainOfIntegrators: dt must be positive and finite, got {dt!r}")
        if int(dim) != dim or dim < 1:
            raise ValueError(f"ChainOfIntegrators: dim must be a positive integer, got {dim!r}")
        self.order = int(order)
        self.dt = float(dt)
        self.dim = int(dim)
        sig = np.broadcast_to(np.asarray(sigma, dtype=float), (self.order,)).copy() \
            if np.ndim(sigma) == 0 else np.asarray(sigma, dtype=float)
        if sig.shape != (self.order,) or not np.all(np.isfinite(sig)) or np.any(sig < 0):
            raise ValueError(
                "ChainOfIntegrators: sigma must be a non-negative scalar or "
                f"{self.order} values, got {sigma!r}"
            )
        self.sigma = sig
        n = self.order
        a = np.zeros((n, n))
        for i in range(n):
            for j in range(i, n):
                a[i, j] = dt ** (j - i) / factorial(j - i)
        w = np.diag([sig[j] ** 2 * dt ** (n - j) / factorial(n - j) for j in range(n)])
        self.A_block = a
        self.W_block = w
        eye = np.eye(self.dim)
        self.A = np.kron(a, eye)
        self.W = np.kron(w, eye)
        self.C = np.zeros((self.dim, n * self.dim))
        self.C[:, : self.dim] = eye

    @property
    def state_size(self) -> int:
        return self.order * self.dim

    def __repr__(self) -> str:
        return (f"ChainOfIntegrators(order={self.order}, dt={self.dt}, "
                f"sigma={self.sigma.tolist()}, dim={self.dim})")


#: Largest measurement component taken as real (in the measurement's units: m, rad). A larger
#: one is a corrupt sample, not a motion; its square and the velocity it implies would overflow
#: to inf and leave NaN in the state for good.
MAX_MEASUREMENT = 1e6


def valid_measurements(y: np.ndarray) -> np.ndarray:
    """(...,) bool over the rows (..., dim) of y: finite, every |component| <= MAX_MEASUREMENT."""
    # a comparison with NaN is False (and warns for nothing)
    return (np.abs(y) <= MAX_MEASUREMENT).all(axis=-1)


@lru_cache(maxsize=64)
def chi2_quantile(confidence: float, dof: int) -> float:
    """chi2_dof quantile at `confidence` (scipy.stats imported here, not at module import;
    remembered: a tracker asks for the same few quantiles at every frame)."""
    from scipy.stats import chi2

    return float(chi2.ppf(float(confidence), int(dof)))


# Fixed points uniform in the unit ball: the 90 % ellipsoid fraction is then deterministic.
_BALL_SAMPLES = 512


@lru_cache(maxsize=16)
def unit_ball_samples(n: int, dim: int) -> np.ndarray:
    """(n, dim) fixed points uniform in the unit ball (seeded: the same on every call; one
    read-only array per (n, dim))."""
    rng = np.random.default_rng(12345)
    direction = rng.standard_normal((n, dim))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    radius = rng.random(n) ** (1.0 / dim)
    samples = direction * radius[:, None]
    samples.flags.writeable = False
    return samples


# Relative and absolute margins of the bounding-box shortcuts below: wider than the rounding of
# the sample arithmetic, so that a shortcut never decides a case the samples would decide otherwise.
_SHORTCUT_REL, _SHORTCUT_ABS = 1e-9, 1e-12


#: the box grid of `box_fraction_in_ellipsoid`: 8 cells per axis, their centres spanning +-7/16
_GRID_CELLS = 8
_GRID_REACH = 0.5 - 0.5 / _GRID_CELLS


@lru_cache(maxsize=4)
def _box_grid(dim: int) -> np.ndarray:
    """(8^dim, dim) cell centres of the unit box centred at 0 (read-only)."""
    cells = np.arange(_GRID_CELLS)
    index = np.stack(np.meshgrid(*[cells] * dim, indexing="ij"), -1).reshape(-1, dim)
    grid = (index + 0.5) / _GRID_CELLS - 0.5
    grid.flags.writeable = False
    return grid


class KalmanFilter:
    """Forward Kalman filter on a chain of integrators, over T independent tracks.

    model: the `ChainOfIntegrators` shared by every track.
    n_tracks: T (8 for a skeleton).
    measurement_std: standard deviation of e_k (E = measurement_std^2 I), eq. (9.4).
    initial_std: per-block standard deviation of the state at the first measurement
        (position block replaced by measurement_std); scalar or `order` values.

    Attributes: x_ (T, S) means, P_ (T, S, S) covariances, initialized_ (T,) bool.
    """

    def __init__(self, model: ChainOfIntegrators, n_tracks: int = 8, measurement_std: float = 0.01,
                 initial_std=1.0):
        if int(n_tracks) != n_tracks or n_tracks < 1:
            raise ValueError(f"KalmanFilter: n_tracks must be a positive integer, got {n_tracks!r}")
        if not np.isfinite(measurement_std) or measurement_std <= 0:
            raise ValueError(f"KalmanFilter: measurement_std must be positive, got {measurement_std!r}")
        self.model = model
        self.n_tracks = int(n_tracks)
        self.measurement_std = float(measurement_std)
        init = np.broadcast_to(np.asarray(initial_std, dtype=float), (model.order,)).copy()
        init[0] = measurement_std
        self._initial_cov = np.kron(np.diag(init**2), np.eye(model.dim))
        self.reset()

    def clone(self) -> KalmanFilter:
        """A copy that shares only what never changes (the model): the tracks are copied."""
        new = shallow_copy(self)
        new.x_ = self.x_.copy()
        new.P_ = self.P_.copy()
        new.initialized_ = self.initialized_.copy()
        return new

    def reset(self) -> None:
        """Forget every track (a new operator)."""
        s = self.model.state_size
        self.x_ = np.zeros((self.n_tracks, s))
        self.P_ = np.broadcast_to(self._initial_cov, (self.n_tracks, s, s)).copy()
        self.initialized_ = np.zeros(self.n_tracks, dtype=bool)

    def _checked(self, y, mask):
        """(y (T, dim) float, mask (T,) bool, all True for None), or ValueError on a wrong shape."""
        y = np.asarray(y, dtype=float)
        if y.shape != (self.n_tracks, self.model.dim):
            raise ValueError(
                "KalmanFilter: measurements must have shape "
                f"({self.n_tracks}, {self.model.dim}), got {y.shape}"
            )
        if mask is None:
            return y, np.ones(self.n_tracks, dtype=bool)
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != (self.n_tracks,):
            raise ValueError(f"KalmanFilter: mask must have shape ({self.n_tracks},), got {mask.shape}")
        return y, mask

    def _measurements(self, y, mask):
        y, mask = self._checked(y, mask)
        return y, valid_measurements(y) & mask

    def predict(self, steps: int = 1) -> None:
        """Time update (open loop): x <- A x, P <- A P A^T + W, `steps` times (compiled:
        `_kernels.kalman_predict`; `_predict_numpy` is its reference)."""
        self.x_, self.P_ = _kernels.kalman_predict(self.x_, self.P_, self.model.A, self.model.W, int(steps))

    def _predict_numpy(self, steps: int = 1) -> None:
        a, w = self.model.A, self.model.W
        for _ in range(int(steps)):
            self.x_ = self.x_ @ a.T
            self.P_ = a @ self.P_ @ a.T + w

    def update(self, y, mask=None) -> None:
        """Measurement update of the tracks with a valid measurement; others stay open loop.

        y: (T, dim) measurements; rows with NaN, inf or a component beyond MAX_MEASUREMENT, or
        with mask False, are missing.
        A track's first valid measurement initializes it (position = y, derivatives 0).
        Compiled (`_kernels.kalman_update`); `_update_numpy` is its reference.
        """
        y, mask = self._checked(y, mask)
        # the kernel writes the tracks in place: they must be C-ordered float64 / bool arrays
        self.x_, self.P_ = (np.ascontiguousarray(a, dtype=float) for a in (self.x_, self.P_))
        self.initialized_ = np.ascontiguousarray(self.initialized_, dtype=bool)
        _kernels.kalman_update(self.x_, self.P_, self.initialized_, y, mask, self._initial_cov,
                              self.measurement_std**2, MAX_MEASUREMENT)

    def _update_numpy(self, y, mask=None) -> None:
        y, valid = self._measurements(y, mask)
        first = valid & ~self.initialized_
        if np.any(first):
            self.x_[first] = 0.0
            self.x_[first, : self.model.dim] = y[first]
            self.P_[first] = self._initial_cov
            self.initialized_ |= first
        upd = valid & ~first
        if not np.any(upd):
            return
        d = self.model.dim
        x, p = self.x_[upd], self.P_[upd]
        # C selects the position block, so C P C^T and P C^T are slices of P.
        s = p[:, :d, :d] + self.measurement_std**2 * np.eye(d)
        pct = p[:, :, :d]
        gain = np.linalg.solve(s, np.swapaxes(pct, 1, 2))  # (t, d, S) = S^-1 C P
        gain = np.swapaxes(gain, 1, 2)  # (t, S, d)
        innovation = y[upd] - x[:, :d]
        self.x_[upd] = x + np.einsum("tsd,td->ts", gain, innovation)
        p = p - gain @ pct.transpose(0, 2, 1)
        self.P_[upd] = 0.5 * (p + p.transpose(0, 2, 1))

    def step(self, y, mask=None) -> None:
        """One filter cycle: predict the initialized tracks, then update with y."""
        self.predict()
        self.update(y, mask)

    @property
    def positions(self) -> np.ndarray:
        """(T, dim) position means."""
        return self.x_[:, : self.model.dim].copy()

    @property
    def position_covariances(self) -> np.ndarray:
        """(T, dim, dim) position covariances."""
        d = self.model.dim
        return self.P_[:, :d, :d].copy()

    def ellipsoid(self, confidence: float = 0.9):
        """Confidence ellipsoid of each position (9.1.3): (centers (T, d), semi_axes (T, d), axes (T, d, d)).

        The ellipsoid is {x : (x - m)^T P^-1 (x - m) <= chi2_d(confidence)}; column i of
        axes[t] is the direction of semi_axes[t, i].
        """
        if not 0 < confidence < 1:
            raise ValueError(f"KalmanFilter.ellipsoid: confidence must be in (0, 1), got {confidence!r}")
        scale = chi2_quantile(confidence, self.model.dim)
        eigval, eigvec = np.linalg.eigh(self.position_covariances)
        return self.positions, np.sqrt(np.clip(eigval, 0.0, None) * scale), eigvec

    def ellipsoid_fraction_in_box(self, center, size, confidence: float = 0.9, ellipsoid=None) -> np.ndarray:
        """(T,) fraction of each confidence ellipsoid's volume inside an axis-aligned box (9.1.3).

        Estimated on a fixed set of points uniform in the ellipsoid, so it is deterministic. An
        ellipsoid whose bounding box lies inside the box (or off it along some axis) has all its
        points inside (none): 1 (0) without the points. ellipsoid: `self.ellipsoid(confidence)`,
        when the caller has it already.
        """
        center = np.asarray(center, dtype=float)
        half = 0.5 * np.asarray(size, dtype=float)
        d = self.model.dim
        if center.shape != (d,) or half.shape != (d,):
            raise ValueError(f"ellipsoid_fraction_in_box: center and size must have shape ({d},)")
        m, semi, axes = ellipsoid if ellipsoid is not None else self.ellipsoid(confidence)
        factor = axes * semi[:, None, :]
        reach = np.sqrt(np.einsum("tij,tij->ti", factor, factor)) * (1 + _SHORTCUT_REL) + _SHORTCUT_ABS
        offset = np.abs(m - center)
        inside = np.all(offset + reach <= half, axis=1)
        outside = np.any(offset - reach > half, axis=1)
        fraction = inside.astype(float)
        mixed = np.flatnonzero(~inside & ~outside)
        if len(mixed):
            ball = unit_ball_samples(_BALL_SAMPLES, d)
            pts = m[mixed, None, :] + np.einsum("tij,nj->tni", factor[mixed], ball)
            fraction[mixed] = np.all(np.abs(pts - center) <= half, axis=2).mean(axis=1)
        return fraction

    def box_fraction_in_ellipsoid(self, center, size, confidence: float = 0.9, tracks=None) -> np.ndarray:
        """(T,) fraction of an axis-aligned box's volume inside each confidence ellipsoid.

        Complements `ellipsoid_fraction_in_box`: an ellipsoid grown far larger than the box
        (long open loop) has a small share inside the box yet covers all of it. A track whose
        ellipsoid is off the box along some axis counts 0 without the grid. tracks: (T,) bool,
        the tracks to compute (the others are 0), default all.
        """
        center = np.asarray(center, dtype=float)
        size = np.asarray(size, dtype=float)
        d = self.model.dim
        if center.shape != (d,) or size.shape != (d,):
            raise ValueError(f"box_fraction_in_ellipsoid: center and size must have shape ({d},)")
        scale = chi2_quantile(confidence, d)
        cov = self.position_covariances + 1e-15 * np.eye(d)
        # Mahalanobis distance >= offset_k^2 / cov_kk: the grid's nearest offset along k (the
        # grid spans +-7/16 of the box) beyond the ellipsoid's reach puts every grid point out.
        gap = np.clip(np.abs(self.positions - center) - _GRID_REACH * size, 0.0, None)
        diagonal = np.einsum("tkk->tk", cov)
        off = np.any(gap**2 > scale * diagonal * (1 + _SHORTCUT_REL) + _SHORTCUT_ABS, axis=1)
        todo = ~off if tracks is None else (~off & np.asarray(tracks, dtype=bool))
        fraction = np.zeros(self.n_tracks)
        idx = np.flatnonzero(todo)
        if len(idx):
            pts = center + _box_grid(d) * size
            offset = pts[None, :, :] - self.positions[idx, None, :]
            solved = np.linalg.solve(cov[idx], np.swapaxes(offset, 1, 2)).swapaxes(1, 2)
            m2 = np.einsum("tnd,tnd->tn", offset, solved)
            fraction[idx] = (m2 <= scale).mean(axis=1)
        return fraction

    def filter_sequence(self, measurements, mask=None):
        """Filter a whole sequence from the current state.

        measurements: (K, T, dim) with NaN rows for missing; mask: optional (K, T) bool.
        Returns filtered means (K, T, S) and covariances (K, T, S, S), the inputs of `rts_smooth`.
        The first step only updates (no prediction) when no track is initialized yet.
        """
        measurements = np.asarray(measurements, dtype=float)
        if measurements.ndim != 3:
            raise ValueError(f"filter_sequence: measurements must be (K, T, dim), got {measurements.shape}")
        k_steps = measurements.shape[0]
        means = np.empty((k_steps, self.n_tracks, self.model.state_size))
        covs = np.empty((k_steps, self.n_tracks, self.model.state_size, self.model.state_size))
        for k in range(k_steps):
            if np.any(self.initialized_):
                self.predict()
            self.update(measurements[k], None if mask is None else mask[k])
            means[k], covs[k] = self.x_, self.P_
        return means, covs


def rts_smoothed_means(model: ChainOfIntegrators, means, covs) -> np.ndarray:
    """The smoothed means phi_{k|K} of `rts_smooth` (eq. 8.6) without its covariances, by the
    compiled `_kernels.rts_means`: means (K, ..., S), covs (K, ..., S, S)."""
    means, covs = _check_window(model, means, covs)
    s = model.state_size
    flat = _kernels.rts_means(model.A, model.W, means.reshape(len(means), -1, s),
                             covs.reshape(len(covs), -1, s, s))
    return flat.reshape(means.shape)


def _check_window(model: ChainOfIntegrators, means, covs) -> tuple[np.ndarray, np.ndarray]:
    """A smoother's window as float arrays, or a ValueError naming what is wrong with it."""
    means = np.asarray(means, dtype=float)
    covs = np.asarray(covs, dtype=float)
    s = model.state_size
    if means.shape[-1] != s or covs.shape != means.shape + (s,):
        raise ValueError(
            f"rts_smooth: means must be (K, ..., {s}) and covs (K, ..., {s}, {s}); "
            f"got {means.shape}, {covs.shape}"
        )
    if not (np.all(np.isfinite(means)) and np.all(np.isfinite(covs))):
        raise ValueError("rts_smooth: means and covariances must be finite")
    return means, covs


def rts_smooth(model: ChainOfIntegrators, means, covs):
    """Rauch-Tung-Striebel smoother, eq. (8.6), applied backwards over a window.

    means: (K, ..., S) filtered means phi_{k|k}; covs: (K, ..., S, S) filtered V_{k|k}
    (any leading track axes after K). Returns smoothed means phi_{k|K} and covariances V_{k|K}
    with the same shapes:
        J_k = V_{k|k} A^T V_{k+1|k}^-1
        phi_{k|K} = phi_{k|k} + J_k (phi_{k+1|K} - A phi_{k|k})
        V_{k|K} = V_{k|k} + J_k (V_{k+1|K} - V_{k+1|k}) J_k^T
    """
    means, covs = _check_window(model, means, covs)
    a, w = model.A, model.W
    smoothed_x = means.copy()
    smoothed_p = covs.copy()
    for k in range(means.shape[0] - 2, -1, -1):
        x_k, p_k = means[k], covs[k]
        x_pred = x_k @ a.T
        p_pred = a @ p_k @ a.T + w
        # J = P_k A^T P_pred^-1, computed as (P_pred^-1 A P_k)^T since both are symmetric.
        gain = np.swapaxes(np.linalg.solve(p_pred, a @ p_k), -1, -2)
        smoothed_x[k] = x_k + np.einsum("...ij,...j->...i", gain, smoothed_x[k + 1] - x_pred)
        p = p_k + gain @ (smoothed_p[k + 1] - p_pred) @ np.swapaxes(gain, -1, -2)
        smoothed_p[k] = 0.5 * (p + np.swapaxes(p, -1, -2))
    return smoothed_x, smoothed_p
