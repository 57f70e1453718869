"""Drake adapter of the activity prediction of thesis Ch. 5 (pipeline of Fig. 5.1)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from ..errors import ConfigError
from ..messages import HUMAN_AGENT, EventLog, Forecast
from ..systems import Frozen, declare_state, get_state, set_state
from .config import NoPredictor
from .factory import make_sequence_model, make_waiting_predictor
from .online import PredictorCore

_SEQ, _CURRENT, _BEGIN, _RUNNING = range(4)


class ActivityPredictor(LeafSystem):
    """Next human action and waiting-time percentiles from the operator's event stream.

    Input "human_events": messages.EventLog of messages.HumanEvent. Only "begin" and "end"
    events of the human agent are used: begins form the action sequence the model learns
    online (`partial_fit`), begin-to-end times are the duration samples of thesis 5.3.
    Output "forecast": messages.Forecast with P(next action) (eq. 5.8 / 5.10) and the
    percentiles of tau^a (Algorithm 1, eq. 5.37) measured from the current time.

    config: one of the kinds of `hrc_drake.prediction.config` (not NoPredictor). Updated
    periodically at `config.rate` Hz. Before the first begin event the forecast is uniform
    with infinite waiting times (documented fallback). Between an "end" and the next "begin"
    the last action counts as finished (no residual time). An event naming an action outside
    `actions` raises ValueError.

    State (all in the Context, set again at initialization):
    abstract 0: Frozen(PredictorCore), replaced (copy-on-write) only when a begin or end
    event of the human arrives; discrete group 0 [last seq, current action index, its begin
    time, running flag]; group 1 [forecast time, next probabilities (A), percentiles (A*P)
    row-major].
    """

    def __init__(self, config, actions: Sequence[str]):
        LeafSystem.__init__(self)
        if isinstance(config, NoPredictor):
            raise ConfigError("predictor", "NoPredictor builds no ActivityPredictor")
        actions = list(actions)
        if len(actions) == 0 or len(set(actions)) != len(actions):
            raise ValueError(f"ActivityPredictor: actions must be distinct and non-empty, got {actions!r}")
        model = make_sequence_model(config, actions)  # validates the config
        model._check_classes()  # the label map is built now, never lazily on a frozen core
        self.config = config
        self._actions = tuple(actions)
        self._levels = np.asarray(config.percentile_levels, dtype=float)
        self._horizon = float(config.horizon)
        self._initial_core = PredictorCore(
            model, make_waiting_predictor(config, model), max(64, 2 * int(model.context_length_))
        )

        n_actions, n_levels = len(actions), self._levels.size
        self._shape = (n_actions, n_levels)
        self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self._core_index = declare_state(self, lambda context: Frozen(self._initial_core))
        self._tracking_index = self.DeclareDiscreteState(BasicVector([-1.0, -1.0, 0.0, 0.0]))
        self._forecast_index = self.DeclareDiscreteState(BasicVector(self._fallback_vector(0.0)))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / config.rate, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclareAbstractOutputPort(
            "forecast",
            lambda: AbstractValue.Make(Forecast()),
            self._calc_forecast,
            prerequisites_of_calc={self.discrete_state_ticket(self._forecast_index)},
        )

    def core(self, context) -> PredictorCore:
        """The predictor's learned core in `context` (read only: do not change it)."""
        return get_state(context, self._core_index).core

    def _fallback_vector(self, time: float) -> np.ndarray:
        n_actions = len(self._actions)
        return np.concatenate(
            [[time], np.full(n_actions, 1.0 / n_actions), np.full(n_actions * self._levels.size, np.inf)]
        )

    def _initialize(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._tracking_index).SetFromVector([-1.0, -1.0, 0.0, 0.0])
        discrete_state.get_mutable_vector(self._forecast_index).SetFromVector(
            self._fallback_vector(context.get_time())
        )
        return EventStatus.Succeeded()

    def _update(self, context, state):
        tracking = np.array(context.get_discrete_state(self._tracking_index).get_value())
        core = get_state(context, self._core_index).core
        log = self.get_input_port(0).Eval(context)
        new_events = log.since(int(tracking[_SEQ]))
        relevant = []
        for event in new_events:
            tracking[_SEQ] = event.seq
            if getattr(event, "agent", HUMAN_AGENT) != HUMAN_AGENT or event.kind not in ("begin", "end"):
                continue
            if event.action not in self._actions:
                raise ValueError(
                    f"ActivityPredictor: event seq={event.seq} names action {event.action!r}, "
                    f"not one of {self._actions!r}"
                )
            relevant.append(event)
        if relevant:  # copy-on-write: only an observed begin or end changes the core
            core = core.clone(model_changes=any(e.kind == "begin" for e in relevant))
            for event in relevant:
                code = self._actions.index(event.action)
                core.learn(event.action, event.kind, event.time)
                if event.kind == "begin":
                    tracking[_CURRENT], tracking[_BEGIN], tracking[_RUNNING] = code, event.time, 1.0
                elif int(tracking[_CURRENT]) == code:
                    tracking[_RUNNING] = 0.0
            set_state(state, self._core_index, Frozen(core))
        state.get_mutable_discrete_state(self._tracking_index).SetFromVector(tracking)

        now = context.get_time()
        if tracking[_CURRENT] < 0:
            vector = self._fallback_vector(now)
        else:
            history = list(core.history)
            probs = core.model.predict_proba(history)
            elapsed = max(0.0, now - tracking[_BEGIN]) if tracking[_RUNNING] > 0 else None
            percentiles = core.waiting.percentiles(history, elapsed, self._levels, self._horizon)
            vector = np.concatenate([[now], probs, percentiles.ravel()])
        state.get_mutable_discrete_state(self._forecast_index).SetFromVector(vector)
        return EventStatus.Succeeded()

    def _calc_forecast(self, context, output):
        vector = context.get_discrete_state(self._forecast_index).get_value()
        n_actions, n_levels = self._shape
        output.set_value(
            Forecast(
                time=float(vector[0]),
                actions=self._actions,
                next_probabilities=np.array(vector[1 : 1 + n_actions]),
                percentile_levels=self._levels.copy(),
                waiting_percentiles=np.array(vector[1 + n_actions :]).reshape(n_actions, n_levels),
            )
        )


def apply_predictor_config(
    config, builder, *, human_events, actions: Sequence[str]
) -> ActivityPredictor | None:
    """Add the ActivityPredictor `config` describes to `builder` (named "activity_predictor"),
    its "human_events" input connected to the output port `human_events`; None for NoPredictor."""
    if isinstance(config, NoPredictor):
        return None
    predictor = builder.AddSystem(ActivityPredictor(config, actions))
    predictor.set_name("activity_predictor")
    builder.Connect(human_events, predictor.GetInputPort("human_events"))
    return predictor


__all__ = ["ActivityPredictor", "PredictorCore", "apply_predictor_config"]
