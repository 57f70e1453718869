"""Gaussian Process Dynamical Model of the human trajectories, thesis 8.2.2, eqs. (8.24)-(8.26).

After J. M. Wang, D. J. Fleet, A. Hertzmann, "Gaussian Process Dynamical Models", NIPS 2005 and
"Gaussian Process Dynamical Models for Human Motion", IEEE PAMI 30(2), 2008.

The training set (8.24) is S sequences Y^s (L_s, D), rows are poses. All N = sum L_s rows, centred
by their mean, are stacked in Y (N, D); their latents (8.25) in X (N, d). Pairs of the first-order
latent dynamics lie within a sequence: X_in (N - S, d) are the rows but the last of each sequence,
X_out the rows but the first. Observation GP g_XY and dynamics GP g_XX (Wang et al.):

    k_Y(x, x') = exp(-beta1/2 |x - x'|^2) + delta / beta2                      K_Y (N, N)
    k_X(x, x') = alpha1 exp(-alpha2/2 |x - x'|^2) + alpha3 x^T x' + delta / alpha4   K_X (N-S, N-S)

W = diag(w) (D,) scales each observation dimension (PAMI). Learning minimises the negative
log posterior -ln p(X, alpha, beta, W | Y) (Wang et al., constants dropped):

    D/2 ln|K_Y| + 1/2 tr(K_Y^-1 Y W^2 Y^T) - N ln|W|
    + lam [d/2 ln|K_X| + 1/2 tr(K_X^-1 X_out X_out^T)] + 1/2 sum_s |x_1^s|^2
    + sum ln alpha_i + sum ln beta_i + sum w_k^2 / (2 kappa^2)

with the first latent of each sequence under an isotropic N(0, I) prior and the hyperparameter
priors p(alpha) ~ prod 1/alpha_i, p(beta) ~ prod 1/beta_i, w_k ~ N(0, kappa^2), kappa = 1e3;
lam = 1 is the plain GPDM, lam = D/d the "balanced" GPDM of the PAMI paper. It is minimised jointly
over X and the log-hyperparameters by L-BFGS-B with analytic gradients (`neg_log_posterior`).
Departures from Wang et al.: one joint optimisation (no alternation); the log-hyperparameters are
bounded to [1e-6, 1e6] (on smooth data the dynamics noise precision alpha4 usually ends at its
bound, i.e. near-deterministic latent dynamics); X is initialised by PCA scaled so the first
component has unit variance (plus optional jitter from random_state). No pydrake here.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import LinAlgError, cho_solve, cholesky, lapack
from scipy.optimize import minimize
from sklearn.exceptions import NotFittedError
from threadpoolctl import ThreadpoolController

N_ALPHA, N_BETA = 4, 2
#: prior width of the observation scales w_k (PAMI: kappa = 10^3)
KAPPA = 1e3
_LOG_BOUND = np.log(1e6)
#: initial (alpha1..4), (beta1, beta2): unit RBF, weak linear term, noise variances 1/e
ALPHA0 = np.array([0.9, 1.0, 0.1, np.e])
BETA0 = np.array([1.0, np.e])
_THREADS = None


def _single_thread():
    """BLAS on one thread: for ~200 x 200 matrices threads only add contention."""
    global _THREADS
    if _THREADS is None:
        _THREADS = ThreadpoolController()
    return _THREADS.limit(limits=1, user_api="blas")


def _sq_dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a_i - b_j|^2 (n, m) of rows a (n, d), b (m, d)."""
    sq = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
    return np.maximum(sq, 0.0)


def pair_indices(lengths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row indices (in, out, starts) into the stacked N rows: X_in -> X_out pairs within each
    sequence and the first row of each sequence."""
    lengths = np.asarray(lengths, dtype=int)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    is_in = np.ones(lengths.sum(), dtype=bool)
    is_out = is_in.copy()
    is_in[starts + lengths - 1] = False
    is_out[starts] = False
    return np.flatnonzero(is_in), np.flatnonzero(is_out), starts


def pack(x: np.ndarray, alpha: np.ndarray, beta: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The optimisation vector [X.ravel(), ln alpha (4), ln beta (2), ln w (D)]."""
    return np.concatenate([x.ravel(), np.log(alpha), np.log(beta), np.log(w)])


def unpack(theta: np.ndarray, n: int, d: int):
    """Inverse of `pack`: X (n, d), alpha (4,), beta (2,), w (D,)."""
    k = n * d
    x = theta[:k].reshape(n, d)
    alpha = np.exp(theta[k:k + N_ALPHA])
    beta = np.exp(theta[k + N_ALPHA:k + N_ALPHA + N_BETA])
    return x, alpha, beta, np.exp(theta[k + N_ALPHA + N_BETA:])


def _gp_term(k: np.ndarray, z: np.ndarray, weight: float):
    """weight [D/2 ln|K| + 1/2 tr(K^-1 Z Z^T)] of targets Z (n, D), with dF/dK (n, n), K^-1 Z."""
    chol, info = lapack.dpotrf(k, lower=1)
    if info != 0:
        raise LinAlgError(f"GPDM: a kernel matrix is not positive definite (LAPACK dpotrf info {info})")
    low = lapack.dpotri(chol, lower=1)[0]  # the lower triangle of K^-1, zeros above (chol is clean)
    k_inv = low + low.T
    k_inv.flat[:: len(k) + 1] *= 0.5
    a = k_inv @ z
    value = weight * (z.shape[1] * np.log(np.diag(chol)).sum() + 0.5 * (a * z).sum())
    return value, 0.5 * weight * (z.shape[1] * k_inv - a @ a.T), weight * a


def _rbf_grad_x(g: np.ndarray, rbf: np.ndarray, gamma: float, x: np.ndarray) -> np.ndarray:
    """d/dX of sum(G * RBF) for RBF_ij = a exp(-gamma/2 |x_i - x_j|^2) (rbf includes a), G symmetric."""
    m = g * rbf
    return -2.0 * gamma * (m.sum(1)[:, None] * x - m @ x)


def neg_log_posterior(theta: np.ndarray, y: np.ndarray, lengths, latent_dim: int,
                      dynamics_weight: float = 1.0) -> tuple[float, np.ndarray]:
    """-ln p(X, alpha, beta, W | Y) of the module docstring (Wang et al.) and its gradient.

    theta is `pack(X, alpha, beta, w)`; y (N, D) the centred stacked poses; lengths (S,) the
    sequence lengths (sum = N); dynamics_weight is lam. Returns (value, d value / d theta).
    """
    n, dim = y.shape
    x, alpha, beta, w = unpack(theta, n, latent_dim)
    i_in, i_out, starts = pair_indices(lengths)
    # observation GP g_XY
    sq_x = -0.5 * _sq_dist(x, x)
    rbf_y = np.exp(beta[0] * sq_x)
    z = y * w
    f_y, g_y, a_y = _gp_term(rbf_y + np.eye(n) / beta[1], z, 1.0)
    grad_x = _rbf_grad_x(g_y, rbf_y, beta[0], x)
    d_beta = np.array([(g_y * rbf_y * sq_x).sum() * beta[0], -np.trace(g_y) / beta[1]])
    d_w = w * (a_y * y).sum(0) - n + w**2 / KAPPA**2
    f_y += -n * np.log(w).sum() + (w**2).sum() / (2 * KAPPA**2)
    # dynamics GP g_XX
    x_in, x_out = x[i_in], x[i_out]
    sq_in = _sq_dist(x_in, x_in)
    rbf_x = alpha[0] * np.exp(-0.5 * alpha[1] * sq_in)
    lin_x = alpha[2] * x_in @ x_in.T
    f_x, g_x, a_x = _gp_term(rbf_x + lin_x + np.eye(len(x_in)) / alpha[3], x_out, dynamics_weight)
    grad_x[i_in] += _rbf_grad_x(g_x, rbf_x, alpha[1], x_in) + 2.0 * alpha[2] * g_x @ x_in
    grad_x[i_out] += a_x
    d_alpha = np.array([(g_x * rbf_x).sum(), -0.5 * alpha[1] * (g_x * rbf_x * sq_in).sum(),
                        (g_x * lin_x).sum(), -np.trace(g_x) / alpha[3]])
    # prior of the first latents and of the hyperparameters
    x0 = x[starts]
    grad_x[starts] += x0
    value = f_y + f_x + 0.5 * (x0 * x0).sum() + np.log(alpha).sum() + np.log(beta).sum()
    grad = np.concatenate([grad_x.ravel(), d_alpha + 1.0, d_beta + 1.0, d_w])
    return float(value), grad


def pca_latents(y: np.ndarray, latent_dim: int) -> np.ndarray:
    """PCA scores (N, d) of centred y (N, D), signs fixed (largest loading positive) and scaled by one
    factor so the first component has unit variance."""
    u, s, vt = np.linalg.svd(y, full_matrices=False)
    u, s, vt = u[:, :latent_dim], s[:latent_dim], vt[:latent_dim]
    sign = np.sign(vt[np.arange(latent_dim), np.abs(vt).argmax(1)])
    sign[sign == 0] = 1.0
    scores = u * s * sign
    scale = s[0] / np.sqrt(len(y)) if s[0] > 0 else 1.0
    return scores / scale


def _as_sequences(sequences) -> list[np.ndarray]:
    """Validated float copies of the training sequences (8.24), each (L_s, D)."""
    if isinstance(sequences, np.ndarray) and sequences.ndim == 2:
        raise ValueError("GPDM.fit: sequences must be a list of (L, D) arrays, got one 2-D array "
                         "(wrap it in a list for a single sequence)")
    try:
        seqs = [np.asarray(s, dtype=float) for s in sequences]
    except (TypeError, ValueError) as err:
        raise ValueError(f"GPDM.fit: sequences must be a list of numeric (L, D) arrays ({err})") from None
    if not seqs:
        raise ValueError("GPDM.fit: sequences is empty; give at least one (L, D) sequence")
    for i, s in enumerate(seqs):
        if s.ndim != 2:
            raise ValueError(f"GPDM.fit: sequence {i} must be 2-D (L, D), got shape {s.shape}")
        if len(s) < 3:
            raise ValueError(f"GPDM.fit: sequence {i} has {len(s)} poses; at least 3 are needed")
        if s.shape[1] != seqs[0].shape[1]:
            raise ValueError(f"GPDM.fit: sequence {i} has D = {s.shape[1]} columns but sequence 0 has "
                             f"D = {seqs[0].shape[1]}; all poses must have the same length")
        if not np.isfinite(s).all():
            raise ValueError(f"GPDM.fit: sequence {i} contains NaN or inf")
    return seqs


class GPDM:
    """Gaussian Process Dynamical Model (Wang, Fleet, Hertzmann 2005/2008) of the realisations of one
    human action, and its regressed trajectory Phi, thesis eq. (8.26).

    Parameters: latent_dim d (1 <= d <= D); max_iter, the L-BFGS iteration cap; balanced, lam = D/d
    (balanced GPDM, PAMI) instead of 1; random_state (int, Generator or None) draws the init jitter
    (jitter x std of the PCA latents, 0 for a purely PCA start).

    Learned: latent_ list of (L_s, d); mean_ (D,); alpha_ (4,), beta_ (2,), w_ (D,) as in the module
    docstring; lengths_ (S,); objective_ (the final -ln posterior); n_iter_.
    """

    def __init__(self, latent_dim: int = 3, max_iter: int = 100, balanced: bool = False,
                 jitter: float = 1e-3, random_state=None):
        self.latent_dim = latent_dim
        self.max_iter = max_iter
        self.balanced = balanced
        self.jitter = jitter
        self.random_state = random_state

    def fit(self, sequences) -> GPDM:
        """Learn X, alpha, beta, W from sequences, a list of (L_s, D) arrays (8.24); returns self."""
        seqs = _as_sequences(sequences)
        dim = seqs[0].shape[1]
        d = self.latent_dim
        if isinstance(d, bool) or not isinstance(d, int | np.integer) or not 1 <= d <= dim:
            raise ValueError(f"GPDM: latent_dim must be an integer in [1, D = {dim}], got {d!r}")
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, int | np.integer) \
                or self.max_iter < 1:
            raise ValueError(f"GPDM: max_iter must be a positive integer, got {self.max_iter!r}")
        if not np.isfinite(self.jitter) or self.jitter < 0:
            raise ValueError(f"GPDM: jitter must be a finite number >= 0, got {self.jitter!r}")
        rng = np.random.default_rng(self.random_state)
        lengths = np.array([len(s) for s in seqs])
        y_all = np.concatenate(seqs)
        self.mean_ = y_all.mean(0)
        y = y_all - self.mean_
        x0 = pca_latents(y, d)
        x0 = x0 + self.jitter * x0.std() * rng.standard_normal(x0.shape)
        std = y.std(0)
        w0 = 1.0 / np.where(std > 1e-12, std, 1.0)
        theta0 = pack(x0, ALPHA0, BETA0, w0)
        n_hyper = N_ALPHA + N_BETA + dim
        bounds = [(None, None)] * x0.size + [(-_LOG_BOUND, _LOG_BOUND)] * n_hyper
        lam = dim / d if self.balanced else 1.0
        try:
            with _single_thread():
                result = minimize(neg_log_posterior, theta0, args=(y, lengths, d, lam), jac=True,
                                  method="L-BFGS-B", bounds=bounds, options={"maxiter": int(self.max_iter)})
        except LinAlgError as err:
            raise ValueError(f"GPDM.fit: the optimisation failed ({err})") from None
        x, self.alpha_, self.beta_, self.w_ = unpack(result.x, len(y), d)
        self.lengths_ = lengths
        self.latent_ = np.split(x, np.cumsum(lengths)[:-1])
        self.objective_ = float(result.fun)
        self.n_iter_ = int(result.nit)
        self._cache(x, y)
        return self

    def _cache(self, x: np.ndarray, y: np.ndarray) -> None:
        """Cholesky factors and K^-1 targets of both GPs (E.18), for the predictions."""
        i_in, i_out, _ = pair_indices(self.lengths_)
        self._x, self._x_in = x, x[i_in]
        try:
            self._chol_y = cholesky(self._k_y(x, x) + np.eye(len(x)) / self.beta_[1], lower=True)
            k_x = self._k_x(self._x_in, self._x_in) + np.eye(len(i_in)) / self.alpha_[3]
            self._chol_x = cholesky(k_x, lower=True)
        except LinAlgError as err:  # pragma: no cover - the noise bounds keep both K positive definite
            raise ValueError(f"GPDM.fit: a kernel matrix is not positive definite ({err})") from None
        self._a_y = cho_solve((self._chol_y, True), y * self.w_)
        self._a_x = cho_solve((self._chol_x, True), x[i_out])

    def _k_y(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.exp(-0.5 * self.beta_[0] * _sq_dist(a, b))

    def _k_x(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        al = self.alpha_
        return al[0] * np.exp(-0.5 * al[1] * _sq_dist(a, b)) + al[2] * a @ b.T

    def _check_fitted(self, what: str) -> None:
        if not hasattr(self, "latent_"):
            raise NotFittedError(f"GPDM.{what}: this GPDM is not fitted yet; call fit(sequences) first")

    def _latent_points(self, x, what: str) -> np.ndarray:
        self._check_fitted(what)
        x = np.atleast_2d(np.asarray(x, dtype=float))
        if x.ndim != 2 or x.shape[1] != self.latent_dim:
            raise ValueError(f"GPDM.{what}: X must be (n, {self.latent_dim}), got shape {x.shape}")
        if not np.isfinite(x).all():
            raise ValueError(f"GPDM.{what}: X contains NaN or inf")
        return x

    def predict_observation(self, x, return_var: bool = False):
        """E[g_XY(X)] (n, D) at latents X (n, d), eq. (E.18) undone by W and the mean; with
        return_var also Var[g_XY(X)] (n, D) = (k(x, x) - k_x K_Y^-1 k_x^T) / w^2 (noise-free)."""
        x = self._latent_points(x, "predict_observation")
        k = self._k_y(x, self._x)
        mean = k @ self._a_y / self.w_ + self.mean_
        if not return_var:
            return mean
        v = cho_solve((self._chol_y, True), k.T)
        var = np.maximum(1.0 - (k * v.T).sum(1), 0.0)
        return mean, var[:, None] / self.w_**2

    def predict_dynamics(self, x, return_var: bool = False):
        """E[g_XX(X)] (n, d): the next latents of X (n, d), eq. (E.18); with return_var also
        Var[g_XX(X)] (n, d) = k(x, x) - k_x K_X^-1 k_x^T, the same for every latent axis (noise-free)."""
        x = self._latent_points(x, "predict_dynamics")
        k = self._k_x(x, self._x_in)
        mean = k @ self._a_x
        if not return_var:
            return mean
        v = cho_solve((self._chol_x, True), k.T)
        prior = self.alpha_[0] + self.alpha_[2] * (x * x).sum(1)
        var = np.maximum(prior - (k * v.T).sum(1), 0.0)
        return mean, np.repeat(var[:, None], self.latent_dim, axis=1)

    def regressed_trajectory(self, length: int | None = None, return_latent: bool = False):
        """The regressed trajectory Phi (L, D) of eq. (8.26): X_1 = the mean of the training
        sequences' first latents, X_{k+1} = E[g_XX(X_k)], Phi_k = E[g_XY(X_k)] + mean.

        length L defaults to the median training length; with return_latent also X (L, d).
        """
        self._check_fitted("regressed_trajectory")
        if length is None:
            length = int(round(float(np.median(self.lengths_))))
        if isinstance(length, bool) or not isinstance(length, int | np.integer) or length < 1:
            raise ValueError(f"GPDM.regressed_trajectory: length must be a positive integer, got {length!r}")
        x = np.empty((int(length), self.latent_dim))
        x[0] = np.mean([s[0] for s in self.latent_], axis=0)
        for k in range(1, len(x)):
            x[k] = self._k_x(x[k - 1:k], self._x_in) @ self._a_x
        phi = self.predict_observation(x)
        return (phi, x) if return_latent else phi
