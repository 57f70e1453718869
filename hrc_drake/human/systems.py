"""Drake adapters of the human model: the synthetic operator, a recorded skeleton, the depth cameras
(analytic, and on a depth image rendered by an `RgbdSensor`).

Each keeps its run in its Context (DESIGN.md): the operator's plans and event logs, the camera's
last frame are abstract state set again at initialization; outputs read only the Context.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    DepthRange,
    DepthRenderCamera,
    MakeRenderEngineVtk,
    RenderCameraCore,
    RenderEngineVtkParams,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem
from pydrake.systems.sensors import CameraInfo, ImageDepth32F, RgbdSensor

from hrc_drake.human.camera import DepthCameraModel, RenderedCameraModel
from hrc_drake.human.operator import SyntheticOperator
from hrc_drake.human.recorded import frame_at, load_skeleton_csv
from hrc_drake.messages import DepthFrame, EventLog, Immutable, SkeletonFrame, WorldSnapshot, no_capsules
from hrc_drake.systems import Frozen, declare_state, get_state, input_or, set_state, state_ticket

#: the human_events and world_requests outputs keep at most this many of the latest events
MAX_EVENTS_OUT = 200


def empty_skeleton_frame(time: float = 0.0) -> SkeletonFrame:
    """A frame where nothing is tracked (NaN points, gaze invalid)."""
    return SkeletonFrame(
        time=time,
        points=np.full((8, 3), np.nan),
        tracked=np.zeros(8, dtype=bool),
        gaze=np.array([1.0, 0.0, 0.0]),
        gaze_valid=False,
    )


@dataclass(frozen=True)
class OperatorRun(Immutable):
    """The operator's run state: its core (plans, indices) and what it emitted so far."""

    operator: Frozen
    human_events: EventLog = EventLog()
    world_requests: EventLog = EventLog()


class OperatorSource(LeafSystem):
    """The synthetic operator as a source: its logic advances at `rate` Hz, its pose is read at any time.

    Input "world" (optional WorldSnapshot): with it the operator asks the world to start and
    finish actions (`world_requests`) and begins when its request is granted; unconnected, it
    starts every action at once. Outputs: "skeleton" (24: the 8 true points flattened
    row-major), "q" (12), "gaze" (3, unit), "human_events" (EventLog of HumanEvent) and
    "world_requests" (EventLog of WorldRequest), each log the last MAX_EVENTS_OUT.
    State: an `OperatorRun` (the core is copied only by updates that change it).
    """

    def __init__(self, operator: SyntheticOperator, rate: float = 50.0):
        super().__init__()
        if not np.isfinite(rate) or rate <= 0 or rate > 50.0:
            raise ValueError(f"OperatorSource: rate must be in (0, 50] Hz, got {rate!r}")
        if operator.world is not None:
            raise ValueError("OperatorSource: the operator must not hold a world (use the 'world' input)")
        self._initial = OperatorRun(Frozen(operator.clone()))
        self._run = declare_state(self, lambda context: self._initial)
        self._world = self.DeclareAbstractInputPort("world", AbstractValue.Make(WorldSnapshot()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._update)
        pose_ticket = state_ticket(self, self._run, self.time_ticket())
        self.DeclareVectorOutputPort("skeleton", BasicVector(24), self._calc_skeleton, pose_ticket)
        self.DeclareVectorOutputPort("q", BasicVector(12), self._calc_q, pose_ticket)
        self.DeclareVectorOutputPort("gaze", BasicVector(3), self._calc_gaze, pose_ticket)
        self.DeclareAbstractOutputPort(
            "human_events",
            lambda: AbstractValue.Make(EventLog()),
            self._calc_events,
            state_ticket(self, self._run),
        )
        self.DeclareAbstractOutputPort(
            "world_requests",
            lambda: AbstractValue.Make(EventLog()),
            self._calc_requests,
            state_ticket(self, self._run),
        )

    def operator(self, context) -> SyntheticOperator:
        """The operator core of `context` (read only)."""
        return get_state(context, self._run).operator.core

    def _update(self, context, state):
        run = get_state(context, self._run)
        t = context.get_time()
        if run.operator.core.busy_until(t):
            return EventStatus.DidNothing()
        view = input_or(self._world, context, None)
        if not run.operator.core.will_change(t, view):
            return EventStatus.DidNothing()
        operator = run.operator.thaw()
        events = operator.update(t, view)
        set_state(
            state,
            self._run,
            OperatorRun(
                Frozen(operator),
                run.human_events.appended(events, MAX_EVENTS_OUT),
                run.world_requests.appended(operator.new_requests, MAX_EVENTS_OUT),
            ),
        )
        return EventStatus.Succeeded()

    def _calc_skeleton(self, context, output):
        output.SetFromVector(self.operator(context).points(context.get_time()).ravel())

    def _calc_q(self, context, output):
        output.SetFromVector(self.operator(context).q(context.get_time()))

    def _calc_gaze(self, context, output):
        output.SetFromVector(self.operator(context).gaze(context.get_time()))

    def _calc_events(self, context, output):
        output.set_value(get_state(context, self._run).human_events)

    def _calc_requests(self, context, output):
        output.set_value(get_state(context, self._run).world_requests)


class RecordedSkeletonSource(LeafSystem):
    """Replays recorded camera frames: output "skeleton_frame" is the sample at the last time <= t.

    times (T,), points (T, 8, 3) with NaN rows where untracked, tracked (T, 8) bool.
    The recording has no gaze: gaze_valid is False. Output "skeleton" (24): the points with
    each untracked point held at its last tracked value (the body's rest is unknown before
    a point is first seen: NaN). Stateless: every output is a function of time.
    """

    def __init__(self, times, points, tracked):
        super().__init__()
        times = np.asarray(times, dtype=float).reshape(-1)
        points = np.asarray(points, dtype=float)
        tracked = np.asarray(tracked, dtype=bool)
        if times.size == 0 or points.shape != (times.size, 8, 3) or tracked.shape != (times.size, 8):
            raise ValueError(
                "RecordedSkeletonSource: need times (T,), points (T, 8, 3), tracked (T, 8) "
                f"with T > 0; got {times.shape}, {points.shape}, {tracked.shape}"
            )
        if np.any(np.diff(times) <= 0):
            raise ValueError("RecordedSkeletonSource: times must strictly increase")
        self.times = times
        self.frames = []
        held = np.full((times.size, 8, 3), np.nan)
        last = np.full((8, 3), np.nan)
        for k, (t, frame, flags) in enumerate(zip(times, points, tracked, strict=True)):
            frame = frame.copy()
            frame[~flags] = np.nan
            last = np.where(np.isfinite(frame), frame, last)
            held[k] = last
            self.frames.append(
                SkeletonFrame(
                    time=float(t),
                    points=frame,
                    tracked=flags.copy(),
                    gaze=np.array([1.0, 0.0, 0.0]),
                    gaze_valid=False,
                )
            )
        self.held_points = held
        self.DeclareAbstractOutputPort(
            "skeleton_frame",
            lambda: AbstractValue.Make(SkeletonFrame()),
            self._calc_frame,
            {self.time_ticket()},
        )
        self.DeclareVectorOutputPort("skeleton", BasicVector(24), self._calc_skeleton, {self.time_ticket()})

    @classmethod
    def from_csv(cls, path) -> RecordedSkeletonSource:
        return cls(*load_skeleton_csv(path))

    @property
    def end_time(self) -> float:
        return float(self.times[-1])

    def _calc_frame(self, context, output):
        output.set_value(self.frames[frame_at(self.times, context.get_time())])

    def _calc_skeleton(self, context, output):
        output.SetFromVector(self.held_points[frame_at(self.times, context.get_time())].ravel())


class DepthCamera(LeafSystem):
    """The depth camera (thesis Ch. 9 measurement model, see `DepthCameraModel`).

    Inputs: "skeleton" (24, true points), "gaze" (3), optional abstract "occluding_capsules"
    (`messages.Capsules`, e.g. robot links; unconnected = none).
    Output: "skeleton_frame" (SkeletonFrame), a pure function of the context: the inputs
    measured at the context's time, with the noise of frame k = floor(t * rate) drawn from a
    generator seeded with (rng_seed, k). Readers sample it at the camera rate (the tracker,
    the intention estimator); nothing is measured where nobody reads it. Stateless.
    """

    def __init__(self, camera_model: DepthCameraModel, rng_seed=0):
        super().__init__()
        self.camera = camera_model
        self.seed = int(rng_seed)
        self._skeleton = self.DeclareVectorInputPort("skeleton", 24)
        self._gaze = self.DeclareVectorInputPort("gaze", 3)
        self._capsules = self.DeclareAbstractInputPort(
            "occluding_capsules", AbstractValue.Make(no_capsules())
        )
        self.DeclareAbstractOutputPort(
            "skeleton_frame", lambda: AbstractValue.Make(SkeletonFrame()), self._calc_frame
        )

    def _calc_frame(self, context, output):
        t = context.get_time()
        k = int(np.floor(t * self.camera.rate + 1e-9))
        points = self._skeleton.Eval(context).reshape(8, 3)
        capsules = input_or(self._capsules, context, None)
        rng = np.random.default_rng([self.seed, k])
        output.set_value(self.camera.measure(t, points, self._gaze.Eval(context), rng, capsules))


@dataclass(frozen=True)
class RenderedFrames(Immutable):
    """The rendered camera's last frame: the measured skeleton and the depth image it came from."""

    skeleton: SkeletonFrame
    depth: DepthFrame


class RenderedSkeletonCamera(LeafSystem):
    """A skeleton tracker on a rendered depth image (thesis Ch. 9 measurement model, see
    `RenderedCameraModel`), in place of `DepthCamera`.

    Inputs: "depth_image" (ImageDepth32F, width x height of the model; from an `RgbdSensor`'s
    depth_image_32f port), "skeleton" (24, true points), "gaze" (3).
    Outputs: "skeleton_frame" (SkeletonFrame, as `DepthCamera`'s) and "depth_frame"
    (`DepthFrame`: the image, its projection and the points it hid; the tracker's L_c1 and the
    replay read it).
    State: a `RenderedFrames`, measured by a periodic update at the camera ticks k / rate (so the
    sensor renders once per frame, when this update reads it), with the noise of frame k drawn
    from a generator seeded with (rng_seed, k). Before the first tick nothing is tracked.
    """

    def __init__(self, camera_model: RenderedCameraModel, rng_seed=0):
        super().__init__()
        self.camera = camera_model
        self.seed = int(rng_seed)
        self._image = self.DeclareAbstractInputPort("depth_image", AbstractValue.Make(ImageDepth32F()))
        self._skeleton = self.DeclareVectorInputPort("skeleton", 24)
        self._gaze = self.DeclareVectorInputPort("gaze", 3)
        initial = RenderedFrames(empty_skeleton_frame(), DepthFrame())
        self._frames = declare_state(self, lambda context: initial)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / camera_model.rate, 0.0, self._update)
        ticket = state_ticket(self, self._frames)
        self.DeclareAbstractOutputPort("skeleton_frame", lambda: AbstractValue.Make(SkeletonFrame()),
                                       self._calc_frame, ticket)
        self.DeclareAbstractOutputPort("depth_frame", lambda: AbstractValue.Make(DepthFrame()),
                                       self._calc_depth, ticket)

    def _update(self, context, state):
        t = context.get_time()
        k = int(np.floor(t * self.camera.rate + 1e-9))
        image = self._image.Eval(context)
        if (image.width(), image.height()) != (self.camera.width, self.camera.height):
            raise ValueError(f"RenderedSkeletonCamera: the depth image is {image.width()} x "
                             f"{image.height()}, the camera model {self.camera.width} x {self.camera.height}")
        rng = np.random.default_rng([self.seed, k])
        points = self._skeleton.Eval(context).reshape(8, 3)
        frame, depth = self.camera.measure(t, points, self._gaze.Eval(context), image.data[:, :, 0], rng)
        set_state(state, self._frames, RenderedFrames(frame, depth))
        return EventStatus.Succeeded()

    def _calc_frame(self, context, output):
        output.set_value(get_state(context, self._frames).skeleton)

    def _calc_depth(self, context, output):
        output.set_value(get_state(context, self._frames).depth)


#: the name of the VTK renderer the rendered camera adds to SceneGraph
DEPTH_RENDERER = "hrc_depth_vtk"


def add_rendered_camera(builder, scene_graph, camera_model: RenderedCameraModel, rng_seed=0):
    """Add the rendered camera: a VTK renderer in `scene_graph` (headless), an `RgbdSensor` at
    the model's pose and intrinsics rendering depth only, and the `RenderedSkeletonCamera` that
    reads it (named "rendered_depth_sensor" and "depth_camera"). The skeleton and gaze inputs
    are left to the caller. Geometry appears in the image where it has the perception role.
    Returns the skeleton camera.
    """
    if not scene_graph.HasRenderer(DEPTH_RENDERER):
        scene_graph.AddRenderer(DEPTH_RENDERER, MakeRenderEngineVtk(RenderEngineVtkParams()))
    m = camera_model
    info = CameraInfo(m.width, m.height, m.fx, m.fy, m.cx, m.cy)
    # the clipping planes bracket the depth range, so that nearer surfaces still hide what is behind
    clipping = ClippingRange(min(0.01, 0.5 * m.min_depth), 1.05 * m.max_depth)
    core = RenderCameraCore(DEPTH_RENDERER, info, clipping, RigidTransform())
    depth_camera = DepthRenderCamera(core, DepthRange(m.min_depth, m.max_depth))
    X_WC = RigidTransform(RotationMatrix(m.R_WC), m.position)
    sensor = builder.AddSystem(RgbdSensor(scene_graph.world_frame_id(), X_WC, depth_camera))
    sensor.set_name("rendered_depth_sensor")
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    camera = builder.AddSystem(RenderedSkeletonCamera(camera_model, rng_seed))
    camera.set_name("depth_camera")
    builder.Connect(sensor.depth_image_32F_output_port(), camera.GetInputPort("depth_image"))
    return camera
