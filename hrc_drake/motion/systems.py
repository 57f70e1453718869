"""Drake systems of reactive safety (thesis 8.1): `HumanMotionPredictor` and `SpeedScaler`, and
`apply_motion_config`.

Thin `LeafSystem` adapters over `reactive.ReactiveMotionPredictor` and `speed.SpeedScalerCore`.
The run lives in the Context (DESIGN.md): the predictor core (joint filter, GP model, generator)
is abstract state held as `Frozen`, cloned by each update (copy-on-write); the swept volumes are
an immutable state value; the speed scaler keeps its two numbers in discrete state.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import AbstractStateIndex, BasicVector, EventStatus, LeafSystem

from hrc_drake.messages import (
    EventLog,
    ProactivePaths,
    RobotEvent,
    SkeletonEstimate,
    SweptVolumes,
    no_capsules,
)
from hrc_drake.motion.config import GPMotionModel, NoMotionModel, SeparationSpeedScaling, WorstCaseMotionModel
from hrc_drake.motion.reactive import LIMIT_GROUPS, ReactiveMotionPredictor
from hrc_drake.motion.speed import SeparationRule, SpeedScalerCore
from hrc_drake.systems import (
    Frozen,
    declare_periodic_discrete_update,
    declare_state,
    get_state,
    input_or,
    set_state,
)

#: Fields of `WorstCaseMotionModel` passed on to `ReactiveMotionPredictor`.
_WORST_CASE_FIELDS = ("horizon", "process_std", "torso_process_std", "base_process_std", "point_std",
                      "measurement_std", "levels", "margin")
#: Fields only `GPMotionModel` has, passed on to `ReactiveMotionPredictor`.
_GP_FIELDS = ("order", "n_trials", "percentile", "refresh_period", "max_samples", "smoothing_window",
              "min_samples", "max_iter", "hyperparameter_every", "cap_by_worst_case", "training_states")


def predictor_kwargs(config: GPMotionModel | WorstCaseMotionModel) -> dict:
    """ReactiveMotionPredictor keyword arguments (kind included, no dt/rng) from a motion config
    (a negative percentile: the mean of the trials)."""
    kwargs = {name: getattr(config, name) for name in _WORST_CASE_FIELDS}
    kwargs["speed_limits"] = {group: getattr(config, f"{group}_speed") for group in LIMIT_GROUPS}
    kwargs["accel_limits"] = {group: getattr(config, f"{group}_accel") for group in LIMIT_GROUPS}
    if isinstance(config, GPMotionModel):
        kwargs.update({name: getattr(config, name) for name in _GP_FIELDS})
        kwargs["kind"] = f"gp_{config.variant.lower()}"
        if kwargs["percentile"] < 0:
            kwargs["percentile"] = None
    elif isinstance(config, WorstCaseMotionModel):
        kwargs["kind"] = "worst_case"
    else:
        raise TypeError(f"predictor_kwargs: not a motion-model config: {config!r}")
    return kwargs


class HumanMotionPredictor(LeafSystem):
    """Swept volumes of the human over the prediction horizon, at `config.rate` Hz (thesis 8.1,
    Fig. 8.4).

    body_model: `hrc_drake.human.body.BodyModel`. config: `GPMotionModel` (models A, B, C of
    8.1.2) or `WorstCaseMotionModel` ([107]). seed: the generator of the Monte Carlo trials.
    Input "skeleton_estimate" (abstract SkeletonEstimate); output "swept_volumes" (abstract
    SweptVolumes; no capsules until the first estimate with 3 points arrives).
    State: `Frozen(ReactiveMotionPredictor)` and the last `SweptVolumes`.
    """

    def __init__(self, body_model, config: GPMotionModel | WorstCaseMotionModel, seed: int = 0):
        super().__init__()
        config.validate("motion_model")
        self.config = config
        self.names = tuple(body_model.CAPSULE_NAMES)
        core = ReactiveMotionPredictor(body_model, dt=1.0 / config.rate, rng=seed, **predictor_kwargs(config))
        self._initial_core = Frozen(core)
        self._core = declare_state(self, lambda context: self._initial_core)
        self._swept = declare_state(
            self, lambda context: SweptVolumes(time=0.0 if context is None else context.get_time()))
        self._input = self.DeclareAbstractInputPort("skeleton_estimate",
                                                    AbstractValue.Make(SkeletonEstimate()))
        self.DeclareAbstractOutputPort(
            "swept_volumes", lambda: AbstractValue.Make(SweptVolumes()), self._calc_swept_volumes,
            {self.abstract_state_ticket(AbstractStateIndex(self._swept))})
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / config.rate, 0.0, self._update)

    def _update(self, context, state):
        estimate = self._input.Eval(context)
        points = np.asarray(estimate.points, dtype=float)
        spread = np.asarray(estimate.spread, dtype=float)
        if points.shape == (8, 3) and spread.shape == (8,):
            # a point of unbounded spread (lost, only its last position held) is no measurement
            points = np.where(np.isfinite(spread)[:, None], points, np.nan)
        if points.shape != (8, 3) or np.sum(np.all(np.isfinite(points), axis=1)) < 3:
            return EventStatus.DidNothing()
        core = get_state(context, self._core).thaw()
        swept = core.update(context.get_time(), points)
        set_state(state, self._core, Frozen(core))
        set_state(state, self._swept, swept)
        return EventStatus.Succeeded()

    def _calc_swept_volumes(self, context, output):
        output.set_value(get_state(context, self._swept))


class SpeedScaler(LeafSystem):
    """Speed override for the path follower from the robot-to-swept-volume clearance (8.1.3).

    config: `SeparationSpeedScaling` (the rule's C, T_r, T_s, v_r, v_h, the rate and the
    lookahead). Inputs "swept_volumes" (abstract SweptVolumes), "robot_capsules" (abstract
    `Capsules`) and, optional, "robot_capsules_ahead" (the same capsules `lookahead` s later
    along the path at full speed: the rule then uses the approach speed, and a robot moving away
    from the operator keeps moving). Outputs "speed_override" (BasicVector 1, in [0, 1]) and
    "min_distance" (BasicVector 1, m; inf when there is no human or robot geometry), both
    computed at each periodic update and at initialization (discrete state [override,
    distance]); a reader sees values at most one period old.
    """

    def __init__(self, config: SeparationSpeedScaling | None = None):
        super().__init__()
        config = config if config is not None else SeparationSpeedScaling()
        config.validate("speed_scaling")
        self.config = config
        self.lookahead = float(config.lookahead)
        self.core = SpeedScalerCore({name: getattr(config, name) for name in
                                     ("clearance", "reaction_time", "stopping_time", "robot_speed",
                                      "human_speed")})
        self.rule: SeparationRule = self.core.rule
        self._state_index = self.DeclareDiscreteState(np.array([1.0, np.inf]))
        self.DeclareAbstractInputPort("swept_volumes", AbstractValue.Make(SweptVolumes()))
        self.DeclareAbstractInputPort("robot_capsules", AbstractValue.Make(no_capsules()))
        self._ahead_port = self.DeclareAbstractInputPort("robot_capsules_ahead",
                                                         AbstractValue.Make(no_capsules()))
        ticket = {self.discrete_state_ticket(self._state_index)}
        self.DeclareVectorOutputPort("speed_override", BasicVector(1), self._calc_override,
                                     prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort("min_distance", BasicVector(1), self._calc_distance,
                                     prerequisites_of_calc=ticket)
        declare_periodic_discrete_update(self, 1.0 / config.rate, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._update)

    def _update(self, context, discrete_state):
        swept = self.get_input_port(0).Eval(context)
        robot = self.get_input_port(1).Eval(context)
        ahead = self._ahead_port.Eval(context) if self._ahead_port.HasValue(context) else None
        override, distance = self.core.step(robot, swept, ahead, self.lookahead)
        discrete_state.get_mutable_vector(self._state_index).SetFromVector([override, distance])
        return EventStatus.Succeeded()

    def _calc_override(self, context, output):
        output.SetAtIndex(0, context.get_discrete_state(self._state_index).get_value()[0])

    def _calc_distance(self, context, output):
        output.SetAtIndex(0, context.get_discrete_state(self._state_index).get_value()[1])


def apply_motion_config(config: NoMotionModel | GPMotionModel | WorstCaseMotionModel, builder, *,
                        speed_scaling: SeparationSpeedScaling, body_model, skeleton_estimate, robot_capsules,
                        robot_capsules_ahead=None, seed: int = 0):
    """Add the human motion predictor of `config` ("human_motion_predictor") and the speed
    scaler of `speed_scaling` ("speed_scaler") to `builder`, and connect them.

    skeleton_estimate: the tracker's estimate output port. robot_capsules: the robot links'
    `Capsules` output port; robot_capsules_ahead: optional, the same capsules `lookahead` s
    ahead along the path. Returns (predictor, scaler), or None for `NoMotionModel`; read the
    scaler's "speed_override".
    """
    if isinstance(config, NoMotionModel):
        return None
    predictor = builder.AddSystem(HumanMotionPredictor(body_model, config, seed=seed))
    predictor.set_name("human_motion_predictor")
    scaler = builder.AddSystem(SpeedScaler(speed_scaling))
    scaler.set_name("speed_scaler")
    builder.Connect(skeleton_estimate, predictor.GetInputPort("skeleton_estimate"))
    builder.Connect(predictor.GetOutputPort("swept_volumes"), scaler.GetInputPort("swept_volumes"))
    builder.Connect(robot_capsules, scaler.GetInputPort("robot_capsules"))
    if robot_capsules_ahead is not None:
        builder.Connect(robot_capsules_ahead, scaler.GetInputPort("robot_capsules_ahead"))
    return predictor, scaler


class ProactivePlannerSystem(LeafSystem):
    """Proactive paths of one robot action around the operator (thesis 8.2, Fig. 8.11).

    core: a `motion.proactive.ProactivePlannerCore`; rate: how often (Hz) the arm points are
    recorded and the events read. Inputs "skeleton_estimate" (SkeletonEstimate), "human_events"
    and "robot_events" (EventLog of HumanEvent / RobotEvent). Output "proactive_paths"
    (`ProactivePaths`, for the task executor; empty until the first replanning).
    State: `Frozen(core)` and the last human and robot event seqs read.
    """

    def __init__(self, core, rate: float = 10.0):
        super().__init__()
        self.rate = float(rate)
        self._initial = Frozen(core)
        self._core = declare_state(self, lambda context: self._initial)
        self._seen = declare_state(self, lambda context: (0, 0))
        self._estimate = self.DeclareAbstractInputPort("skeleton_estimate",
                                                       AbstractValue.Make(SkeletonEstimate()))
        self._human = self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self._robot = self.DeclareAbstractInputPort("robot_events", AbstractValue.Make(EventLog()))
        self.DeclareAbstractOutputPort(
            "proactive_paths", lambda: AbstractValue.Make(ProactivePaths()), self._calc_paths,
            {self.abstract_state_ticket(AbstractStateIndex(self._core))})
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / self.rate, 0.0, self._update)

    def core(self, context):
        """The planner core of `context` (read only)."""
        return get_state(context, self._core).core

    def _update(self, context, state):
        time = context.get_time()
        human_seq, robot_seq = get_state(context, self._seen)
        human = input_or(self._human, context, EventLog()).since(human_seq)
        robot = input_or(self._robot, context, EventLog()).since(robot_seq)
        if not human and not robot and not get_state(context, self._core).core.busy(time):
            return EventStatus.DidNothing()  # nothing to record or replan: no copy of the core
        core = get_state(context, self._core).thaw()
        for event in sorted(robot + human, key=lambda e: e.time):
            if isinstance(event, RobotEvent):
                core.robot_event(event.time, event.agent, event.action, event.kind)
            else:
                core.human_event(event.time, event.action, event.kind)
        if self._estimate.HasValue(context):
            core.observe_points(self._estimate.Eval(context).points)
        core.maybe_replan(time)
        set_state(state, self._core, Frozen(core))
        set_state(state, self._seen, (human[-1].seq if human else human_seq,
                                      robot[-1].seq if robot else robot_seq))
        return EventStatus.Succeeded()

    def _calc_paths(self, context, output):
        core = get_state(context, self._core).core
        if core.path_ is None:
            output.set_value(ProactivePaths())
        else:
            path = (core.robot_agent, core.robot_action, core.path_[1:])
            output.set_value(ProactivePaths(core.seq_, (path,)))
