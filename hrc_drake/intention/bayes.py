"""Recursive Bayesian estimation of each hand's intended goal (thesis 3.1.1-3.1.3).

Methods compared in Table 3.1:
  M1  the method of [135] (3.1.1): angle between the wrist velocity and the nominal velocity of
      a minimum-jerk reach from where the hand's motion started to each goal, zero-mean
      Gaussian likelihood, update eq. (3.1);
  M2  the learned GMM2d on Psi = (delta_W1, d) only, as if the gaze were never valid;
  M3  the full method (3.1.2): GMM4d on Phi when the gaze flag F is valid, GMM2d otherwise,
      update eq. (3.2); uncertain goal centres by averaging over Np samples, eq. (3.12).

Between updates the belief may switch goal with a small probability (a Markov prediction step
the thesis leaves implicit): without it a belief that has converged on one goal could never
move to the next one, and the feedback machine of Fig. 3.6 needs goal 1 after goal 4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hrc_drake.intention import _kernels
from hrc_drake.intention.features import (
    AT_GOAL,
    NEUTRAL_ANGLE,
    PSI_COLUMNS,
    WristVelocityEstimator,
    angle_between,
    skeleton_features,
)
from hrc_drake.intention.likelihood import IntentionModel, default_model
from hrc_drake.messages import HANDS, HEAD, L_WRIST, R_WRIST, shallow_copy
from hrc_drake.rng import clone_generator

METHODS = ("M1", "M2", "M3")
#: Floor of a log-likelihood below the best goal's: keeps every goal recoverable, never -inf.
_LOG_LIKELIHOOD_FLOOR = -30.0
#: the columns of Phi that GMM4d and GMM2d read
_PHI = np.arange(4)
_PSI = np.array(PSI_COLUMNS)


def goal_log_likelihoods_numpy(points, velocity, moving, gaze, samples, density, use_gaze: bool):
    """log L (2, G) of eq. (3.12) in numpy: the log of the mean over the sampled centres (G, Np, 3)
    of the GMM density of Phi (or Psi without gaze). The reference of `_kernels.goal_log_likelihoods`."""
    phi = skeleton_features(points, velocity, moving, gaze, samples)  # (2, G, Np, 4)
    per_sample = density.log_density(phi if use_gaze else phi[..., list(PSI_COLUMNS)])
    top = np.max(per_sample, axis=-1, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    return top[..., 0] + np.log(np.mean(np.exp(per_sample - top), axis=-1))


@dataclass(frozen=True)
class IntentionEvent:
    """ "The robot understood": the probability of `goal` for `hand` crossed the threshold (Fig. 3.6)."""

    time: float
    hand: str
    goal: str
    kind: str = "understood"
    seq: int = 0


def bayes_update(
    prior: np.ndarray,
    log_likelihood: np.ndarray,
    switch_probability: float = 0.0,
    active: np.ndarray | None = None,
) -> np.ndarray:
    """Recursive Bayes, eq. (3.1)/(3.2): P_k(G_i) proportional to L(Phi^i_k | G_i) P_{k-1}(G_i).

    prior: (..., G) rows summing to 1; log_likelihood: (..., G) log L per goal; before the update
    the prior is mixed with the uniform one, (1 - s) P + s / G (goal switch; s a scalar or one
    value per row, (...,)). Rows that are not
    `active` (..., bool) or whose likelihoods are all non-finite keep their prior. Log-likelihoods
    are floored at 30 nats below the row's best, so no goal's probability becomes exactly zero.
    """
    prior = np.asarray(prior, dtype=float)
    log_likelihood = np.asarray(log_likelihood, dtype=float)
    if prior.shape != log_likelihood.shape:
        raise ValueError(
            f"bayes_update: prior {prior.shape} and log_likelihood {log_likelihood.shape} differ"
        )
    switch = np.asarray(switch_probability, dtype=float)
    if not np.all((switch >= 0.0) & (switch <= 1.0)):
        raise ValueError(f"bayes_update: switch_probability must be in [0, 1], got {switch_probability}")
    switch = switch[..., None]
    n_goals = prior.shape[-1]
    finite = np.isfinite(log_likelihood)
    ok = np.any(finite, axis=-1)
    if active is not None:
        ok = ok & np.asarray(active, dtype=bool)
    predicted = (1.0 - switch) * prior + switch / n_goals
    best = np.max(np.where(finite, log_likelihood, -np.inf), axis=-1, keepdims=True)
    best = np.where(np.isfinite(best), best, 0.0)
    relative = np.where(
        finite, np.maximum(log_likelihood - best, _LOG_LIKELIHOOD_FLOOR), _LOG_LIKELIHOOD_FLOOR
    )
    posterior = predicted * np.exp(relative)
    posterior /= np.maximum(posterior.sum(axis=-1, keepdims=True), 1e-300)
    return np.where(ok[..., None], posterior, prior)


def minimum_jerk_velocity(
    p0: np.ndarray, v0: np.ndarray, target: np.ndarray, duration: np.ndarray, t
) -> np.ndarray:
    """Velocity at time t of the quintic from (p0, v0, a=0) to (target, v=0, a=0) in `duration`.

    The nominal velocity of [135] (3.1.1). p0, v0: (..., 3); target: (..., 3); duration and
    t: (...,) or scalars, duration > 0.
    """
    duration = np.asarray(duration, dtype=float)[..., None]
    t = np.asarray(t, dtype=float)[..., None]
    delta = np.asarray(target, dtype=float) - np.asarray(p0, dtype=float)
    v0 = np.asarray(v0, dtype=float)
    a3 = (10.0 * delta - 6.0 * v0 * duration) / duration**3
    a4 = (-15.0 * delta + 8.0 * v0 * duration) / duration**4
    a5 = (6.0 * delta - 3.0 * v0 * duration) / duration**5
    return v0 + 3.0 * a3 * t**2 + 4.0 * a4 * t**3 + 5.0 * a5 * t**4


class GoalIntentionEstimator:
    """Per-hand goal probabilities from skeleton estimates (thesis 3.1, methods M1, M2, M3).

    goal_centers: (G, 3) goal centres C_i; model: the learned `IntentionModel` (default: the
    shipped one; unused by M1); goal_std: (G,) or scalar std (m) of each centre, with
    n_goal_samples > 0 the likelihood is averaged over that many sampled centres, eq. (3.12);
    switch_probability: chance per update that the intended goal changes; restart_switch: the
    same chance at the first update of a motion that follows a pause of at least restart_after
    s (a hand that stopped has reached its goal, the next motion is a new reach, whatever the
    belief was); evidence_weight w in (0, 1]: the likelihoods enter eq. (3.2) as L^w, because
    features from overlapping velocity windows at 30 Hz are not independent evidence (default:
    the model's, learned with it); m1_sigma (rad) and
    m1_mean_speed (m/s, sets the nominal duration |C_i - p_s| / speed of the reach from p_s)
    are the heuristics of M1.
    `probabilities_` (2, G): row 0 left hand, row 1 right hand.
    """

    def __init__(
        self,
        goal_centers: np.ndarray,
        model: IntentionModel | None = None,
        method: str = "M3",
        goal_names=None,
        goal_std=0.0,
        n_goal_samples: int = 0,
        switch_probability: float = 0.02,
        m1_sigma: float = 0.6,
        m1_mean_speed: float = 0.4,
        rng=None,
        evidence_weight: float | None = None,
        restart_switch: float = 0.5,
        restart_after: float = 0.25,
    ):
        centers = np.asarray(goal_centers, dtype=float)
        if (
            centers.ndim != 2
            or centers.shape[1] != 3
            or centers.shape[0] < 1
            or not np.all(np.isfinite(centers))
        ):
            raise ValueError(
                f"GoalIntentionEstimator: goal_centers must be a finite (G, 3) array, got {centers.shape}"
            )
        if method not in METHODS:
            raise ValueError(f"GoalIntentionEstimator: method must be one of {METHODS}, got {method!r}")
        n_goals = centers.shape[0]
        self.goal_names = (
            tuple(goal_names) if goal_names is not None else tuple(f"G{i + 1}" for i in range(n_goals))
        )
        if len(self.goal_names) != n_goals:
            raise ValueError(
                f"GoalIntentionEstimator: {len(self.goal_names)} goal names for {n_goals} centres"
            )
        goal_std = np.broadcast_to(np.asarray(goal_std, dtype=float), (n_goals,)).copy()
        if np.any(goal_std < 0) or not np.all(np.isfinite(goal_std)):
            raise ValueError(f"GoalIntentionEstimator: goal_std must be finite and >= 0, got {goal_std}")
        if not 0.0 <= switch_probability <= 1.0:
            raise ValueError(
                f"GoalIntentionEstimator: switch_probability must be in [0, 1], got {switch_probability}"
            )
        if m1_sigma <= 0 or m1_mean_speed <= 0:
            raise ValueError("GoalIntentionEstimator: m1_sigma and m1_mean_speed must be > 0")
        self.goal_centers = centers
        self.method = method
        self.model = model if model is not None or method == "M1" else default_model()
        self.goal_std = goal_std
        self.n_goal_samples = int(n_goal_samples)
        self.switch_probability = float(switch_probability)
        if not 0.0 <= restart_switch <= 1.0 or not restart_after >= 0.0:
            raise ValueError(
                f"GoalIntentionEstimator: need restart_switch in [0, 1] and restart_after >= 0, got "
                f"{restart_switch}, {restart_after}"
            )
        self.restart_switch = float(restart_switch)
        self.restart_after = float(restart_after)
        if evidence_weight is None:
            evidence_weight = self.model.evidence_weight if self.model is not None else 1.0
        if not 0.0 < evidence_weight <= 1.0:
            raise ValueError(
                f"GoalIntentionEstimator: evidence_weight must be in (0, 1], got {evidence_weight}"
            )
        self.evidence_weight = float(evidence_weight)
        self.m1_sigma = float(m1_sigma)
        self.m1_mean_speed = float(m1_mean_speed)
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        if self.model is not None:
            self._velocity = WristVelocityEstimator(
                self.model.window, self.model.min_speed, self.model.significance
            )
        else:
            self._velocity = WristVelocityEstimator()
        self.reset()

    @property
    def n_goals(self) -> int:
        return self.goal_centers.shape[0]

    def clone(self) -> GoalIntentionEstimator:
        """A copy for copy-on-write state. `update` rebinds every array it changes (never
        writes one in place), so the copy shares them; the velocity window and, when goal
        centres are sampled, the generator are copied."""
        new = shallow_copy(self)
        new._velocity = self._velocity.clone()
        if self.n_goal_samples > 0 and np.any(self.goal_std > 0):
            new.rng = clone_generator(self.rng)
        return new

    def reset(self) -> None:
        """Back to uniform probabilities and an empty velocity history."""
        self._velocity.reset()
        self.probabilities_ = np.full((2, self.n_goals), 1.0 / self.n_goals)
        # M1: where and when each hand's current motion started, and its velocity then
        self._anchor_time = np.full(2, np.nan)
        self._anchor_position = np.full((2, 3), np.nan)
        self._anchor_velocity = np.zeros((2, 3))
        self.last_active_ = np.zeros(2, dtype=bool)
        self._last_motion = np.full(2, -np.inf)  # time of each hand's last update with evidence

    def _goal_samples(self) -> np.ndarray:
        if self.n_goal_samples <= 0 or not np.any(self.goal_std > 0):
            return self.goal_centers[:, None, :]
        noise = self.rng.standard_normal((self.n_goals, self.n_goal_samples, 3))
        return self.goal_centers[:, None, :] + self.goal_std[:, None, None] * noise

    def log_likelihood(self, time: float, points: np.ndarray, gaze: np.ndarray, gaze_valid: bool):
        """Advance the velocity estimate; return log L (2, G) and which hands have evidence (2,)."""
        points = np.asarray(points, dtype=float)
        if points.shape != (8, 3):
            raise ValueError(f"GoalIntentionEstimator: points must be (8, 3), got {points.shape}")
        gaze = np.asarray(gaze, dtype=float)
        if gaze.shape != (3,):
            raise ValueError(f"GoalIntentionEstimator: gaze must be (3,), got {gaze.shape}")
        wrists = points[[L_WRIST, R_WRIST]]
        velocity, moving = self._velocity.update(time, wrists)
        active = moving & np.all(np.isfinite(wrists), axis=1)
        if self.method == "M1":
            log_lik = self._m1_log_likelihood(time, wrists, velocity, moving)
        else:
            samples = self._goal_samples()
            use_gaze = (
                self.method == "M3"
                and bool(gaze_valid)
                and np.all(np.isfinite(points[HEAD]))
                and np.all(np.isfinite(gaze))
                and np.linalg.norm(gaze) > 1e-9
            )
            density, columns = (self.model.gmm4d, _PHI) if use_gaze else (self.model.gmm2d, _PSI)
            # `goal_log_likelihoods_numpy`, compiled: one call instead of ~40 numpy calls a frame
            log_lik = _kernels.goal_log_likelihoods(wrists, velocity, moving, points[HEAD], gaze, samples,
                                                   columns, *density.kernel_arrays(), NEUTRAL_ANGLE, AT_GOAL)
            log_lik = self.evidence_weight * log_lik
        log_lik = np.where(active[:, None], log_lik, np.nan)
        return log_lik, active

    def _m1_log_likelihood(self, time, wrists, velocity, moving):
        """log L(delta^i | G_i) of [135], eq. (3.1): zero-mean Gaussian of the angle to the nominal velocity.

        The nominal velocity of goal i is that of the minimum-jerk reach (quintic, zero end
        velocity and accelerations) from where this hand's motion started, p_s with v_s, to C_i
        in D_i = |C_i - p_s| / m1_mean_speed, at the time elapsed since the start. Re-planned from
        p_{k-1} at every step, the quintic's velocity one step later is v_{k-1} + O(dt^2)
        whatever the goal, and the angles could not tell the goals apart.
        """
        finite = np.all(np.isfinite(wrists), axis=1)
        # A still (or lost) hand re-anchors: its next motion starts here, at rest.
        rest = ~moving & finite
        self._anchor_time = np.where(rest, time, self._anchor_time)
        self._anchor_position = np.where(rest[:, None], wrists, self._anchor_position)
        self._anchor_velocity = np.where(rest[:, None], 0.0, self._anchor_velocity)
        fresh = moving & finite & ~np.isfinite(self._anchor_time)  # moving since the first frame
        self._anchor_time = np.where(fresh, time, self._anchor_time)
        self._anchor_position = np.where(fresh[:, None], wrists, self._anchor_position)
        self._anchor_velocity = np.where(fresh[:, None], velocity, self._anchor_velocity)
        start = self._anchor_position  # (2, 3)
        distance = np.linalg.norm(self.goal_centers[None] - start[:, None], axis=-1)  # (2, G)
        duration = np.clip(distance / self.m1_mean_speed, 0.3, 3.0)
        # past the nominal end the quintic's velocity vanishes: keep its direction just before
        elapsed = np.clip(np.nan_to_num(time - self._anchor_time)[:, None], 0.0, 0.95 * duration)
        nominal = minimum_jerk_velocity(
            start[:, None], self._anchor_velocity[:, None], self.goal_centers[None], duration, elapsed
        )  # (2, G, 3)
        at_start = np.linalg.norm(nominal, axis=-1) < 1e-9
        # at the very start of a reach from rest the nominal direction is that of C_i - p_s
        nominal = np.where(at_start[..., None], self.goal_centers[None] - start[:, None], nominal)
        delta = angle_between(velocity[:, None], nominal)
        log_lik = -0.5 * (delta / self.m1_sigma) ** 2
        return np.where((moving & finite)[:, None], log_lik, np.nan)

    def update(
        self, time: float, points: np.ndarray, gaze: np.ndarray, gaze_valid: bool = True
    ) -> np.ndarray:
        """One step of eq. (3.2) (M2/M3) or (3.1) (M1) for both hands; returns probabilities (2, G).

        points: (8, 3) skeleton (NaN rows allowed); gaze: (3,) head z axis; gaze_valid: flag F.
        A still or lost wrist keeps its hand's probabilities.
        """
        log_lik, active = self.log_likelihood(time, points, gaze, gaze_valid)
        return self.posterior_step(time, log_lik, active)

    def posterior_step(self, time: float, log_likelihood: np.ndarray, active: np.ndarray) -> np.ndarray:
        """The Bayes half of `update`, eq. (3.2) with the goal switch and restart: from log L (2, G)
        and the hands with evidence (2,) of `log_likelihood`. Returns probabilities (2, G).

        Split out so that one likelihood trace can be replayed under other switch settings
        (`evaluation.replay_posteriors`); the likelihood half advances the velocity window."""
        log_lik = np.asarray(log_likelihood, dtype=float)
        active = np.asarray(active, dtype=bool)
        if log_lik.shape != self.probabilities_.shape or active.shape != (2,):
            raise ValueError(f"GoalIntentionEstimator.posterior_step: log_likelihood must be "
                             f"{self.probabilities_.shape} and active (2,), got {log_lik.shape}, "
                             f"{active.shape}")
        restart = active & (time - self._last_motion >= self.restart_after)
        switch = np.where(restart, max(self.restart_switch, self.switch_probability), self.switch_probability)
        # `bayes_update` of the two rows, compiled (its numpy form is the reference)
        self.probabilities_ = _kernels.bayes_rows(self.probabilities_, log_lik, switch, active,
                                                 _LOG_LIKELIHOOD_FLOOR)
        self._last_motion = np.where(active, time, self._last_motion)
        self.last_active_ = active
        return self.probabilities_

    def predict_proba(self) -> np.ndarray:
        """Current goal probabilities (2, G)."""
        return self.probabilities_.copy()


class FeedbackStateMachine:
    """When to tell the operator "the robot understood" (thesis Fig. 3.6).

    With `sequence` (e.g. ("G4", "G1")) it is the machine of Fig. 3.6: it leaves its initial
    state at the first update, then state j waits until the probability of sequence[j] for one
    of `hands` reaches `threshold`, emits, and moves on cyclically. Without a sequence every
    (hand, goal) whose probability rises to `threshold` is emitted; it is re-armed once the
    probability falls below `release`.
    """

    def __init__(self, goal_names, threshold: float = 0.8, sequence=None, hands=HANDS, release: float = 0.5):
        self.goal_names = tuple(goal_names)
        if not 0.0 < threshold <= 1.0 or not 0.0 <= release < threshold:
            raise ValueError(
                f"FeedbackStateMachine: need 0 <= release < threshold <= 1, got {release}, {threshold}"
            )
        unknown = [g for g in (sequence or ()) if g not in self.goal_names]
        if unknown:
            raise ValueError(f"FeedbackStateMachine: sequence goals {unknown} not in {self.goal_names}")
        bad_hands = [h for h in hands if h not in HANDS]
        if bad_hands:
            raise ValueError(f"FeedbackStateMachine: unknown hands {bad_hands}, expected {HANDS}")
        self.threshold = float(threshold)
        self.release = float(release)
        self.sequence = tuple(sequence) if sequence else None
        self.hands = tuple(hands)
        self.reset()

    def clone(self) -> FeedbackStateMachine:
        """A copy for copy-on-write state (`step` rebinds `_armed`, never writes it in place)."""
        return shallow_copy(self)

    def reset(self) -> None:
        self.state = 0  # 0: initial (no human yet); j >= 1 waits for sequence[j - 1]
        self._armed = np.ones((2, len(self.goal_names)), dtype=bool)

    def step(self, probabilities: np.ndarray) -> list[tuple[str, str]]:
        """Advance with the probabilities (2, G) of this update; return the (hand, goal) understood."""
        probabilities = np.asarray(probabilities, dtype=float)
        if probabilities.shape != (2, len(self.goal_names)):
            raise ValueError(
                f"FeedbackStateMachine.step: probabilities must be (2, {len(self.goal_names)}), "
                f"got {probabilities.shape}"
            )
        hand_rows = [HANDS.index(h) for h in self.hands]
        if self.sequence is not None:
            if self.state == 0:
                self.state = 1
            goal = self.sequence[self.state - 1]
            column = self.goal_names.index(goal)
            for row in hand_rows:
                if probabilities[row, column] >= self.threshold:
                    self.state = self.state % len(self.sequence) + 1
                    return [(HANDS[row], goal)]
            return []
        crossed = (probabilities >= self.threshold) & self._armed
        self._armed = (self._armed & ~crossed) | (probabilities < self.release)
        return [
            (HANDS[r], self.goal_names[c])
            for r, c in zip(*np.nonzero(crossed), strict=True)
            if r in hand_rows
        ]
