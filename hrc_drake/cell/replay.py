"""The replay's markers: what SceneGraph does not show, animated in Meshcat and recorded with it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Box as MeshcatBox
from pydrake.geometry import Cylinder, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import EventStatus, LeafSystem

from hrc_drake.cell.schema import Scenario
from hrc_drake.cell.systems import segment_pose
from hrc_drake.messages import (
    DepthFrame,
    EventLog,
    Immutable,
    SkeletonEstimate,
    SkeletonFrame,
    SweptVolumes,
    WorldSnapshot,
)
from hrc_drake.perception.config import NoTracker
from hrc_drake.systems import declare_state, get_state, input_or, set_state

#: a goal flashes this long (s) after the intention estimator understood it (Fig. 3.6)
FLASH_TIME = 0.6

#: the markers' colours (r, g, b, a), which the replay's legend names
MEASURED_COLOR = (0.1, 0.4, 1.0, 1.0)
ESTIMATED_COLOR = (1.0, 0.2, 0.2, 1.0)
UNTRACKED_COLOR = (0.15, 0.15, 0.15, 1.0)
WRONG_SURFACE_COLOR = (1.0, 0.1, 0.9, 0.7)
SPREAD_COLOR = (1.0, 0.3, 0.3, 0.25)
FLASH_COLOR = (1.0, 0.9, 0.1, 0.6)
SWEPT_COLOR = (0.6, 0.2, 0.9, 0.18)
MARKER_PART_COLOR = (0.95, 0.75, 0.1, 1.0)
LAMP_COLORS = {"full": (0.1, 0.9, 0.1, 1.0), "slow": (1.0, 0.7, 0.0, 1.0), "stop": (0.9, 0.1, 0.1, 1.0)}


@dataclass(frozen=True)
class MarkerState(Immutable):
    """What the replay shows: goals flashing (goal -> time the flash ends), the last intention
    seq seen, and the marker paths visible at this tick and at the one before (the publish
    sends only the difference)."""

    until: tuple[tuple[str, float], ...] = ()
    last_seq: int = 0
    shown: frozenset = frozenset()
    shown_before: frozenset = frozenset()


class ReplayMarkers(LeafSystem):
    """Animates parts in buffers, measured and estimated skeleton points, swept volumes,
    intention flashes and a speed lamp as Meshcat objects (recorded with the replay).

    Inputs "world" (WorldSnapshot), "skeleton_frame", "skeleton_estimate", "intention_events",
    "swept_volumes", "speed_override" (1,), "depth_frame" (a rendered camera's `DepthFrame`:
    the points its depth image hides are drawn dark grey at their true place, those that
    jumped to a wrong surface magenta where they were measured). State: a `MarkerState`,
    updated at `fps`; the drawing is a publish event that sends what changed since the
    previous tick.
    """

    def __init__(self, scenario: Scenario, meshcat, fps: float, show_skeleton: bool, show_swept: bool):
        super().__init__()
        self.meshcat = meshcat
        self._buffers = {b.name: b for b in scenario.layout.buffers if b.kind == "intermediate"}
        self._goals = {g.name: g for g in scenario.layout.goals}
        self._show_skeleton = show_skeleton
        #: whether the skeleton (measured and estimated points) is drawn
        self.show_skeleton = show_skeleton
        self._show_swept = show_swept
        self._lamps = {name: Rgba(*c) for name, c in LAMP_COLORS.items()} if scenario.robots else {}
        self._has_occluders = bool(scenario.layout.occluders)
        self._lamp_position = (
            np.asarray(scenario.robots[0].base.xyz, float) + [0.0, 0.0, 0.75] if scenario.robots else None
        )
        self._world = self.DeclareAbstractInputPort("world", AbstractValue.Make(WorldSnapshot()))
        self._frame_port = self.DeclareAbstractInputPort(
            "skeleton_frame", AbstractValue.Make(SkeletonFrame())
        )
        self._estimate_port = self.DeclareAbstractInputPort(
            "skeleton_estimate", AbstractValue.Make(SkeletonEstimate())
        )
        self._intention_port = self.DeclareAbstractInputPort(
            "intention_events", AbstractValue.Make(EventLog())
        )
        self._swept_port = self.DeclareAbstractInputPort("swept_volumes", AbstractValue.Make(SweptVolumes()))
        self._override_port = self.DeclareVectorInputPort("speed_override", 1)
        self._depth_port = self.DeclareAbstractInputPort("depth_frame", AbstractValue.Make(DepthFrame()))
        initial = frozenset(self._initially_shown())
        self._markers = declare_state(self, lambda context: MarkerState(shown=initial, shown_before=initial))
        self.DeclareInitializationPublishEvent(self._setup)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / fps, 0.0, self._update)
        self.DeclarePeriodicPublishEvent(1.0 / fps, 0.0, self._publish)

    def _setup(self, context):
        """Create every marker object (hidden where it has nothing to show yet)."""
        meshcat = self.meshcat
        for b in self._buffers.values():
            shown = min(b.capacity, 4)
            for k in range(shown):
                path = f"/markers/parts/{b.name}/{k}"
                meshcat.SetObject(path, MeshcatBox(0.035, 0.035, 0.035), Rgba(*MARKER_PART_COLOR))
                offset = np.array([0.0, (k - (shown - 1) / 2) * 0.045, 0.025])
                meshcat.SetTransform(path, RigidTransform(np.asarray(b.position, float) + offset))
                self._hide(path)
        # Skeleton markers cost ~2 kB per replay frame: only where a tracker makes them worth it.
        if self._show_skeleton:
            for name, color in (("measured", Rgba(*MEASURED_COLOR)), ("estimated", Rgba(*ESTIMATED_COLOR))):
                for k in range(8):
                    meshcat.SetObject(f"/markers/skeleton/{name}/{k}", Sphere(0.025), color)
            # What a rendered camera's depth image did with each point (hidden until it has a frame).
            for name, radius, color in (
                ("untracked", 0.022, Rgba(*UNTRACKED_COLOR)),
                ("wrong_surface", 0.032, Rgba(*WRONG_SURFACE_COLOR)),
            ):
                for k in range(8):
                    path = f"/markers/skeleton/{name}/{k}"
                    meshcat.SetObject(path, Sphere(radius), color)
                    self._hide(path)
            # The belief's spread around a lost point: a unit sphere scaled to 2 standard deviations.
            for k in range(8):
                path = f"/markers/skeleton/spread/{k}"
                meshcat.SetObject(path, Sphere(1.0), Rgba(*SPREAD_COLOR))
                self._hide(path)
        for g in self._goals.values():
            path = f"/markers/flash/{g.name}"
            meshcat.SetObject(path, Sphere(g.radius * 1.15), Rgba(*FLASH_COLOR))
            meshcat.SetTransform(path, RigidTransform(np.asarray(g.center, float)))
            self._hide(path)
        # Swept volumes (thesis 8.1): a unit cylinder per body part, scaled to each capsule's bounds.
        if self._show_swept:
            for k in range(6):
                path = f"/markers/swept/{k}"
                meshcat.SetObject(path, Cylinder(1.0, 1.0), Rgba(*SWEPT_COLOR))
                self._hide(path)
        # A lamp above the robot: green at full speed, amber when slowed, red when stopped.
        for name, color in self._lamps.items():
            path = f"/markers/speed_lamp/{name}"
            meshcat.SetObject(path, Sphere(0.04), color)
            meshcat.SetTransform(path, RigidTransform(self._lamp_position))
            meshcat.SetProperty(path, "visible", name == "full")
        return EventStatus.Succeeded()

    def legend(self) -> list[tuple[str, tuple]]:
        """What the replay's colours mean, for its legend: (label, (r, g, b, a)) of the cell's
        things (`cell.systems` colours) and of the markers this cell draws."""
        from hrc_drake.cell.systems import BUFFER_COLOR, CAMERA_COLOR, GOAL_COLOR, HUMAN_COLOR, OCCLUDER_COLOR

        items = [("operator's body", tuple(HUMAN_COLOR)),
                 ("goal regions (where the operator reaches)", tuple(GOAL_COLOR)),
                 ("buffers (flat discs on the table, where parts wait)", tuple(BUFFER_COLOR)),
                 ("depth camera (the dark box above the cell, watching the operator)", tuple(CAMERA_COLOR))]
        if self._buffers:
            items.append(("parts in a buffer", MARKER_PART_COLOR))
        if self._has_occluders:
            items.append(("occluders (hide the operator from the camera)", tuple(OCCLUDER_COLOR)))
        if self._show_skeleton:
            items += [("tracked points: measured by the camera", MEASURED_COLOR),
                      ("tracked points: the tracker's estimate", ESTIMATED_COLOR),
                      ("estimate's spread (2 std) where the camera lost a point", SPREAD_COLOR),
                      ("point hidden in the depth image", UNTRACKED_COLOR),
                      ("point measured on a wrong surface", WRONG_SURFACE_COLOR)]
        if self._goals:
            items.append(("goal flash: the robot understood the operator's goal", FLASH_COLOR))
        if self._show_swept:
            items.append(("swept volumes: where the operator may reach next", SWEPT_COLOR))
        if self._lamps:
            items += [("speed lamp: full speed", LAMP_COLORS["full"]),
                      ("speed lamp: slowed", LAMP_COLORS["slow"]),
                      ("speed lamp: stopped", LAMP_COLORS["stop"])]
        return items

    def _hide(self, path: str) -> None:
        self.meshcat.SetProperty(path, "visible", False)

    def _initially_shown(self):
        """The paths `_setup` leaves visible: skeleton points and the full-speed lamp."""
        if self._show_skeleton:
            yield from (f"/markers/skeleton/{n}/{k}" for n in ("measured", "estimated") for k in range(8))
        if self._lamps:
            yield "/markers/speed_lamp/full"

    def _update(self, context, state):
        """Flashes from new intention events, and the set of visible markers at this tick."""
        t = context.get_time()
        markers = get_state(context, self._markers)
        until, last_seq = dict(markers.until), markers.last_seq
        if self._intention_port.HasValue(context):
            new = self._intention_port.Eval(context).since(last_seq)
            for event in new:
                until[event.goal] = t + FLASH_TIME
            if new:
                last_seq = new[-1].seq
        shown = frozenset(self._visible_paths(context, until, t))
        set_state(
            state, self._markers, MarkerState(tuple(sorted(until.items())), last_seq, shown, markers.shown)
        )
        return EventStatus.Succeeded()

    def _visible_paths(self, context, until: dict, t: float):
        parts = input_or(self._world, context, WorldSnapshot()).buffers
        for name, b in self._buffers.items():
            count = min(parts.get(name, 0), b.capacity, 4)
            yield from (f"/markers/parts/{name}/{k}" for k in range(count))
        if self._show_skeleton:
            for port, name in ((self._frame_port, "measured"), (self._estimate_port, "estimated")):
                if port.HasValue(context):
                    for k, (shown, lost) in enumerate(_skeleton_flags(port.Eval(context), name)):
                        if shown:
                            yield f"/markers/skeleton/{name}/{k}"
                        if lost:
                            yield f"/markers/skeleton/spread/{k}"
            if self._depth_port.HasValue(context):
                for name, flags in _depth_flags(self._depth_port.Eval(context)):
                    yield from (f"/markers/skeleton/{name}/{k}" for k in np.flatnonzero(flags))
        yield from (f"/markers/flash/{goal}" for goal in self._goals if until.get(goal, -1.0) > t)
        if self._show_swept and self._swept_port.HasValue(context):
            yield from (
                f"/markers/swept/{k}" for k in range(min(6, len(self._swept_port.Eval(context).radius)))
            )
        if self._lamps and self._override_port.HasValue(context):
            level = float(self._override_port.Eval(context)[0])
            yield "/markers/speed_lamp/" + (
                "full" if level >= 0.99 else ("stop" if level <= 0.01 else "slow")
            )

    def _publish(self, context):
        t = context.get_time()
        markers = get_state(context, self._markers)
        if self._show_skeleton:
            self._publish_skeleton(context, t)
        if self._show_swept and self._swept_port.HasValue(context):
            self._publish_swept(self._swept_port.Eval(context), t)
        for path in markers.shown ^ markers.shown_before:
            self.meshcat.SetProperty(path, "visible", path in markers.shown, t)
        return EventStatus.Succeeded()

    def _publish_skeleton(self, context, t: float) -> None:
        if self._depth_port.HasValue(context):
            depth = self._depth_port.Eval(context)
            frame = self._frame_port.Eval(context) if self._frame_port.HasValue(context) else None
            for name, flags in _depth_flags(depth):
                points = depth.true_points if name == "untracked" or frame is None else frame.points
                for k in np.flatnonzero(flags):
                    self.meshcat.SetTransform(f"/markers/skeleton/{name}/{k}", RigidTransform(points[k]), t)
        for port, name in ((self._frame_port, "measured"), (self._estimate_port, "estimated")):
            if not port.HasValue(context):
                continue
            value = port.Eval(context)
            for k, (shown, lost) in enumerate(_skeleton_flags(value, name)):
                if shown:
                    self.meshcat.SetTransform(
                        f"/markers/skeleton/{name}/{k}", RigidTransform(value.points[k]), t
                    )
                if lost:
                    radius = float(np.clip(2.0 * value.spread[k], 0.03, 0.6))
                    spread_path = f"/markers/skeleton/spread/{k}"
                    self.meshcat.SetTransform(spread_path, RigidTransform(value.points[k]), t)
                    self.meshcat.SetProperty(spread_path, "scale", [radius] * 3, t)

    def _publish_swept(self, swept, t: float) -> None:
        for k in range(min(6, len(swept.radius))):
            path = f"/markers/swept/{k}"
            start, end, radius = swept.start[k], swept.end[k], float(swept.radius[k])
            length = float(np.linalg.norm(end - start)) + 2.0 * radius
            self.meshcat.SetTransform(path, segment_pose(start, end), t)
            self.meshcat.SetProperty(path, "scale", [radius, radius, length], t)


def _depth_flags(depth: DepthFrame):
    """(marker name, (8,) flags) of a depth frame: the points its image hid and that stayed
    lost ("untracked"), and those measured on a wrong surface ("wrong_surface")."""
    finite = np.all(np.isfinite(depth.true_points), axis=1)
    yield "untracked", depth.hidden & ~depth.wrong_surface & finite
    yield "wrong_surface", depth.wrong_surface & finite


def _skeleton_flags(value, name: str):
    """Per point: (drawn, drawn with its spread sphere). A measured point is drawn where tracked;
    an estimated one wherever finite, with a spread sphere where the camera lost it."""
    for k in range(8):
        shown = bool(np.all(np.isfinite(value.points[k]))) and (name == "estimated" or bool(value.tracked[k]))
        lost = name == "estimated" and shown and not bool(value.tracked[k]) and np.isfinite(value.spread[k])
        yield shown, bool(lost)


def add_replay_markers(builder, scenario: Scenario, meshcat, systems: dict, fps: float) -> ReplayMarkers:
    """Add the markers and connect them to what the cell has (`systems`: ports by role)."""
    markers = builder.AddSystem(
        ReplayMarkers(
            scenario,
            meshcat,
            fps,
            show_skeleton=not isinstance(scenario.tracker, NoTracker),
            show_swept="motion_predictor" in systems,
        )
    )
    markers.set_name("replay_markers")
    builder.Connect(systems["world"], markers.GetInputPort("world"))
    if markers.show_skeleton:
        builder.Connect(
            systems["camera"].GetOutputPort("skeleton_frame"), markers.GetInputPort("skeleton_frame")
        )
        builder.Connect(
            systems["tracker"].GetOutputPort("skeleton_estimate"), markers.GetInputPort("skeleton_estimate")
        )
        if systems["camera"].HasOutputPort("depth_frame"):
            builder.Connect(systems["camera"].GetOutputPort("depth_frame"),
                            markers.GetInputPort("depth_frame"))
    if "intention" in systems:
        builder.Connect(
            systems["intention"].GetOutputPort("intention_events"), markers.GetInputPort("intention_events")
        )
    if "motion_predictor" in systems:
        builder.Connect(
            systems["motion_predictor"].GetOutputPort("swept_volumes"), markers.GetInputPort("swept_volumes")
        )
    builder.Connect(systems["speed_override"], markers.GetInputPort("speed_override"))
    return markers


#: meshcat's default camera: its vertical field of view (deg; three.js PerspectiveCamera(75, ...))
MESHCAT_FOV_DEG = 75.0
#: from where the first view looks at the cell: in front of it (-y), a little along x, from above
VIEW_DIRECTION = np.array([0.3, -2.2, 1.1])


def cell_points(scenario: Scenario) -> np.ndarray:
    """(n, 3) points the first view must show: the table's top corners, each robot's base and
    0.8 m above it with its reach (0.5 m) around, the operator from the floor to 1.9 m and 0.4 m
    around, buffers, goals, occluders' corners and the depth camera."""
    lay = scenario.layout
    t = lay.table
    points = [[t.center[0] + sx * t.size[0] / 2, t.center[1] + sy * t.size[1] / 2, t.height]
              for sx in (-1, 1) for sy in (-1, 1)]
    ring = [(dx, dy) for dx, dy in ((0.5, 0), (-0.5, 0), (0, 0.5), (0, -0.5))]
    for robot in scenario.robots:
        x, y, z = robot.base.xyz
        points += [[x, y, z], [x, y, z + 0.8]] + [[x + dx, y + dy, z + 0.3] for dx, dy in ring]
    x, y, z = scenario.operator.base.xyz
    points += [[x, y, z], [x, y, z + 1.9]] + [[x + 0.8 * dx, y + 0.8 * dy, z + 1.2] for dx, dy in ring]
    points += [b.position for b in lay.buffers] + [g.center for g in lay.goals]
    for o in lay.occluders:
        half = np.asarray(o.size, float) / 2
        points += [np.asarray(o.center, float) + half * [sx, sy, sz]
                   for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    points.append(lay.camera.position)
    return np.array([np.asarray(p, float) for p in points])


def initial_view(scenario: Scenario, fov_deg: float = MESHCAT_FOV_DEG, margin: float = 1.1):
    """(camera position, target) of the replay's first view: looking along `VIEW_DIRECTION` at
    the middle of `cell_points`, far enough that the sphere holding them all fits the vertical
    field of view with `margin` (distance = margin x radius / sin(fov / 2))."""
    points = cell_points(scenario)
    target = (points.min(axis=0) + points.max(axis=0)) / 2
    radius = max(float(np.linalg.norm(points - target, axis=1).max()), 0.5)
    distance = margin * radius / np.sin(np.radians(fov_deg) / 2)
    return target + distance * VIEW_DIRECTION / np.linalg.norm(VIEW_DIRECTION), target


#: the overlay `add_overlay` puts into the page: the title box, the clock, the legend
_OVERLAY = """
<div id="hrc-overlay" style="position:fixed;left:8px;top:8px;z-index:10;max-width:46vw;
     font:13px/1.35 system-ui,sans-serif;color:#111;background:rgba(255,255,255,0.82);
     border-radius:6px;padding:6px 10px;pointer-events:none">
  <div id="hrc-title" style="font-weight:600">{title}</div>
  <div id="hrc-subtitle" style="font-size:12px">{subtitle}</div>
  <div id="hrc-verdict" style="font-weight:600;margin-top:2px;color:{verdict_color}">{verdict}</div>
  <div id="hrc-products">{products}</div>
  <div style="font-size:15px;font-weight:600;margin-top:2px">simulated time
    <span id="hrc-clock">t = 0.0 s</span>{of_duration}</div>
</div>
<div id="hrc-legend" style="position:fixed;left:8px;bottom:8px;z-index:10;max-width:46vw;
     font:12px/1.3 system-ui,sans-serif;color:#111;background:rgba(255,255,255,0.82);
     border-radius:6px;padding:6px 10px;pointer-events:none">
{legend}
</div>
<script>
// The simulated clock: the animation's time is meshcat's `viewer.animator.time` (seconds of
// the recording's clip, whose frames are the simulated time x the replay's fps).
(function () {{
  var clock = document.getElementById("hrc-clock");
  var shown = null;
  function tick() {{
    var a = (typeof viewer !== "undefined" && viewer.animator) ? viewer.animator : null;
    var t = a ? Number(a.time) || 0 : 0;
    var text = "t = " + t.toFixed(1) + " s";
    if (text !== shown) {{
      clock.textContent = text;
      shown = text;
    }}
    requestAnimationFrame(tick);
  }}
  requestAnimationFrame(tick);
}})();
</script>
"""


def _products_line(products: dict | None) -> str:
    """"8 products (96.0 per hour)" from metrics' products_finished and products_per_hour."""
    if not products:
        return ""
    n, per_hour = products.get("products_finished", 0), products.get("products_per_hour")
    return f"{n} product{'' if n == 1 else 's'} finished" + (
        f" ({per_hour:.1f} per hour)" if per_hour is not None else "")


def _css_color(rgba) -> str:
    r, g, b, a = (float(c) for c in rgba)
    return f"rgba({round(255 * r)},{round(255 * g)},{round(255 * b)},{max(a, 0.35):.2f})"


#: the verdict line's colour by its first word (metrics.json's `safety.verdict`)
VERDICT_COLORS = {"SAFE:": "#1a7f1a", "UNSAFE:": "#c01818"}


def add_overlay(html: str, name: str, description: str, seed: int, duration: float | None,
                interrupted: bool = False, legend=(), verdict: str | None = None,
                products: dict | None = None) -> str:
    """`html` (meshcat's `StaticHtml()`) with an overlay a reader needs: the title (scenario
    `name` and `description`, seed, simulated duration), the run's safety `verdict` line and its
    `products` (metrics: products_finished, products_per_hour), the simulated time as the replay
    plays (read from meshcat's animator) and a legend of `legend` ((label, rgba) pairs, as
    `ReplayMarkers.legend`). The page's `<title>` names the scenario too."""
    from html import escape

    title = f"{name}: {description}" if description else name
    parts = [f"seed {seed}"]
    if duration is not None:
        parts.append(f"{duration:g} s simulated" + (" (interrupted)" if interrupted else ""))
    parts.append("drag to turn, scroll to zoom; Open Controls &gt; Animations to pause or scrub")
    rows = "\n".join(
        f'  <div class="hrc-legend-item"><span style="display:inline-block;width:11px;height:11px;'
        f'border-radius:50%;margin-right:6px;vertical-align:-1px;border:1px solid #555;'
        f'background:{_css_color(rgba)}"></span>{escape(label)}</div>'
        for label, rgba in legend)
    first_word = (verdict or "").split(" ", 1)[0]
    overlay = _OVERLAY.format(title=escape(title), subtitle=" &middot; ".join(parts), legend=rows,
                              of_duration=f" of {duration:.1f} s" if duration is not None else "",
                              verdict=escape(verdict or ""),
                              verdict_color=VERDICT_COLORS.get(first_word, "#a05a00"),
                              products=escape(_products_line(products)))
    page_title = escape(f"{name} (seed {seed}) - hrc_drake replay")
    html = html.replace("<title>Drake MeshCat</title>", f"<title>{page_title}</title>", 1)
    at = html.rfind("</body>")
    if at < 0:
        raise ValueError("not a meshcat page: no </body>")
    return html[:at] + overlay + html[at:]
