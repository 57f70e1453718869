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
from hrc_drake.drake_helpers import declare_state, get_state, input_or, set_state
from hrc_drake.messages import (
    EventLog,
    Immutable,
    SkeletonEstimate,
    SkeletonFrame,
    SweptVolumes,
    WorldSnapshot,
)
from hrc_drake.perception.config import NoTracker

#: a goal flashes this long (s) after the intention estimator understood it (Fig. 3.6)
FLASH_TIME = 0.6


@dataclass(frozen=True)
class FlashState(Immutable):
    """Goals flashing in the replay: goal -> time the flash ends; the last intention seq seen."""

    until: tuple[tuple[str, float], ...] = ()
    last_seq: int = 0


class ReplayMarkers(LeafSystem):
    """Animates parts in buffers, measured and estimated skeleton points, swept volumes,
    intention flashes and a speed lamp as Meshcat objects (recorded with the replay).

    Inputs "world" (WorldSnapshot), "skeleton_frame", "skeleton_estimate", "intention_events",
    "swept_volumes", "speed_override" (1,). State: the flashing goals (updated at `fps`); the
    drawing is a publish event. What Meshcat shows is mirrored on the system only to skip
    redundant messages; the mirror is cleared at initialization, so a new run redraws all.
    """

    def __init__(self, scenario: Scenario, meshcat, fps: float, show_skeleton: bool, show_swept: bool):
        super().__init__()
        self.meshcat = meshcat
        self._visible: dict[str, bool] = {}
        self._buffers = {b.name: b for b in scenario.layout.buffers if b.kind == "intermediate"}
        self._goals = {g.name: g for g in scenario.layout.goals}
        self._show_skeleton = show_skeleton
        #: whether the skeleton (measured and estimated points) is drawn
        self.show_skeleton = show_skeleton
        self._show_swept = show_swept
        self._lamps = (
            {
                "full": Rgba(0.1, 0.9, 0.1, 1.0),
                "slow": Rgba(1.0, 0.7, 0.0, 1.0),
                "stop": Rgba(0.9, 0.1, 0.1, 1.0),
            }
            if scenario.robots
            else {}
        )
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
        self._flash = declare_state(self, lambda context: FlashState())
        self.DeclareInitializationPublishEvent(self._setup)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / fps, 0.0, self._update_flashes)
        self.DeclarePeriodicPublishEvent(1.0 / fps, 0.0, self._publish)

    def _setup(self, context):
        """Create every marker object (hidden where it has nothing to show yet)."""
        meshcat = self.meshcat
        self._visible = {}
        for b in self._buffers.values():
            shown = min(b.capacity, 4)
            for k in range(shown):
                path = f"/markers/parts/{b.name}/{k}"
                meshcat.SetObject(path, MeshcatBox(0.035, 0.035, 0.035), Rgba(0.95, 0.75, 0.1, 1.0))
                offset = np.array([0.0, (k - (shown - 1) / 2) * 0.045, 0.025])
                meshcat.SetTransform(path, RigidTransform(np.asarray(b.position, float) + offset))
                self._hide(path)
        # Skeleton markers cost ~2 kB per replay frame: only where a tracker makes them worth it.
        if self._show_skeleton:
            for name, color in (
                ("measured", Rgba(0.1, 0.4, 1.0, 1.0)),
                ("estimated", Rgba(1.0, 0.2, 0.2, 1.0)),
            ):
                for k in range(8):
                    meshcat.SetObject(f"/markers/skeleton/{name}/{k}", Sphere(0.025), color)
                    self._visible[f"/markers/skeleton/{name}/{k}"] = True
            # The belief's spread around a lost point: a unit sphere scaled to 2 standard deviations.
            for k in range(8):
                path = f"/markers/skeleton/spread/{k}"
                meshcat.SetObject(path, Sphere(1.0), Rgba(1.0, 0.3, 0.3, 0.25))
                self._hide(path)
        for g in self._goals.values():
            path = f"/markers/flash/{g.name}"
            meshcat.SetObject(path, Sphere(g.radius * 1.15), Rgba(1.0, 0.9, 0.1, 0.6))
            meshcat.SetTransform(path, RigidTransform(np.asarray(g.center, float)))
            self._hide(path)
        # Swept volumes (thesis 8.1): a unit cylinder per body part, scaled to each capsule's bounds.
        if self._show_swept:
            for k in range(6):
                path = f"/markers/swept/{k}"
                meshcat.SetObject(path, Cylinder(1.0, 1.0), Rgba(0.6, 0.2, 0.9, 0.18))
                self._hide(path)
        # A lamp above the robot: green at full speed, amber when slowed, red when stopped.
        for name, color in self._lamps.items():
            path = f"/markers/speed_lamp/{name}"
            meshcat.SetObject(path, Sphere(0.04), color)
            meshcat.SetTransform(path, RigidTransform(self._lamp_position))
            meshcat.SetProperty(path, "visible", name == "full")
            self._visible[path] = name == "full"
        return EventStatus.Succeeded()

    def _hide(self, path: str) -> None:
        self.meshcat.SetProperty(path, "visible", False)
        self._visible[path] = False

    def _update_flashes(self, context, state):
        if not self._intention_port.HasValue(context):
            return EventStatus.DidNothing()
        flash = get_state(context, self._flash)
        new = self._intention_port.Eval(context).since(flash.last_seq)
        if not new:
            return EventStatus.DidNothing()
        until = dict(flash.until)
        for event in new:
            until[event.goal] = context.get_time() + FLASH_TIME
        set_state(state, self._flash, FlashState(tuple(sorted(until.items())), new[-1].seq))
        return EventStatus.Succeeded()

    def _set_visible(self, path: str, visible: bool, t: float) -> None:
        if self._visible.get(path) != visible:
            self.meshcat.SetProperty(path, "visible", visible, t)
            self._visible[path] = visible

    def _publish(self, context):
        t = context.get_time()
        parts = input_or(self._world, context, WorldSnapshot()).buffers
        for name, b in self._buffers.items():
            count = parts.get(name, 0)
            for k in range(min(b.capacity, 4)):
                self._set_visible(f"/markers/parts/{name}/{k}", k < count, t)
        if self._show_skeleton:
            self._publish_skeleton(context, t)
        flashing = dict(get_state(context, self._flash).until)
        for goal in self._goals:
            self._set_visible(f"/markers/flash/{goal}", flashing.get(goal, -1.0) > t, t)
        if self._show_swept and self._swept_port.HasValue(context):
            self._publish_swept(self._swept_port.Eval(context), t)
        if self._lamps and self._override_port.HasValue(context):
            level = float(self._override_port.Eval(context)[0])
            state = "full" if level >= 0.99 else ("stop" if level <= 0.01 else "slow")
            for name in self._lamps:
                self._set_visible(f"/markers/speed_lamp/{name}", name == state, t)
        return EventStatus.Succeeded()

    def _publish_skeleton(self, context, t: float) -> None:
        for port, name in ((self._frame_port, "measured"), (self._estimate_port, "estimated")):
            if not port.HasValue(context):
                continue
            value = port.Eval(context)
            for k in range(8):
                path = f"/markers/skeleton/{name}/{k}"
                p = value.points[k]
                shown = bool(np.all(np.isfinite(p))) and (name == "estimated" or bool(value.tracked[k]))
                if shown:
                    self.meshcat.SetTransform(path, RigidTransform(p), t)
                self._set_visible(path, shown, t)
                if name == "estimated":
                    spread_path = f"/markers/skeleton/spread/{k}"
                    lost = shown and not bool(value.tracked[k]) and np.isfinite(value.spread[k])
                    if lost:
                        radius = float(np.clip(2.0 * value.spread[k], 0.03, 0.6))
                        self.meshcat.SetTransform(spread_path, RigidTransform(p), t)
                        self.meshcat.SetProperty(spread_path, "scale", [radius] * 3, t)
                    self._set_visible(spread_path, lost, t)

    def _publish_swept(self, swept, t: float) -> None:
        for k in range(6):
            path = f"/markers/swept/{k}"
            shown = k < len(swept.radius)
            if shown:
                start, end, radius = swept.start[k], swept.end[k], float(swept.radius[k])
                length = float(np.linalg.norm(end - start)) + 2.0 * radius
                self.meshcat.SetTransform(path, segment_pose(start, end), t)
                self.meshcat.SetProperty(path, "scale", [radius, radius, length], t)
            self._set_visible(path, shown, t)


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
