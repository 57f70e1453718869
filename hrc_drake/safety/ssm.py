"""Speed and separation monitoring of ISO/TS 15066 clause 5.5.4 (eq. 1-2), per robot point.

With constant speeds over the reaction time T_r and a robot braking at a constant deceleration a
(its stopping model: T_s = v_r / a, S_s = v_r^2 / (2a), computed, not assumed), eq. (1)-(2) give
the protective separation distance of a robot point moving toward the human at v_r:

    S_p(v_r) = S_h + S_r + S_s + C + Z_d + Z_r
    S_h = v_h (T_r + T_s)       the human's approach while the robot reacts and stops
    S_r = v_r (T_r + P)         the robot's travel during its reaction time (and a period P it
                                moves at once when its command acts, `actuation_period`)
    S_s = v_r^2 / (2 a)         the robot's stopping distance

v_h follows ISO 13855 (eq. 1 there: S = K T + C): K = 2.0 m/s while K T <= 0.5 m, else
K = 1.6 m/s with S_h >= 0.5 m; a scenario may fix v_h instead. S_p grows with v_r, so the
permissible speed at separation d is the root of S_p(v) = d, a quadratic on each piece of the
ISO 13855 rule (the closed form of the standard's Annex-free SSM formulation); no positive speed
satisfies it when d < S_p(0): a protective stop.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

#: ISO 13855: approach speed of the upper limbs K = 2000 mm/s while S <= 500 mm ...
ISO13855_FAST = 2.0
#: ... of a walking person K = 1600 mm/s beyond, with S >= 500 mm.
ISO13855_SLOW = 1.6
ISO13855_SWITCH = 0.5


@dataclass(frozen=True)
class SeparationParameters:
    """The terms of eq. (1)-(2) that do not depend on the robot's speed (SI units).

    reaction_time: T_r; deceleration: a of the stopping model; intrusion: C; robot_uncertainty:
    Z_r; human_speed: v_h, or 0 for ISO 13855's rule; actuation_period: P, a period the robot
    travels at v before the next command can act (a controller whose override moves the robot a
    whole period at once adds v P to S_r). Z_d is per region, given with each call.
    """

    reaction_time: float = 0.1
    deceleration: float = 5.0
    intrusion: float = 0.05
    robot_uncertainty: float = 0.01
    human_speed: float = 0.0
    actuation_period: float = 0.0

    def __post_init__(self):
        for name in ("reaction_time", "intrusion", "robot_uncertainty", "human_speed", "actuation_period"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"SeparationParameters.{name} must be a finite number >= 0, got {value!r}")
        if not (np.isfinite(self.deceleration) and self.deceleration > 0):
            raise ValueError(f"SeparationParameters.deceleration must be > 0, got {self.deceleration!r}")

    def _pieces(self, covered_time: float = 0.0):
        """(K, constant human term, v_low, v_high) of each piece of S_h(T_r + v / a); with a
        `covered_time` H (swept volumes), S_h = K max(T_r + v / a - H, 0) at K = v_h or 2.0 m/s."""
        a, t_r = self.deceleration, self.reaction_time
        if covered_time > 0:
            speed = self.human_speed if self.human_speed > 0 else ISO13855_FAST
            switch = max(a * (covered_time - t_r), 0.0)
            return ((0.0, 0.0, 0.0, switch), (speed, -speed * covered_time, switch, np.inf))
        if self.human_speed > 0:
            return ((self.human_speed, 0.0, 0.0, np.inf),)
        fast_end = max(a * (ISO13855_SWITCH / ISO13855_FAST - t_r), 0.0)
        slow_start = max(a * (ISO13855_SWITCH / ISO13855_SLOW - t_r), 0.0)
        return ((ISO13855_FAST, 0.0, 0.0, fast_end),
                (0.0, ISO13855_SWITCH, fast_end, slow_start),
                (ISO13855_SLOW, 0.0, slow_start, np.inf))


def path_stop(params: SeparationParameters, speed: float, fastest: float) -> SeparationParameters:
    """`params` for a point approaching at `speed` when the controller brakes the whole path at a on
    its fastest point (`fastest`, both at full path speed): the point decelerates at a v / V, so
    its T_s = V / a and S_s = v V / (2a), the stop the controller makes (`rules.decelerated_override`)."""
    if fastest > speed > 0.0:
        return replace(params, deceleration=params.deceleration * speed / fastest)
    return params


def human_approach(time, human_speed: float = 0.0):
    """S_h (m) over `time` (s): v_h T, or ISO 13855's 2.0 T while <= 0.5 m, else max(1.6 T, 0.5)."""
    time = np.asarray(time, dtype=float)
    if human_speed > 0:
        return human_speed * time
    fast = ISO13855_FAST * time
    return np.where(fast <= ISO13855_SWITCH, fast, np.maximum(ISO13855_SLOW * time, ISO13855_SWITCH))


def stopping_distance(speed, deceleration: float):
    """S_s = v^2 / (2a) (m) and T_s = v / a (s) of a constant-deceleration stop."""
    speed = np.maximum(np.asarray(speed, dtype=float), 0.0)
    return speed * speed / (2.0 * deceleration), speed / deceleration


def protective_separation(speed, params: SeparationParameters, z_d=0.0, covered_time: float = 0.0):
    """S_p (m) of eq. (1)-(2) for robot points approaching at `speed` (m/s), Z_d = `z_d`; broadcasts.
    covered_time: H of swept volumes that already hold the human's motion over H s."""
    speed = np.maximum(np.asarray(speed, dtype=float), 0.0)
    s_s, t_s = stopping_distance(speed, params.deceleration)
    if covered_time > 0:
        human = (params.human_speed if params.human_speed > 0 else ISO13855_FAST) * np.maximum(
            params.reaction_time + t_s - covered_time, 0.0)
    else:
        human = human_approach(params.reaction_time + t_s, params.human_speed)
    return (human + speed * (params.reaction_time + params.actuation_period) + s_s + params.intrusion + z_d
            + params.robot_uncertainty)


def permissible_speed(distance, params: SeparationParameters, z_d=0.0, covered_time: float = 0.0):
    """The largest v_r (m/s) with S_p(v_r) <= `distance` (closed form per ISO 13855 piece): 0 where
    even a stopped robot is too near (a protective stop), inf where the separation is infinite.
    covered_time: as `protective_separation`."""
    margins = params.intrusion + params.robot_uncertainty + np.asarray(z_d, dtype=float)
    d = np.asarray(distance, dtype=float) - margins
    a, t_r = params.deceleration, params.reaction_time
    best = np.zeros(np.broadcast(d, np.zeros(())).shape)
    for k, constant, low, high in params._pieces(covered_time):
        if high <= low:
            continue
        # v^2 / (2a) + v (K / a + T_r) + (K T_r + constant - d) = 0, the root v >= 0
        b = k / a + t_r + params.actuation_period
        c = k * t_r + constant - d
        disc = np.maximum(b * b - 2.0 * c / a, 0.0)
        root = a * (np.sqrt(disc) - b)
        inside = (root >= low - 1e-12) & (root <= high + 1e-12)
        best = np.where(inside & (c <= 0), np.maximum(best, root), best)
    best = np.where(np.isinf(d) & (d > 0), np.inf, best)
    return float(best) if best.ndim == 0 else best
