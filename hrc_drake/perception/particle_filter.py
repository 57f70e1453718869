"""Occlusion-aware particle filter over the 8 skeletal points (thesis 9.1.1-9.1.2).

Every skeletal point is tracked independently by its own particle set (9.1.2, "Dealing with
occlusions"); all sets are stored in one array and updated with the same numpy calls:

    particles_ (P, N, S): P = 8 points, N particles, S = order * 3 state (position first).

NOT THE LITERAL THESIS BY DEFAULT. `tracked_update` chooses how the points the camera sees
are updated; occluded points are handled the same way in both modes.
- "kalman" (default, our deviation): while a point is seen its model (9.1)-(9.5) is linear
  and Gaussian, so the posterior the thesis' bootstrap PF approximates is exactly the Kalman
  one; the point's particles are *drawn from that Kalman posterior* every frame instead of
  being weighted by eq. (9.8) and resampled. Why: with a 12-dim state (position .. jerk),
  1 cm measurement noise and 500 particles, the bootstrap PF impoverishes (few particles
  fall inside the 1 cm likelihood, the velocity samples collapse): on a point moving at up to
  0.6 m/s its error is ~2 cm RMS and up to 6-8 cm, against 1.2 cm and 2.5 cm with Kalman
  sampling (test_seen_points_follow_a_moving_measurement); it is also ~3x slower.
  At the frame a point gets hidden its full 12-dim state is sampled from the Kalman posterior
  and the particles then run the thesis' motion update + constraint likelihood + resampling;
  when the point is seen again the Kalman posterior restarts from the moments of the
  constrained cloud. `hidden_onset="at_rest"` (a variant, not the thesis) keeps only the
  position samples at that frame and sets velocity .. jerk to 0: on real recorded arms, which
  mostly rest (median wrist speed 0.06 m/s, tools/bench_real.py), the inherited derivatives
  carried the cloud away from a still hidden point (issue 37).
- "bootstrap" (the literal thesis; tracker parameter `bootstrap_tracked: 1`): every point is
  a bootstrap PF, seen or not: motion update, weights (9.8)-(9.9), resampling. It works as
  such with a short chain (order 2: position, velocity; tests test_literal_bootstrap_*). With
  the default 4-block jerk model and 1 cm noise, position-only weights cannot hold the
  velocity..jerk samples: the cloud drifts off the measurement and the re-acquisition gate
  re-seeds a seen point on most frames (still errors of 4-7 cm).

One `step` (in "kalman" mode, step 2a and the resampling of seen points are replaced by the
Kalman sampling above):
1. motion update: each particle drawn from p(U_{k+1} | U_k) = N(A U_k, W), eq. (9.1)-(9.3);
2. weights, eq. (9.9) with resampling every step (so omega_k is uniform):
   a. tracked point: Gaussian likelihood h of eq. (9.8), R = measurement_std^2 I;
   b. occluded point (tracked False, or NaN/missing row): the constraint likelihood
     L_c = L_c1 L_c2 of eq. (9.10)-(9.12): L_c1 = 1 where `is_hidden(position)` (consistent
     with the depth map), L_c2 = 1 inside the admissible region of the bone lengths,
     eq. (9.13)-(9.14):
       case 1 (wrist hidden, elbow seen): spherical crown d_EH +/- theta around the elbow;
       case 2 (elbow hidden, wrist seen): crowns d_SE around the shoulder and d_EH around
               the wrist (2 > 4 and 6 > 4);
       case 3 (both hidden): elbow in the crown d_SE around the shoulder, wrist inside the
               ball d_SE + d_EH (+ theta) around the shoulder.
     The same rules follow `SKELETON_PARENTS` for any other point: the anchor is the nearest
     seen ancestor (crown if it is the parent, ball of the summed lengths otherwise) plus a
     crown around every seen child. Anchors use the posterior means of the seen points.
3. resampling: bootstrap (multinomial, as in the thesis) or systematic.

Degeneracy: when every weight of a point is zero, the point's particles are re-seeded inside
the admissible region (rejection sampling around its anchor) instead of dividing by zero;
a seen point whose measurement lies outside the whole cloud is re-seeded around it.
Segment lengths are calibrated from the first frames of a new operator (median over frames
where both ends are seen), or given.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hrc_drake.messages import SKELETON_PARENTS, shallow_copy
from hrc_drake.perception import _kernels
from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter, valid_measurements
from hrc_drake.rng import clone_generator

_WHERE = "SkeletonParticleFilter: "
IsHidden = Callable[[np.ndarray], np.ndarray]

#: Default per-block process standard deviations (position, velocity, acceleration, jerk).
DEFAULT_SIGMA = (0.1, 0.2, 1.0, 5.0)
#: Default per-block standard deviations of a new track (position replaced by measurement_std).
DEFAULT_INITIAL_STD = (0.01, 0.2, 1.0, 5.0)


def resample_indices(weights: np.ndarray, rng: np.random.Generator, method: str = "bootstrap") -> np.ndarray:
    """Indices drawn from each row of `weights` (P, N), for all rows at once.

    bootstrap: N independent draws per row (multinomial, the thesis' bootstrap resampling);
    systematic: one uniform offset per row and N evenly spaced positions.
    Rows must be non-negative with a positive sum.
    """
    weights = np.asarray(weights, dtype=float)
    p, n = weights.shape
    cdf = np.cumsum(weights, axis=1)
    total = cdf[:, -1:]
    if np.any(~np.isfinite(total)) or np.any(total <= 0):
        raise ValueError("resample_indices: every row of weights needs a finite positive sum")
    cdf /= total
    if method == "bootstrap":
        u = rng.random((p, n))
    elif method == "systematic":
        u = (rng.random((p, 1)) + np.arange(n)) / n
    else:
        raise ValueError(f"resample_indices: method must be 'bootstrap' or 'systematic', got {method!r}")
    rows = np.arange(p)[:, None]
    # One searchsorted over all rows: row r's cdf lives in (r, r + 1].
    flat = np.searchsorted((cdf + rows).ravel(), (u + rows).ravel(), side="right")
    return np.minimum(flat.reshape(p, n) - rows * n, n - 1)


def _sigma_for_order(sigma, order: int) -> np.ndarray:
    if np.ndim(sigma) == 0:
        return np.full(order, float(sigma))
    sig = np.asarray(sigma, dtype=float)
    if sig.shape[0] < order:
        raise ValueError(f"need {order} per-block values, got {sig.tolist()}")
    return sig[:order]


class SkeletonParticleFilter:
    """Per-point particle filters for the skeleton with occlusion constraints (9.1.2).

    n_particles: N per point (the thesis used 500).
    dt: camera period (s). order: blocks of the chain of integrators (4: up to jerk, eq. 9.2).
    sigma: process standard deviations per block (or one scalar), eq. (9.3).
    measurement_std: sqrt of R in eq. (9.8) (m).
    crown: half amplitude theta of the spherical crowns, eq. (9.13) (m).
    resampling: "bootstrap" (thesis) or "systematic".
    calibration_frames: frames with both ends seen used to calibrate each segment length.
    segment_lengths: optional (P,) fixed lengths point -> parent (NaN for the root); disables
        calibration.
    initial_std: per-block spread of a new track (position block = measurement_std).
    gate: a seen point whose measurement is farther than gate * measurement_std from every
        particle is re-seeded around the measurement (re-acquisition after an occlusion).
    reseed_tries: rounds of rejection sampling when re-seeding an occluded point.
    tracked_update: "kalman" (default, NOT the literal thesis: seen points sampled from their
        exact Kalman posterior) or "bootstrap" (the thesis' bootstrap PF for seen points too);
        see the module docstring.
    hidden_onset: in "kalman" mode, the state a newly hidden point's particles start from:
        "posterior" (default: the full Kalman posterior) or "at_rest" (its positions, with
        velocity .. jerk 0; a variant, see the module docstring).
    seen_samples: in "kalman" mode, how many particles of a seen point are drawn from its
        Kalman posterior each frame (None: all N). With fewer, the other rows of a seen point
        are stale and unused: `spread` and `fraction_in_box` of a seen point come from the
        posterior itself (exact spread; box probability from the per-axis marginals, exact for
        the diagonal covariance the posterior has except in the frames after an occlusion),
        not from its samples. A tracker that displays k particles per point passes k.
    rng: numpy Generator or seed.

    Learned/state attributes: particles_ (P, N, S), initialized_ (P,), segment_lengths_ (P,),
    means_ (P, 3), n_reseeds_ (P,) counts of degeneracy re-seeds.
    """

    def __init__(self, n_particles: int = 500, dt: float = 1.0 / 30.0, order: int = 4, sigma=DEFAULT_SIGMA,
                 measurement_std: float = 0.01, crown: float = 0.05, resampling: str = "bootstrap",
                 calibration_frames: int = 10, segment_lengths=None, initial_std=DEFAULT_INITIAL_STD,
                 gate: float = 6.0, reseed_tries: int = 4, tracked_update: str = "kalman",
                 parents=SKELETON_PARENTS, seen_samples: int | None = None, hidden_onset: str = "posterior",
                 rng=None):
        if int(n_particles) != n_particles or n_particles < 2:
            raise ValueError(_WHERE + f"n_particles must be an integer >= 2, got {n_particles!r}")
        if resampling not in ("bootstrap", "systematic"):
            raise ValueError(_WHERE + f"resampling must be bootstrap|systematic, got {resampling!r}")
        if not (np.isfinite(measurement_std) and measurement_std > 0):
            raise ValueError(_WHERE + f"measurement_std must be > 0, got {measurement_std!r}")
        if not (np.isfinite(crown) and crown >= 0):
            raise ValueError(_WHERE + f"crown must be >= 0, got {crown!r}")
        if int(calibration_frames) != calibration_frames or calibration_frames < 1:
            raise ValueError(_WHERE + f"calibration_frames must be >= 1, got {calibration_frames!r}")
        self.model = ChainOfIntegrators(order, dt, _sigma_for_order(sigma, order), dim=3)
        self.n_particles = int(n_particles)
        self.measurement_std = float(measurement_std)
        self.crown = float(crown)
        self.resampling = resampling
        self.calibration_frames = int(calibration_frames)
        self.gate = float(gate)
        self.reseed_tries = int(reseed_tries)
        self.parents = tuple(int(p) for p in parents)
        self.n_points = len(self.parents)
        for i, p in enumerate(self.parents):
            if p >= i:
                raise ValueError(_WHERE + f"parents must precede children, point {i} has parent {p}")
        if tracked_update not in ("kalman", "bootstrap"):
            raise ValueError(_WHERE + f"tracked_update must be kalman|bootstrap, got {tracked_update!r}")
        self.tracked_update = tracked_update
        if hidden_onset not in ("posterior", "at_rest"):
            raise ValueError(_WHERE + f"hidden_onset must be posterior|at_rest, got {hidden_onset!r}")
        self.hidden_onset = hidden_onset
        if seen_samples is not None and (int(seen_samples) != seen_samples or seen_samples < 1):
            raise ValueError(_WHERE + f"seen_samples must be None or an integer >= 1, got {seen_samples!r}")
        self.seen_samples = None if seen_samples is None or seen_samples >= self.n_particles \
            else int(seen_samples)
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        init = _sigma_for_order(initial_std, order).copy()
        init[0] = measurement_std
        self._initial_std = np.repeat(init, 3)
        self._kf = KalmanFilter(self.model, self.n_points, measurement_std, init)
        # Keeps sampled covariances positive definite (1e-6 m is far below any motion).
        self._cov_floor = 1e-12 * np.eye(self.model.state_size)
        self._noise_std = np.sqrt(np.diag(self.model.W))
        self._a_t = self.model.A.T.copy()
        self._children = [tuple(c for c, p in enumerate(self.parents) if p == i)
                          for i in range(self.n_points)]
        self._fixed_lengths = None
        if segment_lengths is not None:
            lengths = np.asarray(segment_lengths, dtype=float)
            if lengths.shape != (self.n_points,):
                raise ValueError(f"segment_lengths must have shape ({self.n_points},), got {lengths.shape}")
            self._fixed_lengths = lengths.copy()
        self.reset()

    # ------------------------------------------------------------------ state
    def clone(self) -> SkeletonParticleFilter:
        """A copy for copy-on-write state: what `step` writes in place is copied (particles,
        means, flags, calibration, the Kalman tracks, the constraint cache, the generator);
        the model and the constants are shared."""
        new = shallow_copy(self)
        new.particles_ = self.particles_.copy()
        new.initialized_ = self.initialized_.copy()
        new.means_ = self.means_.copy()
        new.n_reseeds_ = self.n_reseeds_.copy()
        new.segment_lengths_ = self.segment_lengths_.copy()
        new._length_samples = [list(s) for s in self._length_samples]
        new._constraint_cache = dict(self._constraint_cache)
        new._kf = self._kf.clone()
        new.rng = clone_generator(self.rng)
        return new

    def reset(self) -> None:
        """Forget the operator: particles, and the segment-length calibration."""
        s = self.model.state_size
        self.particles_ = np.zeros((self.n_points, self.n_particles, s))
        self.initialized_ = np.zeros(self.n_points, dtype=bool)
        self.means_ = np.zeros((self.n_points, 3))
        self.n_reseeds_ = np.zeros(self.n_points, dtype=int)
        self._length_samples = [[] for _ in range(self.n_points)]
        if self._fixed_lengths is not None:
            self.segment_lengths_ = self._fixed_lengths.copy()
        else:
            self.segment_lengths_ = np.full(self.n_points, np.nan)
        self._constraint_cache = {}
        self._hidden_before = np.zeros(self.n_points, dtype=bool)
        # seen points whose particles are only seen_samples draws: moments from the posterior
        self._posterior_only = np.zeros(self.n_points, dtype=bool)
        if hasattr(self, "_kf"):
            self._kf.reset()

    @property
    def positions(self) -> np.ndarray:
        """(P, N, 3) particle positions (a view)."""
        return self.particles_[:, :, :3]

    def summaries(self, center, size) -> tuple[np.ndarray, np.ndarray]:
        """(`spread()`, `fraction_in_box(center, size)`) in one compiled pass
        (`_kernels.cloud_summaries`; those two numpy methods are its reference)."""
        center = np.asarray(center, dtype=float)
        half = 0.5 * np.asarray(size, dtype=float)
        if center.shape != (3,) or half.shape != (3,):
            raise ValueError(f"SkeletonParticleFilter.summaries: center and size must be (3,), got "
                             f"{center.shape}, {half.shape}")
        kf = self._kf
        return _kernels.cloud_summaries(self.particles_, self._posterior_only, kf.x_, kf.P_, center, half)

    def spread(self) -> np.ndarray:
        """(P,) isotropic standard deviation sqrt(trace(cov) / 3) of each point's particles (of
        its Kalman posterior for a seen point drawn with `seen_samples`)."""
        out = np.empty(self.n_points)
        cloud = ~self._posterior_only
        out[cloud] = np.sqrt(self.positions[cloud].var(axis=1).sum(axis=1) / 3.0)
        post = self._posterior_only
        if np.any(post):
            variances = np.einsum("pkk->pk", self._kf.P_[post, :3, :3])
            out[post] = np.sqrt(variances.sum(axis=1) / 3.0)
        return out

    def fraction_in_box(self, center, size) -> np.ndarray:
        """(P,) fraction of each point's particles inside an axis-aligned box (the 9.1.3 rule);
        for a seen point drawn with `seen_samples`, the probability of its Kalman posterior's
        per-axis marginals (see the class docstring)."""
        from scipy.special import ndtr

        center = np.asarray(center, dtype=float)
        half = 0.5 * np.asarray(size, dtype=float)
        out = np.empty(self.n_points)
        cloud = ~self._posterior_only
        inside = np.all(np.abs(self.positions[cloud] - center) <= half, axis=2)
        out[cloud] = inside.mean(axis=1)
        post = self._posterior_only
        if np.any(post):
            mean = self._kf.x_[post, :3]
            std = np.sqrt(np.einsum("pkk->pk", self._kf.P_[post, :3, :3]))
            low, high = (center - half - mean) / std, (center + half - mean) / std
            # the tail on the far side of the mean: no cancellation of two values near 1
            right = low > 0
            per_axis = np.where(right, ndtr(-low) - ndtr(-high), ndtr(high) - ndtr(low))
            out[post] = np.clip(per_axis, 0.0, 1.0).prod(axis=1)
        return out

    # ------------------------------------------------------------ calibration
    def _calibrate(self, points: np.ndarray, seen: np.ndarray) -> None:
        if self._fixed_lengths is not None:
            return
        changed = False
        for i, p in enumerate(self.parents):
            samples = self._length_samples[i]
            if p < 0 or len(samples) >= self.calibration_frames or not (seen[i] and seen[p]):
                continue
            samples.append(float(np.linalg.norm(points[i] - points[p])))
            self.segment_lengths_[i] = float(np.median(samples))
            changed = True
        if changed:
            self._constraint_cache.clear()

    @property
    def calibrated(self) -> bool:
        """True once every segment has its calibration_frames samples (or lengths were given)."""
        if self._fixed_lengths is not None:
            return True
        return all(len(s) >= self.calibration_frames for i, s in enumerate(self._length_samples)
                   if self.parents[i] >= 0)

    # ------------------------------------------------------------ constraints
    def _constraints(self, seen: np.ndarray):
        """Rows (point, anchor, low, high) of the admissible regions L_c2, eq. (9.13)-(9.14)."""
        key = seen.tobytes()
        cached = self._constraint_cache.get(key)
        if cached is not None:
            return cached
        rows = []
        lengths = self.segment_lengths_
        for i in range(self.n_points):
            if seen[i]:
                continue
            # Nearest seen ancestor: the parent gives a crown, a farther one the ball of the chain.
            chain, a = 0.0, i
            while self.parents[a] >= 0:
                chain += lengths[a]
                a = self.parents[a]
                if seen[a] and self.initialized_[a]:
                    break
            else:
                a = -1
            if a >= 0 and np.isfinite(chain):
                if a == self.parents[i]:
                    rows.append((i, a, chain - self.crown, chain + self.crown))
                else:
                    rows.append((i, a, 0.0, chain + self.crown))
            for c in self._children[i]:
                if seen[c] and self.initialized_[c] and np.isfinite(lengths[c]):
                    rows.append((i, c, lengths[c] - self.crown, lengths[c] + self.crown))
        if rows:
            arr = np.array(rows, dtype=float)
            out = (arr[:, 0].astype(int), arr[:, 1].astype(int), arr[:, 2], arr[:, 3])
        else:
            out = (np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0))
        # Membership matrix: one matmul folds the rows into per-point violation counts.
        member = np.zeros((self.n_points, len(out[0])))
        member[out[0], np.arange(len(out[0]))] = 1.0
        out = out + (member,)
        self._constraint_cache[key] = out
        return out

    def _admissible(self, positions: np.ndarray, points_idx: np.ndarray, seen: np.ndarray,
                    is_hidden: IsHidden | None) -> np.ndarray:
        """L_c = L_c1 L_c2 (eq. 9.12) for the positions (len(points_idx), M, 3) of hidden points."""
        ok = np.ones(positions.shape[:2], dtype=bool)
        if is_hidden is not None:
            hidden = np.asarray(is_hidden(positions.reshape(-1, 3)), dtype=bool)
            if hidden.shape != (positions.shape[0] * positions.shape[1],):
                raise ValueError(
                    "is_hidden must return a bool array of shape "
                    f"({positions.shape[0] * positions.shape[1]},), got {hidden.shape}"
                )
            ok &= hidden.reshape(positions.shape[:2])
        point, anchor, low, high, member = self._constraints(seen)
        if len(point):
            local = np.full(self.n_points, -1)
            local[points_idx] = np.arange(len(points_idx))
            rows_local = local[point]
            use = rows_local >= 0
            if np.any(use):
                offset = positions[rows_local[use]] - self.means_[anchor[use]][:, None, :]
                dist = np.linalg.norm(offset, axis=2)
                bad = ((dist < low[use, None]) | (dist > high[use, None])).astype(float)
                violations = member[points_idx][:, use] @ bad
                ok &= violations == 0
        return ok

    # -------------------------------------------------------------- re-seeding
    def _new_states(self, positions: np.ndarray, template: np.ndarray | None) -> np.ndarray:
        """States with the given positions (k, M, 3); derivatives from `template` particles or fresh."""
        k, m, _ = positions.shape
        s = self.model.state_size
        states = np.empty((k, m, s))
        if template is None:
            states[:] = self.rng.standard_normal((k, m, s)) * self._initial_std
        else:
            pick = self.rng.integers(0, template.shape[1], size=(k, m))
            states[:] = template[np.arange(k)[:, None], pick]
        states[:, :, :3] = positions
        return states

    def _reseed_hidden(self, idx: np.ndarray, seen: np.ndarray, is_hidden: IsHidden | None,
                       predicted: np.ndarray, keep_if_none: bool = True) -> np.ndarray:
        """Degeneracy: draw particles of the hidden points `idx` inside their admissible region.

        Returns (len(idx),) bool, True where admissible particles were found.
        """
        success = np.zeros(len(idx), dtype=bool)
        point, anchor, low, high, _ = self._constraints(seen)
        n = self.n_particles
        for j, i in enumerate(idx):
            rows = np.flatnonzero(point == i)
            found = []
            have = 0
            for attempt in range(self.reseed_tries):
                m = 2 * n
                if len(rows):
                    r = rows[0]
                    center = self.means_[anchor[r]]
                    direction = self.rng.standard_normal((m, 3))
                    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
                    lo = max(low[r], 0.0)
                    # Uniform in the shell volume between lo and high.
                    radius = np.cbrt(lo**3 + self.rng.random(m) * (high[r] ** 3 - lo**3))
                    cand = center + direction * radius[:, None]
                else:
                    # No anchor: widen the predicted cloud, more at every attempt.
                    base = predicted[i, self.rng.integers(0, n, m), :3]
                    cand = base + self.rng.standard_normal((m, 3)) * 0.05 * (attempt + 1)
                ok = self._admissible(cand[None], np.array([i]), seen, is_hidden)[0]
                if np.any(ok):
                    found.append(cand[ok])
                    have += int(ok.sum())
                if have >= n // 4:
                    break
            if have:
                pool = np.concatenate(found)
                chosen = pool[self.rng.integers(0, len(pool), n)]
                success[j] = True
            elif keep_if_none:
                # Nothing admissible found: keep the prediction rather than invent a position.
                chosen = predicted[i, :, :3]
            else:
                continue
            # Fresh derivatives: the old ones are what carried every particle out of the region.
            self.particles_[i] = self._new_states(chosen[None], None)[0]
            self.n_reseeds_[i] += 1
        return success

    # -------------------------------------------------------------------- step
    def _check_frame(self, points, tracked):
        points = np.asarray(points, dtype=float)
        if points.shape != (self.n_points, 3):
            raise ValueError(f"SkeletonParticleFilter.step: points must have shape ({self.n_points}, 3), "
                             f"got {points.shape}")
        if tracked is None:
            tracked = np.ones(self.n_points, dtype=bool)
        tracked = np.asarray(tracked, dtype=bool)
        if tracked.shape != (self.n_points,):
            raise ValueError(f"SkeletonParticleFilter.step: tracked must have shape ({self.n_points},), "
                             f"got {tracked.shape}")
        # NaN, infinite or absurd rows (beyond MAX_MEASUREMENT) are occlusions whatever the flag says.
        return points, tracked & valid_measurements(points)

    def step(self, points, tracked=None, is_hidden: IsHidden | None = None, steps: int = 1) -> None:
        """One filter cycle on a frame: motion update (x `steps`), weights, resampling.

        points: (P, 3) measurements (NaN rows allowed). tracked: (P,) bool, False = occluded; a
            row with NaN, inf or a coordinate beyond MAX_MEASUREMENT m counts as occluded.
        is_hidden: depth-map query, (M, 3) positions -> (M,) bool, True where the camera
            cannot see the position (L_c1). None: no depth constraint.
        """
        points, seen = self._check_frame(points, tracked)
        if int(steps) < 1:
            raise ValueError(_WHERE + f"steps must be >= 1, got {steps!r}")
        steps = int(steps)
        self._calibrate(points, seen)
        n, rng = self.n_particles, self.rng

        # First sight of a point: particles around the measurement.
        new = seen & ~self.initialized_
        if np.any(new):
            idx = np.flatnonzero(new)
            self.particles_[idx] = self._new_states(
                points[idx, None, :] + rng.standard_normal((len(idx), n, 3)) * self.measurement_std, None)
            self.means_[idx] = points[idx]
            self.initialized_[new] = True
            self._kf.initialized_[idx] = False
            self._constraint_cache.clear()
        active = self.initialized_ & ~new
        upd_seen = np.flatnonzero(seen & active)
        hidden_idx = np.flatnonzero(~seen & active)

        if self.tracked_update == "kalman":
            # Newly hidden points start from their full Kalman posterior (12-dim samples).
            onset = hidden_idx[~self._hidden_before[hidden_idx]]
            if len(onset):
                chol = np.linalg.cholesky(self._kf.P_[onset] + self._cov_floor)
                z = rng.standard_normal((len(onset), n, self.model.state_size))
                self.particles_[onset] = self._kf.x_[onset, None, :] + z @ np.swapaxes(chol, 1, 2)
                if self.hidden_onset == "at_rest":
                    self.particles_[onset, :, 3:] = 0.0
            self._seen_kalman(points, seen, active, np.flatnonzero(seen), steps)
            moving = hidden_idx
        else:
            moving = np.flatnonzero(active)
        # 1. Motion update, eq. (9.1), of every set that the particles carry.
        if len(moving):
            x = self.particles_[moving]
            for _ in range(steps):
                x = x @ self._a_t + rng.standard_normal(x.shape) * self._noise_std
            self.particles_[moving] = x

        log_w = np.zeros((self.n_points, n))
        if self.tracked_update == "bootstrap" and len(upd_seen):
            log_w[upd_seen] = self._seen_bootstrap_log_weights(points, upd_seen)

        # 2b. Hidden points: constraint likelihood L_c1 L_c2, eq. (9.10)-(9.14).
        degenerate = np.zeros(0, dtype=int)
        if len(hidden_idx):
            ok = self._admissible(self.particles_[hidden_idx, :, :3], hidden_idx, seen, is_hidden)
            log_w[hidden_idx] = np.where(ok, 0.0, -np.inf)
            dead = ~np.any(ok, axis=1)
            degenerate = hidden_idx[dead]
            log_w[degenerate] = 0.0

        # 3. Resampling of the sets that were weighted.
        res = hidden_idx if self.tracked_update == "kalman" else np.flatnonzero(active)
        if len(res):
            w = np.exp(log_w[res] - log_w[res].max(axis=1, keepdims=True))
            idx = resample_indices(w, rng, self.resampling)
            self.particles_[res] = self.particles_[res[:, None], idx]
        if len(degenerate):
            self._reseed_hidden(degenerate, seen, is_hidden, self.particles_.copy())

        # Points never seen yet: try to place them in their admissible region.
        unseen_new = np.flatnonzero(~self.initialized_)
        if len(unseen_new):
            point = self._constraints(seen)[0]
            placeable = [i for i in unseen_new if np.any(point == i)]
            if placeable:
                placeable = np.array(placeable)
                placed = self._reseed_hidden(placeable, seen, is_hidden, self.particles_.copy(),
                                             keep_if_none=False)
                if np.any(placed):
                    self.initialized_[placeable[placed]] = True
                    self._constraint_cache.clear()
        # Seen points keep their posterior means (the anchors used above); hidden ones average.
        cloud = self.initialized_ & ~seen
        self.means_[cloud] = self.positions[cloud].mean(axis=1)
        self._hidden_before = self.initialized_ & ~seen

    def _seen_bootstrap_log_weights(self, points, upd_seen):
        """Log of the Gaussian likelihood (9.8) of seen points (bootstrap PF, weights 9.9).

        Also re-acquires a point whose measurement lies outside its whole cloud, and sets the
        posterior means used as constraint anchors.
        """
        diff = self.particles_[upd_seen, :, :3] - points[upd_seen, None, :]
        d2 = np.einsum("pnk,pnk->pn", diff, diff) / self.measurement_std**2
        log_w = -0.5 * d2
        lost = d2.min(axis=1) > self.gate**2
        if np.any(lost):
            li = upd_seen[lost]
            n = self.n_particles
            self.particles_[li] = self._new_states(
                points[li, None, :] + self.rng.standard_normal((len(li), n, 3)) * self.measurement_std,
                self.particles_[li])
            log_w[lost] = 0.0
            self.n_reseeds_[li] += 1
        w = np.exp(log_w - log_w.max(axis=1, keepdims=True))
        w /= w.sum(axis=1, keepdims=True)
        self.means_[upd_seen] = np.einsum("pn,pnk->pk", w, self.particles_[upd_seen, :, :3])
        return log_w

    def _seen_kalman(self, points, seen, active, upd_seen, steps):
        """Seen points in "kalman" mode: particles drawn from the exact Gaussian posterior.

        The model is linear-Gaussian while a point is seen, so the posterior the canonical PF
        approximates is the Kalman one; sampling it avoids the sample impoverishment of the
        12-dim per-point state. A point seen again after an occlusion starts its Kalman
        posterior from the moments of its constrained particle cloud.
        """
        kf = self._kf
        back = np.flatnonzero(seen & active & self._hidden_before)
        if len(back):
            x = self.particles_[back]
            mean = x.mean(axis=1)
            centered = x - mean[:, None, :]
            cov = np.einsum("pns,pnt->pst", centered, centered) / (self.n_particles - 1)
            kf.x_[back] = mean
            kf.P_[back] = cov + self._cov_floor
        kf.predict(steps)
        if len(upd_seen):
            d = 3
            # nu^T S^-1 nu of the innovations nu, S = C P C^T + R (compiled: ~10 numpy calls)
            d2 = _kernels.kalman_gate(kf.x_, kf.P_, points, upd_seen, self.measurement_std**2)
            lost = (d2 > self.gate**2) & kf.initialized_[upd_seen]
            if np.any(lost):
                # Measurement far from the prediction: restart the track at the measurement.
                kf.initialized_[upd_seen[lost]] = False
                self.n_reseeds_[upd_seen[lost]] += 1
            mask = np.zeros(self.n_points, dtype=bool)
            mask[upd_seen] = True
            kf.update(np.where(mask[:, None], points, 0.0), mask)
            # Only positions are sampled while seen (display, spread, workspace fraction); the
            # full state is sampled from the posterior when the point gets hidden.
            k = self.seen_samples or self.n_particles
            z = self.rng.standard_normal((len(upd_seen), k, d))
            # m + L z, L the Cholesky factor of the position covariance (compiled: ~8 numpy calls)
            self.particles_[upd_seen, :k, :d] = _kernels.position_samples(kf.x_, kf.P_, upd_seen, z)
            self.means_[upd_seen] = kf.x_[upd_seen, :d]
        posterior_only = np.zeros(self.n_points, dtype=bool)  # a new array: clones share the old
        if self.seen_samples is not None:
            posterior_only[upd_seen] = True
        self._posterior_only = posterior_only
