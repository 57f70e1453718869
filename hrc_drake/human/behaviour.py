"""The quirks of the realistic operator (`human.config.RealisticBehaviour`), as plain draws.

`SyntheticOperator` asks this module, once per person, for its speed factor and its smooth
noise, and once per phase of an action for the phase's timing (eye-hand lead, reach time,
hesitation, aborted start) and for the glances of the action. Every draw comes from a generator
the operator seeds with its seed and the action's index, so the same seed gives the same run,
and a clone or a replanning draws the same quirks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hrc_drake.distributions import sample_duration

#: time for the head to turn to a glance target, and again to turn back (s; assumption)
GLANCE_TURN = 0.15
#: the person's speed factor is kept in this range
SPEED_RANGE = (0.5, 2.0)
#: the eye-hand lead takes at most this share of a phase (the hand must still get there)
MAX_LEAD_SHARE = 0.4
#: the hand's motions fill at most this share of a phase after the lead (the rest is a dwell)
MOTION_SHARE = 0.95
#: a hesitation stops the hand at a share of its reach drawn uniformly in this range
HESITATION_AT = (0.3, 0.7)
#: a wrong goal of an aborted reach lies at least this far from the right one (m)
ABORT_MIN_SEPARATION = 0.15
#: random cosines per channel of `SmoothNoise`
NOISE_FEATURES = 32


class SmoothNoise:
    """Zero-mean smooth random signals, a closed-form function of time (channels,).

    Each channel c is sqrt(2 / n) sigma_c sum_j cos(w_cj t + phi_cj), with w_cj ~ N(0, 1 / tau_c^2)
    and phi_cj ~ U(0, 2 pi): random Fourier features (Rahimi & Recht 2007) of a Gaussian process
    with correlation sigma_c^2 exp(-dt^2 / (2 tau_c^2)), so its value at a lag of tau_c keeps
    61 % of its correlation. A function of t rather than a simulated process (e.g. an
    Ornstein-Uhlenbeck one): it holds no run state, so copies, replanning and queries at any
    time agree. std, time: (channels,) sigma_c (any unit) and tau_c (s).
    """

    def __init__(self, std, time, rng: np.random.Generator, n_features: int = NOISE_FEATURES):
        std = np.asarray(std, dtype=float).reshape(-1)
        time = np.broadcast_to(np.asarray(time, dtype=float), std.shape)
        self.omega = rng.standard_normal((std.size, n_features)) / time[:, None]
        self.phase = rng.uniform(0.0, 2.0 * math.pi, (std.size, n_features))
        self.amplitude = std * math.sqrt(2.0 / n_features)

    def at(self, t: float) -> np.ndarray:
        return self.amplitude * np.cos(self.omega * float(t) + self.phase).sum(axis=1)

    def __deepcopy__(self, memo):
        return self  # immutable


def person_speed(behaviour, rng: np.random.Generator) -> float:
    """The person's speed factor: normal around 1 with `speed_std`, kept in SPEED_RANGE."""
    return float(np.clip(1.0 + behaviour.speed_std * rng.standard_normal(), *SPEED_RANGE))


@dataclass(frozen=True)
class PhaseTiming:
    """When and how the hand moves in one phase of an action (times in s from the phase start).

    The gaze turns to the goal (to `wrong_goal` first on an aborted reach) at the phase start;
    the hand starts at `lead`. An aborted reach first covers `abort_fraction` of the way to the
    wrong goal in `wrong_time`, then reaches the right goal in `reach`; a hesitation stops the
    reach at `hesitate_at` of its way for `pause` s.
    """

    lead: float
    reach: float
    hesitate_at: float | None = None
    pause: float = 0.0
    wrong_goal: int | None = None
    wrong_time: float = 0.0


def draw_phase(behaviour, rng: np.random.Generator, phase: float, speed: float, n_wrong_goals: int,
               reach_fraction: float) -> PhaseTiming:
    """The timing of one phase of length `phase` (s); n_wrong_goals: goals an aborted reach may
    start towards (wrong_goal indexes them). The reach takes `reach_fraction` of the time after
    the lead, divided by the person's speed; what does not fit in the phase is shortened (the
    pause first)."""
    lead = min(float(sample_duration(behaviour.eye_hand_lead, rng)), MAX_LEAD_SHARE * phase)
    budget = MOTION_SHARE * (phase - lead)
    reach = min(reach_fraction * (phase - lead) / speed, budget)
    hesitates = rng.random() < behaviour.hesitation_probability
    hesitate_at = float(rng.uniform(*HESITATION_AT))
    pause = float(sample_duration(behaviour.hesitation_duration, rng))
    aborts = n_wrong_goals > 0 and rng.random() < behaviour.abort_probability
    wrong_goal = int(rng.integers(max(n_wrong_goals, 1)))
    if not aborts:
        wrong_time = 0.0
        wrong_goal = None
    else:
        wrong_time = behaviour.abort_fraction * reach
        scale = min(1.0, budget / (reach + wrong_time))
        reach, wrong_time = scale * reach, scale * wrong_time
    if not hesitates:
        return PhaseTiming(lead, reach, wrong_goal=wrong_goal, wrong_time=wrong_time)
    pause = min(pause, max(budget - reach - wrong_time, 0.0))
    return PhaseTiming(lead, reach, hesitate_at, pause, wrong_goal, wrong_time)


def draw_glances(behaviour, rng: np.random.Generator, windows, n_goals: int, n_robots: int) -> list:
    """Glances in the time windows [(start, end)] of an action: (time the head starts turning
    away, fixation time, target) with target ("goal", i) or ("robot", i).

    While the gaze is on the task, a glance starts at rate `glance_rate` (a renewal process:
    the clock restarts when the gaze is back); a glance that would not end inside its window
    is not made.
    """
    glances = []
    if behaviour.glance_rate <= 0.0 or n_goals + n_robots == 0:
        return glances
    for start, end in windows:
        t = start
        while True:
            t += rng.exponential(1.0 / behaviour.glance_rate)
            fixation = float(sample_duration(behaviour.glance_duration, rng))
            at_robot = rng.random() < behaviour.glance_at_robot
            index = int(rng.integers(1 << 30))
            back = t + GLANCE_TURN + fixation
            if back + GLANCE_TURN > end:
                break
            if n_robots and (at_robot or not n_goals):
                glances.append((t, fixation, ("robot", index % n_robots)))
            else:
                glances.append((t, fixation, ("goal", index % n_goals)))
            t = back + GLANCE_TURN
    return glances
