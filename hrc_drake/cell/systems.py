"""Drake systems of the cell: human geometry, static scene, robot capsules, metrics."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydrake.common import MemoryFile
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box,
    Capsule,
    Cylinder,
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    InMemoryMesh,
    MakePhongIllustrationProperties,
    Mesh,
    PerceptionProperties,
    Rgba,
    Role,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem, ValueProducer

from hrc_drake.cell.metrics import AppendOnly, DecimatedTrace, LoggedEvent, MetricsLog, SampleStats
from hrc_drake.cell.schema import Scenario
from hrc_drake.kernels import capsule_clearances
from hrc_drake.messages import (
    AgentActivity,
    Capsules,
    EventLog,
    Forecast,
    Immutable,
    WorldSnapshot,
    no_capsules,
)
from hrc_drake.systems import Frozen, declare_state, get_state, input_or, set_state, state_ticket

HUMAN_COLOR = [0.95, 0.65, 0.45, 1.0]
GOAL_COLOR = [0.2, 0.8, 0.3, 0.35]
BUFFER_COLOR = [0.3, 0.5, 0.9, 0.6]
PART_COLOR = [0.95, 0.8, 0.1, 1.0]
OCCLUDER_COLOR = [0.5, 0.5, 0.55, 0.8]
TABLE_COLOR = [0.75, 0.7, 0.6, 1.0]
CAMERA_COLOR = [0.1, 0.1, 0.1, 1.0]
MAX_PARTS_SHOWN = 4
PART_SIZE = 0.035


def perception_properties(color) -> PerceptionProperties:
    """The perception role (what a rendered depth camera sees), with the colour made opaque
    (a rendered camera sees the replay's translucent things as solid)."""
    properties = PerceptionProperties()
    properties.AddProperty("phong", "diffuse", Rgba(*color[:3], 1.0))
    return properties


#: sides and rings per hemisphere of the coarse meshes a rendered camera sees in place of
#: capsules, spheres and cylinders
COARSE_SIDES, COARSE_RINGS = 12, 3


def round_mesh_obj(radius: float, length: float, caps: str = "round", sides: int = COARSE_SIDES,
                   rings: int = COARSE_RINGS) -> str:
    """OBJ text (vertices, normals, triangles) of a coarse capsule (caps "round"; a sphere when
    length is 0) or cylinder (caps "flat") along z, centred at the origin. Its faces touch the
    true surface from outside (circumscribed), so it hides at least what the shape hides.

    Why: RenderEngineVtk tessellates Capsule and Sphere finely; on a 2-core machine without a
    GPU each capsule costs ~2 ms per depth frame, a 12 x 3 one ~0.05 ms.
    """
    half = 0.5 * float(length)
    grow = 1.0 / np.cos(np.pi / sides)  # circumscribe the polygon around the circle
    if caps == "round":
        grow /= np.cos(0.25 * np.pi / rings)
        angles = np.concatenate([np.linspace(-0.5 * np.pi, 0.0, rings + 1)[1:],
                                 np.linspace(0.0, 0.5 * np.pi, rings + 1)[:-1]])
        centres = np.where(np.arange(2 * rings) < rings, -half, half)
        ring_r, ring_z = np.cos(angles), centres + radius * grow * np.sin(angles)
        poles = [-half - radius * grow, half + radius * grow]
    elif caps == "flat":
        ring_r, ring_z = np.ones(2), np.array([-half, half])
        poles = [-half, half]
    else:
        raise ValueError(f"round_mesh_obj: caps must be 'round' or 'flat', got {caps!r}")
    theta = 2.0 * np.pi * np.arange(sides) / sides
    rings_xyz = np.stack([np.outer(ring_r, np.cos(theta)) * radius * grow,
                          np.outer(ring_r, np.sin(theta)) * radius * grow,
                          np.repeat(ring_z[:, None], sides, axis=1)], axis=-1).reshape(-1, 3)
    vertices = np.vstack([[0.0, 0.0, poles[0]], rings_xyz, [0.0, 0.0, poles[1]]])
    if caps == "round":
        axis = np.clip(vertices[:, 2], -half, half)
        normals = vertices - np.column_stack([np.zeros_like(axis), np.zeros_like(axis), axis])
    else:  # flat caps: side normals on the rings, axial ones at the poles
        normals = np.vstack([[0.0, 0.0, -1.0], rings_xyz * [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    n_rings, top = len(ring_r), len(vertices)

    def ring(i, j):
        return 2 + i * sides + j % sides

    faces = [(1, ring(0, j + 1), ring(0, j)) for j in range(sides)]
    for i in range(n_rings - 1):
        for j in range(sides):
            faces += [(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1),
                                                                            ring(i + 1, j))]
    faces += [(ring(n_rings - 1, j), ring(n_rings - 1, j + 1), top) for j in range(sides)]
    return ("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in vertices)
            + "".join(f"vn {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in normals)
            + "".join(f"f {a}//{a} {b}//{b} {c}//{c}\n" for a, b, c in faces))


def _coarse_mesh(shape):
    """The coarse mesh of a Capsule, Sphere or Cylinder (None for other shapes)."""
    if isinstance(shape, Capsule):
        text = round_mesh_obj(shape.radius(), shape.length())
    elif isinstance(shape, Sphere):
        text = round_mesh_obj(shape.radius(), 0.0)
    elif isinstance(shape, Cylinder):
        text = round_mesh_obj(shape.radius(), shape.length(), caps="flat")
    else:
        return None
    return Mesh(InMemoryMesh(mesh_file=MemoryFile(text, ".obj", "coarse_perception_mesh")), 1.0)


def use_coarse_perception_meshes(scene_graph) -> int:
    """Give the perception role of every capsule, sphere and cylinder of `scene_graph` to a
    coarse mesh on the same frame (`round_mesh_obj`); illustration and proximity keep the
    exact shapes. Call after every geometry is registered. Returns how many were replaced."""
    inspector = scene_graph.model_inspector()
    sources = {inspector.GetName(source): source for source in inspector.GetAllSourceIds()}
    replaced = 0
    for geometry in inspector.GetAllGeometryIds(Role.kPerception):
        mesh = _coarse_mesh(inspector.GetShape(geometry))
        if mesh is None:
            continue
        source = sources[inspector.GetOwningSourceName(geometry)]
        instance = GeometryInstance(inspector.GetPoseInFrame(geometry), mesh,
                                    inspector.GetName(geometry) + "_perception")
        instance.set_perception_properties(PerceptionProperties(inspector.GetPerceptionProperties(geometry)))
        frame = inspector.GetFrameId(geometry)
        scene_graph.RemoveRole(source, geometry, Role.kPerception)
        if frame == scene_graph.world_frame_id():
            scene_graph.RegisterAnchoredGeometry(source, instance)
        else:
            scene_graph.RegisterGeometry(source, frame, instance)
        replaced += 1
    return replaced


def segment_pose(start: np.ndarray, end: np.ndarray) -> RigidTransform:
    """Pose whose z axis runs from `start` to `end`, centred between them."""
    axis = end - start
    length = np.linalg.norm(axis)
    R = RotationMatrix.MakeFromOneVector(axis / length, 2) if length > 1e-9 else RotationMatrix()
    return RigidTransform(R, 0.5 * (start + end))


class HumanCapsules(LeafSystem):
    """The operator's body capsules (`messages.Capsules`) in the world.

    source "q": input "q" (12,), capsules of the body model at q.
    source "points": input "skeleton" (24,), capsules through those 8 points (e.g. a recorded
    skeleton with lost points held, `RecordedSkeletonSource`). Outputs "capsules" and "points"
    (24,), both read from one cache entry (the body's kinematics run once per input value).
    Stateless.
    """

    def __init__(self, body_model, source: str = "q"):
        super().__init__()
        if source not in ("q", "points"):
            raise ValueError(f"HumanCapsules: source must be 'q' or 'points', got {source!r}")
        self.body = body_model
        self.source = source
        if source == "q":
            self._input = self.DeclareVectorInputPort("q", 12)
        else:
            self._input = self.DeclareVectorInputPort("skeleton", 24)
        self._body = self.DeclareCacheEntry(
            "points and capsules",
            ValueProducer(allocate=lambda: AbstractValue.Make(_BodyGeometry()), calc=self._calc_body),
            {self._input.ticket()},
        )
        self.DeclareAbstractOutputPort(
            "capsules", lambda: AbstractValue.Make(no_capsules()), self._calc_capsules, {self._body.ticket()}
        )
        self.DeclareVectorOutputPort("points", 24, self._calc_points, {self._body.ticket()})

    def _calc_body(self, context, value):
        if self.source == "q":
            points, capsules = self.body.points_and_capsules(self._input.Eval(context))
            capsules = Capsules(*capsules)
        else:
            points = self._input.Eval(context).reshape(8, 3)
            capsules = Capsules(*self.body.capsules_from_points(points))
        value.set_value(_BodyGeometry(points.ravel(), capsules))

    def _calc_capsules(self, context, output):
        output.set_value(self._body.Eval(context).capsules)

    def _calc_points(self, context, output: BasicVector):
        output.SetFromVector(self._body.Eval(context).points)


@dataclass(frozen=True)
class _BodyGeometry(Immutable):
    """The cache value of `HumanCapsules`: points (24,) and the capsules through them."""

    points: np.ndarray = field(default_factory=lambda: np.zeros(24))
    capsules: Capsules = field(default_factory=no_capsules)


class HumanGeometry(LeafSystem):
    """Registers the operator's body capsules in SceneGraph and poses them.

    Input "capsules" (from `HumanCapsules`); output "geometry_pose" (FramePoseVector). The
    capsule lengths are the body model's; each is centred on its segment.
    """

    def __init__(self, scene_graph, body_model, name: str = "human", color=HUMAN_COLOR):
        super().__init__()
        from hrc_drake.human.body import CAPSULE_NAMES

        self.source_id = scene_graph.RegisterSource(name)
        start, end, radius = body_model.capsules(body_model.rest_q())
        lengths = np.linalg.norm(end - start, axis=-1)
        self.frame_ids = []
        for k, cap_name in enumerate(CAPSULE_NAMES):
            frame_id = scene_graph.RegisterFrame(self.source_id, GeometryFrame(f"{name}_{cap_name}"))
            instance = GeometryInstance(
                RigidTransform(), Capsule(float(radius[k]), float(lengths[k])), cap_name
            )
            instance.set_illustration_properties(MakePhongIllustrationProperties(color))
            # the body is solid to a rendered depth camera, even where the replay shows it translucent
            instance.set_perception_properties(perception_properties(HUMAN_COLOR))
            scene_graph.RegisterGeometry(self.source_id, frame_id, instance)
            self.frame_ids.append(frame_id)
        self._capsules = self.DeclareAbstractInputPort("capsules", AbstractValue.Make(no_capsules()))
        self.DeclareAbstractOutputPort(
            "geometry_pose", lambda: AbstractValue.Make(FramePoseVector()), self._calc_poses
        )

    def _calc_poses(self, context, output):
        start, end, _ = self._capsules.Eval(context)
        poses = output.get_mutable_value()
        for k, frame_id in enumerate(self.frame_ids):
            poses.set_value(frame_id, segment_pose(start[k], end[k]))


def register_scene(scene_graph, scenario: Scenario):
    """Anchored geometry of the layout: table, goal spheres, buffers, occluders, camera.

    All of it is illustrated; the solid things (table, buffers, occluders) also have the
    perception role, so that a rendered depth camera sees them (goal regions and the camera's
    own box are not there for it). Returns the source id.
    """
    source_id = scene_graph.RegisterSource("cell")
    lay = scenario.layout

    def add(shape, X, name, color, solid=True):
        instance = GeometryInstance(X, shape, name)
        instance.set_illustration_properties(MakePhongIllustrationProperties(color))
        if solid:
            instance.set_perception_properties(perception_properties(color))
        scene_graph.RegisterAnchoredGeometry(source_id, instance)

    t = lay.table
    add(
        Box(*t.size),
        RigidTransform([t.center[0], t.center[1], t.height - t.size[2] / 2]),
        "table",
        TABLE_COLOR,
    )
    for g in lay.goals:
        add(Sphere(g.radius), RigidTransform(g.center), f"goal_{g.name}", GOAL_COLOR, solid=False)
    for b in lay.buffers:
        add(Cylinder(0.035, 0.01), RigidTransform(b.position), f"buffer_{b.name}", BUFFER_COLOR)
    for o in lay.occluders:
        add(Box(*o.size), RigidTransform(o.center), f"occluder_{o.name}", OCCLUDER_COLOR)
    cam = lay.camera
    direction = np.asarray(cam.target, float) - np.asarray(cam.position, float)
    add(
        Box(0.06, 0.06, 0.12),
        segment_pose(np.asarray(cam.position), np.asarray(cam.position) + direction),
        "camera",
        CAMERA_COLOR,
        solid=False,
    )
    return source_id


class _KeptCapsules:
    """RobotCapsules' cache value: the last positions and their capsules (both replaced, never
    changed in place, so a copy of the Context shares them and goes on independently)."""

    __slots__ = ("positions", "capsules")

    def __init__(self, positions=None, capsules=None):
        self.positions, self.capsules = positions, capsules

    def __deepcopy__(self, memo):
        return _KeptCapsules(self.positions, self.capsules)


class RobotCapsules(LeafSystem):
    """World capsules of every robot link, from the plant positions.

    Input "positions" (n >= nq; the first nq entries are the plant's positions).
    Output "capsules": `messages.Capsules`. Stateless: the plant context on the system is
    scratch space, fully overwritten before each use; a cache entry of the Context keeps the
    last positions and their capsules (immutable), given again while the positions stay the
    same (a robot at rest).
    """

    def __init__(self, plant, kinematics, input_size: int):
        super().__init__()
        self.plant = plant
        self.kinematics = kinematics
        self._plant_context = plant.CreateDefaultContext()
        self._nq = plant.num_positions()
        self._positions = self.DeclareVectorInputPort("positions", input_size)
        self._kept = self.DeclareCacheEntry(
            "last capsules",
            ValueProducer(allocate=lambda: AbstractValue.Make(_KeptCapsules()), calc=lambda *_: None),
            {self.nothing_ticket()},
        )
        self.DeclareAbstractOutputPort("capsules", lambda: AbstractValue.Make(no_capsules()), self._calc)

    def _calc(self, context, output):
        q = self._positions.Eval(context)[: self._nq]
        kept = self._kept.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()
        if kept.positions is None or not np.array_equal(q, kept.positions):
            self.plant.SetPositions(self._plant_context, q)
            kept.positions = np.array(q)
            kept.capsules = Capsules(*self.kinematics.capsules(self._plant_context))
        output.set_value(kept.capsules)


class CellWorldSystem(LeafSystem):
    """The cell's ground truth in the diagram (thesis Table 6.1 buffers and resources).

    State: the `CellWorld` (parts in every buffer, reservations, finished products, pending
    start requests). Inputs "requests_<source>" (EventLog of `WorldRequest`, one per source of
    agents, e.g. the operator and the robot task executor) and optional "robot_activity"
    (`AgentActivity`). At each tick (`period`) the new requests are arbitrated
    (`CellWorld.handle_requests`). Output "snapshot" (`WorldSnapshot`): parts, products, what
    each agent does, and which start requests were granted or refused.
    """

    def __init__(self, world, sources: list[str], period: float):
        super().__init__()
        self._initial = WorldRun(Frozen(world.clone()), (0,) * len(sources))
        self._snapshots: dict = {}
        self._run = declare_state(self, lambda context: self._initial)
        self._sources = [
            self.DeclareAbstractInputPort(f"requests_{name}", AbstractValue.Make(EventLog()))
            for name in sources
        ]
        self._activity = self.DeclareAbstractInputPort("robot_activity", AbstractValue.Make(AgentActivity()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._tick)
        self.DeclareAbstractOutputPort(
            "snapshot",
            lambda: AbstractValue.Make(WorldSnapshot()),
            self._calc,
            state_ticket(self, self._run, self._activity.ticket()),
        )

    def world(self, context):
        """The `CellWorld` of `context` (read only)."""
        return get_state(context, self._run).world.core

    def _tick(self, context, state):
        run = get_state(context, self._run)
        new, seen = [], list(run.seen)
        for k, port in enumerate(self._sources):
            events = port.Eval(context).events
            if events and events[-1].seq > seen[k]:
                fresh = port.Eval(context).since(seen[k])
                seen[k] = fresh[-1].seq
                new.extend(fresh)
        now = context.get_time()
        if not new and now < run.world.core.next_deadline():
            # nothing changed since the last tick: a pending start still cannot start
            return EventStatus.DidNothing()
        world = run.world.thaw()
        world.handle_requests(new, now)
        set_state(state, self._run, WorldRun(Frozen(world), tuple(seen), context.get_time()))
        return EventStatus.Succeeded()

    def _calc(self, context, output):
        run = get_state(context, self._run)
        robots = self._activity.Eval(context) if self._activity.HasValue(context) else None
        # A memo of snapshots (a pure function of the run and the activity input): Drake
        # recomputes this output whenever any update at the same time succeeds.
        memo = self._snapshots.get((id(run), id(robots)))
        if memo is not None and memo[0] is run and memo[1] is robots:
            output.set_value(memo[2])
            return
        world = run.world.core
        activity = dict(world.running)
        if robots is not None:
            activity.update(robots.as_dict())
        snapshot = world.snapshot(run.time, activity)
        if len(self._snapshots) > 64:
            self._snapshots.clear()
        self._snapshots[(id(run), id(robots))] = (run, robots, snapshot)
        output.set_value(snapshot)


@dataclass(frozen=True)
class WorldRun(Immutable):
    """The world's run state: the world, the last request seq seen from each source, and the
    time of the last change (the snapshot's time)."""

    world: Frozen
    seen: tuple[int, ...] = ()
    time: float = 0.0


class MinOverride(LeafSystem):
    """The smallest of several speed overrides (each (1,) in [0, 1]); unconnected inputs are 1."""

    def __init__(self, num_inputs: int):
        super().__init__()
        self._inputs = [self.DeclareVectorInputPort(f"override_{i}", 1) for i in range(num_inputs)]
        self.DeclareVectorOutputPort("speed_override", 1, self._calc)

    def _calc(self, context, output: BasicVector):
        value = 1.0
        for port in self._inputs:
            if port.HasValue(context):
                value = min(value, float(port.Eval(context)[0]))
        output.SetAtIndex(0, value if np.isfinite(value) else 0.0)


def _intention_to_logged(event) -> LoggedEvent:
    return LoggedEvent(event.time, "intention", f"{event.goal} ({event.hand} hand)", event.kind, event.seq)


class _Recording:
    """The recorder's cache value: the `RecorderRun` so far (replaced by each sample, never
    changed in place, so a copy of the Context shares it and goes on independently)."""

    __slots__ = ("run",)

    def __init__(self, run: RecorderRun | None = None):
        self.run = run if run is not None else RecorderRun()

    def __deepcopy__(self, memo):
        return _Recording(self.run)


@dataclass(frozen=True)
class RecorderRun(Immutable):
    """What the recorder has recorded so far: append-only logs and the last seq seen per source."""

    #: (time, distance, override, buffers, products, human points), bounded (see `max_samples`)
    samples: DecimatedTrace = DecimatedTrace()
    #: exact figures over every sample taken
    stats: SampleStats = SampleStats()
    events: AppendOnly = AppendOnly()
    perceived: AppendOnly = AppendOnly()
    #: (time, Forecast) at every sample whose forecast differs from the last one, bounded as `samples`
    forecasts: DecimatedTrace = DecimatedTrace()
    #: the last seq read from human, robot, intention and perceived events
    seen: tuple[int, int, int, int] = (0, 0, 0, 0)
    last_time: float = -np.inf
    #: the last forecast kept (None before the first)
    last_forecast: object = None


class MetricsRecorder(LeafSystem):
    """Collects events, buffer contents and the true human-robot distance (periodic, `period` s).

    Inputs "human_events", "robot_events", "intention_events", "perceived_events" (EventLog: the
    action detector's, kept apart from the truth), "forecast" (the activity predictor's, kept
    at each sample where it changed), "human_points" (24,),
    "human_capsules", "robot_capsules" (`messages.Capsules`), "speed_override" (1,), "world"
    (`WorldSnapshot`). `log(context)` gives the `MetricsLog` of a run, with a last sample at
    the context's time. safety_distance: samples under it are counted (the scenario's).

    Memory is flat in simulated time: the samples are a `DecimatedTrace` of at most
    `max_samples` (every sample up to max_samples * period s, then evenly thinned; the changed
    forecasts likewise), while the minimum distance and the mean override are exact over every
    sample. Events are all kept (a few hundred bytes each: ~0.3 MB per hour of a cell).

    A recorder, as Drake's `VectorLogSink`: what it recorded is a `RecorderRun` in a cache entry
    of the Context that its periodic publish event replaces (the entry depends on nothing, so
    Drake never recomputes it), cleared by an initialization publish event. It reads every input
    after the updates of the same time and changes no state, so recording costs the
    simulation no state copies (DESIGN.md, performance rules).
    """

    def __init__(self, period: float = 0.1, max_samples: int = 8192, safety_distance: float = -np.inf):
        super().__init__()
        self._max_samples = max_samples
        self._period = float(period)
        self._safety_distance = float(safety_distance)
        self._human_events = self.DeclareAbstractInputPort("human_events", AbstractValue.Make(EventLog()))
        self._robot_events = self.DeclareAbstractInputPort("robot_events", AbstractValue.Make(EventLog()))
        self._intention_events = self.DeclareAbstractInputPort(
            "intention_events", AbstractValue.Make(EventLog())
        )
        self._perceived_events = self.DeclareAbstractInputPort(
            "perceived_events", AbstractValue.Make(EventLog())
        )
        self._forecast = self.DeclareAbstractInputPort("forecast", AbstractValue.Make(Forecast()))
        self._human_points = self.DeclareVectorInputPort("human_points", 24)
        self._human_capsules = self.DeclareAbstractInputPort(
            "human_capsules", AbstractValue.Make(no_capsules())
        )
        self._robot_capsules = self.DeclareAbstractInputPort(
            "robot_capsules", AbstractValue.Make(no_capsules())
        )
        self._override = self.DeclareVectorInputPort("speed_override", 1)
        self._world = self.DeclareAbstractInputPort("world", AbstractValue.Make(WorldSnapshot()))
        self._record_entry = self.DeclareCacheEntry(
            "recorded run",
            ValueProducer(allocate=lambda: AbstractValue.Make(_Recording()), calc=lambda *_: None),
            {self.nothing_ticket()},
        )
        self.DeclareInitializationPublishEvent(self._clear)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._record)

    def _recording(self, context) -> _Recording:
        return self._record_entry.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()

    def _clear(self, context):
        self._recording(context).run = RecorderRun(samples=DecimatedTrace(self._max_samples),
                                                   forecasts=DecimatedTrace(self._max_samples))
        return EventStatus.Succeeded()

    def _sample(self, context, run: RecorderRun) -> RecorderRun:
        t = context.get_time()
        seen = list(run.seen)
        events = run.events
        sources = (
            (self._human_events, None),
            (self._robot_events, None),
            (self._intention_events, _intention_to_logged),
        )
        for k, (port, convert) in enumerate(sources):
            if port.HasValue(context):
                new = port.Eval(context).since(seen[k])
                if new:
                    seen[k] = new[-1].seq
                    events = events.extend(map(convert, new) if convert else new)
        forecasts, last_forecast = run.forecasts, run.last_forecast
        if self._forecast.HasValue(context):
            forecast = self._forecast.Eval(context)
            if forecast is not last_forecast:
                forecasts, last_forecast = forecasts.offer((t, forecast)), forecast
        perceived = run.perceived
        if self._perceived_events.HasValue(context):
            new = self._perceived_events.Eval(context).since(seen[3])
            if new:
                seen[3] = new[-1].seq
                perceived = perceived.extend(new)
        distance = np.inf
        points = self._human_points.Eval(context).copy() if self._human_points.HasValue(context) else None
        if self._human_capsules.HasValue(context) and self._robot_capsules.HasValue(context):
            r_start, r_end, r_radius = self._robot_capsules.Eval(context)
            h_start, h_end, h_radius = self._human_capsules.Eval(context)
            if len(r_radius) and len(h_radius):
                distance = float(capsule_clearances(h_start, h_end, h_radius, r_start, r_end, r_radius).min())
        override = float(self._override.Eval(context)[0]) if self._override.HasValue(context) else 1.0
        world = input_or(self._world, context, WorldSnapshot())
        sample = (t, distance, override, world.buffers, world.finished_products, points)
        stats = run.stats.add(distance, override, self._safety_distance)
        return RecorderRun(run.samples.offer(sample), stats, events, perceived,
                           forecasts, tuple(seen), t, last_forecast)

    def _record(self, context):
        recording = self._recording(context)
        if context.get_time() <= recording.run.last_time:
            return EventStatus.DidNothing()
        recording.run = self._sample(context, recording.run)
        return EventStatus.Succeeded()

    def log(self, context) -> MetricsLog:
        """The run recorded in `context`, closed by a sample at the context's time (not stored)."""
        run = self._recording(context).run
        if context.get_time() > run.last_time:
            run = self._sample(context, run)
        log = MetricsLog(events=list(run.events), perceived_events=list(run.perceived),
                         forecasts=list(run.forecasts), stats=run.stats, sample_stride=run.samples.stride,
                         safety_distance=self._safety_distance, sample_period=self._period)
        for t, distance, override, buffers, products, points in run.samples:
            log.record(t, distance, override, buffers, products, points)
        return log
