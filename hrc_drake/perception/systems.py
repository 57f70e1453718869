"""Drake adapters of skeleton tracking (thesis 9.1): `OcclusionTracker` (particle filter, Kalman
baseline or hold-last-seen with the slow-down rule), `MeasurementAsEstimate` (no tracker), and
`apply_tracker_config`.

The run lives in the Context (DESIGN.md): the tracker core is abstract state held as a
`Frozen` value, cloned (copy-on-write) by each update and rebuilt by the initialization event.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import AbstractStateIndex, BasicVector, EventStatus, LeafSystem

from hrc_drake.messages import DepthFrame, SkeletonEstimate, SkeletonFrame, no_capsules
from hrc_drake.perception.config import HoldLastSeenTracker, KalmanTracker, NoTracker, ParticleFilterTracker
from hrc_drake.perception.tracker import SkeletonTracker, speed_override
from hrc_drake.systems import (
    Frozen,
    declare_periodic_discrete_update,
    declare_state,
    get_state,
    set_state,
)

TrackingConfig = ParticleFilterTracker | KalmanTracker | HoldLastSeenTracker


def tracker_params(config: TrackingConfig) -> tuple[str, dict]:
    """(kind, params) of `SkeletonTracker` for a tracker config."""
    if isinstance(config, HoldLastSeenTracker):
        return "none", {}
    names = ("order", "sigma_position", "sigma_velocity", "sigma_acceleration", "sigma_jerk",
             "measurement_std", "initial_velocity_std", "initial_acceleration_std", "initial_jerk_std",
             "display_particles")
    params = {name: getattr(config, name) for name in names}
    if isinstance(config, ParticleFilterTracker):
        params.update(particles=config.particles, crown=config.crown, systematic=int(config.systematic),
                      bootstrap_tracked=int(config.bootstrap_tracked),
                      hidden_at_rest=int(config.hidden_at_rest),
                      calibration_frames=config.calibration_frames, gate=config.gate)
        return "particle_filter", params
    if isinstance(config, KalmanTracker):
        params["confidence"] = config.confidence
        return "kalman", params
    raise TypeError(f"tracker_params: not a tracker config: {config!r}")


class OcclusionTracker(LeafSystem):
    """Occlusion-aware skeleton tracker at `rate` Hz: the particle filter of 9.1.2, the Kalman
    baseline of 9.1.3, or the hold-last-seen baseline (`HoldLastSeenTracker`), chosen by the
    type of `config`; each drives the slow-down rule of 9.1.3.

    Inputs:
      "skeleton_frame": abstract `SkeletonFrame` (from `DepthCamera`).
      "occluding_capsules": optional abstract `Capsules`, the capsules that also hide points
        from the camera (robot links); when connected they are passed to
        `is_hidden(points, capsules)`.
      "depth_frame": optional abstract `DepthFrame` (a rendered camera's image); when
        connected, L_c1 is `DepthFrame.is_hidden` of that frame's image, and `is_hidden` and
        the capsules are not used.
    Outputs:
      "skeleton_estimate": abstract `SkeletonEstimate` (particles (8, <= display_particles, 3)).
      "speed_override": BasicVector(1), the slow-down rule of 9.1.3 (`slow_factor` or 1).

    State: one abstract value, `Frozen(SkeletonTracker)` (particles, Kalman tracks, calibration,
    generator, last estimate); each periodic update clones it (`SkeletonTracker.clone`), feeds
    the frame and stores the new core; the initialization event restores the core built from
    `seed`, so a restarted run repeats the first. The update runs at `offset` (default: half a
    period) after the camera ticks, so it reads the frame measured at the same tick.
    `listeners`: pure observers `fn(frame, estimate)` called after every update that produced a
    new estimate (probes of benchmarks); they hold no state of the run and must not modify
    their arguments. `core_listeners`: the same for `fn(frame, core)`, given the updated
    `SkeletonTracker` itself (whole particle sets, Kalman covariances: the belief regions of
    `perception.regions`); they must not modify it.
    """

    def __init__(self, config: TrackingConfig, is_hidden, workspace_center,
                 workspace_size, rate: float = 30.0, seed: int = 0, offset: float | None = None):
        super().__init__()
        config.validate("tracker")
        self.config = config
        kind, params = tracker_params(config)
        core = SkeletonTracker(kind, params, None, workspace_center, workspace_size, rate, seed)
        self.is_hidden = is_hidden
        self.threshold = float(config.slow_down_threshold)
        self.slow = float(config.slow_factor)
        speed_override(core.estimate_, self.threshold, self.slow)  # validates both
        self._initial = Frozen(core)
        self.listeners: list = []
        self.core_listeners: list = []
        self._frame = self.DeclareAbstractInputPort("skeleton_frame", AbstractValue.Make(SkeletonFrame()))
        self._capsules = self.DeclareAbstractInputPort("occluding_capsules",
                                                       AbstractValue.Make(no_capsules()))
        self._depth_frame = self.DeclareAbstractInputPort("depth_frame", AbstractValue.Make(DepthFrame()))
        self._core = declare_state(self, lambda context: self._initial)
        period = 1.0 / float(rate)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.5 * period if offset is None else offset,
                                                    self._update)
        ticket = {self.abstract_state_ticket(AbstractStateIndex(self._core))}
        self.DeclareAbstractOutputPort("skeleton_estimate", lambda: AbstractValue.Make(SkeletonEstimate()),
                                       self._calc_estimate, ticket)
        self.DeclareVectorOutputPort("speed_override", BasicVector(1), self._calc_speed, ticket)

    def _depth_query(self, context):
        if self._depth_frame.HasValue(context):
            return self._depth_frame.Eval(context).is_hidden
        if self.is_hidden is None or not self._capsules.HasValue(context):
            return self.is_hidden
        capsules = self._capsules.Eval(context)
        if not len(capsules[2]):
            return self.is_hidden
        is_hidden = self.is_hidden
        return lambda points: is_hidden(points, capsules)

    def _update(self, context, state):
        frame = self._frame.Eval(context)
        frozen = get_state(context, self._core)
        core = frozen.thaw()
        core.is_hidden = self._depth_query(context)
        previous = core.estimate_
        estimate = core.update(frame)
        core.is_hidden = None  # the stored core keeps no input of this update
        if estimate is previous:
            return EventStatus.DidNothing()
        set_state(state, self._core, Frozen(core))
        for listener in self.listeners:
            listener(frame, estimate)
        for listener in self.core_listeners:
            listener(frame, core)
        return EventStatus.Succeeded()

    def estimate(self, context) -> SkeletonEstimate:
        """The last estimate held in `context` (this system's context)."""
        return get_state(context, self._core).core.estimate_

    def _calc_estimate(self, context, output):
        output.set_value(self.estimate(context))

    def _calc_speed(self, context, output):
        output.SetAtIndex(0, speed_override(self.estimate(context), self.threshold, self.slow))


class MeasurementAsEstimate(LeafSystem):
    """No tracker: the estimate is the measurement; a lost point keeps its last seen position.

    Input "skeleton_frame" (abstract `SkeletonFrame`); output "skeleton_estimate" (abstract
    `SkeletonEstimate`: spread 0 for seen points, inf for lost ones, NaN rows for points never
    seen; workspace fraction 0/1).
    State: the last seen position of every point, (8, 3) discrete state (NaN until seen),
    updated at the camera `rate` at the camera ticks; the output is a pure function of the
    frame on the input and that state.
    """

    def __init__(self, workspace_center, workspace_size, rate: float = 30.0, offset: float = 0.0):
        super().__init__()
        if not (np.isfinite(rate) and rate > 0):
            raise ValueError(f"MeasurementAsEstimate: rate must be positive, got {rate!r}")
        self._frame = self.DeclareAbstractInputPort("skeleton_frame", AbstractValue.Make(SkeletonFrame()))
        self._lo = np.asarray(workspace_center, float) - 0.5 * np.asarray(workspace_size, float)
        self._hi = np.asarray(workspace_center, float) + 0.5 * np.asarray(workspace_size, float)
        self._held = self.DeclareDiscreteState(np.full(24, np.nan))
        declare_periodic_discrete_update(self, 1.0 / float(rate), float(offset), self._update)
        self.DeclareAbstractOutputPort(
            "skeleton_estimate", lambda: AbstractValue.Make(SkeletonEstimate()), self._calc,
            {self._frame.ticket(), self.discrete_state_ticket(self._held)},
        )

    def _points(self, context, frame):
        held = context.get_discrete_state(self._held).get_value().reshape(8, 3)
        return np.where(frame.tracked[:, None], frame.points, held)

    def _update(self, context, discrete_state):
        frame = self._frame.Eval(context)
        held = context.get_discrete_state(self._held).get_value().reshape(8, 3)
        points = self._points(context, frame)
        discrete_state.get_mutable_vector(self._held).SetFromVector(
            np.where(np.isfinite(points), points, held).ravel())
        return EventStatus.Succeeded()

    def _calc(self, context, output):
        frame = self._frame.Eval(context)
        points = self._points(context, frame)
        inside = np.all((points >= self._lo) & (points <= self._hi), axis=1)
        output.set_value(
            SkeletonEstimate(
                time=frame.time,
                points=points,  # NaN for a point never seen yet (not the world origin)
                spread=np.where(frame.tracked, 0.0, np.inf),
                tracked=frame.tracked.copy(),
                workspace_fraction=inside.astype(float),
                gaze=frame.gaze,
                gaze_valid=frame.gaze_valid,
            )
        )


def apply_tracker_config(config: NoTracker | TrackingConfig, builder, *,
                         skeleton_frame, occluding_capsules=None, is_hidden=None, depth_frame=None,
                         workspace_center, workspace_size, rate: float = 30.0, seed: int = 0) -> LeafSystem:
    """Add the tracker of `config` to `builder`, named "tracker", and connect its inputs.

    skeleton_frame: the camera's `SkeletonFrame` output port. occluding_capsules: optional
    `Capsules` output port (robot links) of the depth query `is_hidden(points, capsules)`.
    depth_frame: optional `DepthFrame` output port of a rendered camera: the depth query is
    then its image (`is_hidden` and the capsules are not needed).
    workspace_center, workspace_size: the robot workspace box (m). rate: camera rate (Hz).
    Returns the system: read "skeleton_estimate" (and, but for `NoTracker`, "speed_override").
    """
    if isinstance(config, NoTracker):
        tracker = builder.AddSystem(MeasurementAsEstimate(workspace_center, workspace_size, rate=rate))
    else:
        tracker = builder.AddSystem(
            OcclusionTracker(config, is_hidden, workspace_center, workspace_size, rate=rate, seed=seed))
        if occluding_capsules is not None:
            builder.Connect(occluding_capsules, tracker.GetInputPort("occluding_capsules"))
        if depth_frame is not None:
            builder.Connect(depth_frame, tracker.GetInputPort("depth_frame"))
    tracker.set_name("tracker")
    builder.Connect(skeleton_frame, tracker.GetInputPort("skeleton_frame"))
    return tracker

