"""Evidence for the intended goal of each hand (thesis 3.1.2).

For hand h and goal i the full feature vector is

    Phi^i = (delta_W1, delta_W2, delta_H, d)                                    (Phi, 3.1.2)

delta_W1: angle between this wrist's velocity and the vector wrist -> C_i;
delta_W2: the same angle for the other wrist; delta_H: angle between the gaze z and the vector
head -> C_i; d: distance wrist -> C_i. When the gaze flag F is invalid the reduced vector
Psi^i = (delta_W1, d) is used instead.

Wrist velocities come from a least-squares line through the last `window` samples (robust to
jitter, NaN samples skipped). A wrist is "still" when it is slower than `min_speed` or when its
slope is not `significance` standard errors away from zero (the standard error comes from the
residuals of the line, so camera noise of any level is not mistaken for motion): its direction
says nothing, so its angle is set to pi/2 (the value of a direction orthogonal to every goal).
"""

from __future__ import annotations

import numpy as np

from hrc_drake.intention import _kernels
from hrc_drake.messages import HEAD, L_WRIST, R_WRIST

#: Columns of Phi (GMM4d) and the columns of Phi that form Psi (GMM2d).
FEATURE_NAMES: tuple[str, ...] = ("delta_W1", "delta_W2", "delta_H", "d")
PSI_COLUMNS: tuple[int, ...] = (0, 3)
#: Angle given to a still wrist or an invalid gaze: no preferred goal.
NEUTRAL_ANGLE = 0.5 * np.pi
#: Below this distance (m) the direction wrist -> goal is undefined: the wrist is at the goal.
AT_GOAL = 1e-6

DEFAULT_WINDOW = 8
DEFAULT_MIN_SPEED = 0.15
#: a wrist moves when its speed is this many standard errors of the least-squares slope
DEFAULT_SIGNIFICANCE = 3.5


def angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle in [0, pi] between vectors u and v (..., 3), broadcast; 0 where either is ~zero.

    Uses atan2(|u x v|, u.v), accurate also for nearly parallel vectors.
    """
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u0, u1, u2 = u[..., 0], u[..., 1], u[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    # the components of u x v written out: np.cross costs ~50 us a call on these small arrays
    c0 = u1 * v2 - u2 * v1
    c1 = u2 * v0 - u0 * v2
    c2 = u0 * v1 - u1 * v0
    cross = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    dot = u0 * v0 + u1 * v1 + u2 * v2
    return np.arctan2(cross, dot)


def least_squares_velocity(
    times: np.ndarray,
    positions: np.ndarray,
    min_speed: float = DEFAULT_MIN_SPEED,
    min_samples: int | None = None,
    significance: float = DEFAULT_SIGNIFICANCE,
):
    """Slope of the least-squares line through windows of samples.

    times: (..., K) sample times of each window; positions: (..., K, P, 3) P points per sample,
    NaN rows are skipped. Returns velocity (..., P, 3) (zero where unknown) and moving (..., P)
    bool: at least `min_samples` (default K // 2 + 1) valid samples (fewer would turn the
    measurement noise into large spurious velocities), speed >= min_speed and
    speed >= significance * s / sqrt(sum (t - t_mean)^2), s^2 the residual variance per
    coordinate (a still wrist seen with noise has a slope of the order of its standard error).
    """
    times = np.asarray(times, dtype=float)
    positions = np.asarray(positions, dtype=float)
    valid = np.all(np.isfinite(positions), axis=-1)  # (..., K, P)
    weight = valid.astype(float)
    x = np.where(valid[..., None], positions, 0.0)
    t = times[..., :, None]  # (..., K, 1)
    count = weight.sum(axis=-2)  # (..., P)
    safe_count = np.maximum(count, 1.0)
    t_mean = (weight * t).sum(axis=-2) / safe_count  # (..., P)
    dt = (t - t_mean[..., None, :]) * weight  # (..., K, P)
    x_mean = x.sum(axis=-3) / safe_count[..., None]  # (..., P, 3)
    sxx = (dt * dt).sum(axis=-2)  # (..., P)
    sxy = (dt[..., None] * (x - x_mean[..., None, :, :])).sum(axis=-3)  # (..., P, 3)
    if min_samples is None:
        min_samples = times.shape[-1] // 2 + 1
    known = (count >= max(2, min_samples)) & (sxx > 1e-12)
    safe_sxx = np.where(known, sxx, 1.0)
    velocity = np.where(known[..., None], sxy / safe_sxx[..., None], 0.0)
    speed2 = np.sum(velocity * velocity, axis=-1)
    moving = known & (speed2 >= min_speed * min_speed)
    if significance > 0:
        centred = (x - x_mean[..., None, :, :]) * weight[..., None]
        total = np.sum(centred * centred, axis=(-3, -1))  # (..., P)
        residual = np.maximum(total - speed2 * safe_sxx, 0.0)  # RSS of the line, 3 coordinates
        dof = np.maximum(3.0 * (count - 2.0), 1.0)
        # |v|^2 sxx / s^2 >= significance^2, with s^2 = RSS / dof
        moving &= speed2 * safe_sxx * dof >= significance * significance * residual
    return velocity, moving


def trajectory_velocities(
    times: np.ndarray,
    wrists: np.ndarray,
    window: int = DEFAULT_WINDOW,
    min_speed: float = DEFAULT_MIN_SPEED,
    significance: float = DEFAULT_SIGNIFICANCE,
):
    """Causal wrist velocities along a whole recording (the batch twin of `WristVelocityEstimator`).

    times: (T,); wrists: (T, 2, 3). Sample k uses samples max(0, k-window+1)..k, exactly as the
    on-line estimator does. Returns velocity (T, 2, 3) and moving (T, 2).
    """
    times = np.asarray(times, dtype=float)
    wrists = np.asarray(wrists, dtype=float)
    if times.ndim != 1 or wrists.shape != (times.shape[0], 2, 3):
        raise ValueError(
            f"trajectory_velocities: times (T,) and wrists (T, 2, 3) expected, "
            f"got {times.shape} and {wrists.shape}"
        )
    if window < 2:
        raise ValueError(f"trajectory_velocities: window must be >= 2, got {window}")
    # Pad the start with NaN samples so every step has a full window (NaN rows are skipped).
    pad_t = np.concatenate([np.full(window - 1, times[0] if len(times) else 0.0), times])
    pad_x = np.concatenate([np.full((window - 1, 2, 3), np.nan), wrists])
    win_t = np.lib.stride_tricks.sliding_window_view(pad_t, window)  # (T, K)
    win_x = np.moveaxis(np.lib.stride_tricks.sliding_window_view(pad_x, window, axis=0), -1, 1)
    return least_squares_velocity(win_t, win_x, min_speed, significance=significance)


class WristVelocityEstimator:
    """On-line wrist velocities from the last `window` samples (least-squares slope)."""

    def __init__(
        self,
        window: int = DEFAULT_WINDOW,
        min_speed: float = DEFAULT_MIN_SPEED,
        significance: float = DEFAULT_SIGNIFICANCE,
    ):
        if int(window) < 2:
            raise ValueError(f"WristVelocityEstimator: window must be >= 2, got {window}")
        if not min_speed >= 0.0:
            raise ValueError(f"WristVelocityEstimator: min_speed must be >= 0, got {min_speed}")
        if not significance >= 0.0:
            raise ValueError(f"WristVelocityEstimator: significance must be >= 0, got {significance}")
        self.window = int(window)
        self.min_speed = float(min_speed)
        self.significance = float(significance)
        self.reset()

    def clone(self) -> WristVelocityEstimator:
        """A copy for copy-on-write state: `update` shifts the window into new arrays, so the
        copy shares the current ones."""
        new = WristVelocityEstimator.__new__(WristVelocityEstimator)
        new.__dict__.update(self.__dict__)
        return new

    def reset(self) -> None:
        self._times = np.zeros(self.window)
        self._wrists = np.full((self.window, 2, 3), np.nan)

    def update(self, time: float, wrists: np.ndarray):
        """Add the sample (2, 3) taken at `time`; return velocity (2, 3) and moving (2,)."""
        wrists = np.asarray(wrists, dtype=float)
        if wrists.shape != (2, 3):
            raise ValueError(f"WristVelocityEstimator.update: wrists must be (2, 3), got {wrists.shape}")
        # new arrays (the window shifted by one), never written in place: clones share the old
        self._times = np.concatenate([self._times[1:], [float(time)]])
        self._wrists = np.concatenate([self._wrists[1:], wrists[None]])
        # `least_squares_velocity` of this one window, compiled (its numpy form is the reference)
        return _kernels.window_velocity(self._times, self._wrists, self.min_speed, self.window // 2 + 1,
                                       self.significance)


def as_goal_samples(goal_centers: np.ndarray) -> np.ndarray:
    """Goal centres as (G, Np, 3) hypotheses; (G, 3) becomes (G, 1, 3)."""
    centers = np.asarray(goal_centers, dtype=float)
    if centers.ndim == 2 and centers.shape[1] == 3:
        centers = centers[:, None, :]
    if centers.ndim != 3 or centers.shape[2] != 3 or centers.shape[0] == 0:
        raise ValueError(f"goal centres must be (G, 3) or (G, Np, 3) with G >= 1, got {centers.shape}")
    if not np.all(np.isfinite(centers)):
        raise ValueError("goal centres contain NaN or inf")
    return centers


def goal_features(
    wrists: np.ndarray,
    velocities: np.ndarray,
    moving: np.ndarray,
    head: np.ndarray,
    gaze: np.ndarray,
    goal_centers: np.ndarray,
) -> np.ndarray:
    """Phi^i of thesis 3.1.2 for both hands and every goal (hypothesis).

    wrists, velocities: (..., 2, 3) left then right; moving: (..., 2); head, gaze: (..., 3);
    goal_centers: (G, 3) or (G, Np, 3) sampled hypotheses of each centre (eq. 3.12).
    Returns Phi (..., 2, G, Np, 4): for hand h, (delta_W1, delta_W2, delta_H, d) with W1 = h.
    NaN wrists give NaN distances; callers skip those hands. An invalid head or gaze gives the
    neutral angle (GMM2d should be used then).
    """
    centers = as_goal_samples(goal_centers)  # (G, Np, 3)
    wrists = np.asarray(wrists, dtype=float)
    velocities = np.asarray(velocities, dtype=float)
    moving = np.asarray(moving, dtype=bool)
    head = np.asarray(head, dtype=float)
    gaze = np.asarray(gaze, dtype=float)
    to_goal = centers - wrists[..., :, None, None, :]  # (..., 2, G, Np, 3)
    distance = np.linalg.norm(to_goal, axis=-1)  # (..., 2, G, Np)
    wrist_angle = angle_between(velocities[..., :, None, None, :], to_goal)
    wrist_angle = np.where(distance < AT_GOAL, 0.0, wrist_angle)
    wrist_angle = np.where(moving[..., :, None, None], wrist_angle, NEUTRAL_ANGLE)
    head_angle = angle_between(gaze[..., None, None, :], centers - head[..., None, None, :])  # (..., G, Np)
    head_angle = np.where(np.isfinite(head_angle), head_angle, NEUTRAL_ANGLE)
    other = wrist_angle[..., ::-1, :, :]
    head_both = np.broadcast_to(head_angle[..., None, :, :], wrist_angle.shape)
    return np.stack([wrist_angle, other, head_both, distance], axis=-1)


def skeleton_features(
    points: np.ndarray, velocities: np.ndarray, moving: np.ndarray, gaze: np.ndarray, goal_centers: np.ndarray
) -> np.ndarray:
    """`goal_features` reading wrists and head from skeleton points (..., 8, 3)."""
    points = np.asarray(points, dtype=float)
    wrists = points[..., [L_WRIST, R_WRIST], :]
    return goal_features(wrists, velocities, moving, points[..., HEAD, :], gaze, goal_centers)
