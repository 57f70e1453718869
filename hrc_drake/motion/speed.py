"""Speed scaling from the distance to the human swept volumes (thesis 8.1.3, ISO/TS 15066 SSM).

The robot keeps a protective separation distance (speed and separation monitoring)

    S_p(s) = C + v_h (T_r + T_s) + s v_r T_r + s v_r T_s / 2

where s in [0, 1] is the speed override of the nominal path speed, v_r the robot's speed at
s = 1, T_r the reaction time (sensing + one controller period), T_s the stopping time (a
constant deceleration stops in s v_r T_s / 2), C the minimum clearance and v_h the human
speed not already covered by the swept volumes (0 when their horizon >= T_r + T_s). The
override is the largest s with S_p(s) <= d, d the clearance between robot and swept volumes:
1 far away, 0 (stop) once d <= C + v_h (T_r + T_s), linear and monotone in between.

ISO/TS 15066 takes v_r as the robot speed toward the operator. When the caller knows where the
robot will be shortly along its path at full speed, the approach speed is the rate at which
that motion shrinks the clearance; a robot moving away (approach speed <= 0) keeps full speed,
so a robot stopped next to the operator can still retreat.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hrc_drake.motion.geometry import capsule_capsule_distance


@dataclass(frozen=True)
class SeparationRule:
    """Parameters of the speed-and-separation rule (SI units)."""

    clearance: float = 0.1
    reaction_time: float = 0.1
    stopping_time: float = 0.3
    robot_speed: float = 1.0
    human_speed: float = 0.0

    def __post_init__(self):
        for name in ("clearance", "reaction_time", "stopping_time", "human_speed"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"SeparationRule: {name} must be a finite number >= 0, got {value!r}")
        if not np.isfinite(self.robot_speed) or self.robot_speed <= 0:
            raise ValueError(f"SeparationRule: robot_speed must be > 0, got {self.robot_speed!r}")
        if self.reaction_time + self.stopping_time <= 0:
            raise ValueError("SeparationRule: reaction_time + stopping_time must be > 0")

    @classmethod
    def from_params(cls, params: dict) -> SeparationRule:
        """Build from a scenario params dict; unknown keys among the rule's names are ignored."""
        names = ("clearance", "reaction_time", "stopping_time", "robot_speed", "human_speed")
        return cls(**{k: float(params[k]) for k in names if k in params})

    @property
    def stop_distance(self) -> float:
        """Clearance at or below which the override is 0."""
        return self.clearance + self.human_speed * (self.reaction_time + self.stopping_time)

    @property
    def full_speed_distance(self) -> float:
        """Clearance from which the override is 1: S_p(1)."""
        return self.stop_distance + self.robot_speed * (self.reaction_time + 0.5 * self.stopping_time)

    def override(self, distance, approach_speed=None) -> np.ndarray | float:
        """Speed override in [0, 1] for the clearance `distance` (m), vectorised; NaN is an error.

        approach_speed: speed (m/s) at which the robot's full-speed motion shrinks the clearance
        (None: `robot_speed`, any direction); <= 0 (moving away) gives 1.
        """
        d = np.asarray(distance, dtype=float)
        if np.any(np.isnan(d)):
            raise ValueError("SeparationRule.override: distance is NaN")
        speed = self.robot_speed if approach_speed is None else np.asarray(approach_speed, dtype=float)
        if np.any(np.isnan(speed)):
            raise ValueError("SeparationRule.override: approach_speed is NaN")
        slope = np.maximum(speed, 1e-9) * (self.reaction_time + 0.5 * self.stopping_time)
        s = np.clip((d - self.stop_distance) / slope, 0.0, 1.0)
        s = np.where(speed <= 0.0, 1.0, s)
        return float(s) if s.ndim == 0 else s


def minimum_distance(robot_capsules, swept_start, swept_end, swept_radius) -> float:
    """Smallest clearance (m) between robot link capsules and swept-volume capsules.

    robot_capsules: (start (K, 3), end (K, 3), radius (K,)). inf when either set is empty;
    negative when they overlap. One vectorised computation over all K x H pairs.
    """
    try:
        start, end, radius = robot_capsules
    except (TypeError, ValueError) as err:
        raise ValueError("minimum_distance: robot_capsules must be a tuple (start, end, radius)") from err
    start = np.asarray(start, dtype=float).reshape(-1, 3)
    swept_start = np.asarray(swept_start, dtype=float).reshape(-1, 3)
    if len(start) == 0 or len(swept_start) == 0:
        return float("inf")
    return float(capsule_capsule_distance(start, end, radius, swept_start, swept_end, swept_radius).min())


class SpeedScalerCore:
    """Distance to the swept volumes -> speed override, one step (8.1.3).

    params: the `SeparationRule` fields (clearance, reaction_time, stopping_time,
    robot_speed, human_speed).
    """

    def __init__(self, params: dict | None = None):
        self.rule = SeparationRule.from_params(params or {})

    def step(self, robot_capsules, swept, capsules_ahead=None, lookahead: float = 0.1) -> tuple[float, float]:
        """(override, min_distance) for robot capsules and a `SweptVolumes` message.

        capsules_ahead: optional robot capsules `lookahead` s later along the path at full speed
        (same capsules, same order). With them each robot capsule k gets its own approach speed
        (d_k - d_k_ahead) / lookahead, d_k its clearance to the swept volumes, and the override
        is the smallest of the per-capsule rules.
        """
        distance = minimum_distance(robot_capsules, swept.start, swept.end, swept.radius)
        if capsules_ahead is None or len(np.asarray(capsules_ahead[0]).reshape(-1, 3)) == 0 \
                or not np.isfinite(distance):
            return self.rule.override(distance), distance
        if not lookahead > 0:
            raise ValueError(f"SpeedScalerCore.step: lookahead must be > 0, got {lookahead!r}")
        now = _per_capsule_distance(robot_capsules, swept)
        ahead = _per_capsule_distance(capsules_ahead, swept)
        if now.shape != ahead.shape:
            raise ValueError(f"SpeedScalerCore.step: {len(now)} robot capsules but {len(ahead)} ahead")
        return float(np.min(self.rule.override(now, (now - ahead) / lookahead))), distance


def _per_capsule_distance(robot_capsules, swept) -> np.ndarray:
    """Clearance (K,) of each robot capsule to the nearest swept volume."""
    start, end, radius = robot_capsules
    return capsule_capsule_distance(start, end, radius, swept.start, swept.end, swept.radius).min(axis=1)
