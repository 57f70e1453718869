"""Drake adapters of the intention area: the intended-goal estimator (thesis 3.1),
`IntentionEstimator` and `apply_intention_config`; the action detector on goal regions (thesis
Ch. 2), `ActionDetector` and `apply_action_detector_config`.

The run lives in the Context (DESIGN.md): the estimator, the feedback machine, the last belief
and the event log are one abstract state value (`Frozen(IntentionRun)`), cloned by each update
(copy-on-write) and rebuilt by the initialization event.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import AbstractStateIndex, EventStatus, LeafSystem

from hrc_drake.intention.bayes import FeedbackStateMachine, GoalIntentionEstimator, IntentionEvent
from hrc_drake.intention.config import (
    MAX_RATE,
    GmmBayesIntention,
    GoalRegionActionDetector,
    NoActionDetector,
    NoIntention,
    SegmenterActionDetector,
)
from hrc_drake.intention.detector import GoalRegionDetector
from hrc_drake.intention.segmentation import Segment
from hrc_drake.messages import EventLog, GoalBelief, HumanEvent, Immutable, SkeletonEstimate
from hrc_drake.systems import Frozen, declare_state, get_state, input_or, set_state

#: the intention_events output keeps at most this many of the latest events
MAX_EVENTS_OUT = 200


class IntentionRun:
    """What changes during a run of `IntentionEstimator`: the estimator core, the feedback
    machine, the last belief, the event log (the last MAX_EVENTS_OUT) and the event count."""

    def __init__(self, estimator: GoalIntentionEstimator, feedback: FeedbackStateMachine,
                 belief: GoalBelief, log: EventLog, count: int):
        self.estimator = estimator
        self.feedback = feedback
        self.belief = belief
        self.log = log
        self.count = count

    def clone(self) -> IntentionRun:
        """A copy whose cores may be changed (belief and log are immutable values, shared)."""
        return IntentionRun(self.estimator.clone(), self.feedback.clone(), self.belief, self.log, self.count)


class IntentionEstimator(LeafSystem):
    """Per-hand goal probabilities at `config.rate` Hz (methods M1-M3 of 3.1, M3 by default) and
    "robot understood" feedback (Fig. 3.6).

    Input "skeleton_estimate" (abstract `SkeletonEstimate`; its gaze and gaze_valid give delta_H
    and the flag F). Outputs "goal_belief" (abstract `GoalBelief`, `understood` holding the
    (hand, goal) pairs of the feedback events of the latest update) and "intention_events"
    (abstract `EventLog` of `IntentionEvent`, the last MAX_EVENTS_OUT). Feedback: with
    `config.feedback_sequence` (e.g. ["G4", "G1"]) the cyclic machine of the thesis, otherwise
    every rise of a goal's probability to `config.threshold`.
    model: the learned `IntentionModel` (None: the shipped one). seed: the generator of the
    sampled goal centres of eq. (3.12).
    State: one abstract value `Frozen(IntentionRun)`, outputs read from it only.
    """

    def __init__(self, config: GmmBayesIntention, goal_names: list[str], goal_centers: np.ndarray,
                 model=None, seed: int = 0):
        super().__init__()
        if not np.isfinite(config.rate) or config.rate <= 0 or config.rate > MAX_RATE:
            raise ValueError(f"IntentionEstimator: rate must be in (0, {MAX_RATE}] Hz, got {config.rate!r}")
        config.validate("intention")
        self.config = config
        self.goal_names = tuple(str(g) for g in goal_names)
        estimator = GoalIntentionEstimator(
            goal_centers, model, method=config.method, goal_names=self.goal_names, goal_std=config.goal_std,
            n_goal_samples=config.n_goal_samples, switch_probability=config.switch_probability,
            m1_sigma=config.m1_sigma, m1_mean_speed=config.m1_mean_speed, rng=np.random.default_rng(seed),
            evidence_weight=config.evidence_weight or None, restart_switch=config.restart_switch,
            restart_after=config.restart_after)
        feedback = FeedbackStateMachine(self.goal_names, config.threshold,
                                        tuple(config.feedback_sequence) or None,
                                        tuple(config.feedback_hands), release=config.release)
        self._cores = (estimator, feedback)
        self._input = self.DeclareAbstractInputPort("skeleton_estimate",
                                                    AbstractValue.Make(SkeletonEstimate()))
        self._run = declare_state(self, self._initial)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / config.rate, 0.0, self._update)
        ticket = {self.abstract_state_ticket(AbstractStateIndex(self._run))}
        self.DeclareAbstractOutputPort("goal_belief", lambda: AbstractValue.Make(GoalBelief()),
                                       self._calc_belief, ticket)
        self.DeclareAbstractOutputPort("intention_events", lambda: AbstractValue.Make(EventLog(())),
                                       self._calc_events, ticket)

    def _initial(self, context) -> Frozen:
        estimator, feedback = self._cores
        time = 0.0 if context is None else context.get_time()
        belief = GoalBelief(time=time, goals=self.goal_names,
                            probabilities=np.full((2, len(self.goal_names)), 1.0 / len(self.goal_names)))
        return Frozen(IntentionRun(estimator, feedback, belief, EventLog(()), 0))

    def _update(self, context, state):
        time = context.get_time()
        estimate = input_or(self._input, context, None) or SkeletonEstimate(time=time)
        run = get_state(context, self._run).thaw()
        probabilities = run.estimator.update(time, estimate.points, estimate.gaze, bool(estimate.gaze_valid))
        understood = tuple(run.feedback.step(probabilities))
        if understood:
            new = tuple(IntentionEvent(time=time, hand=hand, goal=goal, seq=run.count + k + 1)
                        for k, (hand, goal) in enumerate(understood))
            run.count += len(new)
            run.log = run.log.appended(new, MAX_EVENTS_OUT)
        run.belief = GoalBelief(time=time, goals=self.goal_names, probabilities=np.array(probabilities),
                                understood=understood)
        set_state(state, self._run, Frozen(run))
        return EventStatus.Succeeded()

    def _calc_belief(self, context, output):
        output.set_value(get_state(context, self._run).core.belief)

    def _calc_events(self, context, output):
        output.set_value(get_state(context, self._run).core.log)


def apply_intention_config(config: NoIntention | GmmBayesIntention, builder, *, skeleton_estimate,
                           goal_names: list[str], goal_centers, model_dir: str | Path = ".",
                           seed: int = 0) -> IntentionEstimator | None:
    """Add the intention estimator of `config` to `builder`, named "intention", fed by the
    `skeleton_estimate` output port; None for `NoIntention`.

    goal_names, goal_centers (G, 3): the cell's goal regions. model_dir: the folder
    `config.model` is relative to (the scenario's). seed: the scenario seed.
    """
    if isinstance(config, NoIntention):
        return None
    config.validate("intention")
    model = None
    if config.model:
        from hrc_drake.intention.likelihood import IntentionModel

        model = IntentionModel.load((Path(model_dir) / config.model).resolve())
    unknown = [g for g in config.feedback_sequence if g not in goal_names]
    if unknown:
        from hrc_drake.errors import ConfigError

        raise ConfigError("intention.feedback_sequence",
                          f"unknown goals {unknown}; the cell has {goal_names}")
    estimator = builder.AddSystem(
        IntentionEstimator(config, goal_names, np.asarray(goal_centers, float), model=model, seed=seed))
    estimator.set_name("intention")
    builder.Connect(skeleton_estimate, estimator.GetInputPort("skeleton_estimate"))
    return estimator


def _declare_event_source(system: LeafSystem, rate: float, initial):
    """The ports of a system that perceives the operator's actions: input "skeleton_estimate",
    one abstract state value (`initial(context)`) updated every 1/rate s by `system._update`,
    and output "human_events" computed by `system._calc_events` from that state. Returns
    (input port, state index)."""
    port = system.DeclareAbstractInputPort("skeleton_estimate", AbstractValue.Make(SkeletonEstimate()))
    index = declare_state(system, initial)
    system.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, system._update)
    system.DeclareAbstractOutputPort("human_events", lambda: AbstractValue.Make(EventLog()),
                                     system._calc_events,
                                     {system.abstract_state_ticket(AbstractStateIndex(index))})
    return port, index


@dataclass(frozen=True)
class DetectorRun(Immutable):
    """What changes during a run of `ActionDetector`: the detector (an immutable value) and the
    log of the events it emitted (the last MAX_EVENTS_OUT)."""

    detector: GoalRegionDetector
    log: EventLog = EventLog()


class ActionDetector(LeafSystem):
    """The operator's actions perceived from the skeleton estimate: begin when a wrist enters
    the goal region G_a of an action and stays `min_dwell` s, end when it leaves (thesis Ch. 2;
    `intention.detector.GoalRegionDetector`), at `config.rate` Hz.

    Input "skeleton_estimate" (abstract `SkeletonEstimate`; a wrist whose spread exceeds
    `config.max_spread` is lost). Output "human_events" (abstract `EventLog` of `HumanEvent`,
    with hand and goal, the last MAX_EVENTS_OUT): the perceived events, read as the operator's
    own `human_events` are. State: one abstract value `DetectorRun`, replaced only by an update
    at which a hand changes phase.
    """

    def __init__(self, config: GoalRegionActionDetector, goal_names, goal_centers, goal_radii,
                 actions=None, agent: str = "human"):
        super().__init__()
        config.validate("action_detector")
        self.config = config
        self._initial = DetectorRun(GoalRegionDetector(
            tuple(goal_names), np.asarray(goal_centers, float), np.asarray(goal_radii, float),
            actions=tuple(actions) if actions else (), entry_scale=config.entry_scale,
            exit_scale=config.exit_scale, min_dwell=config.min_dwell, max_spread=config.max_spread,
            lost_timeout=config.lost_timeout, agent=agent, end_rule=config.end_rule))
        self._input, self._run = _declare_event_source(self, config.rate, lambda context: self._initial)

    def detector(self, context) -> GoalRegionDetector:
        """The detector of `context` (read only): e.g. `.active()`."""
        return get_state(context, self._run).detector

    def _update(self, context, state):
        estimate = input_or(self._input, context, None)
        if estimate is None:
            return EventStatus.DidNothing()
        run = get_state(context, self._run)
        wrists, known = run.detector.known_wrists(estimate.points, estimate.spread)
        detector, events = run.detector.update(context.get_time(), wrists, known)
        if detector is run.detector:
            return EventStatus.DidNothing()
        set_state(state, self._run, DetectorRun(detector, run.log.appended(events, MAX_EVENTS_OUT)))
        return EventStatus.Succeeded()

    def _calc_events(self, context, output):
        output.set_value(get_state(context, self._run).log)


def apply_action_detector_config(config: NoActionDetector | GoalRegionActionDetector, builder, *,
                                 skeleton_estimate, goal_names, goal_centers, goal_radii,
                                 actions=None, agent: str = "human") -> ActionDetector | None:
    """Add the action detector of `config` to `builder`, named "action_detector", fed by the
    `skeleton_estimate` output port; None for `NoActionDetector`.

    goal_names, goal_centers (G, 3), goal_radii (G,): the goal regions of the perceived actions;
    actions: the action of each goal (default: the goal names); agent: the perceived events' agent.
    """
    if isinstance(config, NoActionDetector):
        return None
    detector = builder.AddSystem(ActionDetector(config, goal_names, goal_centers, goal_radii, actions, agent))
    detector.set_name("action_detector")
    builder.Connect(skeleton_estimate, detector.GetInputPort("skeleton_estimate"))
    return detector


class SegmenterRun:
    """What changes during a run of `ActionSegmenterSystem`: the segmenter's stream, the time of
    its first frame, the last finite estimate of each point (held over a lost one), the last
    closed segment (held until a segment of another action closes: adjacent segments of one
    action are one action), the event count and the log."""

    def __init__(self, segmenter, rate: float):
        self.segmenter = segmenter
        self.rate = float(rate)
        self.start_time: float | None = None
        self.points: np.ndarray | None = None
        self.pending = None
        self.seq = 0
        self.log = EventLog()

    def clone(self) -> SegmenterRun:
        twin = object.__new__(SegmenterRun)
        twin.__dict__.update(self.__dict__)
        twin.segmenter = self.segmenter.clone()
        return twin

    def frame_time(self, index: int) -> float:
        return self.start_time + index / self.rate

    def step(self, time: float, points: np.ndarray, agent: str) -> bool:
        """Feed one sample; True when an event was emitted."""
        if self.points is None:
            if not np.all(np.isfinite(points)):
                return False  # the segmenter starts once every point has been seen
            self.start_time, self.points = float(time), points.copy()
        else:
            self.points = np.where(np.isfinite(points), points, self.points)
        new = []
        for segment in self.segmenter.update(self.points):
            new += self._close(segment, agent)
        if new:
            self.log = self.log.appended(new, MAX_EVENTS_OUT)
        return bool(new)

    def _close(self, segment, agent: str) -> list:
        held = self.pending
        if held is not None and held.action == segment.action and held.end == segment.start:
            self.pending = Segment(held.start, segment.end, held.action)
            return []
        self.pending = segment
        if held is None:
            return []
        events = []
        for kind, frame in (("begin", held.start), ("end", held.end - 1)):
            self.seq += 1
            events.append(HumanEvent(self.frame_time(frame), str(held.action), kind, self.seq, agent=agent))
        return events


class ActionSegmenterSystem(LeafSystem):
    """The operator's actions perceived by the segmenter of thesis 4.1 (factor graphs evolved by
    a genetic algorithm on sliding windows, `intention.segmentation.Segmenter`), at `config.rate`.

    segmenter: a fitted `Segmenter` whose window_length is config.window * config.rate samples.
    Input "skeleton_estimate" (abstract `SkeletonEstimate`; a lost point keeps its last estimate).
    Output "human_events" (abstract `EventLog` of `HumanEvent`, the last MAX_EVENTS_OUT), read as
    the goal-region detector's are. An action is known once its segment is closed: up to one
    batch of L windows (12 s in 4.2) after it ends, plus the next segment of another action.
    State: `Frozen(SegmenterRun)`.
    """

    def __init__(self, config: SegmenterActionDetector, segmenter, agent: str = "human"):
        super().__init__()
        config.validate("action_detector")
        if segmenter.model_ is None:
            raise ValueError("ActionSegmenterSystem: the segmenter has no model; fit it first")
        self.config, self.agent = config, agent
        self._initial = Frozen(SegmenterRun(segmenter.clone(), config.rate))
        self._input, self._run = _declare_event_source(self, config.rate, lambda context: self._initial)

    def run(self, context) -> SegmenterRun:
        """The run of `context` (read only)."""
        return get_state(context, self._run).core

    def _update(self, context, state):
        estimate = input_or(self._input, context, None)
        points = None if estimate is None else np.asarray(estimate.points, dtype=float)
        if points is None or points.shape != (8, 3):
            return EventStatus.DidNothing()
        run = get_state(context, self._run).thaw()
        run.step(context.get_time(), points, self.agent)
        set_state(state, self._run, Frozen(run))
        return EventStatus.Succeeded()

    def _calc_events(self, context, output):
        output.set_value(get_state(context, self._run).core.log)


def apply_segmenter_config(config: SegmenterActionDetector, builder, *, skeleton_estimate, segmenter,
                           agent: str = "human") -> ActionSegmenterSystem:
    """Add the segmenter of `config` (with its fitted `segmenter`), named "action_detector", fed
    by the `skeleton_estimate` output port."""
    system = builder.AddSystem(ActionSegmenterSystem(config, segmenter, agent))
    system.set_name("action_detector")
    builder.Connect(skeleton_estimate, system.GetInputPort("skeleton_estimate"))
    return system
