"""Drake adapter of the skeleton tracker (thesis 9.1): `OcclusionTracker`."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from hrc_drake.messages import SkeletonEstimate, SkeletonFrame
from hrc_drake.perception.tracker import SkeletonTracker, speed_override


def _no_capsules():
    return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


class OcclusionTracker(LeafSystem):
    """Occlusion-aware skeleton tracker at `rate` Hz (particle filter, Kalman baseline or none).

    Inputs:
      "skeleton_frame": abstract `SkeletonFrame` (from `DepthCamera`).
      "occluding_capsules": optional abstract (start (K, 3), end (K, 3), radius (K,)), the
        capsules that also hide points from the camera (robot links); when connected they are
        passed to `is_hidden(points, capsules)`.
    Outputs:
      "skeleton_estimate": abstract `SkeletonEstimate` (particles (8, <= display_particles, 3)).
      "speed_override": BasicVector(1), the slow-down rule of 9.1.3 (`slow` or 1).

    The filter object lives on the system (`self.tracker`); the context's abstract state only
    holds the last estimate. `listeners`: callables `fn(frame, estimate)` called after every
    update that produced a new estimate (probes of benchmarks and tests; they must not
    modify their arguments). The update runs at `offset` (default: half a period) after the
    camera ticks, so it reads the frame measured at the same tick. A simulation restarted at
    an earlier time resets the filter (the core notices time going backwards).
    """

    def __init__(self, kind: str, params: dict | None, is_hidden, workspace_center, workspace_size,
                 rate: float = 30.0, seed=0, threshold: float = 0.1, slow: float = 0.3,
                 offset: float | None = None):
        super().__init__()
        self.tracker = SkeletonTracker(kind, params, None, workspace_center, workspace_size, rate, seed)
        self.is_hidden = is_hidden
        self.threshold = float(threshold)
        self.slow = float(slow)
        speed_override(self.tracker.estimate_, self.threshold, self.slow)  # validates both
        self.listeners: list = []
        self._frame = self.DeclareAbstractInputPort("skeleton_frame", AbstractValue.Make(SkeletonFrame()))
        self._capsules = self.DeclareAbstractInputPort("occluding_capsules",
                                                       AbstractValue.Make(_no_capsules()))
        self._estimate = self.DeclareAbstractState(AbstractValue.Make(self.tracker.estimate_))
        period = 1.0 / float(rate)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.5 * period if offset is None else offset,
                                                    self._update)
        self.DeclareAbstractOutputPort("skeleton_estimate", lambda: AbstractValue.Make(SkeletonEstimate()),
                                       self._calc_estimate, {self.abstract_state_ticket(self._estimate)})
        self.DeclareVectorOutputPort("speed_override", BasicVector(1), self._calc_speed,
                                     {self.abstract_state_ticket(self._estimate)})

    def _update(self, context, state):
        frame = self._frame.Eval(context)
        if self.is_hidden is not None and self._capsules.HasValue(context):
            capsules = self._capsules.Eval(context)
            if len(capsules[2]):
                self.tracker.is_hidden = lambda points: self.is_hidden(points, capsules)
            else:
                self.tracker.is_hidden = self.is_hidden
        else:
            self.tracker.is_hidden = self.is_hidden
        previous = self.tracker.estimate_
        estimate = self.tracker.update(frame)
        state.get_mutable_abstract_state(int(self._estimate)).set_value(estimate)
        if estimate is not previous:
            for listener in self.listeners:
                listener(frame, estimate)
        return EventStatus.Succeeded()

    def _calc_estimate(self, context, output):
        output.set_value(context.get_abstract_state(int(self._estimate)).get_value())

    def _calc_speed(self, context, output):
        estimate = context.get_abstract_state(int(self._estimate)).get_value()
        output.SetAtIndex(0, speed_override(estimate, self.threshold, self.slow))
