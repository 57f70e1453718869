"""Gaussian-process human motion models h_GP, thesis 8.1.2 and App. E.

The joint state of one step is phi_k (n_dof, 3) = [q, q', q''] per joint (the content of
eq. 8.2 in the position-first order of `hrc_drake.perception.kalman`). A model is a set of
joint groups; each group g is one multi-output GP (E.17)-(E.18) mapping its last P states
(phi^g_{k-1}, ..., phi^g_{k-P}) to phi^g_k:

    model A: 12 groups of one joint, eq. (8.11)-(8.13)
    model B: one group of all joints, eq. (8.14)
    model C: base, left arm, right arm, eq. (8.15)-(8.18)

Kernel (8.7): k(x, x') = theta1 x^T x' + theta3 exp(-theta2/2 ||x - x'||^2) + theta4 delta,
equal to scikit-learn's DotProduct, RBF and WhiteKernel composed by `motion_kernel`;
hyperparameters maximise the multi-output marginal likelihood (E.16) with its gradient
(E.9), in plain numpy (scikit-learn's optimiser loop costs ~10x more per evaluation).
Inputs and outputs are centred and scaled with the training
set's mean and standard deviation, so one RBF length fits features of different units.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs
from threadpoolctl import ThreadpoolController

from hrc_drake.messages import shallow_copy
from hrc_drake.motion import _kernels
from hrc_drake.rng import clone_generator

N_DOF = 12
#: joint groups of the three models of 8.1.2 (indices of q, body-model order)
MODEL_GROUPS: dict[str, tuple[tuple[int, ...], ...]] = {
    "gp_a": tuple((j,) for j in range(N_DOF)),
    "gp_b": (tuple(range(N_DOF)),),
    "gp_c": ((0, 1, 2, 3), (4, 5, 6, 7), (8, 9, 10, 11)),
}
GROUP_NAMES: dict[str, tuple[str, ...]] = {
    "gp_a": tuple(f"q{j}" for j in range(N_DOF)),
    "gp_b": ("all",),
    "gp_c": ("base", "left_arm", "right_arm"),
}

_THETA_BOUNDS = (1e-5, 1e3)
_THREADS = None
#: smallest scale of a feature (rad, m, per s, per s^2)
_SCALE_FLOOR = 1e-3


def _single_thread():
    """BLAS limited to one thread: on 100 x 100 matrices threads only add contention (10x slower
    on a loaded 2-core machine)."""
    global _THREADS
    if _THREADS is None:
        _THREADS = ThreadpoolController()
    return _THREADS.limit(limits=1, user_api="blas")


def motion_kernel(theta1: float = 0.1, theta2: float = 0.1, theta3: float = 1.0, theta4: float = 0.01):
    """The kernel of eq. (8.7) as a scikit-learn kernel.

    theta1 X^T X' (ConstantKernel x DotProduct with sigma_0 = 0), theta3 exp(-theta2/2 d^2)
    (ConstantKernel x RBF with length scale 1/sqrt(theta2)), theta4 delta (WhiteKernel).
    """
    for name, value in (("theta1", theta1), ("theta2", theta2), ("theta3", theta3), ("theta4", theta4)):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"motion_kernel: {name} must be a positive number, got {value!r}")
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, DotProduct, WhiteKernel

    linear = ConstantKernel(theta1, _THETA_BOUNDS) * DotProduct(sigma_0=0.0, sigma_0_bounds="fixed")
    rbf = ConstantKernel(theta3, _THETA_BOUNDS) * RBF(length_scale=1.0 / np.sqrt(theta2),
                                                       length_scale_bounds=(1e-2, 1e3))
    return linear + rbf + WhiteKernel(theta4, _THETA_BOUNDS)


def kernel_theta(kernel) -> np.ndarray:
    """(theta1, theta2, theta3, theta4) of eq. (8.7) from a kernel built by `motion_kernel`."""
    try:
        theta1 = kernel.k1.k1.k1.constant_value
        theta3 = kernel.k1.k2.k1.constant_value
        length = kernel.k1.k2.k2.length_scale
        theta4 = kernel.k2.noise_level
    except AttributeError as err:
        raise ValueError(f"kernel_theta: not a kernel built by motion_kernel: {kernel!r}") from err
    return np.array([theta1, 1.0 / float(length) ** 2, theta3, theta4], dtype=float)


def kernel_8_7(x_a, x_b, theta, a_sq=None, b_sq=None) -> np.ndarray:
    """Eq. (8.7) without the white-noise term, between rows of x_a (..., A, D) and x_b (..., B, D).
    a_sq, b_sq: the rows' squared norms (..., A) and (..., B), when the caller has them."""
    theta1, theta2, theta3 = theta[..., 0], theta[..., 1], theta[..., 2]
    dot = x_a @ np.swapaxes(x_b, -1, -2)
    a_sq = (x_a**2).sum(-1) if a_sq is None else a_sq
    b_sq = (x_b**2).sum(-1) if b_sq is None else b_sq
    sq = a_sq[..., :, None] + b_sq[..., None, :] - 2.0 * dot
    sq = np.maximum(sq, 0.0)
    rbf = np.exp(-0.5 * theta2[..., None, None] * sq)
    return theta1[..., None, None] * dot + theta3[..., None, None] * rbf


#: bounds of (theta1, theta2, theta3, theta4) on standardised data; the noise floor theta4 >= 1e-3
#: acts as the hyperparameter prior of (E.8): it keeps the linear part from over-fitting 100
#: samples with up to 144 inputs, which would make rollouts diverge.
THETA_BOUNDS = np.array([[1e-5, 1e2], [1e-4, 1e2], [1e-5, 1e2], [1e-3, 1e1]])


def _cholesky_lower(k: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of a symmetric positive definite matrix, by LAPACK potrf directly:
    the factor scipy.linalg.cholesky returns, without its checks and copies (1.6x of its time
    at N = 100)."""
    if not np.all(np.isfinite(k)):
        raise ValueError("GP kernel matrix: array must not contain infs or NaNs")
    chol, info = dpotrf(k, lower=1, clean=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"GP kernel matrix is not positive definite (potrf info {info})")
    return chol


def _cholesky_solve(chol: np.ndarray, b: np.ndarray) -> np.ndarray:
    """K^-1 b from the lower factor of K (LAPACK potrs, as scipy's cho_solve, without its checks)."""
    x, info = dpotrs(chol, b, lower=1)
    if info != 0:
        raise ValueError(f"potrs: illegal argument {-info}")
    return x


def _cholesky_inverse(chol: np.ndarray) -> np.ndarray:
    """K^-1 from the lower factor of K: potrs on the identity, what scipy's cho_solve does
    (potri takes 3x longer here: it is not blocked for N = 100)."""
    return _cholesky_solve(chol, np.eye(len(chol)))


def log_marginal_likelihood(log_theta, gram, sq_dist, y) -> tuple[float, np.ndarray]:
    """Multi-output log marginal likelihood (E.15)-(E.16) and its gradient w.r.t. log theta (E.9).

    gram: (N, N) X X^T; sq_dist: (N, N) squared distances; y: (N, m) targets.
    """
    value, gradient, _ = _log_marginal_likelihood(log_theta, gram, sq_dist, y)
    return value, gradient


def _log_marginal_likelihood(log_theta, gram, sq_dist, y):
    """`log_marginal_likelihood` and the factorisation it made: (k, chol, alpha, K^-1), with k
    the factored matrix K + (theta4 + 1e-8) I, or None when K is not positive definite."""
    theta1, theta2, theta3, theta4 = np.exp(log_theta)
    n, m = y.shape
    rbf = np.exp(-0.5 * theta2 * sq_dist)
    k = theta1 * gram + theta3 * rbf
    k[np.diag_indices(n)] += theta4 + 1e-8
    try:
        chol = _cholesky_lower(k)
    except np.linalg.LinAlgError:
        return -1e25, np.zeros(4), None
    alpha = _cholesky_solve(chol, y)
    value = -0.5 * np.sum(y * alpha) - m * np.log(np.diag(chol)).sum() - 0.5 * n * m * np.log(2 * np.pi)
    k_inv = _cholesky_inverse(chol)
    inner = alpha @ alpha.T - m * k_inv
    gradient = 0.5 * np.array([
        np.sum(inner * gram) * theta1,
        np.sum(inner * rbf * sq_dist) * (-0.5 * theta2 * theta3),
        np.sum(inner * rbf) * theta3,
        np.trace(inner) * theta4,
    ])
    return value, gradient, (k, chol, alpha, k_inv)


def fit_hyperparameters(x, y, initial_theta, max_iter: int = 15) -> np.ndarray:
    """Hyperparameters of (8.7) maximising (E.16) by L-BFGS-B in log space, from initial_theta."""
    return _fit_hyperparameters(x, y, initial_theta, max_iter)[0]


def _fit_hyperparameters(x, y, initial_theta, max_iter: int = 15):
    """`fit_hyperparameters` and the factorisation (k, chol, alpha, K^-1) of its last objective
    evaluation (None without one), which is usually the one at the optimum: `_factor` reuses it."""
    gram = x @ x.T
    sq_norm = np.einsum("ij,ij->i", x, x)
    sq_dist = np.maximum(sq_norm[:, None] + sq_norm[None, :] - 2.0 * gram, 0.0)
    start = np.log(np.clip(initial_theta, THETA_BOUNDS[:, 0], THETA_BOUNDS[:, 1]))
    if max_iter <= 0:
        return np.exp(start), None
    last = [None]

    def objective(log_theta):
        value, gradient, last[0] = _log_marginal_likelihood(log_theta, gram, sq_dist, y)
        return -value, -gradient

    from scipy.optimize import minimize

    result = minimize(objective, start, method="L-BFGS-B", jac=True, bounds=np.log(THETA_BOUNDS),
                      options={"maxiter": int(max_iter)})
    return np.exp(result.x), last[0]


def _factor(xs, ys, theta, last=None):
    """(alpha, K^-1) of the GP on standardised xs (N, D), ys (N, m) with hyperparameters theta:
    K = (8.7)(xs, xs) + (theta4 + 1e-8) I by `kernel_8_7`, factored by potrf. `last`, the
    factorisation of the hyperparameter fit's last evaluation (`_fit_hyperparameters`), is reused
    when its matrix is bit for bit this K (its alpha and K^-1 are then the same bits too); else
    K is factored afresh, the reference (the fit builds K from its own squared norms, so the
    bits differ in ~6% of the refits of box_pcb_coexistence)."""
    k = kernel_8_7(xs, xs, theta)
    k[np.diag_indices(len(xs))] += theta[3] + 1e-8
    if last is not None and np.array_equal(k, last[0]):
        return last[2], last[3]
    chol = _cholesky_lower(k)
    return _cholesky_solve(chol, ys), _cholesky_inverse(chol)


def _derivative_scale(values: np.ndarray) -> np.ndarray:
    """One scale per derivative order (q, q', q'') over all joints and lags of a group.

    values: (N, F) with features ordered (..., joint, derivative). A per-feature scale would
    blow the noise of a still joint up to the size of a moving one.
    """
    by_order = values.reshape(len(values), -1, 3)
    spread = by_order.std(axis=0)  # (F / 3, 3)
    scale = np.sqrt((spread**2).mean(axis=0))  # rms over joints and lags
    # Floor at a measurement-noise size: a still group keeps still rollouts, not unit noise.
    scale = np.maximum(scale, _SCALE_FLOOR)
    return np.tile(scale, by_order.shape[1])


class GPMotionModel:
    """h_GP of eq. (8.4)-(8.5): one multi-output GP per joint group, of order P.

    groups: joint index tuples (or "gp_a" | "gp_b" | "gp_c", the models A, B, C of 8.1.2).
    order: P, the number of past states a prediction looks at.
    max_samples: fixed size of the training set (100 in 8.1.3).
    max_iter: L-BFGS iterations per refit; the previous hyperparameters are the start point,
        so a few iterations track a slowly changing optimum.
    hyperparameter_every: re-optimise the hyperparameters at every k-th refit only, reusing them
        (with the new training set) in between. A variant: 8.1.3 recomputes them at every
        refresh (k = 1, the default); larger k trades the refits' L-BFGS time for kernels that
        lag the training set (see tools/bench_motion.py --sweep-hyperparameters).
    random_state: seed or Generator for choosing which samples to replace.

    Learned attributes (after `fit`/`partial_fit`): X_ (N, P, n_dof, 3) inputs, Y_ (N, n_dof, 3)
    targets of the training set, theta_ (G, 4) kernel hyperparameters per group.
    """

    def __init__(self, groups="gp_c", order: int = 4, n_dof: int = N_DOF, max_samples: int = 100,
                 max_iter: int = 15, initial_theta=(0.1, 0.1, 1.0, 0.01), random_state=None,
                 hyperparameter_every: int = 1):
        if isinstance(groups, str):
            if groups not in MODEL_GROUPS:
                raise ValueError(f"GPMotionModel: unknown model {groups!r}; "
                                 f"use one of {sorted(MODEL_GROUPS)}")
            groups = MODEL_GROUPS[groups]
        groups = tuple(tuple(int(j) for j in g) for g in groups)
        used = [j for g in groups for j in g]
        if not groups or any(len(g) == 0 for g in groups):
            raise ValueError("GPMotionModel: groups must be non-empty tuples of joint indices")
        if sorted(used) != list(range(n_dof)):
            raise ValueError(f"GPMotionModel: groups {groups} must cover joints 0..{n_dof - 1} exactly once")
        if int(order) != order or order < 1:
            raise ValueError(f"GPMotionModel: order must be a positive integer, got {order!r}")
        if int(max_samples) != max_samples or max_samples < 2:
            raise ValueError(f"GPMotionModel: max_samples must be an integer >= 2, got {max_samples!r}")
        self.groups = groups
        self.order = int(order)
        self.n_dof = int(n_dof)
        self.max_samples = int(max_samples)
        self.max_iter = int(max_iter)
        if int(hyperparameter_every) != hyperparameter_every or hyperparameter_every < 1:
            raise ValueError(f"GPMotionModel: hyperparameter_every must be an integer >= 1, "
                             f"got {hyperparameter_every!r}")
        self.hyperparameter_every = int(hyperparameter_every)
        self.initial_theta = tuple(float(v) for v in initial_theta)
        for name, value in zip(("theta1", "theta2", "theta3", "theta4"), self.initial_theta, strict=True):
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"GPMotionModel: initial {name} must be a positive number, got {value!r}")
        self.random_state = random_state

    def clone(self, rng: np.random.Generator | None = None) -> GPMotionModel:
        """A copy for copy-on-write state. Training never writes an array in place (it builds new
        ones), so the copy shares the training set and the fitted buckets; its generator is
        `rng`, else a copy of this model's."""
        new = shallow_copy(self)
        if hasattr(self, "_rng"):
            new._rng = rng if rng is not None else clone_generator(self._rng)
            if self.random_state is self._rng:
                new.random_state = new._rng
        return new

    # ---------------------------------------------------------------- training
    def _check_windows(self, windows) -> np.ndarray:
        windows = np.asarray(windows, dtype=float)
        expected = (self.order + 1, self.n_dof, 3)
        if windows.ndim != 4 or windows.shape[1:] != expected:
            raise ValueError(
                f"GPMotionModel: windows must be (S, {expected[0]}, {expected[1]}, 3) (P + 1 consecutive "
                f"states, oldest first), got {windows.shape}"
            )
        if not np.all(np.isfinite(windows)):
            raise ValueError("GPMotionModel: windows contain NaN or inf")
        return windows

    def fit(self, windows) -> GPMotionModel:
        """Train on sample windows (S, P+1, n_dof, 3): states k-P .. k, oldest first (eq. 8.13).

        Keeps at most `max_samples` of them (a uniform random subset).
        """
        windows = self._check_windows(windows)
        if len(windows) < 2:
            raise ValueError(f"GPMotionModel.fit: need at least 2 sample windows, got {len(windows)}")
        self._rng = np.random.default_rng(self.random_state)
        if len(windows) > self.max_samples:
            windows = windows[np.sort(self._rng.choice(len(windows), self.max_samples, replace=False))]
        self.X_ = windows[:, :-1].copy()
        self.Y_ = windows[:, -1].copy()
        self.theta_ = np.tile(np.array(self.initial_theta), (len(self.groups), 1))
        self.n_refits_ = 0
        self._refit()
        return self

    def partial_fit(self, windows) -> GPMotionModel:
        """Add new sample windows and refit (8.1.3): the set grows to `max_samples`, then each
        new sample replaces a uniformly chosen old one (recent and remote past both stay)."""
        windows = self._check_windows(windows)
        if not hasattr(self, "X_"):
            return self.fit(windows)
        if len(windows) == 0:
            return self
        new_x, new_y = windows[:, :-1], windows[:, -1]
        room = self.max_samples - len(self.X_)
        old = len(self.X_)
        if room > 0:
            take = min(room, len(new_x))
            self.X_ = np.concatenate([self.X_, new_x[:take]])
            self.Y_ = np.concatenate([self.Y_, new_y[:take]])
            new_x, new_y = new_x[take:], new_y[take:]
        if len(new_x):
            if len(new_x) > old:
                new_x, new_y = new_x[-old:], new_y[-old:]
            slots = self._rng.choice(old, len(new_x), replace=False)  # only samples older than this call
            # New arrays, never in place: a clone (copy-on-write state) may share the old ones.
            self.X_, self.Y_ = self.X_.copy(), self.Y_.copy()
            self.X_[slots] = new_x
            self.Y_[slots] = new_y
        self._refit()
        return self

    def _group_data(self, g: int):
        joints = list(self.groups[g])
        n = len(self.X_)
        x = self.X_[:, ::-1][:, :, joints, :].reshape(n, -1)  # phi_{k-1}, ..., phi_{k-P}
        y = self.Y_[:, joints, :].reshape(n, -1)
        return x, y

    def _refit(self) -> None:
        with _single_thread():
            self._refit_groups()

    def _refit_groups(self) -> None:
        n = len(self.X_)
        self.theta_ = self.theta_.copy()  # written below; a clone may share the old one
        optimise = self.n_refits_ % self.hyperparameter_every == 0
        self.n_refits_ += 1
        buckets: dict[int, list[int]] = {}
        for g, joints in enumerate(self.groups):
            buckets.setdefault(len(joints), []).append(g)
        self.buckets_ = []
        for size, members in buckets.items():
            d_in, d_out = 3 * size * self.order, 3 * size
            x_train = np.empty((len(members), n, d_in))
            alpha = np.empty((len(members), n, d_out))
            k_inv = np.empty((len(members), n, n))
            x_mean = np.empty((len(members), d_in))
            x_std = np.empty((len(members), d_in))
            y_mean = np.empty((len(members), d_out))
            y_std = np.empty((len(members), d_out))
            for i, g in enumerate(members):
                x, y = self._group_data(g)
                x_mean[i], y_mean[i] = x.mean(0), y.mean(0)
                x_std[i] = _derivative_scale(x)
                y_std[i] = _derivative_scale(y)
                xs = (x - x_mean[i]) / x_std[i]
                ys = (y - y_mean[i]) / y_std[i]
                last = None
                if optimise:
                    self.theta_[g], last = _fit_hyperparameters(xs, ys, self.theta_[g], self.max_iter)
                x_train[i] = xs
                alpha[i], k_inv[i] = _factor(xs, ys, self.theta_[g], last)
            self.buckets_.append({
                "members": members, "joints": np.array([self.groups[g] for g in members]),
                "x_train": x_train, "x_train_sq": (x_train**2).sum(-1), "alpha": alpha, "k_inv": k_inv,
                "theta": self.theta_[members],
                "x_mean": x_mean, "x_std": x_std, "y_mean": y_mean, "y_std": y_std,
            })

    @property
    def n_samples_(self) -> int:
        return len(self.X_)

    def _check_fitted(self, where: str) -> None:
        if not hasattr(self, "buckets_"):
            raise ValueError(f"GPMotionModel.{where}: the model is not fitted yet (call fit or partial_fit)")

    # ---------------------------------------------------------------- prediction
    def _predict_bucket(self, bucket, inputs):
        """Mean and variance (E.6) of the standardised outputs for raw inputs (G, T, d_in)."""
        xs = (inputs - bucket["x_mean"][:, None]) / bucket["x_std"][:, None]
        theta = bucket["theta"]
        xs_sq = (xs**2).sum(-1)
        k_x = kernel_8_7(xs, bucket["x_train"], theta, xs_sq, bucket["x_train_sq"])  # (G, T, N)
        mean = k_x @ bucket["alpha"]  # (G, T, d_out)
        k_xx = theta[:, 0, None] * xs_sq + theta[:, 2, None] + theta[:, 3, None]
        explained = ((k_x @ bucket["k_inv"]) * k_x).sum(-1)
        return mean, np.maximum(k_xx - explained, 0.0)

    def predict(self, history, return_std: bool = False):
        """Mean next state phi_k (n_dof, 3) from `history` (P, n_dof, 3), oldest first (E.18).

        With return_std, also the predictive standard deviation (n_dof, 3) of (E.17).
        """
        self._check_fitted("predict")
        history = np.asarray(history, dtype=float)
        if history.shape != (self.order, self.n_dof, 3) or not np.all(np.isfinite(history)):
            raise ValueError(f"GPMotionModel.predict: history must be finite "
                             f"({self.order}, {self.n_dof}, 3), got {history.shape}")
        out = np.empty((self.n_dof, 3))
        std = np.empty((self.n_dof, 3))
        for bucket in self.buckets_:
            joints = bucket["joints"]  # (G, s)
            inputs = history[::-1][:, joints, :]  # (P, G, s, 3)
            inputs = inputs.transpose(1, 0, 2, 3).reshape(len(joints), 1, -1)
            mean, var = self._predict_bucket(bucket, inputs)
            y = mean[:, 0] * bucket["y_std"] + bucket["y_mean"]
            out[joints] = y.reshape(joints.shape + (3,))
            s = np.sqrt(var[:, 0, None]) * bucket["y_std"]
            std[joints] = s.reshape(joints.shape + (3,))
        return (out, std) if return_std else out

    def sample_rollouts(self, history, steps: int, n_trials: int, rng) -> np.ndarray:
        """Monte Carlo trials of eq. (8.8): T sampled futures of M steps from `history`.

        history: (P, n_dof, 3) the last P filtered states, oldest first; each step draws
        phi~_{k+l} from the predictive Gaussian (E.17) given the previous P (sampled) states.
        Returns q~ (T, M, n_dof), the joint positions along every trial.
        """
        self._check_fitted("sample_rollouts")
        history = np.asarray(history, dtype=float)
        if history.shape != (self.order, self.n_dof, 3) or not np.all(np.isfinite(history)):
            raise ValueError(f"sample_rollouts: history must be finite ({self.order}, {self.n_dof}, 3), "
                             f"got {history.shape}")
        if int(steps) != steps or steps < 1 or int(n_trials) != n_trials or n_trials < 1:
            raise ValueError(f"sample_rollouts: steps and n_trials must be positive integers, "
                             f"got {steps}, {n_trials}")
        rng = np.random.default_rng(rng)
        with _single_thread():
            return self._rollouts(history, int(steps), int(n_trials), rng)

    def _rollouts(self, history, steps, n_trials, rng):
        """The trials of `sample_rollouts`, compiled (`_kernels.gp_rollouts`): the same normal
        draws in the same order as `_rollouts_numpy`, the reference."""
        positions = np.empty((n_trials, steps, self.n_dof))
        for bucket in self.buckets_:
            joints = bucket["joints"]  # (G, s)
            n_groups, size = joints.shape
            past = history[:, joints, :].transpose(1, 0, 2, 3).reshape(n_groups, self.order, 3 * size)
            noise = rng.standard_normal((steps, n_groups, n_trials, 3 * size))
            states = _kernels.gp_rollouts(past, noise, bucket)  # (M, G, T, 3 s)
            q = states.reshape(steps, n_groups, n_trials, size, 3)[..., 0]  # (M, G, T, s)
            positions[:, :, joints.reshape(-1)] = q.transpose(2, 0, 1, 3).reshape(n_trials, steps, -1)
        return positions

    def _rollouts_numpy(self, history, steps, n_trials, rng):
        """The trials of `sample_rollouts` as numpy operations on all trials at once (the
        reference of the compiled `_rollouts`)."""
        positions = np.empty((n_trials, steps, self.n_dof))
        for bucket in self.buckets_:
            joints = bucket["joints"]  # (G, s)
            n_groups, size = joints.shape
            # past: (G, T, P, 3 s), newest last
            past = history[:, joints, :].transpose(1, 0, 2, 3).reshape(n_groups, 1, self.order, 3 * size)
            first_mean, first_var = self._predict_bucket(bucket, past[:, :, ::-1].reshape(n_groups, 1, -1))
            past = np.repeat(past, n_trials, axis=1)
            for step in range(steps):
                if step == 0:  # every trial starts from the same history: one prediction serves all
                    mean = np.broadcast_to(first_mean, (n_groups, n_trials, first_mean.shape[-1]))
                    var = np.broadcast_to(first_var, (n_groups, n_trials))
                else:
                    inputs = past[:, :, ::-1].reshape(n_groups, n_trials, -1)
                    mean, var = self._predict_bucket(bucket, inputs)
                noise = rng.standard_normal(mean.shape)
                standardised = mean + np.sqrt(var)[..., None] * noise
                nxt = standardised * bucket["y_std"][:, None] + bucket["y_mean"][:, None]
                past = np.concatenate([past[:, :, 1:], nxt[:, :, None]], axis=2)
                q = nxt.reshape(n_groups, n_trials, size, 3)[..., 0]  # (G, T, s)
                positions[:, step, joints.reshape(-1)] = q.transpose(1, 0, 2).reshape(n_trials, -1)
        return positions
