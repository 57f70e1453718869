"""Drake adapters of the human model: the synthetic operator, a recorded skeleton, the depth camera."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.human.operator import SyntheticOperator
from hrc_drake.human.recorded import frame_at, load_skeleton_csv
from hrc_drake.messages import EventLog, SkeletonFrame

#: the human_events output keeps at most this many of the latest events
MAX_EVENTS_OUT = 200


def empty_skeleton_frame(time: float = 0.0) -> SkeletonFrame:
    """A frame where nothing is tracked (NaN points, gaze invalid)."""
    return SkeletonFrame(time=time, points=np.full((8, 3), np.nan), tracked=np.zeros(8, dtype=bool),
                         gaze=np.array([1.0, 0.0, 0.0]), gaze_valid=False)


def no_capsules():
    """Value of an empty `occluding_capsules` input: (start (0, 3), end (0, 3), radius (0,))."""
    return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


class OperatorSource(LeafSystem):
    """The synthetic operator as a source: its logic advances at `rate` Hz, its pose is read at any time.

    Output ports: "skeleton" (24: the 8 true points flattened row-major), "q" (12),
    "gaze" (3, unit), "human_events" (EventLog of HumanEvent, the last MAX_EVENTS_OUT).
    One simulation per operator object: the operator keeps its own logic state.
    """

    def __init__(self, operator: SyntheticOperator, rate: float = 50.0):
        super().__init__()
        if not np.isfinite(rate) or rate <= 0 or rate > 50.0:
            raise ValueError(f"OperatorSource: rate must be in (0, 50] Hz, got {rate!r}")
        self.operator = operator
        self.events: list = []
        self._log = EventLog(())
        self._log_size = 0
        # the number of events so far, so that outputs depend on the state the update changed
        self._count_index = self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        self.DeclareVectorOutputPort("skeleton", BasicVector(24), self._calc_skeleton)
        self.DeclareVectorOutputPort("q", BasicVector(12), self._calc_q)
        self.DeclareVectorOutputPort("gaze", BasicVector(3), self._calc_gaze)
        self.DeclareAbstractOutputPort("human_events", lambda: AbstractValue.Make(EventLog(())),
                                       self._calc_events)

    def _update(self, context, discrete_state):
        self.events.extend(self.operator.update(context.get_time()))
        discrete_state.get_mutable_vector(self._count_index).SetAtIndex(0, float(len(self.events)))
        return EventStatus.Succeeded()

    def _calc_skeleton(self, context, output):
        output.SetFromVector(self.operator.points(context.get_time()).ravel())

    def _calc_q(self, context, output):
        output.SetFromVector(self.operator.q(context.get_time()))

    def _calc_gaze(self, context, output):
        output.SetFromVector(self.operator.gaze(context.get_time()))

    def _calc_events(self, context, output):
        if self._log_size != len(self.events):
            self._log = EventLog(tuple(self.events[-MAX_EVENTS_OUT:]))
            self._log_size = len(self.events)
        output.set_value(self._log)


class RecordedSkeletonSource(LeafSystem):
    """Replays recorded camera frames: output "skeleton_frame" is the sample at the last time <= t.

    times (T,), points (T, 8, 3) with NaN rows where untracked, tracked (T, 8) bool.
    The recording has no gaze: gaze_valid is False.
    """

    def __init__(self, times, points, tracked):
        super().__init__()
        times = np.asarray(times, dtype=float).reshape(-1)
        points = np.asarray(points, dtype=float)
        tracked = np.asarray(tracked, dtype=bool)
        if times.size == 0 or points.shape != (times.size, 8, 3) or tracked.shape != (times.size, 8):
            raise ValueError("RecordedSkeletonSource: need times (T,), points (T, 8, 3), tracked (T, 8) "
                             f"with T > 0; got {times.shape}, {points.shape}, {tracked.shape}")
        if np.any(np.diff(times) <= 0):
            raise ValueError("RecordedSkeletonSource: times must strictly increase")
        self.times = times
        self.frames = []
        for t, frame, flags in zip(times, points, tracked, strict=True):
            frame = frame.copy()
            frame[~flags] = np.nan
            self.frames.append(SkeletonFrame(time=float(t), points=frame, tracked=flags.copy(),
                                             gaze=np.array([1.0, 0.0, 0.0]), gaze_valid=False))
        self.DeclareAbstractOutputPort("skeleton_frame", lambda: AbstractValue.Make(SkeletonFrame()),
                                       self._calc_frame)

    @classmethod
    def from_csv(cls, path) -> RecordedSkeletonSource:
        return cls(*load_skeleton_csv(path))

    @property
    def end_time(self) -> float:
        return float(self.times[-1])

    def _calc_frame(self, context, output):
        output.set_value(self.frames[frame_at(self.times, context.get_time())])


class DepthCamera(LeafSystem):
    """The depth camera at its frame rate (thesis Ch. 9 measurement model, see `DepthCameraModel`).

    Inputs: "skeleton" (24, true points), "gaze" (3), optional abstract "occluding_capsules"
    ((start (K, 3), end (K, 3), radius (K,)), e.g. robot links; unconnected = none).
    Output: "skeleton_frame" (SkeletonFrame): frame k = floor(t * rate) is measured when it is
    first read, from the pose at that moment, and held until frame k + 1. Measuring on demand
    costs nothing in a cell where no system reads the camera; the noise of frame k comes from a
    generator seeded with (rng_seed, k), so runs are reproducible whoever reads it and when.
    """

    def __init__(self, camera_model: DepthCameraModel, rng_seed=0):
        super().__init__()
        self.camera = camera_model
        self.seed = int(rng_seed)
        self._frame_index = None
        self._frame = empty_skeleton_frame()
        self._skeleton = self.DeclareVectorInputPort("skeleton", 24)
        self._gaze = self.DeclareVectorInputPort("gaze", 3)
        self._capsules = self.DeclareAbstractInputPort("occluding_capsules",
                                                       AbstractValue.Make(no_capsules()))
        self.DeclareAbstractOutputPort("skeleton_frame", lambda: AbstractValue.Make(SkeletonFrame()),
                                       self._calc_frame, prerequisites_of_calc={self.time_ticket()})

    def _calc_frame(self, context, output):
        t = context.get_time()
        k = int(np.floor(t * self.camera.rate + 1e-9))
        if k != self._frame_index:
            points = self._skeleton.Eval(context).reshape(8, 3)
            gaze = self._gaze.Eval(context)
            capsules = self._capsules.Eval(context) if self._capsules.HasValue(context) else None
            rng = np.random.default_rng([self.seed, k])
            self._frame = self.camera.measure(t, points, gaze, rng, capsules)
            self._frame_index = k
        output.set_value(self._frame)
