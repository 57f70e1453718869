"""Drake adapter of the intended-goal estimator (thesis 3.1): `IntentionEstimator`."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem

from hrc_drake.intention.bayes import FeedbackStateMachine, GoalIntentionEstimator, IntentionEvent
from hrc_drake.messages import EventLog, GoalBelief, SkeletonEstimate

#: the intention_events output keeps at most this many of the latest events
MAX_EVENTS_OUT = 200
_MAX_RATE = 50.0


class IntentionEstimator(LeafSystem):
    """Per-hand goal probabilities at `rate` Hz (method M3 of 3.1.2) and "robot understood" feedback.

    Input "skeleton_estimate" (abstract `SkeletonEstimate`; its gaze and gaze_valid give delta_H
    and the flag F). Outputs "goal_belief" (abstract `GoalBelief`, `understood` holding the
    (hand, goal) pairs of the feedback events of the latest update) and "intention_events"
    (abstract `EventLog` of `IntentionEvent`, the last MAX_EVENTS_OUT). Feedback (Fig. 3.6):
    with `feedback_sequence` (e.g. ("G4", "G1")) the cyclic machine of the thesis, otherwise
    every rise of a goal's probability to `threshold`. Extra keyword arguments go to
    `GoalIntentionEstimator` (method, goal_std, n_goal_samples, switch_probability, rng).
    One simulation per system object at a time: the core lives on the system and is reset at
    initialisation.
    """

    def __init__(
        self,
        goal_names: list[str],
        goal_centers: np.ndarray,
        model=None,
        rate: float = 30.0,
        threshold: float = 0.8,
        feedback_sequence=None,
        feedback_hands=("left", "right"),
        **estimator_options,
    ):
        super().__init__()
        if not np.isfinite(rate) or rate <= 0 or rate > _MAX_RATE:
            raise ValueError(f"IntentionEstimator: rate must be in (0, {_MAX_RATE}] Hz, got {rate!r}")
        self.goal_names = tuple(str(g) for g in goal_names)
        self.estimator = GoalIntentionEstimator(
            goal_centers, model, goal_names=self.goal_names, **estimator_options
        )
        self.feedback = FeedbackStateMachine(self.goal_names, threshold, feedback_sequence, feedback_hands)
        self.events: list[IntentionEvent] = []
        self._log = EventLog(())
        self._log_size = -1
        n_goals = len(self.goal_names)
        self._n_prob = 2 * n_goals
        # probabilities (2G), time of the last update, events so far, events before the last update
        initial = np.concatenate([np.full(self._n_prob, 1.0 / n_goals), [0.0, 0.0, 0.0]])
        self._state_index = self.DeclareDiscreteState(initial)
        self._input = self.DeclareAbstractInputPort(
            "skeleton_estimate", AbstractValue.Make(SkeletonEstimate())
        )
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        self.DeclareAbstractOutputPort(
            "goal_belief",
            lambda: AbstractValue.Make(GoalBelief()),
            self._calc_belief,
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclareAbstractOutputPort(
            "intention_events",
            lambda: AbstractValue.Make(EventLog(())),
            self._calc_events,
            prerequisites_of_calc={self.xd_ticket()},
        )

    def _initialize(self, context, discrete_state):
        self.estimator.reset()
        self.feedback.reset()
        self.events = []
        self._log_size = -1
        n_goals = len(self.goal_names)
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(
            np.concatenate([np.full(self._n_prob, 1.0 / n_goals), [context.get_time(), 0.0, 0.0]])
        )
        return EventStatus.Succeeded()

    def _update(self, context, discrete_state):
        time = context.get_time()
        estimate = self._input.Eval(context) if self._input.HasValue(context) else SkeletonEstimate(time=time)
        probabilities = self.estimator.update(time, estimate.points, estimate.gaze, bool(estimate.gaze_valid))
        before = len(self.events)
        for hand, goal in self.feedback.step(probabilities):
            self.events.append(IntentionEvent(time=time, hand=hand, goal=goal, seq=len(self.events) + 1))
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(
            np.concatenate([probabilities.ravel(), [time, float(len(self.events)), float(before)]])
        )
        return EventStatus.Succeeded()

    def _counts(self, context):
        state = context.get_discrete_state(self._state_index).value()
        return state, int(round(state[self._n_prob + 1])), int(round(state[self._n_prob + 2]))

    def _calc_belief(self, context, output):
        state, count, before = self._counts(context)
        understood = tuple((e.hand, e.goal) for e in self.events[before:count])
        output.set_value(
            GoalBelief(
                time=float(state[self._n_prob]),
                goals=self.goal_names,
                probabilities=state[: self._n_prob].reshape(2, -1).copy(),
                understood=understood,
            )
        )

    def _calc_events(self, context, output):
        _, count, _ = self._counts(context)
        if self._log_size != count:
            self._log = EventLog(tuple(self.events[max(0, count - MAX_EVENTS_OUT) : count]))
            self._log_size = count
        output.set_value(self._log)
