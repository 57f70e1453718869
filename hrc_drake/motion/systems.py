"""Drake systems of reactive safety (thesis 8.1): `HumanMotionPredictor` and `SpeedScaler`.

Thin `LeafSystem` adapters over `reactive.ReactiveMotionPredictor` and `speed.SpeedScalerCore`.
Both keep only numbers in discrete state; the algorithm cores live on the system.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from hrc_drake.messages import SkeletonEstimate, SweptVolumes
from hrc_drake.motion.reactive import MOTION_KINDS, ReactiveMotionPredictor
from hrc_drake.motion.speed import SeparationRule, SpeedScalerCore

#: scenario `motion_model.params` keys of HumanMotionPredictor, with their types
PREDICTOR_PARAMS = {
    "order": int, "horizon": float, "n_trials": int, "percentile": float, "refresh_period": float,
    "max_samples": int, "smoothing_window": int, "min_samples": int, "process_std": float,
    "torso_process_std": float, "base_process_std": float, "point_std": float, "measurement_std": float,
    "max_iter": int, "joint_speed": float, "joint_accel": float, "base_speed": float,
    "base_accel": float, "levels": int, "margin": float,
}
#: scenario keys of SpeedScaler
SCALER_PARAMS = ("clearance", "reaction_time", "stopping_time", "robot_speed", "human_speed", "rate",
                 "lookahead")


def predictor_kwargs(params: dict) -> dict:
    """ReactiveMotionPredictor keyword arguments from a scenario params dict (percentile < 0: mean)."""
    unknown = sorted(set(params) - set(PREDICTOR_PARAMS) - set(SCALER_PARAMS))
    if unknown:
        raise ValueError(f"motion_model.params: unknown keys {unknown}; known: {sorted(PREDICTOR_PARAMS)}")
    kwargs = {}
    for key, cast in PREDICTOR_PARAMS.items():
        if key in params:
            value = float(params[key])
            if not np.isfinite(value):
                raise ValueError(f"motion_model.params.{key}: must be finite, got {params[key]!r}")
            if cast is int and value != int(value):
                raise ValueError(f"motion_model.params.{key}: must be an integer, got {params[key]!r}")
            kwargs[key] = cast(value)
    if "percentile" in kwargs and kwargs["percentile"] < 0:
        kwargs["percentile"] = None
    return kwargs


class HumanMotionPredictor(LeafSystem):
    """Swept volumes of the human over the prediction horizon, at `rate` Hz (thesis 8.1, Fig. 8.4).

    body_model: `hrc_drake.human.body.BodyModel`. kind: gp_a | gp_b | gp_c | worst_case.
    params: see `PREDICTOR_PARAMS` (speed-scaler keys are accepted and ignored).
    Input "skeleton_estimate" (abstract SkeletonEstimate); output "swept_volumes" (abstract
    SweptVolumes; no capsules until the first estimate arrives).
    """

    def __init__(self, body_model, kind: str = "gp_c", params: dict | None = None, rate: float = 20.0,
                 seed: int = 0):
        super().__init__()
        if kind not in MOTION_KINDS:
            raise ValueError(f"HumanMotionPredictor: unknown kind {kind!r}; use one of {MOTION_KINDS}")
        if not rate > 0 or rate > 50:
            raise ValueError(f"HumanMotionPredictor: rate must be in (0, 50] Hz, got {rate!r}")
        self.core = ReactiveMotionPredictor(body_model, kind, dt=1.0 / rate, rng=seed,
                                            **predictor_kwargs(params or {}))
        self.names = tuple(body_model.CAPSULE_NAMES)
        k = len(self.names)
        self._k = k
        # [valid, time, horizon, start (K*3), end (K*3), radius (K)]
        self._state_index = self.DeclareDiscreteState(3 + 7 * k)
        self.DeclareAbstractInputPort("skeleton_estimate", AbstractValue.Make(SkeletonEstimate()))
        self.DeclareAbstractOutputPort("swept_volumes", lambda: AbstractValue.Make(SweptVolumes()),
                                       self._calc_swept_volumes,
                                       prerequisites_of_calc={self.discrete_state_ticket(self._state_index)})
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)

    def _update(self, context, discrete_state):
        estimate = self.get_input_port(0).Eval(context)
        points = np.asarray(estimate.points, dtype=float)
        if points.shape != (8, 3) or np.sum(np.all(np.isfinite(points), axis=1)) < 3:
            return EventStatus.DidNothing()
        swept = self.core.update(context.get_time(), points)
        vector = np.concatenate([[1.0, swept.time, swept.horizon], swept.start.ravel(), swept.end.ravel(),
                                 swept.radius])
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(vector)
        return EventStatus.Succeeded()

    def _calc_swept_volumes(self, context, output):
        x = context.get_discrete_state(self._state_index).get_value()
        if x[0] < 0.5:
            output.set_value(SweptVolumes(time=context.get_time()))
            return
        k = self._k
        output.set_value(SweptVolumes(
            time=float(x[1]), names=self.names, start=x[3:3 + 3 * k].reshape(k, 3).copy(),
            end=x[3 + 3 * k:3 + 6 * k].reshape(k, 3).copy(), radius=x[3 + 6 * k:].copy(), horizon=float(x[2]),
        ))


def _empty_capsules():
    return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


class SpeedScaler(LeafSystem):
    """Speed override for the path follower from the robot-to-swept-volume clearance (8.1.3).

    params: `SeparationRule` fields (clearance, reaction_time, stopping_time, robot_speed,
    human_speed), "rate" (Hz, default 20) and "lookahead" (s, default 0.1). Inputs
    "swept_volumes" (abstract SweptVolumes), "robot_capsules" (abstract tuple (start (K, 3),
    end (K, 3), radius (K,))) and, optional, "robot_capsules_ahead" (the same capsules
    `lookahead` s later along the path at full speed: the rule then uses the approach speed,
    and a robot moving away from the operator keeps moving). Outputs
    "speed_override" (BasicVector 1, in [0, 1]) and "min_distance" (BasicVector 1, m; inf when
    there is no human or robot geometry), both computed at each periodic update and at
    initialization; a reader sees values at most one period old.
    """

    def __init__(self, params: dict | None = None):
        super().__init__()
        params = dict(params or {})
        unknown = sorted(set(params) - set(SCALER_PARAMS) - set(PREDICTOR_PARAMS))
        if unknown:
            raise ValueError(f"SpeedScaler params: unknown keys {unknown}; known: {list(SCALER_PARAMS)}")
        rate = float(params.pop("rate", 20.0))
        self.lookahead = float(params.pop("lookahead", 0.1))
        if not self.lookahead > 0:
            raise ValueError(f"SpeedScaler: lookahead must be > 0 s, got {self.lookahead!r}")
        if not 0 < rate <= 50:
            raise ValueError(f"SpeedScaler: rate must be in (0, 50] Hz, got {rate!r}")
        self.core = SpeedScalerCore({k: v for k, v in params.items() if k in SCALER_PARAMS})
        self.rule: SeparationRule = self.core.rule
        self._state_index = self.DeclareDiscreteState(np.array([1.0, np.inf]))
        self.DeclareAbstractInputPort("swept_volumes", AbstractValue.Make(SweptVolumes()))
        self.DeclareAbstractInputPort("robot_capsules", AbstractValue.Make(_empty_capsules()))
        self._ahead_port = self.DeclareAbstractInputPort("robot_capsules_ahead",
                                                         AbstractValue.Make(_empty_capsules()))
        ticket = {self.discrete_state_ticket(self._state_index)}
        self.DeclareVectorOutputPort("speed_override", BasicVector(1), self._calc_override,
                                     prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort("min_distance", BasicVector(1), self._calc_distance,
                                     prerequisites_of_calc=ticket)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
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
