"""Reactive safety core, thesis 8.1: human joint state, excursions, swept volumes.

Pipeline of Fig. 8.4, one `ReactiveMotionPredictor.update` per camera sample:
skeleton points -> q (body-model IK, warm-started) -> Kalman filter on the three-integrator
chain (8.3), each joint with its own IK noise (from the Jacobian at q: a shoulder rotation
next to a straight elbow is barely observable) and its own jerk density (trunk slower than
arms) -> every `refresh_period` the RTS-smoothed window (8.6) refreshes the GP model (8.13)
-> Monte Carlo excursions Delta+/- (8.8)-(8.10), capped by the worst-case bounds of [107]
(also the fallback until the GP holds `min_samples` samples) -> capsules bounding the body
over the horizon (`SweptVolumes`).

Filtering IK jitter matters twice: noisy joint velocities inflate the worst-case bounds, and
a GP trained on jitter predicts jitter; base yaw and torso flexion excursions move every
capsule, so their noise alone can make the swept volumes tens of centimetres too large.
"""

from __future__ import annotations

import time as _time

import numpy as np

from hrc_drake.messages import SweptVolumes, shallow_copy
from hrc_drake.motion.geometry import bounding_capsules
from hrc_drake.motion.gp import MODEL_GROUPS, GPMotionModel
from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter, rts_smooth
from hrc_drake.rng import clone_generator

MOTION_KINDS = ("gp_a", "gp_b", "gp_c", "worst_case")
TRAINING_STATES = ("smoothed", "filtered")
_BASE_TRANSLATION = (0, 1)
_TORSO = (2, 3)  # base yaw and torso flexion
#: Body-model joints of each limit group (`human.body`: 4..7 left arm, 8..11 right arm).
LIMIT_GROUPS = {"base": (0, 1), "yaw": (2,), "torso": (3,), "shoulder": (4, 5, 8, 9),
                "shoulder_rotation": (6, 10), "elbow": (7, 11)}
#: Default human limits of [107]: speeds (rad/s, base m/s) and accelerations (rad/s^2, base m/s^2);
#: sources in `motion.config.WorstCaseMotionModel`.
DEFAULT_SPEEDS = {"base": 1.6, "yaw": 2.3, "torso": 1.7, "shoulder": 3.0, "shoulder_rotation": 5.4,
                  "elbow": 5.4}
DEFAULT_ACCELS = {"base": 3.0, "yaw": 15.0, "torso": 15.0, "shoulder": 15.0, "shoulder_rotation": 15.0,
                  "elbow": 15.0}


def joint_limit_vector(groups: dict) -> np.ndarray:
    """The (12,) per-joint vector of group values {group: value} (every group of `LIMIT_GROUPS`)."""
    missing = set(LIMIT_GROUPS) - set(groups)
    unknown = set(groups) - set(LIMIT_GROUPS)
    if missing or unknown:
        raise ValueError(f"joint_limit_vector: need exactly the groups {sorted(LIMIT_GROUPS)}; "
                         f"missing {sorted(missing)}, unknown {sorted(unknown)}")
    vector = np.empty(12)
    for group, joints in LIMIT_GROUPS.items():
        vector[list(joints)] = float(groups[group])
    return vector


def excursions_from_rollouts(q_now, rollouts, percentile=None) -> tuple[np.ndarray, np.ndarray]:
    """Reachable excursions from Monte Carlo trials, eq. (8.8)-(8.10).

    q_now: (n,) current joint values q_k|k; rollouts: (T, M, n) sampled futures.
    Per trial, Delta~+ = max(0, max_l q~_{k+l} - q_k) and Delta~- = max(0, q_k - min_l q~_{k+l});
    the result is their mean over trials (8.9)-(8.10), or the given percentile (0-100), the
    risk trade-off of Fig. 8.3. Returns (delta_plus (n,), delta_minus (n,)).
    """
    q_now = np.asarray(q_now, dtype=float)
    rollouts = np.asarray(rollouts, dtype=float)
    if rollouts.ndim != 3 or rollouts.shape[2] != q_now.shape[-1] or q_now.ndim != 1:
        raise ValueError(f"excursions_from_rollouts: need q_now (n,) and rollouts (T, M, n); "
                         f"got {q_now.shape} and {rollouts.shape}")
    if not (np.all(np.isfinite(q_now)) and np.all(np.isfinite(rollouts))):
        raise ValueError("excursions_from_rollouts: q_now or rollouts contain NaN or inf")
    plus = np.maximum(rollouts.max(axis=1) - q_now, 0.0)
    minus = np.maximum(q_now - rollouts.min(axis=1), 0.0)
    if percentile is None:
        return plus.mean(axis=0), minus.mean(axis=0)
    if not 0.0 <= percentile <= 100.0:
        raise ValueError(f"excursions_from_rollouts: percentile must be in [0, 100], got {percentile!r}")
    return np.percentile(plus, percentile, axis=0), np.percentile(minus, percentile, axis=0)


def worst_case_excursions(qdot, horizon: float, v_max, a_max) -> tuple[np.ndarray, np.ndarray]:
    """Worst-case reachable excursions of [107]: bounded velocity and acceleration, eq. (8.1).

    From velocity qdot (n,), the joint accelerates at a_max until |qdot| reaches v_max; the
    largest displacement within [0, horizon] is max(0, d(horizon)) because d(t) is convex
    then linear with positive slope. Returns (delta_plus (n,), delta_minus (n,)).
    """
    qdot = np.asarray(qdot, dtype=float)
    v_max = np.broadcast_to(np.asarray(v_max, dtype=float), qdot.shape)
    a_max = np.broadcast_to(np.asarray(a_max, dtype=float), qdot.shape)
    if not np.all(np.isfinite(qdot)):
        raise ValueError("worst_case_excursions: qdot contains NaN or inf")
    if np.any(v_max <= 0) or np.any(a_max <= 0) or not horizon >= 0:
        raise ValueError("worst_case_excursions: v_max and a_max must be positive and horizon >= 0")

    def reach(v0):
        v0 = np.clip(v0, -v_max, v_max)
        t_sat = np.minimum((v_max - v0) / a_max, horizon)
        d = v0 * t_sat + 0.5 * a_max * t_sat**2 + v_max * (horizon - t_sat)
        return np.maximum(d, 0.0)

    return reach(qdot), reach(-qdot)


def _rot_z(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    zero, one = np.zeros_like(angle), np.ones_like(angle)
    rows = [np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)]
    return np.stack(rows, -2)


class SweptVolumeBuilder:
    """Capsules bounding each body capsule over the joint box [q - Delta-, q + Delta+] (8.1.1, Fig. 8.2c).

    The box is sampled on a grid of `levels` values per rotation (torso flexion, the 8 arm
    joints, base yaw); the two arms share a sample index (an arm capsule does not depend on
    the other arm), so every combination a capsule depends on is visited. Forward kinematics
    runs once per (flexion, arm) sample at the origin; base yaw is a rigid rotation of the
    whole body applied to the capsule end points, at the centre of the base translation box.
    Each body capsule's instances are bounded by one capsule (`geometry.bounding_capsules`),
    inflated by `margin`, by the half diagonal of the translation box, and by the largest
    gap between the arc a rotation sweeps and its chord between grid values,
    lever * (1 - cos(step / 2)), summed over the rotations.
    """

    def __init__(self, body, levels: int = 3, margin: float = 0.0):
        if int(levels) != levels or levels < 2:
            raise ValueError(f"SweptVolumeBuilder: levels must be an integer >= 2, got {levels!r}")
        if not margin >= 0:
            raise ValueError(f"SweptVolumeBuilder: margin must be >= 0, got {margin!r}")
        self.body = body
        self.levels = int(levels)
        self.margin = float(margin)
        self.names = tuple(body.CAPSULE_NAMES)
        self._arm_parts = np.array(["arm" in name for name in self.names])
        axis = np.linspace(0.0, 1.0, self.levels)
        arm = np.stack(np.meshgrid(axis, axis, axis, axis, indexing="ij"), -1).reshape(-1, 4)
        flex_index, arm_index = np.meshgrid(np.arange(self.levels), np.arange(len(arm)), indexing="ij")
        self._flex_fraction = axis[flex_index.ravel()]
        self._arm_fraction = arm[arm_index.ravel()]
        # the samples with the first arm value already visit every flexion value
        self._base_only = arm_index.ravel() == 0
        self._axis = axis
        reach = sum(getattr(body, name, 0.5) for name in ("upper_arm", "forearm", "hand_length"))
        torso = getattr(body, "torso", 0.6)
        half_width = 0.5 * getattr(body, "shoulder_width", 0.5)
        head = getattr(body, "neck", 0.3) + 0.06
        # distance of any capsule point from each rotation axis (conservative)
        self._levers = np.concatenate([
            [torso + half_width + reach, torso + head + half_width + reach], np.full(8, reach)])

    def build(self, q, delta_plus, delta_minus) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bounding capsules (start (K, 3), end (K, 3), radius (K,)) for the joint box around q."""
        q = np.asarray(q, dtype=float)
        delta_plus = np.asarray(delta_plus, dtype=float)
        delta_minus = np.asarray(delta_minus, dtype=float)
        if not (q.shape == delta_plus.shape == delta_minus.shape == (12,)):
            raise ValueError(f"SweptVolumeBuilder.build: q, delta_plus, delta_minus must be (12,), got "
                             f"{q.shape}, {delta_plus.shape}, {delta_minus.shape}")
        if not np.all(np.isfinite(np.concatenate([q, delta_plus, delta_minus]))):
            raise ValueError("SweptVolumeBuilder.build: q or excursions contain NaN or inf")
        if np.any(delta_plus < 0) or np.any(delta_minus < 0):
            raise ValueError("SweptVolumeBuilder.build: excursions must be >= 0")
        low = np.maximum(q - delta_minus, self.body.q_lower)
        high = np.minimum(q + delta_plus, self.body.q_upper)
        high = np.maximum(high, low)
        span = high - low
        local = np.zeros((len(self._flex_fraction), 12))
        local[:, 3] = low[3] + self._flex_fraction * span[3]
        local[:, 4:8] = low[4:8] + self._arm_fraction * span[4:8]
        local[:, 8:12] = low[8:12] + self._arm_fraction * span[8:12]
        starts, ends, radius = self.body.capsules(local)  # (F, K, 3) at the origin, yaw 0
        rotations = _rot_z(low[2] + self._axis * span[2])  # (L, 3, 3)
        shift = np.array([low[0] + 0.5 * span[0], low[1] + 0.5 * span[1], 0.0])

        def place(points):  # (F, K, 3) -> (L * F, K, 3) at the centre of the translation box
            turned = np.einsum("lij,fkj->lfki", rotations, points)
            return (turned + shift).reshape(-1, *points.shape[1:])

        rotation_span = np.concatenate([[span[2], span[3]], span[4:]])
        arc_gap = float(np.sum(self._levers * (1.0 - np.cos(0.5 * rotation_span / (self.levels - 1)))))
        # the translation box lies within a disc of its half diagonal around its centre
        translation = 0.5 * float(np.hypot(span[0], span[1]))
        start = np.empty((len(self.names), 3))
        end = np.empty((len(self.names), 3))
        bound = np.empty(len(self.names))
        for parts, rows in ((self._arm_parts, slice(None)), (~self._arm_parts, self._base_only)):
            if np.any(parts):
                start[parts], end[parts], bound[parts] = bounding_capsules(
                    place(starts[rows][:, parts]), place(ends[rows][:, parts]), radius[parts],
                    self.margin + arc_gap + translation)
        return start, end, bound


class JointStateEstimator:
    """Kalman filter on the three-integrator chain of eq. (8.3), one track per joint.

    The state of joint j is [q_j, q'_j, q''_j] (position first). process_std: jerk density
    sigma_j of each joint (scalar or (n_dof,), rad/s^3 or m/s^3); measurement_std: default
    standard deviation of the measured q_j (scalar or (n_dof,)), replaced at each `step` by
    the given one (IK noise changes with the pose). The tracks are filtered in units of
    their own sigma_j (x_j / sigma_j), so every track shares one chain model, exact for a
    linear filter, and the RTS smoother (8.6) of the perception module applies unchanged.
    Keeps the last `window` filtered means and covariances for the smoother.
    """

    def __init__(self, n_dof: int = 12, dt: float = 0.05, process_std=30.0, measurement_std=0.02,
                 window: int = 20):
        self.n_dof = int(n_dof)
        self.process_std = self._per_joint("process_std", process_std)
        self.measurement_std = self._per_joint("measurement_std", measurement_std)
        if int(window) != window or window < 2:
            raise ValueError(f"JointStateEstimator: window must be an integer >= 2, got {window!r}")
        self.window = int(window)
        self.model = ChainOfIntegrators(order=3, dt=dt, sigma=[0.0, 0.0, 1.0], dim=1)
        self.filter = KalmanFilter(self.model, n_tracks=self.n_dof, measurement_std=1.0,
                                   initial_std=[1.0, 1.0, 5.0])
        self._scale = self.process_std[:, None]  # filter units -> joint units
        self.reset()

    def _per_joint(self, name, value) -> np.ndarray:
        value = np.broadcast_to(np.asarray(value, dtype=float), (self.n_dof,)).copy() \
            if np.ndim(value) == 0 else np.asarray(value, dtype=float)
        if value.shape != (self.n_dof,) or not np.all(np.isfinite(value)) or np.any(value <= 0):
            raise ValueError(f"JointStateEstimator: {name} must be positive, a scalar or {self.n_dof} "
                             f"values, got {value!r}")
        return value

    def clone(self) -> JointStateEstimator:
        """A copy for copy-on-write state: the filter's tracks and the window lists are copied
        (the stored means and covariances are never written, so they are shared)."""
        new = shallow_copy(self)
        new.filter = self.filter.clone()
        new.means_ = list(self.means_)
        new.covs_ = list(self.covs_)
        return new

    def reset(self) -> None:
        self.filter.reset()
        self.means_: list[np.ndarray] = []
        self.covs_: list[np.ndarray] = []

    def _update(self, y, std) -> None:
        """Measurement update with one noise std per track (filter units); first sample initialises."""
        kf = self.filter
        if not np.all(kf.initialized_):
            kf.x_[:] = 0.0
            kf.x_[:, 0] = y
            kf.P_[:] = np.diag([1.0, 1.0, 25.0]) / self._scale[:, :, None] ** 2
            kf.P_[:, 0, 0] = std**2
            kf.initialized_[:] = True
            return
        p = kf.P_
        gain = p[:, :, 0] / (p[:, 0, 0] + std**2)[:, None]  # (T, 3)
        kf.x_ = kf.x_ + gain * (y - kf.x_[:, 0])[:, None]
        p = p - gain[:, :, None] * p[:, None, 0, :]
        kf.P_ = 0.5 * (p + np.swapaxes(p, 1, 2))

    def step(self, q, measurement_std=None) -> np.ndarray:
        """Filter one measurement q (n_dof,) with noise std (n_dof,) (default: the constructor's);
        returns phi_k|k (n_dof, 3)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_dof,) or not np.all(np.isfinite(q)):
            raise ValueError(f"JointStateEstimator.step: q must be {self.n_dof} finite values, got {q}")
        std = self.measurement_std if measurement_std is None else self._per_joint("measurement_std",
                                                                                     measurement_std)
        if np.all(self.filter.initialized_):
            self.filter.predict()
        self._update(q / self.process_std, std / self.process_std)
        self.means_.append(self.filter.x_.copy())
        self.covs_.append(self.filter.P_.copy())
        if len(self.means_) > self.window:
            del self.means_[0], self.covs_[0]
        return self.filter.x_ * self._scale

    def filtered_window(self, length: int | None = None) -> np.ndarray:
        """phi_k|k (W, n_dof, 3) over the last `length` stored steps (all by default), eq. (8.3)."""
        start = 0 if length is None else max(0, len(self.means_) - int(length))
        return np.array(self.means_[start:]) * self._scale

    def smoothed_window(self, length: int | None = None) -> np.ndarray:
        """phi_k|K (W, n_dof, 3) over the last `length` stored steps (all by default), eq. (8.6)."""
        start = 0 if length is None else max(0, len(self.means_) - int(length))
        means, _ = rts_smooth(self.model, np.array(self.means_[start:]), np.array(self.covs_[start:]))
        return means * self._scale


def _points_and_jacobian(body, q, visible) -> tuple[np.ndarray, np.ndarray]:
    """Visible skeletal points (3V,) at q and their Jacobian (3V, 12), one batched forward kinematics."""
    step = 1e-5
    points = body.points(q + np.vstack([np.zeros(12), step * np.eye(12)]))[:, visible]  # (13, V, 3)
    return points[0].ravel(), ((points[1:] - points[0]) / step).reshape(12, -1).T


def _visible(points) -> np.ndarray:
    return np.all(np.isfinite(points), axis=1)


def ik_joint_std(body, q, point_std: float, visible=None, cap: float = 1.0) -> np.ndarray:
    """Standard deviation (12,) of the IK solution q for isotropic noise `point_std` (m) on the
    visible skeletal points: sqrt(diag(point_std^2 (J^T J + (point_std / cap)^2 I)^-1)), J the
    Jacobian of the visible points at q.

    Near a singular arm (straight elbow: the shoulder rotation barely moves any point) the
    std grows toward `cap`: such joints are measured badly, and the filter should not follow
    their IK jitter.
    """
    q = np.asarray(q, dtype=float)
    if q.shape != (12,) or not np.all(np.isfinite(q)):
        raise ValueError(f"ik_joint_std: q must be 12 finite values, got {q}")
    if not point_std > 0 or not cap > 0:
        raise ValueError(f"ik_joint_std: point_std and cap must be positive, got {point_std!r}, {cap!r}")
    visible = np.ones(8, dtype=bool) if visible is None else np.asarray(visible, dtype=bool)
    _, jacobian = _points_and_jacobian(body, q, visible)
    information = jacobian.T @ jacobian + (point_std / cap) ** 2 * np.eye(12)
    return point_std * np.sqrt(np.diag(np.linalg.inv(information)))


def tracking_inverse(body, points, q0, iterations: int = 4, regularization: float = 1e-3,
                     tolerance: float = 0.02) -> np.ndarray:
    """IK of the 8 skeletal points warm-started at the previous pose q0 (thesis 8.1.1, ref. [134]).

    Damped Gauss-Newton steps on sum ||FK_i(q) - p_i||^2 + regularization^2 ||q - q0||^2 over
    the visible points (the cost of `BodyModel.inverse`), clipped to the joint limits: a few
    batched forward kinematics (~1 ms) instead of a full solve (~30 ms). Falls back on
    `BodyModel.inverse` without q0, or when the rms point residual stays above `tolerance` (m).
    """
    points = np.asarray(points, dtype=float)
    if points.shape != (8, 3):
        raise ValueError(f"tracking_inverse: points must have shape (8, 3), got {points.shape}")
    visible = _visible(points)
    if q0 is None or visible.sum() < 3:
        return body.inverse(points, q0=q0)
    q0 = np.asarray(q0, dtype=float)
    target = points[visible].ravel()
    q = q0.copy()
    damping = regularization**2 * np.eye(12)
    for _ in range(int(iterations)):
        model, jacobian = _points_and_jacobian(body, q, visible)
        gradient = jacobian.T @ (target - model) - regularization**2 * (q - q0)
        q = q + np.linalg.solve(jacobian.T @ jacobian + damping, gradient)
        q = np.clip(q, body.q_lower, body.q_upper)
    residual = body.points(q)[visible].ravel() - target
    if np.sqrt(np.mean(residual**2) * 3.0) > tolerance:
        return body.inverse(points, q0=q0)
    return q


def _limits(value, default: dict, name: str) -> np.ndarray:
    if value is None or isinstance(value, dict):
        vector = joint_limit_vector(default if value is None else value)
    else:
        vector = np.asarray(value, dtype=float)
    if vector.shape != (12,) or not np.all(np.isfinite(vector)) or np.any(vector <= 0):
        raise ValueError(f"ReactiveMotionPredictor: {name} must be 12 positive finite values, got {vector}")
    return vector


class ReactiveMotionPredictor:
    """Swept volumes of the human from skeleton estimates, thesis 8.1 (Fig. 8.4).

    kind: gp_a | gp_b | gp_c (models A, B, C of 8.1.2) or worst_case ([107]).
    order: P. dt: sample time (s). horizon: prediction time (s), M = round(horizon / dt).
    n_trials: T Monte Carlo trials. percentile: None for the mean (8.9)-(8.10), else 0-100.
    refresh_period: model update period (s, 0.5 in 8.1.3); each update adds the samples of
        the RTS-smoothed window that arrived since the last one (10 at 20 Hz).
    max_samples: training-set size (100). smoothing_window: RTS window length (steps).
    min_samples: training samples the GP needs before it replaces the worst-case bounds.
    process_std, torso_process_std (rad/s^3), base_process_std (m/s^3): jerk densities of the
        KF (8.3) for the arm joints, base yaw + torso flexion, and the base translation (the
        trunk moves slower than the arms: a lower density filters its IK noise harder).
    point_std: noise of the skeletal points (m); `update` turns it into a per-joint, per-pose
        measurement noise through the IK Jacobian (`ik_joint_std`). measurement_std: the
        joint noise `update_q` assumes when given none.
    speed_limits, accel_limits: per-joint human limits of [107] (12,) or {group: value} over
        `LIMIT_GROUPS` (default `DEFAULT_SPEEDS`, `DEFAULT_ACCELS`); the worst-case model and
        the fallback before the GP is trained.
    training_states: "smoothed" (eq. 8.13: the GP learns and rolls out RTS-smoothed states) or
        "filtered" (a variant: the Kalman-filtered states phi_k|k, the states the excursions are
        measured on). Smoothed states follow the filter's integrator chain almost exactly, so
        h_GP learns that chain with the smoother's tiny residual and its rollouts are too narrow.
    cap_by_worst_case: clip the GP excursions to the worst-case ones (a safety option, off in
        the thesis's comparison: with it a GP model can never be less safe than [107]).
    levels, margin: swept-volume sampling, see `SweptVolumeBuilder`.
    """

    def __init__(self, body, kind: str = "gp_c", order: int = 4, dt: float = 0.05, horizon: float = 0.5,
                 n_trials: int = 50, percentile: float | None = None, refresh_period: float = 0.5,
                 max_samples: int = 100, smoothing_window: int = 20, min_samples: int = 30,
                 process_std: float = 3.0, torso_process_std: float = 1.0, base_process_std: float = 0.5,
                 point_std: float = 0.01,
                 measurement_std: float = 0.05, max_iter: int = 15, speed_limits=None, accel_limits=None,
                 cap_by_worst_case: bool = False, training_states: str = "smoothed", levels: int = 3,
                 margin: float = 0.0, rng=None):
        if kind not in MOTION_KINDS:
            raise ValueError(f"ReactiveMotionPredictor: unknown kind {kind!r}; use one of {MOTION_KINDS}")
        if not (dt > 0 and horizon > 0 and refresh_period > 0 and point_std > 0):
            raise ValueError("ReactiveMotionPredictor: dt, horizon, refresh_period and point_std "
                             "must be positive")
        if int(n_trials) != n_trials or n_trials < 1:
            raise ValueError(f"ReactiveMotionPredictor: n_trials must be a positive integer, "
                             f"got {n_trials!r}")
        if percentile is not None and not 0 <= percentile <= 100:
            raise ValueError(f"ReactiveMotionPredictor: percentile must be in [0, 100], got {percentile!r}")
        if int(min_samples) != min_samples or not 2 <= min_samples <= max_samples:
            raise ValueError(f"ReactiveMotionPredictor: min_samples must be an integer in [2, max_samples], "
                             f"got {min_samples!r}")
        self.body = body
        self.kind = kind
        self.order = int(order)
        self.dt = float(dt)
        self.steps = max(1, int(round(horizon / dt)))
        self.horizon = self.steps * self.dt
        self.n_trials = int(n_trials)
        self.percentile = percentile
        self.refresh_steps = max(1, int(round(refresh_period / dt)))
        window = max(int(smoothing_window), self.refresh_steps + self.order + 1)
        jerk = np.full(12, float(process_std))
        jerk[list(_BASE_TRANSLATION)] = base_process_std
        jerk[list(_TORSO)] = torso_process_std
        self.estimator = JointStateEstimator(12, dt, jerk, measurement_std, window)
        self.point_std = float(point_std)
        self.max_samples = int(max_samples)
        self.min_samples = int(min_samples)
        self.max_iter = int(max_iter)
        self.v_max = _limits(speed_limits, DEFAULT_SPEEDS, "speed_limits")
        self.a_max = _limits(accel_limits, DEFAULT_ACCELS, "accel_limits")
        self.cap_by_worst_case = bool(cap_by_worst_case)
        if training_states not in TRAINING_STATES:
            raise ValueError(f"ReactiveMotionPredictor: training_states must be one of {TRAINING_STATES}, "
                             f"got {training_states!r}")
        self.training_states = training_states
        self.builder = SweptVolumeBuilder(body, levels, margin)
        self._seed = rng
        self.reset()

    def reset(self) -> None:
        """Forget the operator: filter, history and model."""
        self.rng = np.random.default_rng(self._seed)
        self.estimator.reset()
        self.model_ = None
        if self.kind != "worst_case":
            self.model_ = GPMotionModel(MODEL_GROUPS[self.kind], self.order, max_samples=self.max_samples,
                                        max_iter=self.max_iter, random_state=self.rng)
        self.q_ = None
        self.phi_ = None
        self._steps_seen = 0
        self._history: list[np.ndarray] = []
        self.fit_seconds_: list[float] = []
        self.last_time_ = None

    def clone(self) -> ReactiveMotionPredictor:
        """A copy for copy-on-write state: the joint filter, the history, the generator (shared
        by the GP model, as in the original) and the GP model are copied; the GP shares its
        training set, which training never writes in place."""
        new = shallow_copy(self)
        new.estimator = self.estimator.clone()
        new.rng = clone_generator(self.rng)
        if self.model_ is not None:
            new.model_ = self.model_.clone(rng=new.rng if getattr(self.model_, "_rng", None) is self.rng
                                           else None)
            if self.model_.random_state is self.rng:
                new.model_.random_state = new.rng
        new._history = list(self._history)
        new.fit_seconds_ = list(self.fit_seconds_)
        return new

    @property
    def model_ready(self) -> bool:
        """The GP holds at least `min_samples` training samples."""
        return (self.model_ is not None and hasattr(self.model_, "buckets_")
                and self.model_.n_samples_ >= self.min_samples)

    def _states(self, length: int | None = None) -> np.ndarray:
        """The joint states h_GP learns from and starts its rollouts at (`training_states`)."""
        if self.training_states == "filtered":
            return self.estimator.filtered_window(length)
        return self.estimator.smoothed_window(length)

    def _refresh_model(self) -> None:
        states = self._states()
        count = min(self.refresh_steps, len(states) - self.order)
        if count <= 0 or (count < 2 and not self.model_ready):
            return
        last = len(states)
        windows = np.stack([states[k - self.order:k + 1] for k in range(last - count, last)])
        start = _time.perf_counter()
        self.model_.partial_fit(windows)
        self.fit_seconds_.append(_time.perf_counter() - start)

    def update_q(self, q, measurement_std=None) -> tuple[np.ndarray, np.ndarray]:
        """One step from a measured q (12,) with noise std (12,) (default: `measurement_std`):
        filter, maybe refresh h_GP, excursions (Delta+, Delta-)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (12,) or not np.all(np.isfinite(q)):
            raise ValueError(f"ReactiveMotionPredictor.update_q: q must be 12 finite values, got {q}")
        phi = self.estimator.step(q, measurement_std)
        self.phi_ = phi
        self.q_ = phi[:, 0].copy()
        self._history.append(phi)
        if len(self._history) > self.order:
            del self._history[0]
        self._steps_seen += 1
        if (self.model_ is not None and self._steps_seen % self.refresh_steps == 0
                and self._steps_seen > self.order):
            self._refresh_model()
        bound_plus, bound_minus = worst_case_excursions(phi[:, 1], self.horizon, self.v_max, self.a_max)
        if self.model_ready and len(self._history) == self.order:
            # Start from phi_{k-P+1|k} .. phi_{k|k}: smoothed like the training samples (8.13),
            # the newest one equal to the filtered state of (8.8).
            history = self._states(self.order + 2)[-self.order:]
            rollouts = self.model_.sample_rollouts(history, self.steps, self.n_trials, self.rng)
            plus, minus = excursions_from_rollouts(self.q_, rollouts, self.percentile)
            if self.cap_by_worst_case:
                return np.minimum(plus, bound_plus), np.minimum(minus, bound_minus)
            return plus, minus
        return bound_plus, bound_minus

    def update(self, time: float, points) -> SweptVolumes:
        """Skeleton points (8, 3) (NaN rows ignored) at `time` -> swept volumes over the horizon."""
        points = np.asarray(points, dtype=float)
        if self.last_time_ is not None and time < self.last_time_:
            self.reset()  # a new simulation started from an earlier time
        self.last_time_ = float(time)
        q = tracking_inverse(self.body, points, self.q_)
        std = ik_joint_std(self.body, q, self.point_std, _visible(points))
        delta_plus, delta_minus = self.update_q(q, std)
        return self.swept_volumes(time, delta_plus, delta_minus)

    def swept_volumes(self, time: float, delta_plus, delta_minus) -> SweptVolumes:
        """The `SweptVolumes` message around the current filtered q for the given excursions."""
        if self.q_ is None:
            raise ValueError("ReactiveMotionPredictor.swept_volumes: no state yet (call update first)")
        start, end, radius = self.builder.build(self.q_, delta_plus, delta_minus)
        return SweptVolumes(time=float(time), names=self.builder.names, start=start, end=end, radius=radius,
                            horizon=self.horizon)
