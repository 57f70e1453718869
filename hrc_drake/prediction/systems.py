"""Drake adapter of the activity prediction of thesis Ch. 5 (pipeline of Fig. 5.1)."""

from __future__ import annotations

from collections import deque
from collections.abc import Hashable, Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from ..messages import HUMAN_AGENT, EventLog, Forecast
from .factory import WAITING_PARAMS, make_sequence_model
from .waiting import WaitingTimePredictor

_SEQ, _CURRENT, _BEGIN, _RUNNING = range(4)


class ActivityPredictor(LeafSystem):
    """Next human action and waiting-time percentiles from the operator's event stream.

    Input "human_events": messages.EventLog of messages.HumanEvent. Only "begin" and "end"
    events of the human agent are used: begins form the action sequence the model learns
    online (`partial_fit`), begin-to-end times are the duration samples of thesis 5.3.
    Output "forecast": messages.Forecast with P(next action) (eq. 5.8 / 5.10) and the
    percentiles of tau^a (Algorithm 1, eq. 5.37) measured from the current time.

    Updated periodically at `rate` Hz. Before the first begin event the forecast is uniform
    with infinite waiting times (documented fallback). Between an "end" and the next "begin"
    the last action counts as finished (no residual time). An event naming an action outside
    `actions` raises ValueError.

    The sequence model and duration samples live on this object (not in the Context): they
    are rebuilt by an initialization event, so one simulation at a time per system.
    Discrete state: group 0 [last seq, current action index, its begin time, running flag];
    group 1 [forecast time, next probabilities (A), percentiles (A*P) row-major].
    params: the model's parameters (see factory.make_sequence_model) plus the waiting-time
    ones: resolution, epsilon, max_samples, default_duration, max_nodes.
    """

    def __init__(
        self,
        actions: list[str],
        kind: str = "homm",
        params: dict | None = None,
        rate: float = 10.0,
        percentile_levels: Sequence[float] = (0.2, 0.5, 0.8),
        horizon: float = 60.0,
        affine_sets: Sequence[Sequence[Hashable]] = (),
    ):
        LeafSystem.__init__(self)
        if len(actions) == 0 or len(set(actions)) != len(actions):
            raise ValueError(f"ActivityPredictor: actions must be distinct and non-empty, got {actions!r}")
        if not (np.isfinite(rate) and 0 < rate <= 50):
            raise ValueError(f"ActivityPredictor: rate={rate} must be in (0, 50] Hz")
        levels = np.asarray(percentile_levels, dtype=float)
        if levels.ndim != 1 or np.any((levels <= 0) | (levels >= 1)):
            raise ValueError(f"ActivityPredictor: percentile_levels must be in (0, 1), got {levels}")
        if not (np.isfinite(horizon) and horizon > 0):
            raise ValueError(f"ActivityPredictor: horizon={horizon} must be positive")
        self._actions = tuple(actions)
        self._kind = kind
        self._params = dict(params or {})
        self._affine_sets = [list(s) for s in affine_sets]
        self._levels = levels
        self._horizon = float(horizon)
        self._waiting_kwargs = {k: v for k, v in self._params.items() if k in WAITING_PARAMS}
        for key in ("max_samples", "max_nodes"):
            if key in self._waiting_kwargs:
                self._waiting_kwargs[key] = int(self._waiting_kwargs[key])
        self._reset_core()  # builds the model once now, so bad parameters fail at construction

        n_actions, n_levels = len(actions), levels.size
        self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self._tracking_index = self.DeclareDiscreteState(BasicVector([-1.0, -1.0, 0.0, 0.0]))
        self._forecast_index = self.DeclareDiscreteState(BasicVector(self._fallback_vector(0.0)))
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclareAbstractOutputPort(
            "forecast",
            lambda: AbstractValue.Make(Forecast()),
            self._calc_forecast,
            prerequisites_of_calc={self.discrete_state_ticket(self._forecast_index)},
        )
        self._shape = (n_actions, n_levels)

    # ---------------------------------------------------------------- core
    def _reset_core(self) -> None:
        self.model = make_sequence_model(self._kind, self._params, self._actions, self._affine_sets)
        self.waiting = WaitingTimePredictor(self.model, **self._waiting_kwargs)
        self._history: deque = deque(maxlen=max(64, 2 * int(self.model.context_length_)))
        self._open_begins: dict[str, float] = {}

    def _fallback_vector(self, time: float) -> np.ndarray:
        n_actions = len(self._actions)
        return np.concatenate(
            [[time], np.full(n_actions, 1.0 / n_actions), np.full(n_actions * self._levels.size, np.inf)]
        )

    def _initialize(self, context, discrete_state):
        self._reset_core()
        discrete_state.get_mutable_vector(self._tracking_index).SetFromVector([-1.0, -1.0, 0.0, 0.0])
        discrete_state.get_mutable_vector(self._forecast_index).SetFromVector(
            self._fallback_vector(context.get_time())
        )
        return EventStatus.Succeeded()

    def _update(self, context, discrete_state):
        tracking = np.array(context.get_discrete_state(self._tracking_index).get_value())
        log = self.get_input_port(0).Eval(context)
        for event in log.since(int(tracking[_SEQ])):
            tracking[_SEQ] = event.seq
            if getattr(event, "agent", HUMAN_AGENT) != HUMAN_AGENT or event.kind not in ("begin", "end"):
                continue
            if event.action not in self._actions:
                raise ValueError(
                    f"ActivityPredictor: event seq={event.seq} names action {event.action!r}, "
                    f"not one of {self._actions!r}"
                )
            code = self._actions.index(event.action)
            if event.kind == "begin":
                self.model.partial_fit(event.action)
                self._history.append(event.action)
                self._open_begins[event.action] = float(event.time)
                tracking[_CURRENT], tracking[_BEGIN], tracking[_RUNNING] = code, event.time, 1.0
            else:
                began = self._open_begins.pop(event.action, None)
                duration = None if began is None else float(event.time) - began
                if duration is not None and np.isfinite(duration) and duration > 0:
                    self.waiting.observe_duration(event.action, duration)
                if int(tracking[_CURRENT]) == code:
                    tracking[_RUNNING] = 0.0
        discrete_state.get_mutable_vector(self._tracking_index).SetFromVector(tracking)

        now = context.get_time()
        if tracking[_CURRENT] < 0:
            vector = self._fallback_vector(now)
        else:
            history = list(self._history)
            probs = self.model.predict_proba(history)
            elapsed = max(0.0, now - tracking[_BEGIN]) if tracking[_RUNNING] > 0 else None
            percentiles = self.waiting.percentiles(history, elapsed, self._levels, self._horizon)
            vector = np.concatenate([[now], probs, percentiles.ravel()])
        discrete_state.get_mutable_vector(self._forecast_index).SetFromVector(vector)
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
