"""The robot's choice between its autonomous task and the collaboration of use case a (thesis
5.4.1, Fig. 5.14), and the two baselines the thesis compares it with.

At each decision the robot either starts its autonomous subtask (the quality check) or waits,
ready to assist, for the human to initiate the collaborative operation; once the human has
initiated it, the robot assists. The three policies differ in how they judge whether the
collaboration is near:

- `PredictiveRobotPolicy` (Fig. 5.14): the p-percentile t_p of the waiting time until the
  human's collaborative action (thesis 5.3, the `Forecast` of the activity predictor, a HOMM
  updated after every perceived action); start the autonomous task if t_p exceeds its duration,
  otherwise wait;
- `ReactiveRobotPolicy` (5.4.1, "purely reactive"): always the autonomous task unless the
  human has already initiated the collaboration;
- `DataDrivenPercentilePolicy` (Fig. 5.17, "purely data-driven"): the same rule as the
  predictive robot, with t_p the p-percentile of the observed intervals between consecutive
  collaboration requests minus the time since the last one.

Each `decide` returns a `CollaborationDecision`; the policies are immutable values (the
data-driven one returns a new value from `observe`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from hrc_drake.messages import Forecast, Immutable

AUTONOMOUS, ASSIST, WAIT = "autonomous", "assist", "wait"


@dataclass(frozen=True)
class CollaborationDecision(Immutable):
    """What the robot does now: `choice` is AUTONOMOUS, ASSIST or WAIT; `waiting_time` the t_p
    the choice was made on (s; inf when unknown, nan when not used); `reason` in words."""

    choice: str
    waiting_time: float = math.nan
    reason: str = ""


def waiting_percentile(forecast: Forecast, action: str, level: float) -> float:
    """t_p of `action` in `forecast`: its waiting-time percentile at `level`, interpolated
    linearly between the forecast's levels (inf beyond the horizon, and where the forecast does
    not know the action or covers no level around `level`)."""
    if action not in forecast.actions or forecast.percentile_levels.size == 0:
        return math.inf
    levels = np.asarray(forecast.percentile_levels, dtype=float)
    row = np.asarray(forecast.waiting_percentiles, dtype=float)[forecast.actions.index(action)]
    if level < levels[0] - 1e-12 or level > levels[-1] + 1e-12:
        return math.inf
    k = int(np.searchsorted(levels, level - 1e-12))
    if k < len(levels) and abs(levels[k] - level) <= 1e-12:
        return float(row[k])
    lo, hi = row[k - 1], row[k]
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return math.inf
    w = (level - levels[k - 1]) / (levels[k] - levels[k - 1])
    return float(lo + w * (hi - lo))


def _rule(waiting_time: float, autonomous_duration: float, source: str) -> CollaborationDecision:
    """Fig. 5.14: the autonomous task if it fits before the collaboration, else wait."""
    if waiting_time > autonomous_duration:
        return CollaborationDecision(AUTONOMOUS, waiting_time,
                                     f"{source} t_p = {waiting_time:.2f} s > {autonomous_duration:.2f} s")
    return CollaborationDecision(
        WAIT, waiting_time,
        f"{source} t_p = {waiting_time:.2f} s <= {autonomous_duration:.2f} s: ready to assist")


def _check(autonomous_duration: float, percentile: float) -> None:
    if not (math.isfinite(autonomous_duration) and autonomous_duration > 0):
        raise ValueError(f"autonomous_duration must be a positive number of seconds, "
                         f"got {autonomous_duration!r}")
    if not 0.0 < percentile < 1.0:
        raise ValueError(f"percentile must be in (0, 1), got {percentile!r}")


@dataclass(frozen=True)
class PredictiveRobotPolicy(Immutable):
    """Fig. 5.14: assist once the human initiated the collaboration; otherwise start the
    autonomous task when t_p (the `percentile` of the forecast waiting time until
    `request_action`, thesis 5.3) exceeds `autonomous_duration` (s), else wait."""

    request_action: str
    autonomous_duration: float
    percentile: float = 0.8

    def __post_init__(self):
        _check(self.autonomous_duration, self.percentile)

    def decide(self, time: float, collaboration_begun: bool, forecast: Forecast) -> CollaborationDecision:
        if collaboration_begun:
            return CollaborationDecision(ASSIST, reason="the human initiated the collaboration")
        t_p = waiting_percentile(forecast, self.request_action, self.percentile)
        return _rule(t_p, self.autonomous_duration, "forecast")


@dataclass(frozen=True)
class ReactiveRobotPolicy(Immutable):
    """The reactive robot of 5.4.1: the autonomous task unless the human has already
    initiated the collaboration (no prediction)."""

    def decide(self, time: float, collaboration_begun: bool, forecast: Forecast | None = None
               ) -> CollaborationDecision:
        if collaboration_begun:
            return CollaborationDecision(ASSIST, reason="the human initiated the collaboration")
        return CollaborationDecision(AUTONOMOUS, reason="reactive: no collaboration initiated")


@dataclass(frozen=True)
class DataDrivenPercentilePolicy(Immutable):
    """The data-driven robot of Fig. 5.17: t_p = the `percentile` of the intervals between
    consecutive collaboration requests observed so far, minus the time since the last request
    (at least 0), in the rule of Fig. 5.14. With fewer than two requests seen it has no
    interval and starts the autonomous task."""

    autonomous_duration: float
    percentile: float = 0.8
    request_times: tuple[float, ...] = ()

    def __post_init__(self):
        _check(self.autonomous_duration, self.percentile)

    def observe(self, request_time: float) -> DataDrivenPercentilePolicy:
        """This policy with one more collaboration request (the human's begin) at `request_time`."""
        return replace(self, request_times=self.request_times + (float(request_time),))

    def decide(self, time: float, collaboration_begun: bool, forecast: Forecast | None = None
               ) -> CollaborationDecision:
        if collaboration_begun:
            return CollaborationDecision(ASSIST, reason="the human initiated the collaboration")
        if len(self.request_times) < 2:
            return CollaborationDecision(AUTONOMOUS, math.inf, "data-driven: no interval observed yet")
        intervals = np.diff(self.request_times)
        t_p = max(float(np.quantile(intervals, self.percentile)) - (time - self.request_times[-1]), 0.0)
        return _rule(t_p, self.autonomous_duration, "data-driven")
