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
from scipy.spatial import ConvexHull, QhullError

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import SweptVolumes, shallow_copy
from hrc_drake.motion import _kernels
from hrc_drake.motion.gp import MODEL_GROUPS, GPMotionModel
from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter, rts_smoothed_means
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


def _linspace(low: float, high: float, num: int) -> np.ndarray:
    """np.linspace(low, high, num) of scalars, num >= 2, as numpy computes it (arange * step +
    low, the last value set to high) without its ~25 us of argument handling."""
    step = (high - low) / (num - 1)
    values = np.arange(num, dtype=float) / (num - 1) * (high - low) if step == 0 else np.arange(num) * step
    values += low
    values[-1] = high
    return values


def _joint_samples(low: float, high: float, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Values and perpendicular scales of one rotation's samples on [low, high] split in `cells`
    (0: the single value low).

    The even samples are the grid values; the odd ones sit mid-cell with scale 1 / cos(h), h the
    half cell: a point turned through a cell by a rotation sweeps an arc that lies in the
    triangle of its two grid images and the crossing of their tangents, which is the point
    turned to mid-cell and pushed away from the axis by 1 / cos(h).
    """
    if cells == 0:
        return np.array([low]), np.ones(1)
    values = _linspace(low, high, 2 * cells + 1)
    scale = np.ones(2 * cells + 1)
    scale[1::2] = 1.0 / np.cos((high - low) / (2 * cells))
    return values, scale


def _scaled_rotations(angle: np.ndarray, scale: np.ndarray, axis: int) -> np.ndarray:
    """(n, 3, 3): rotations by `angle` about coordinate `axis`, scaled by `scale` across the axis."""
    i, j = ((1, 2), (2, 0), (0, 1))[axis]
    c, s = np.cos(angle) * scale, np.sin(angle) * scale
    m = np.zeros((len(angle), 3, 3))
    m[:, axis, axis] = 1.0
    m[:, i, i] = c
    m[:, j, j] = c
    m[:, i, j] = -s
    m[:, j, i] = s
    return m


def _hull_vertices(points: np.ndarray, at_least: int = 200) -> np.ndarray:
    """The vertices of the convex hull of points (N, 3): all points when there are fewer than
    `at_least` (not worth a hull) or the hull is flat."""
    if len(points) < at_least:
        return points
    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):
        return points


#: for each candidate axis (an eigenvector), the two eigenvectors across it
_ACROSS = ((1, 2), (0, 2), (0, 1))


def _bounding_capsule(points: np.ndarray, offsets: np.ndarray, stride: int = 1
                      ) -> tuple[np.ndarray, np.ndarray, float]:
    """One capsule around points (3, N) translated by every corner in offsets (C, 3), hence around
    their hull translated over the hull of the corners.

    The axis is one of the points' principal directions, the one whose capsule around every
    `stride`-th point, untranslated, has the smallest volume; the axis line runs through the
    middle of the points' extent across it; the radius is the largest distance of a point to
    that line, and the segment is shortened as far as every point stays within the radius (as
    `geometry.bounding_capsules`). Returns (start (3,), end (3,), radius).
    """
    mean = points.mean(axis=1)
    x = points - mean[:, None]
    _, vectors = np.linalg.eigh(x @ x.T)  # columns: principal directions
    coords = vectors.T @ x
    middle = 0.5 * (coords.max(axis=1) + coords.min(axis=1))
    rel = coords - middle[:, None]
    # choose the direction on every `stride`-th point (the choice only needs to be good)
    sample = rel[:, ::stride]
    square = sample * sample
    across2 = square.sum(axis=0) - square  # squared distance to the line along each direction
    cover2 = across2.max(axis=1)
    slack = np.sqrt(np.maximum(cover2[:, None] - across2, 0.0))
    length = np.maximum((sample - slack).max(axis=1) - (sample + slack).min(axis=1), 0.0)
    k = int(np.argmin(cover2 * length + 4.0 / 3.0 * cover2**1.5))
    i, j = _ACROSS[k]
    # the chosen line, exactly, with the translation corners
    shift = offsets @ vectors  # (C, 3)
    along = rel[k] + shift[:, k, None]  # (C, N)
    across2 = (rel[i] + shift[:, i, None]) ** 2 + (rel[j] + shift[:, j, None]) ** 2
    radius2 = across2.max()
    slack = np.sqrt(np.maximum(radius2 - across2, 0.0))
    low, high, radius = (along + slack).min(), (along - slack).max(), np.sqrt(radius2)
    if low > high:  # rounding: the points fit a ball around the middle of the axis
        low = high = 0.5 * (low + high)
        radius = np.sqrt(((along - low) ** 2 + across2).max())
    base = mean + vectors @ middle
    return base + low * vectors[:, k], base + high * vectors[:, k], float(radius)


class SweptVolumeBuilder:
    """Capsules bounding each body capsule over the joint box [q - Delta-, q + Delta+] (8.1.1, Fig. 8.2c).

    Every capsule point is hip + R_z(yaw) R_y(flexion) p, p in the torso frame from the arm
    chain of `human.body` (shoulder R_y(-flexion) R_x(m abduction) R_z(m rotation), elbow
    R_y(-elbow)): the builder samples that chain itself (checked against `body.capsules` at
    construction). Each rotation's range is split in cells (`_cells`: at most levels - 1 for
    the arm joints, levels for yaw and flexion) and sampled at the grid values and at one
    tangent point per cell (`_joint_samples`): the hull of a cell's samples holds every pose of
    the cell, exactly, where a grid alone needs an arc-to-chord inflation. The samples multiply
    through the chain (only the joints a capsule depends on), the forearm's down to the vertices
    of their hull, before yaw and flexion turn them; the base translation box is the hull of its
    four corners. One capsule bounds each body capsule's points (`_bounding_capsule`, compiled as
    `_kernels.bounding_capsule`), plus its body radius and `margin`: the union holds every
    instance of every body capsule on the joint box. (Bounding a forearm's points in 2-4 groups
    split by yaw cells, one capsule each, moved the worst-case frontier from rest by under 3 cm
    and grew the union's volume by 8-15%.)
    """

    #: largest distance (m) of a tangent sample beyond the arc it stands for that needs no finer
    #: grid (a looser volume, never a smaller one)
    TANGENT_TOLERANCE = 0.005

    def __init__(self, body, levels: int = 3, margin: float = 0.0):
        if int(levels) != levels or levels < 2:
            raise ValueError(f"SweptVolumeBuilder: levels must be an integer >= 2, got {levels!r}")
        if not margin >= 0:
            raise ValueError(f"SweptVolumeBuilder: margin must be >= 0, got {margin!r}")
        self.body = body
        self.levels = int(levels)
        self.margin = float(margin)
        self.names = tuple(body.CAPSULE_NAMES)
        if self.names[:2] != ("torso", "head") or len(self.names) != 6:
            raise ValueError(f"SweptVolumeBuilder: expected the capsules torso, head, upper arms, forearms "
                             f"of `human.body`, got {self.names}")
        start, end, self._radius = body.capsules(np.zeros(12))
        hip = np.array([0.0, 0.0, body.hip_height])
        self._hip_height = float(body.hip_height)
        self._trunk = np.stack([start[0], end[0], start[1], end[1]]) - hip  # torso, head (torso frame)
        self._shoulder = {1.0: start[2] - hip, -1.0: start[3] - hip}
        self._upper = float(np.linalg.norm(end[2] - start[2]))
        self._fore = float(np.linalg.norm(end[4] - start[4]))
        # farthest capsule point from each rotation axis (base translation: unused)
        arm = self._upper + self._fore
        trunk = max(np.linalg.norm(self._trunk, axis=1).max(), np.linalg.norm(self._shoulder[1.0]) + arm)
        self._levers = np.array([1.0, 1.0, trunk, trunk] + [arm, arm, self._fore, self._fore] * 2)
        self._check_chain(body)

    def _check_chain(self, body) -> None:
        """The torso-frame chain of `_arm` must reproduce `body.capsules` (same conventions)."""
        low, high = np.maximum(body.q_lower, -3.0), np.minimum(body.q_upper, 3.0)
        for q in low + np.random.default_rng(0).uniform(0.1, 0.9, (3, 12)) * (high - low):
            start, end, _ = self._build(q, q, single=True)
            s, e, _ = body.capsules(q)
            if not (np.allclose(start, s, atol=1e-9) and np.allclose(end, e, atol=1e-9)):
                raise ValueError("SweptVolumeBuilder: the body model's kinematics differ from the arm chain "
                                 "of `human.body` the builder samples")

    def _cells(self, span: np.ndarray) -> np.ndarray:
        """Cells per rotation: as few as keep every tangent sample within `TANGENT_TOLERANCE` of
        its arc (lever (1 / cos(h) - 1), lever the farthest capsule point from the axis), at most
        levels - 1 for the arm joints and levels for base yaw and torso flexion (they only turn
        the sampled points: a finer grid is cheap), at least one per 90 degrees; none for a
        joint that does not move."""
        most = np.full(12, self.levels - 1)
        most[2:4] = self.levels
        half = np.arccos(1.0 / (1.0 + self.TANGENT_TOLERANCE / self._levers))
        cells = np.minimum(np.ceil(span / (2.0 * half)), most)
        cells = np.maximum(cells, np.ceil(span / (0.5 * np.pi)))
        return np.where(span > 0.0, np.maximum(cells, 1), 0).astype(int)

    def _arm(self, low, high, cells, m: float, first: int):
        """Torso-frame samples of one arm (mirror m): its elbows (n, 3) and hands (n * n', 3)."""
        mats = []
        for k, (axis, sign) in enumerate(((1, -1.0), (0, m), (2, m), (1, -1.0))):
            values, scale = _joint_samples(low[first + k], high[first + k], cells[first + k])
            mats.append(_scaled_rotations(sign * values, scale, axis))
        flexion, abduction, rotation, elbow_flexion = mats
        upper = (flexion[:, None] @ abduction[None]).reshape(-1, 3, 3)  # R_y(-f) R_x(m a)
        elbow = self._shoulder[m] - self._upper * upper[:, :, 2]  # shoulder + L R (-e_z)
        forearm = -(rotation[:, None] @ elbow_flexion[None, :, :, 2:3]).reshape(-1, 3)  # R_z R_y (-e_z)
        # the forearm's end points below the shoulder joints: the elbow and the hands (upper-arm frame)
        reach = _hull_vertices(np.vstack([[0.0, 0.0, -self._upper],
                                          [0.0, 0.0, -self._upper] + self._fore * forearm]), at_least=20)
        forearm_points = self._shoulder[m] + (reach @ upper.transpose(0, 2, 1)).reshape(-1, 3)
        return elbow, _hull_vertices(forearm_points)

    def _build(self, low, high, single: bool = False):
        span = high - low
        cells = self._cells(span)
        yaw, yaw_scale = _joint_samples(low[2], high[2], cells[2])
        lean, lean_scale = _joint_samples(low[3], high[3], cells[3])
        turns = (_scaled_rotations(yaw, yaw_scale, 2)[:, None]
                 @ _scaled_rotations(lean, lean_scale, 1)[None]).reshape(-1, 3, 3)
        (left_elbow, left_fore), (right_elbow, right_fore) = (self._arm(low, high, cells, m, first)
                                                              for m, first in ((1.0, 4), (-1.0, 8)))
        if single:  # one pose (low == high): the capsule end points, for `_check_chain`
            ends = np.array([self._trunk[0], self._trunk[1], self._trunk[2], self._trunk[3],
                             self._shoulder[1.0], left_elbow[0], self._shoulder[-1.0], right_elbow[0],
                             left_fore[0], left_fore[1], right_fore[0], right_fore[1]]) @ turns[0].T
            ends = ends.reshape(6, 2, 3) + np.array([low[0], low[1], self._hip_height])
            return ends[:, 0], ends[:, 1], self._radius
        parts = [self._trunk[0:2], self._trunk[2:4],
                 np.vstack([self._shoulder[1.0], left_elbow]), np.vstack([self._shoulder[-1.0], right_elbow]),
                 left_fore, right_fore]
        hx, hy = 0.5 * span[0], 0.5 * span[1]
        offsets = np.array([[-hx, -hy, 0.0], [-hx, hy, 0.0], [hx, -hy, 0.0], [hx, hy, 0.0]])
        columns = turns.transpose(2, 0, 1).reshape(3, -1)  # (3, 3T): the transposed turns side by side
        start, end, radius = np.empty((6, 3)), np.empty((6, 3)), np.empty(6)
        for k, local in enumerate(parts):
            # (3, T * n): every torso-frame point under every turn
            points = (local @ columns).reshape(len(local), -1, 3).transpose(2, 1, 0).reshape(3, -1)
            stride = 1 + points.shape[1] // 1000
            start[k], end[k], radius[k] = _kernels.bounding_capsule(points, offsets, stride)
        centre = np.array([low[0] + hx, low[1] + hy, self._hip_height])
        return start + centre, end + centre, radius + self._radius + self.margin

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
        high = np.maximum(np.minimum(q + delta_plus, self.body.q_upper), low)
        return self._build(low, high)


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
        means = rts_smoothed_means(self.model, np.array(self.means_[start:]), np.array(self.covs_[start:]))
        return means * self._scale


#: forward-difference step of the IK Jacobian (rad or m)
_JACOBIAN_STEP = 1e-5


def _kernel_dims(body) -> np.ndarray | None:
    """The segment dimensions the compiled skeleton kernels take, for a `BodyModel` whose forward
    kinematics is the stock one; None for any other body (it keeps the numpy path)."""
    kind = type(body)
    stock = all(getattr(kind, name) is getattr(BodyModel, name)
                for name in ("points", "_points", "_points_single"))
    if not (isinstance(body, BodyModel) and stock):
        return None
    return np.array([body.hip_height, body.torso, body.neck, 0.5 * body.shoulder_width, body.upper_arm,
                     body.forearm])


def _points_and_jacobian(body, q, visible) -> tuple[np.ndarray, np.ndarray]:
    """Visible skeletal points (3V,) at q and their Jacobian (3V, 12), one batched forward kinematics."""
    points = body.points(q + np.vstack([np.zeros(12), _JACOBIAN_STEP * np.eye(12)]))[:, visible]  # (13, V, 3)
    return points[0].ravel(), ((points[1:] - points[0]) / _JACOBIAN_STEP).reshape(12, -1).T


def _jacobian(body, q, visible) -> np.ndarray:
    """The Jacobian of `_points_and_jacobian`, compiled for a stock `BodyModel`."""
    dims = _kernel_dims(body)
    if dims is None:
        return _points_and_jacobian(body, q, visible)[1]
    return _kernels.skeleton_jacobian(dims, q, visible, _JACOBIAN_STEP)[1]


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
    jacobian = _jacobian(body, q, visible)
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
    dims = _kernel_dims(body)
    if dims is None:
        q, rms = _tracking_gauss_newton(body, target, visible, q0, int(iterations), regularization)
    else:
        q, rms = _kernels.tracking_gauss_newton(dims, body.q_lower, body.q_upper, target, visible, q0,
                                               int(iterations), regularization, _JACOBIAN_STEP)
    if rms > tolerance:
        return body.inverse(points, q0=q0)
    return q


def _tracking_gauss_newton(body, target, visible, q0, iterations: int, regularization: float):
    """The damped Gauss-Newton steps of `tracking_inverse` in numpy, for any body model (the
    reference of `_kernels.tracking_gauss_newton`): q and the rms point residual at it."""
    q = q0.copy()
    damping = regularization**2 * np.eye(12)
    for _ in range(iterations):
        model, jacobian = _points_and_jacobian(body, q, visible)
        gradient = jacobian.T @ (target - model) - regularization**2 * (q - q0)
        q = q + np.linalg.solve(jacobian.T @ jacobian + damping, gradient)
        q = np.clip(q, body.q_lower, body.q_upper)
    residual = body.points(q)[visible].ravel() - target
    return q, float(np.sqrt(np.mean(residual**2) * 3.0))


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
    max_iter, hyperparameter_every: L-BFGS iterations of a hyperparameter refit, and every how
        many model updates one is made (1, as 8.1.3; see `GPMotionModel`).
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
                 measurement_std: float = 0.05, max_iter: int = 15, hyperparameter_every: int = 1,
                 speed_limits=None, accel_limits=None,
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
        self.hyperparameter_every = int(hyperparameter_every)
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
                                        max_iter=self.max_iter, random_state=self.rng,
                                        hyperparameter_every=self.hyperparameter_every)
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
