"""STOMP path optimisation and the proactive path cost of thesis 8.2.3 (no Drake).

`stomp` is Stochastic Trajectory Optimization for Motion Planning (Kalakrishnan, Chitta,
Theodorou, Pastor, Schaal, ICRA 2011, Table 1) over a joint path of N+1 waypoints q_0..q_N
whose end points are fixed (thesis footnote 4): it minimises eq. (8.31), sum_k J(q_k) over the
N-1 interior waypoints, plus the paper's control cost 1/2 theta^T R theta. `ProactiveCost` is
J(q_k) of eq. (8.32): obstacle penetration + lambda1 * repulsion of the GPDM probability cloud
+ lambda2 * deviation from the nominal path. `plan_proactive_path` runs STOMP from the nominal
path. Kinematics enters as callables, so the core knows no robot (e.g. `SerialChain.capsules`).

Array axes: n joints; W = N-1 interior waypoints; K rollouts; C capsules; B boxes; T control
points; g cloud points.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

#: cost callable: a batch of interior paths (K, W, n) -> per-waypoint costs (K, W)
PathCost = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class StompResult:
    """Result of `stomp`.

    path: (N+1, n) the cheapest path seen (end points as given); costs: (iterations+1,) total
    cost of the iterate before each update and after the last (costs[0]: initial path);
    best_cost: total cost of `path`; iterations: updates made; converged: stopped by `tol`.
    """

    path: np.ndarray
    costs: np.ndarray
    best_cost: float
    iterations: int
    converged: bool


def acceleration_matrix(num_free: int) -> np.ndarray:
    """Finite-difference matrix A (W, W): (A theta + b)_i = q_{i-1} - 2 q_i + q_{i+1}, i = 1..N-1."""
    return -2.0 * np.eye(num_free) + np.eye(num_free, k=1) + np.eye(num_free, k=-1)


def _accelerations(A: np.ndarray, theta: np.ndarray, q0: np.ndarray, qN: np.ndarray) -> np.ndarray:
    """Second differences (..., W, n) of interior waypoints theta (..., W, n) between fixed q0 and qN."""
    acc = np.einsum("ij,...jn->...in", A, theta)
    acc[..., 0, :] += q0
    acc[..., -1, :] += qN
    return acc


def _smoothing(num_free: int) -> tuple[np.ndarray, np.ndarray]:
    """(L, M): Cholesky factor of R^-1 / max(R^-1) (noise) and M = R^-1, columns scaled to max 1/W."""
    A = acceleration_matrix(num_free)
    R_inv = np.linalg.inv(A.T @ A)
    L = np.linalg.cholesky(R_inv / R_inv.max())
    M = R_inv / (num_free * R_inv.max(axis=0, keepdims=True))
    return L, M


def _limits(joint_limits, n: int) -> tuple[np.ndarray, np.ndarray]:
    if joint_limits is None:
        return np.full(n, -np.inf), np.full(n, np.inf)
    lower, upper = (np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in joint_limits)
    if np.any(lower > upper):
        raise ValueError(f"joint limits: lower {lower} above upper {upper}")
    return lower, upper


def _check_options(initial_path, n_rollouts: int, max_iterations: int, patience: int, h: float) -> np.ndarray:
    """The initial path as a float array (N+1, n), after checking the options of `stomp`."""
    path = np.array(initial_path, dtype=float)
    if path.ndim != 2 or path.shape[0] < 3 or not np.all(np.isfinite(path)):
        raise ValueError(f"initial_path must be a finite (N+1, n) array with N >= 2, got {path.shape}")
    if n_rollouts < 1 or max_iterations < 0 or patience < 1 or not h > 0:
        raise ValueError(f"stomp: need n_rollouts >= 1, max_iterations >= 0, patience >= 1, h > 0; got "
                         f"{n_rollouts}, {max_iterations}, {patience}, {h}")
    return path


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


def stomp(
    initial_path,
    cost: PathCost,
    joint_limits: tuple[Sequence[float], Sequence[float]] | None = None,
    rng: int | np.random.Generator | None = None,
    *,
    n_rollouts: int = 10,
    max_iterations: int = 50,
    noise_std: float | Sequence[float] = 0.1,
    h: float = 10.0,
    control_cost_weight: float = 0.0,
    noise_decay: float = 1.0,
    tol: float = 1e-3,
    patience: int = 10,
) -> StompResult:
    """STOMP (Kalakrishnan et al. 2011, Table 1) of `initial_path` (N+1, n), end points fixed.

    Per iteration: K = n_rollouts noisy paths theta + eps_k, eps_k ~ N(0, R^-1) (R = A^T A,
    `acceleration_matrix`; R^-1 normalised to max 1, so noise_std (scalar or (n,)) is the std
    of the most mobile waypoint) times noise_decay^iteration, clipped to joint_limits (lower
    (n,), upper (n,)); S (K, W) = cost(paths) + control_cost_weight * 1/2 ||(A theta + b)_i||^2
    (the paper's S is the state cost alone: control_cost_weight=0);
    P = exp(-h (S - min_k S) / (max_k S - min_k S)) normalised over k; theta += M sum_k P eps_k
    (M = R^-1, each column scaled to max 1/W), clipped. The total cost, eq. (8.31) plus the
    paper's 1/2 theta^T R theta (with the end points' terms), of the iterate is evaluated in the
    same batch as the rollouts; the run stops when the best cost improved by less than tol
    (relative) over `patience` iterations, or after max_iterations. rng: seed or Generator.
    """
    path = _check_options(initial_path, n_rollouts, max_iterations, patience, h)
    num_free, n = path.shape[0] - 2, path.shape[1]
    lower, upper = _limits(joint_limits, n)
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    std = np.broadcast_to(np.asarray(noise_std, dtype=float), (n,)).copy()
    A = acceleration_matrix(num_free)
    L, M = _smoothing(num_free)
    q0, qN = path[0], path[-1]

    def costs_of(batch):  # (K, W, n) -> (K, W), state cost plus control cost per waypoint
        S = np.asarray(cost(batch), dtype=float).reshape(batch.shape[:2])
        if control_cost_weight:
            S = S + control_cost_weight * 0.5 * np.square(_accelerations(A, batch, q0, qN)).sum(-1)
        return S

    theta = np.clip(path[1:-1], lower, upper)
    history, best_theta, best_cost, converged, iterations = [], theta, np.inf, False, 0
    for iterations in range(max_iterations + 1):
        if iterations == max_iterations:  # the last update's result, evaluated alone
            history.append(float(costs_of(theta[None]).sum()))
            rollouts = None
        else:
            eps = std * np.einsum("ij,kjn->kin", L, rng.standard_normal((n_rollouts, num_free, n)))
            rollouts = np.clip(theta + eps, lower, upper)
            S = costs_of(np.concatenate([theta[None], rollouts]))
            history.append(float(S[0].sum()))
        if history[-1] < best_cost:
            best_theta, best_cost = theta, history[-1]
        if rollouts is None:
            break
        if _stalled(history, patience, tol):
            converged = True
            break
        theta = np.clip(theta + M @ _weighted_noise(S[1:], rollouts - theta, h), lower, upper)
        std = std * noise_decay
    best = np.concatenate([q0[None], best_theta, qN[None]])
    return StompResult(_frozen(best), _frozen(history), float(best_cost), iterations, converged)


def _weighted_noise(S: np.ndarray, eps: np.ndarray, h: float) -> np.ndarray:
    """sum_k P_k,i eps_k,i (W, n), P = exp(-h (S - min S)/(max S - min S)) normalised per waypoint."""
    low, high = S.min(axis=0), S.max(axis=0)
    span = np.where(high - low > 0, high - low, 1.0)
    P = np.exp(-h * (S - low) / span)
    P /= P.sum(axis=0)
    return np.einsum("ki,kin->in", P, eps)


def _stalled(history: list[float], patience: int, tol: float) -> bool:
    """Best cost improved by less than tol * |best| over the last `patience` evaluations."""
    if len(history) <= patience:
        return False
    before, now = min(history[:-patience]), min(history)
    return before - now <= tol * abs(before)


@dataclass(frozen=True)
class Box:
    """A fixed box obstacle: centre (3,) m, half_extents (3,) m, rotation (3, 3) R_WB (box axes in world)."""

    centre: Sequence[float]
    half_extents: Sequence[float]
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        for name, shape in (("centre", (3,)), ("half_extents", (3,)), ("rotation", (3, 3))):
            value = np.array(getattr(self, name), dtype=float)
            if value.shape != shape or not np.all(np.isfinite(value)):
                raise ValueError(f"Box.{name}: expected finite {shape}, got {getattr(self, name)!r}")
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        if np.any(self.half_extents < 0):
            raise ValueError(f"Box.half_extents must be >= 0, got {self.half_extents}")


def _candidate_parameters(o: np.ndarray, d: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Parameters s (..., 49) holding the minimiser of the convex sd(o + s d) (box frame, half sizes h)."""
    safe = np.where(np.abs(d) > 1e-15, d, np.inf)
    faces = np.concatenate([(h - o) / safe, (-h - o) / safe, -o / safe], axis=-1)  # p_i = +-h_i, 0
    crossings = []  # inside pieces: s_i (o_i + s d_i) - h_i = s_j (o_j + s d_j) - h_j
    for i, j in ((0, 1), (0, 2), (1, 2)):
        for si in (1.0, -1.0):
            for sj in (1.0, -1.0):
                den = si * d[..., i] - sj * d[..., j]
                num = h[..., i] - h[..., j] - si * o[..., i] + sj * o[..., j]
                crossings.append(num / np.where(np.abs(den) > 1e-15, den, np.inf))
    E = np.array([e for e in np.ndindex(3, 3, 3) if e != (1, 1, 1)], dtype=float) - 1.0  # (26, 3)
    # outside pieces (axis i beyond face e_i h_i for e_i != 0): stationary s of sum (p_i - e_i h_i)^2
    num = -(o * d) @ np.abs(E).T + (h * d) @ E.T
    den = (d * d) @ np.abs(E).T
    pieces = num / np.where(den > 1e-30, den, np.inf)
    ends = np.zeros((*o.shape[:-1], 2))
    ends[..., 1] = 1.0
    return np.clip(np.concatenate([ends, faces, np.stack(crossings, -1), pieces], -1), 0.0, 1.0)


def _box_frame(starts, ends, boxes: Sequence[Box]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Segments (..., C, 3) in the box frames: start o, direction d, half sizes h, each (..., C, B, 3)."""
    starts, ends = np.asarray(starts, dtype=float), np.asarray(ends, dtype=float)
    c = np.array([b.centre for b in boxes], dtype=float).reshape(-1, 3)
    h = np.array([b.half_extents for b in boxes], dtype=float).reshape(-1, 3)
    R = np.array([b.rotation for b in boxes], dtype=float).reshape(-1, 3, 3)
    o = np.einsum("bij,...bi->...bj", R, starts[..., None, :] - c)
    d = np.einsum("bij,...bi->...bj", R, (ends - starts)[..., None, :])
    return o, d, np.broadcast_to(h, o.shape)


def _exact_signed_distance(o: np.ndarray, d: np.ndarray, h: np.ndarray) -> np.ndarray:
    """min over s in [0, 1] of the box signed distance of o + s d (..., 3), boxes of half sizes h."""
    s = _candidate_parameters(o, d, h)  # (..., 49)
    q = np.abs(o[..., None, :] + s[..., None] * d[..., None, :]) - h[..., None, :]
    sd = np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)
    return sd.min(axis=-1)


def segment_box_signed_distance(starts, ends, boxes: Sequence[Box]) -> np.ndarray:
    """Exact signed distance (..., C, B) of segments (..., C, 3) to boxes (negative: penetration).

    sd(p) = ||max(|p| - h, 0)|| + min(max_i(|p_i| - h_i), 0) in the box frame is convex, so along
    a segment it is a convex piecewise function of s in [0, 1]; its minimum lies at an end point,
    a piece boundary (|p_i| = h_i, p_i = 0, equal face distances inside) or a stationary point of
    an outside piece. All 49 candidates are evaluated (exact, no sampling).
    """
    return _exact_signed_distance(*_box_frame(starts, ends, boxes))


def capsule_box_penetration(starts, ends, radii, boxes: Sequence[Box]) -> np.ndarray:
    """Penetration depth (..., C, B) of capsules into boxes: max(0, radius - sd(segment, box)), exact.

    Pairs whose slab bound max_i(min_s |p_i(s)| - h_i) <= sd already clears the radius skip the
    exact `segment_box_signed_distance`.
    """
    radii = np.asarray(radii, dtype=float)
    if not boxes:
        return np.zeros((*np.shape(starts)[:-1], 0))
    o, d, h = _box_frame(starts, ends, boxes)
    crosses = o * (o + d) <= 0.0
    bound = (np.where(crosses, 0.0, np.minimum(np.abs(o), np.abs(o + d))) - h).max(axis=-1)
    depth = np.zeros(bound.shape)
    near = bound < radii[:, None]
    if np.any(near):
        r = np.broadcast_to(radii[:, None], bound.shape)[near]
        depth[near] = np.maximum(r - _exact_signed_distance(o[near], d[near], h[near]), 0.0)
    return depth


def repulsive_potential(points, cloud, gamma, alpha: float, cutoff: float | None = None,
                        chunk: int = 1 << 15, dtype=np.float64) -> np.ndarray:
    """Potential sum_j gamma_j exp(-alpha ||p_j - t||) (...,) of the cloud at points t (..., 3), eq. (8.32).

    cloud: (g, 3) points p_Cj; gamma: (g,) their weights. Default: every pair, in row chunks of
    about `chunk` pairs, with alpha^2 ||p - t||^2 from one matrix product of augmented coordinates
    (exact up to ~1e-7 relative rounding at coincident points). dtype=np.float32 halves the time at
    ~1e-6 relative error. cutoff (m): only pairs closer than cutoff (scipy k-d tree), an error below
    sum(gamma) exp(-alpha cutoff) per point; it pays only when few pairs are that close (738 points x
    3286 cloud points: all pairs 7 ms, cutoff 0.3 m 10 ms, 0.15 m 3 ms).
    """
    points = np.asarray(points, dtype=float)
    flat = points.reshape(-1, 3)
    cloud, gamma = np.asarray(cloud, dtype=float).reshape(-1, 3), np.asarray(gamma, dtype=float).reshape(-1)
    if cutoff is not None:
        from scipy.spatial import cKDTree

        pairs = cKDTree(flat).sparse_distance_matrix(cKDTree(cloud), cutoff, output_type="ndarray")
        out = np.bincount(pairs["i"], gamma[pairs["j"]] * np.exp(-alpha * pairs["v"]), len(flat))
        return out.reshape(points.shape[:-1])
    ones_t, ones_c = np.ones((len(flat), 1)), np.ones((len(cloud), 1))
    T = np.concatenate([flat, ones_t, np.einsum("mi,mi->m", flat, flat)[:, None]], 1).astype(dtype)
    C = alpha**2 * np.concatenate([-2.0 * cloud, np.einsum("gi,gi->g", cloud, cloud)[:, None], ones_c], 1)
    C, weights = C.T.astype(dtype), gamma.astype(dtype)
    out = np.empty(len(flat))
    rows = max(1, chunk // max(len(cloud), 1))
    for a in range(0, len(flat), rows):  # chunks of points that stay in cache
        e = T[a:a + rows] @ C  # alpha^2 ||t - p||^2, (rows, g)
        np.maximum(e, 0.0, out=e)
        np.sqrt(e, out=e)
        np.negative(e, out=e)
        np.exp(e, out=e)
        out[a:a + rows] = e @ weights
    return out.reshape(points.shape[:-1])


class ProactiveCost:
    """Per-waypoint proactive cost J(q_k) of eq. (8.32), batched: (..., W, n) -> (..., W).

    J = J_Ob + lambda1 J_Rep + lambda2 J_Diff with
      J_Ob   sum over capsules c and boxes b of max(0, r_c - sd(segment_c, b)) (exact segment-box
             signed distance, `segment_box_signed_distance`);
      J_Rep  sum over control points t (points_fn) and cloud points of gamma_j exp(-alpha ||p_j - t||);
      J_Diff ||q_nominal_k - q_k||_2.
    capsules_fn(Q (..., n)) -> (starts (..., C, 3), ends (..., C, 3), radii (C,)); points_fn(Q) ->
    (..., T, 3), e.g. `SerialChain.capsules` and `SerialChain.points`. nominal_path: (N+1, n),
    whose interior waypoints q_nominal_1..N-1 J_Diff compares against; cloud_points (g, 3) and
    cloud_gamma (g,): the weighted cloud of eq. (8.30); cutoff, chunk, dtype: see `repulsive_potential`.
    """

    def __init__(self, capsules_fn, points_fn, nominal_path, cloud_points, cloud_gamma,
                 boxes: Sequence[Box] = (), lambda1: float = 1.0, lambda2: float = 1.0, alpha: float = 10.0,
                 cutoff: float | None = None, chunk: int = 1 << 15, dtype=np.float64):
        self.capsules_fn, self.points_fn = capsules_fn, points_fn
        self.nominal = np.array(nominal_path, dtype=float)[1:-1]
        self.cloud_points = np.asarray(cloud_points, dtype=float).reshape(-1, 3)
        self.cloud_gamma = np.asarray(cloud_gamma, dtype=float).reshape(-1)
        if len(self.cloud_points) != len(self.cloud_gamma):
            raise ValueError(f"{len(self.cloud_points)} cloud points but {len(self.cloud_gamma)} weights")
        keep = self.cloud_gamma != 0.0  # points of zero weight add nothing: drop them (exact)
        self.cloud_points, self.cloud_gamma = self.cloud_points[keep], self.cloud_gamma[keep]
        self.boxes = tuple(boxes)
        self.lambda1, self.lambda2, self.alpha = float(lambda1), float(lambda2), float(alpha)
        self.cutoff, self.chunk, self.dtype = cutoff, chunk, dtype

    def terms(self, Q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J_Ob, J_Rep, J_Diff), each (..., W), unweighted, for interior paths Q (..., W, n)."""
        Q = np.asarray(Q, dtype=float)
        if Q.shape[-2:] != self.nominal.shape:
            raise ValueError(f"paths must be (..., W, n) = (..., {', '.join(map(str, self.nominal.shape))}), "
                             f"got {Q.shape}")
        starts, ends, radii = self.capsules_fn(Q)
        j_ob = capsule_box_penetration(starts, ends, radii, self.boxes).sum(axis=(-2, -1))
        potential = repulsive_potential(self.points_fn(Q), self.cloud_points, self.cloud_gamma,
                                        self.alpha, self.cutoff, self.chunk, self.dtype)
        j_diff = np.linalg.norm(Q - self.nominal, axis=-1)
        return j_ob, potential.sum(axis=-1), j_diff

    def __call__(self, Q) -> np.ndarray:
        j_ob, j_rep, j_diff = self.terms(Q)
        return j_ob + self.lambda1 * j_rep + self.lambda2 * j_diff

    def total(self, path) -> float:
        """Path cost eq. (8.31), sum of J over the interior waypoints of a path (N+1, n)."""
        return float(self(np.asarray(path, dtype=float)[1:-1]).sum())


def plan_proactive_path(
    nominal_path, cost: PathCost, joint_limits=None, rng=None, **stomp_options
) -> StompResult:
    """Proactive path (thesis 8.2.3): STOMP on eq. (8.31) initialised at the nominal path (N+1, n).

    cost: e.g. a `ProactiveCost` of this nominal path; stomp_options: keywords of `stomp`.
    """
    return stomp(nominal_path, cost, joint_limits, rng, **stomp_options)
