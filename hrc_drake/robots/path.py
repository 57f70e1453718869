"""Joint-space path following with velocity limits and a speed override (pure numpy core).

Each arm follows a list of waypoints. A segment from q_a to q_b takes
T = 1.875 * max_j |q_b,j - q_a,j| / (f * v_max,j) at full speed, where 1.875 is the peak of the
minimum-jerk velocity profile s'(tau) = 30 tau^2 (1 - tau)^2, so the joint velocity limits
hold for any override in [0, 1]. The override scales the rate of progress (thesis 8.1: the
robot keeps its path and changes its speed). After each waypoint the arm dwells for the
given time (its work at that station), also scaled by the override.
"""

from __future__ import annotations

import numpy as np

from hrc_drake.messages import shallow_copy

MIN_JERK_PEAK = 1.875
MIN_SEGMENT_TIME = 0.2


def min_jerk_profile(tau: np.ndarray | float) -> np.ndarray | float:
    """Normalised minimum-jerk position s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, tau in [0, 1]."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


class ArmPath:
    """The path one arm is following: waypoints (n, dof), dwell per waypoint, progress."""

    def __init__(
        self, start: np.ndarray, waypoints: np.ndarray, dwells: np.ndarray, v_max: np.ndarray, fraction: float
    ):
        self.points = np.vstack([start[None, :], waypoints])
        deltas = np.abs(np.diff(self.points, axis=0))
        self.move_times = np.maximum(
            MIN_JERK_PEAK * np.max(deltas / (fraction * v_max), axis=1), MIN_SEGMENT_TIME
        )
        self.dwells = np.asarray(dwells, dtype=float)
        self.segment = 0
        self.phase = 0.0  # progress in seconds at full speed within the segment's move + dwell
        self.finished = len(waypoints) == 0

    def progress_after(self, segment: int, phase: float, dt: float) -> tuple[int, float, bool]:
        """Progress (segment, phase, finished) `dt` seconds of full-speed time after (segment, phase);
        a negative dt goes back along the path (a retreat), no further than its start."""
        if dt < 0:
            return (*self._back(segment, phase, dt), False)
        n = len(self.move_times)
        while dt > 0 and segment < n:
            total = self.move_times[segment] + self.dwells[segment]
            step = min(dt, total - phase)
            phase += step
            dt -= step
            if phase >= total - 1e-12:
                segment += 1
                phase = 0.0
        return segment, phase, segment >= n

    def _back(self, segment: int, phase: float, dt: float) -> tuple[int, float]:
        """(segment, phase) -dt seconds of full-speed time before (segment, phase), dt < 0."""
        while dt < 0:
            if phase > 0:
                step = max(dt, -phase)
                phase += step
                dt -= step
            elif segment > 0:
                segment -= 1
                phase = self.move_times[segment] + self.dwells[segment]
            else:
                break
        return segment, phase

    def position_at(self, segment: int, phase: float) -> np.ndarray:
        """Joint positions at progress (segment, phase); phase may run past the segment."""
        while segment < len(self.move_times) and phase >= self.move_times[segment] + self.dwells[segment]:
            phase -= self.move_times[segment] + self.dwells[segment]
            segment += 1
        if segment >= len(self.move_times):
            return self.points[-1].copy()
        a, b = self.points[segment], self.points[segment + 1]
        u = min(max(phase / self.move_times[segment], 0.0), 1.0)  # scalar min-jerk: no numpy call
        return a + (b - a) * (u * u * u * (10.0 + u * (-15.0 + 6.0 * u)))

    def advance(self, dt: float) -> np.ndarray:
        """Advance by `dt` seconds of full-speed time; return the arm's joint positions."""
        if not self.finished:
            self.segment, self.phase, self.finished = self.progress_after(self.segment, self.phase, dt)
        return self.position()

    def position(self) -> np.ndarray:
        return self.position_ahead(0.0)

    def position_ahead(self, dt: float) -> np.ndarray:
        """Joint positions `dt` seconds of full-speed time ahead, without advancing."""
        if self.finished:
            return self.points[-1].copy()
        return self.position_at(self.segment, self.phase + dt)

    def velocity(self) -> np.ndarray:
        if self.finished:
            return np.zeros(self.points.shape[1])
        return self.velocity_at(self.segment, self.phase)

    def velocity_at(self, segment: int, phase: float) -> np.ndarray:
        """Joint velocities at full speed at progress (segment, phase) (0 while dwelling)."""
        if segment >= len(self.move_times):
            return np.zeros(self.points.shape[1])
        a, b = self.points[segment], self.points[segment + 1]
        T = self.move_times[segment]
        tau = phase / T
        if tau >= 1.0 or tau < 0.0:  # done, or held before its start (`PathFollower.hold_new_paths`)
            return np.zeros_like(a)
        return (b - a) * 30.0 * tau**2 * (1.0 - tau) ** 2 / T


class BlendedArmPath(ArmPath):
    """One minimum-jerk move along the whole polyline start -> waypoints, then the last dwell.

    For dense paths (a proactive path of thesis 8.2.3, 43 waypoints): the arm does not stop
    at every waypoint, as a robot controller blending its zones would not. Progress along the
    polyline is its length in full-speed time, sum_i max_j |dq_ij| / (f v_max,j), scaled by
    the minimum-jerk profile, so every joint stays within f * v_max.
    """

    def __init__(
        self, start: np.ndarray, waypoints: np.ndarray, dwells: np.ndarray, v_max: np.ndarray, fraction: float
    ):
        self.points = np.vstack([start[None, :], waypoints])
        deltas = np.abs(np.diff(self.points, axis=0))
        self._lengths = np.max(deltas / (fraction * v_max), axis=1)  # full-speed time per piece
        self._cumulative = np.concatenate([[0.0], np.cumsum(self._lengths)])
        total = float(self._cumulative[-1])
        self.move_times = np.array([max(MIN_JERK_PEAK * total, MIN_SEGMENT_TIME)])
        dwells = np.asarray(dwells, dtype=float)
        self.dwells = dwells[-1:] if len(dwells) else np.zeros(1)
        self.segment = 0
        self.phase = 0.0
        self.finished = len(waypoints) == 0

    def _piece(self, arc: float) -> tuple[int, float]:
        """(piece index, fraction within it) of the point at full-speed length `arc`."""
        i = int(np.searchsorted(self._cumulative, arc, side="right")) - 1
        i = min(max(i, 0), len(self._lengths) - 1)
        length = self._lengths[i]
        return i, 0.0 if length <= 0 else min(max((arc - self._cumulative[i]) / length, 0.0), 1.0)

    def position_at(self, segment: int, phase: float) -> np.ndarray:
        T = self.move_times[0]
        if segment >= 1 or phase >= T:
            return self.points[-1].copy()
        u = max(phase / T, 0.0)
        i, f = self._piece(self._cumulative[-1] * (u * u * u * (10.0 + u * (-15.0 + 6.0 * u))))
        return self.points[i] + (self.points[i + 1] - self.points[i]) * f

    def velocity_at(self, segment: int, phase: float) -> np.ndarray:
        T = self.move_times[0]
        if segment >= 1 or phase >= T or self._cumulative[-1] <= 0:
            return np.zeros(self.points.shape[1])
        u = max(phase / T, 0.0)
        i, _ = self._piece(self._cumulative[-1] * float(min_jerk_profile(u)))
        rate = self._cumulative[-1] * 30.0 * u**2 * (1.0 - u) ** 2 / T  # full-speed length per second
        if self._lengths[i] <= 0:
            return np.zeros(self.points.shape[1])
        return (self.points[i + 1] - self.points[i]) / self._lengths[i] * rate


def make_arm_path(start, waypoints, dwells, v_max, fraction, blended: bool = False) -> ArmPath:
    """An `ArmPath` (stop at every waypoint) or, when `blended`, a `BlendedArmPath`."""
    return (BlendedArmPath if blended else ArmPath)(start, waypoints, dwells, v_max, fraction)


class JointPathFollower:
    """Follows one path per arm over a robot (or cell) position vector.

    arm_indices: for every arm, the indices of its joints in the position vector q.
    v_max: for every arm, its joint velocity limits (rad/s).
    """

    def __init__(
        self,
        q0: np.ndarray,
        arm_indices: list[np.ndarray],
        v_max: list[np.ndarray],
        velocity_fraction: float = 0.8,
    ):
        if not 0 < velocity_fraction <= 1:
            raise ValueError(f"velocity_fraction must be in (0, 1], got {velocity_fraction}")
        self.q = np.asarray(q0, dtype=float).copy()
        self.arm_indices = [np.asarray(i, dtype=int) for i in arm_indices]
        self.v_max = [np.asarray(v, dtype=float) for v in v_max]
        for k, (idx, v) in enumerate(zip(self.arm_indices, self.v_max, strict=True)):
            if idx.shape != v.shape or np.any(v <= 0):
                raise ValueError(f"arm {k}: need one positive velocity limit per joint")
        self.fraction = velocity_fraction
        self.paths: list[ArmPath | None] = [None] * len(self.arm_indices)
        self.requested_seq = [0] * len(self.arm_indices)
        self.done_seq = [0] * len(self.arm_indices)

    def clone(self) -> JointPathFollower:
        """A copy that `request`/`step` may change; the paths' arrays are shared (never written)."""
        other = shallow_copy(self)
        other.q = self.q.copy()
        other.paths = [None if p is None else shallow_copy(p) for p in self.paths]
        other.requested_seq = list(self.requested_seq)
        other.done_seq = list(self.done_seq)
        return other

    def request(self, arm: int, seq: int, waypoints: np.ndarray, dwells: np.ndarray,
                blended: bool = False) -> None:
        """Start following `waypoints` (n, dof) from where the arm is; `seq` tags completion;
        `blended`: one move along the polyline (`BlendedArmPath`)."""
        waypoints = np.atleast_2d(np.asarray(waypoints, dtype=float))
        if waypoints.shape[1] != len(self.arm_indices[arm]):
            raise ValueError(
                f"arm {arm}: waypoints have {waypoints.shape[1]} joints, "
                f"expected {len(self.arm_indices[arm])}"
            )
        start = self.q[self.arm_indices[arm]]
        self.paths[arm] = make_arm_path(
            start, waypoints, np.broadcast_to(dwells, len(waypoints)), self.v_max[arm], self.fraction, blended
        )
        self.requested_seq[arm] = seq

    def step(self, dt: float, override: float) -> np.ndarray:
        """Advance every arm by `dt` seconds at speed `override` in [0, 1]; return q."""
        override = float(np.clip(override, 0.0, 1.0)) if np.isfinite(override) else 0.0
        for arm, path in enumerate(self.paths):
            if path is None:
                continue
            self.q[self.arm_indices[arm]] = path.advance(dt * override)
            if path.finished:
                self.done_seq[arm] = self.requested_seq[arm]
                self.paths[arm] = None
        return self.q

    def positions_ahead(self, dt: float, override: float) -> np.ndarray:
        """q after `dt` more seconds at speed `override`, without advancing (smooth output between ticks)."""
        q = self.q.copy()
        for arm, path in enumerate(self.paths):
            if path is not None:
                q[self.arm_indices[arm]] = path.position_ahead(dt * override)
        return q

    def velocities(self, override: float) -> np.ndarray:
        v = np.zeros_like(self.q)
        for arm, path in enumerate(self.paths):
            if path is not None:
                v[self.arm_indices[arm]] = path.velocity() * override
        return v
