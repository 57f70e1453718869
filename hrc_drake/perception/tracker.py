"""Skeleton tracker core: SkeletonFrame in, SkeletonEstimate out (thesis 9.1.2-9.1.3).

kind:
- "particle_filter": the occlusion-aware `SkeletonParticleFilter` (9.1.2). By default NOT the
  literal thesis: seen points are sampled from their exact Kalman posterior instead of being
  weighted by eq. (9.8) (occluded points follow the thesis); `bootstrap_tracked: 1` gives the
  literal bootstrap PF for every point (see particle_filter.py);
- "kalman": the per-point Kalman baseline of 9.1.3, open loop under occlusion, with the
  90 % confidence ellipsoid as its belief volume;
- "none": the measurement itself, a lost point held at its last seen position.

The estimate's `workspace_fraction` is the share of each point's belief inside the robot
workspace box (particles for the PF; for the KF the larger of the share of the 90 % ellipsoid
inside the box and the share of the box inside the ellipsoid; 0/1 for "none");
`speed_override` is the slow-down rule of 9.1.3 built on it. Outputs never hold NaN: a point
never seen yet sits at its parent (or the origin) with spread UNKNOWN_SPREAD and workspace
fraction 1 (unknown counts as possibly inside the workspace).

A point whose row holds NaN, inf or a coordinate beyond `kalman.MAX_MEASUREMENT` counts as
untracked. A frame whose time is not finite is ignored; time going backwards, or no frame for
more than MAX_GAP s, starts a new run (`reset`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hrc_drake.messages import SKELETON_PARENTS, SkeletonEstimate, SkeletonFrame, shallow_copy
from hrc_drake.perception.geometry import points_in_box
from hrc_drake.perception.kalman import (
    ChainOfIntegrators,
    KalmanFilter,
    unit_ball_samples,
    valid_measurements,
)
from hrc_drake.perception.particle_filter import DEFAULT_INITIAL_STD, DEFAULT_SIGMA, SkeletonParticleFilter
from hrc_drake.perception.regions import (
    PARTICLE_RADIUS,
    REGION_MASS,
    ball_union_volume,
    ball_volume,
    ellipsoid_volume,
    in_ball_union,
    in_ellipsoid,
)

KINDS = ("particle_filter", "kalman", "none")
#: Spread (m) reported for a point never seen yet.
UNKNOWN_SPREAD = 1.0
#: A longer pause between two frames (s) starts a new run: an open-loop prediction over it says
#: nothing, costs one filter step per camera period, and past ~20 s loses the covariance to
#: round-off (the particle filter's Cholesky factorisation then fails).
MAX_GAP = 10.0

#: Parameters a scenario may give (`tracker: {kind: ..., params: {...}}`) and their defaults.
DEFAULT_PARAMS = {
    "particles": 500,  # N per skeletal point (thesis 9.1.3)
    "order": 4,  # blocks of the chain of integrators (4: up to jerk, eq. 9.2)
    "sigma_position": DEFAULT_SIGMA[0],  # eq. (9.3) per-block process standard deviations
    "sigma_velocity": DEFAULT_SIGMA[1],
    "sigma_acceleration": DEFAULT_SIGMA[2],
    "sigma_jerk": DEFAULT_SIGMA[3],
    "measurement_std": 0.01,  # R = measurement_std^2 I, eq. (9.8)
    "crown": 0.05,  # half amplitude theta of the spherical crowns (m), eq. (9.13)
    "systematic": 0,  # 1: systematic resampling instead of the thesis' bootstrap
    "bootstrap_tracked": 0,  # 1: literal thesis, seen points by the bootstrap PF (9.8); 0: Kalman sampling
    "hidden_at_rest": 0,  # 1: a variant, a newly hidden point's particles start with velocity .. jerk 0
    "calibration_frames": 10,  # frames used to calibrate the segment lengths
    "gate": 6.0,  # re-acquisition gate (measurement std units)
    "confidence": 0.9,  # KF ellipsoid confidence (9.1.3)
    "initial_velocity_std": DEFAULT_INITIAL_STD[1],
    "initial_acceleration_std": DEFAULT_INITIAL_STD[2],
    "initial_jerk_std": DEFAULT_INITIAL_STD[3],
    "display_particles": 50,  # particles per point copied into the estimate
}


def speed_override(estimate: SkeletonEstimate, threshold: float = 0.1, slow: float = 0.3) -> float:
    """Slow-down rule of 9.1.3: `slow` when some point has >= threshold of its belief in the
    robot workspace (particles for the PF, the 90 % ellipsoid for the KF), else 1."""
    if not 0.0 < threshold <= 1.0:
        raise ValueError(f"speed_override: threshold must be in (0, 1], got {threshold!r}")
    if not 0.0 <= slow <= 1.0:
        raise ValueError(f"speed_override: slow must be in [0, 1], got {slow!r}")
    fraction = np.asarray(estimate.workspace_fraction, dtype=float)
    if fraction.size and np.nanmax(fraction) >= threshold:
        return float(slow)
    return 1.0


def _check_params(params: dict | None) -> dict:
    out = dict(DEFAULT_PARAMS)
    for key, value in (params or {}).items():
        if key not in DEFAULT_PARAMS:
            raise ValueError(
                f"SkeletonTracker: unknown tracker parameter {key!r}; known: {sorted(DEFAULT_PARAMS)}")
        if not np.isfinite(float(value)):
            raise ValueError(f"SkeletonTracker: parameter {key!r} must be finite, got {value!r}")
        out[key] = float(value)
    for key in ("particles", "order", "calibration_frames", "display_particles"):
        if out[key] != int(out[key]) or out[key] < 1:
            raise ValueError(
                f"SkeletonTracker: parameter {key!r} must be a positive integer, got {out[key]!r}")
        out[key] = int(out[key])
    return out


class SkeletonTracker:
    """Tracks the 8 skeletal points from camera frames (thesis 9.1).

    kind: "particle_filter" | "kalman" | "none".
    params: overrides of DEFAULT_PARAMS (numbers only, as in a scenario file).
    is_hidden: depth-map query (M, 3) -> (M,) bool, True where the camera cannot see (L_c1);
        None disables the depth constraint.
    workspace_center, workspace_size: the robot workspace box of the slow-down rule.
    rate: camera rate (Hz), the filters' 1 / dt.
    seed: seed or numpy Generator of the particle filter.
    """

    def __init__(self, kind: str = "particle_filter", params: dict | None = None,
                 is_hidden: Callable[[np.ndarray], np.ndarray] | None = None,
                 workspace_center=(0.45, 0.0, 1.0), workspace_size=(0.5, 0.8, 0.6), rate: float = 30.0,
                 seed=0):
        if kind not in KINDS:
            raise ValueError(f"SkeletonTracker: kind must be one of {KINDS}, got {kind!r}")
        if not (np.isfinite(rate) and rate > 0):
            raise ValueError(f"SkeletonTracker: rate must be positive, got {rate!r}")
        self.workspace_center = np.asarray(workspace_center, dtype=float)
        self.workspace_size = np.asarray(workspace_size, dtype=float)
        if self.workspace_center.shape != (3,) or self.workspace_size.shape != (3,):
            raise ValueError("SkeletonTracker: workspace_center and workspace_size must have 3 values")
        if np.any(self.workspace_size < 0):
            raise ValueError(f"SkeletonTracker: workspace_size must be >= 0, got {self.workspace_size}")
        self.kind = kind
        self.params = _check_params(params)
        self.is_hidden = is_hidden
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        self.seed = seed
        p = self.params
        sigma = (p["sigma_position"], p["sigma_velocity"], p["sigma_acceleration"], p["sigma_jerk"])
        initial = (p["measurement_std"], p["initial_velocity_std"], p["initial_acceleration_std"],
                   p["initial_jerk_std"])
        order = p["order"]
        if order > 4:
            raise ValueError(f"SkeletonTracker: order must be <= 4 (per-block sigmas), got {order}")
        self._sigma = sigma[:order]
        self._initial = initial[:order]
        self.reset()

    def reset(self) -> None:
        """Forget the operator (new operator: calibration starts again)."""
        p = self.params
        rng = self.seed if isinstance(self.seed, np.random.Generator) else np.random.default_rng(self.seed)
        self._pf = None
        self._kf = None
        if self.kind == "particle_filter":
            self._pf = SkeletonParticleFilter(
                n_particles=p["particles"], dt=self.dt, order=p["order"], sigma=self._sigma,
                measurement_std=p["measurement_std"], crown=p["crown"],
                resampling="systematic" if p["systematic"] else "bootstrap",
                calibration_frames=p["calibration_frames"], initial_std=self._initial, gate=p["gate"],
                tracked_update="bootstrap" if p["bootstrap_tracked"] else "kalman",
                hidden_onset="at_rest" if p["hidden_at_rest"] else "posterior",
                seen_samples=p["display_particles"], rng=rng)  # only the displayed ones are read
        elif self.kind == "kalman":
            model = ChainOfIntegrators(p["order"], self.dt, self._sigma, dim=3)
            self._kf = KalmanFilter(model, 8, p["measurement_std"], self._initial)
        self._last_time = None
        self._held = np.zeros((8, 3))
        self._ever_seen = np.zeros(8, dtype=bool)
        self.estimate_ = SkeletonEstimate(workspace_fraction=np.ones(8), spread=np.full(8, UNKNOWN_SPREAD),
                                          tracked=np.zeros(8, dtype=bool))

    def clone(self) -> SkeletonTracker:
        """A copy for copy-on-write state: the filter and what `update` writes in place are
        copied, the configuration is shared."""
        new = shallow_copy(self)
        if self._pf is not None:
            new._pf = self._pf.clone()
        if self._kf is not None:
            new._kf = self._kf.clone()
        new._held = self._held.copy()
        new._ever_seen = self._ever_seen.copy()
        return new

    @property
    def particle_filter(self) -> SkeletonParticleFilter | None:
        return self._pf

    @property
    def kalman_filter(self) -> KalmanFilter | None:
        return self._kf

    def region_contains(self, truth, which=None, mass: float = REGION_MASS,
                        radius: float = PARTICLE_RADIUS) -> tuple[np.ndarray, np.ndarray]:
        """Whether each true point lies inside this tracker's belief region, and the region's
        volume (`perception.regions`; thesis 9.1.3): the particle filter's particles inflated
        by `radius`, the Kalman filter's `mass` ellipsoid, a ball of `radius` around a held
        point.

        truth (8, 3): true positions; which (8,) bool: the points to judge (default all).
        Returns inside (8,) bool and volume (8,) m^3; a point not judged, or never seen yet
        (no region), is False with volume NaN.
        """
        truth = np.asarray(truth, dtype=float).reshape(8, 3)
        which = np.ones(8, dtype=bool) if which is None else np.asarray(which, dtype=bool).copy()
        inside, volume = np.zeros(8, dtype=bool), np.full(8, np.nan)
        if self._pf is not None:
            which &= self._pf.initialized_
            idx = np.flatnonzero(which)
            cloud = self._pf.positions[idx]
            inside[idx] = in_ball_union(cloud, truth[idx], radius)
            # The same seed for every point and frame: the volume's Monte Carlo noise is common
            # to all regions compared.
            volume[idx] = [ball_union_volume(c, radius) for c in cloud]
        elif self._kf is not None:
            which &= self._kf.initialized_
            idx = np.flatnonzero(which)
            cov = self._kf.position_covariances[idx]
            inside[idx] = in_ellipsoid(self._kf.positions[idx], cov, truth[idx], mass)
            volume[idx] = ellipsoid_volume(cov, mass)
        else:
            which &= self._ever_seen
            idx = np.flatnonzero(which)
            inside[idx] = np.linalg.norm(truth[idx] - self._held[idx], axis=1) <= radius
            volume[idx] = ball_volume(radius)
        return inside, volume

    def _check_frame(self, frame: SkeletonFrame):
        points = np.asarray(frame.points, dtype=float)
        tracked = np.asarray(frame.tracked, dtype=bool)
        if points.shape != (8, 3) or tracked.shape != (8,):
            raise ValueError(
                f"SkeletonTracker: frame at t={frame.time} needs points (8, 3) and tracked (8,), "
                f"got {points.shape} and {tracked.shape}")
        return points, tracked & valid_measurements(points)

    def update(self, frame: SkeletonFrame) -> SkeletonEstimate:
        """Process one frame and return the new estimate (the same frame twice: no change)."""
        points, seen = self._check_frame(frame)
        t = float(frame.time)
        if not np.isfinite(t):
            return self.estimate_  # no usable time: the frame cannot be placed in the run
        if self._last_time is not None and (t < self._last_time - 1e-9 or t - self._last_time > MAX_GAP):
            self.reset()  # time went backwards, or a long pause: a new run
        if (self._last_time is not None and abs(t - self._last_time) < 1e-9
                and np.array_equal(points, self._last_points, equal_nan=True)
                and np.array_equal(seen, self._last_seen)):
            return self.estimate_  # the same frame again: nothing new
        steps = 1 if self._last_time is None else max(1, int(round((t - self._last_time) / self.dt)))
        self._last_time = t
        self._last_points, self._last_seen = points.copy(), seen.copy()
        self._ever_seen |= seen
        self._held[seen] = points[seen]
        if self.kind == "particle_filter":
            est = self._update_pf(points, seen, steps)
        elif self.kind == "kalman":
            est = self._update_kf(points, seen, steps)
        else:
            est = self._update_none()
        gaze = np.asarray(frame.gaze, dtype=float)
        if gaze.shape != (3,) or not np.all(np.isfinite(gaze)):
            gaze, gaze_valid = self.estimate_.gaze, False
        else:
            gaze_valid = bool(frame.gaze_valid)
        positions, spread, fraction, particles = est
        self.estimate_ = SkeletonEstimate(time=t, points=positions, spread=spread, tracked=seen.copy(),
                                          workspace_fraction=fraction, gaze=gaze, gaze_valid=gaze_valid,
                                          particles=particles)
        return self.estimate_

    def _fill_unknown(self, positions, spread, fraction, known):
        """Points never estimated: parent's position, UNKNOWN_SPREAD, workspace fraction 1."""
        for i in range(8):
            if not known[i]:
                parent = SKELETON_PARENTS[i]
                positions[i] = positions[parent] if parent >= 0 else 0.0
                spread[i] = UNKNOWN_SPREAD
                fraction[i] = 1.0
        return positions, spread, fraction

    def _update_pf(self, points, seen, steps):
        pf = self._pf
        pf.step(points, seen, self.is_hidden, steps=steps)
        positions = pf.means_.copy()
        spread, fraction = pf.summaries(self.workspace_center, self.workspace_size)
        positions, spread, fraction = self._fill_unknown(positions, spread, fraction, pf.initialized_)
        k = min(self.params["display_particles"], pf.n_particles)
        particles = pf.positions[:, :k].copy()
        particles[~pf.initialized_] = positions[~pf.initialized_, None, :]
        return positions, spread, fraction, particles

    def _update_kf(self, points, seen, steps):
        kf = self._kf
        if np.any(kf.initialized_):
            kf.predict(steps)
        kf.update(points, seen)
        positions = kf.positions
        cov = kf.position_covariances
        spread = np.sqrt(np.clip(np.trace(cov, axis1=1, axis2=2), 0.0, None) / 3.0)
        conf = self.params["confidence"]
        ellipsoid = kf.ellipsoid(conf)
        # Share of the ellipsoid in the workspace, or of the workspace in the ellipsoid: a long
        # open loop grows the ellipsoid past the box, which must still count as inside (the
        # second share matters only where the first is below 1).
        in_box = kf.ellipsoid_fraction_in_box(self.workspace_center, self.workspace_size, conf, ellipsoid)
        fraction = np.maximum(in_box, kf.box_fraction_in_ellipsoid(
            self.workspace_center, self.workspace_size, conf, tracks=in_box < 1.0))
        positions, spread, fraction = self._fill_unknown(positions, spread, fraction, kf.initialized_)
        # Display samples: fixed points of the confidence ellipsoid.
        k = self.params["display_particles"]
        _, semi, axes = ellipsoid
        ball = unit_ball_samples(k, 3)
        particles = positions[:, None, :] + np.einsum("tij,nj->tni", axes * semi[:, None, :], ball)
        particles[~kf.initialized_] = positions[~kf.initialized_, None, :]
        return positions, spread, fraction, particles

    def _update_none(self):
        positions = self._held.copy()
        spread = np.zeros(8)
        fraction = points_in_box(positions, self.workspace_center, self.workspace_size).astype(float)
        positions, spread, fraction = self._fill_unknown(positions, spread, fraction, self._ever_seen)
        return positions, spread, fraction, None
