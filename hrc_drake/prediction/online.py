"""The online activity predictor of thesis Ch. 5 (pipeline of Fig. 5.1) without Drake: a
sequence model learning the human's begun actions and the waiting-time predictor around it,
fed one event at a time. `prediction.systems.ActivityPredictor` keeps a `PredictorCore` in its
Context; `OnlineForecaster` runs the same core for event-level simulations."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..messages import Forecast
from .factory import make_sequence_model, make_waiting_predictor


class PredictorCore:
    """What an activity predictor learns during a run: the sequence model, the waiting-time
    predictor around it, the recent begun actions (history, oldest first) and the begin time of
    each action still running. `clone` copies only what an observed event writes (copy-on-write)."""

    def __init__(self, model, waiting, history_length: int):
        self.model = model
        self.waiting = waiting
        self.history_length = int(history_length)
        self.history: tuple = ()
        self.open_begins: dict[str, float] = {}

    def clone(self, model_changes: bool = True) -> PredictorCore:
        """A private copy for an update; the model is copied only when `model_changes` (a begin)."""
        new = object.__new__(PredictorCore)
        new.model = self.model.clone() if model_changes else self.model
        new.waiting = self.waiting.clone(new.model)
        new.history_length = self.history_length
        new.history = self.history
        new.open_begins = dict(self.open_begins)
        return new

    def learn(self, action: str, kind: str, time: float) -> None:
        """One human event: a begin extends the sequence the model learns (`partial_fit`), an
        end gives a duration sample of the action (thesis 5.3)."""
        if kind == "begin":
            self.model.partial_fit(action)
            self.history = (self.history + (action,))[-self.history_length:]
            self.open_begins[action] = float(time)
        elif kind == "end":
            began = self.open_begins.pop(action, None)
            duration = None if began is None else float(time) - began
            if duration is not None and np.isfinite(duration) and duration > 0:
                self.waiting.observe_duration(action, duration)


class OnlineForecaster:
    """Forecasts (`messages.Forecast`) of the human's next action and waiting times from its
    begin and end events, as `ActivityPredictor` computes them, for event-level simulators.

    config: a predictor kind of `prediction.config` (not NoPredictor); actions: the human's
    action names. Before the first begin the forecast is uniform with infinite waiting times.
    """

    def __init__(self, config, actions: Sequence[str]):
        self.actions = tuple(actions)
        model = make_sequence_model(config, self.actions)
        model._check_classes()
        self.levels = np.asarray(config.percentile_levels, dtype=float)
        self.horizon = float(config.horizon)
        history_length = max(64, 2 * int(model.context_length_))
        self.core = PredictorCore(model, make_waiting_predictor(config, model), history_length)
        self.current: str | None = None
        self.begin_time = 0.0
        self.running = False

    def observe(self, action: str, kind: str, time: float) -> None:
        """A human event ("begin" / "end" of `action`; other kinds are ignored)."""
        if kind not in ("begin", "end"):
            return
        if action not in self.actions:
            raise ValueError(f"OnlineForecaster: unknown action {action!r}, not one of {self.actions!r}")
        self.core.learn(action, kind, time)
        if kind == "begin":
            self.current, self.begin_time, self.running = action, float(time), True
        elif action == self.current:
            self.running = False

    def forecast(self, now: float) -> Forecast:
        """The forecast at time `now` (waiting times measured from `now`)."""
        n = len(self.actions)
        if self.current is None:
            probs, percentiles = np.full(n, 1.0 / n), np.full((n, self.levels.size), np.inf)
        else:
            history = list(self.core.history)
            probs = self.core.model.predict_proba(history)
            elapsed = max(0.0, now - self.begin_time) if self.running else None
            percentiles = self.core.waiting.percentiles(history, elapsed, self.levels, self.horizon)
        return Forecast(time=float(now), actions=self.actions, next_probabilities=np.asarray(probs, float),
                        percentile_levels=self.levels.copy(),
                        waiting_percentiles=np.asarray(percentiles, float).reshape(n, self.levels.size))

    def clone(self) -> OnlineForecaster:
        new = object.__new__(OnlineForecaster)
        new.__dict__.update(self.__dict__)
        new.core = self.core.clone()
        return new
