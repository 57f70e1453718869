"""Robot records from data: the shipped robots' descriptions (`models/<name>.yaml`) and a
scenario's own robot (`robots[i].urdf`) become the same `RobotModel`.

A description names the URDF, the root link, each arm as the chain from the root to its tool
frame, and optionally capsules, static bodies, PD gains and the stopping deceleration. Whatever it
leaves out is read from the URDF: the chain's joints, capsules fitted to each link's collision
geometry (or to the segment between its joint origins), the static bodies, PD gains from each
joint's load. Errors are `DescriptionError(field, reason)`, the field relative to the description.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

import numpy as np
import yaml

from hrc_drake.robots.records import MODELS_PACKAGE, ArmModel, Capsule, RobotModel
from hrc_drake.robots.urdf import (
    UrdfJoint,
    UrdfLink,
    file_parser,
    mesh_vertices,
    read_urdf_joints,
    read_urdf_links,
    root_link,
    tree_poses,
)
from hrc_drake.untrusted import one_line

#: a of the protective stop (m/s^2) the shipped robots assume (ABB publishes none; docs/safety.md);
#: a robot of the scenario's own that states none is judged with it
DEFAULT_STOPPING_DECELERATION = 5.0
#: the largest stopping deceleration a description may state (m/s^2): beyond any arm's brakes
MAX_STOPPING_DECELERATION = 50.0
#: the smallest (m/s^2): slower, a robot hardly brakes, and the judge's stop check would pass it
MIN_STOPPING_DECELERATION = 1.0
#: the smallest radius of a capsule fitted to a link without collision geometry (m)
MIN_CAPSULE_RADIUS = 0.03
#: the static sag (rad, or m for a sliding joint) the default PD gains allow under the joint's load
DEFAULT_SAG = 0.005
GRAVITY = 9.81


class DescriptionError(ValueError):
    """A robot description at fault: `field` (relative to the description) and `reason`."""

    def __init__(self, field: str, reason: str):
        # names in a reason come from an untrusted URDF or scenario: no control character reaches a terminal
        reason = one_line(reason)
        super().__init__(f"{field}: {reason}")
        self.field, self.reason = field, reason


@dataclass
class Description:
    """The fields of a robot description (a shipped `models/<name>.yaml` or a scenario robot)."""

    name: str
    urdf: str
    root_link: str = ""
    chains: list = field(default_factory=list)
    capsules: list = field(default_factory=list)
    capsule_radius: float = 0.06
    capsule_margin: float = 0.0
    static_bodies: list = field(default_factory=list)
    pd_gains: dict = field(default_factory=dict)
    stopping_deceleration: float | None = None


def _get(item, key, default=None):
    return item.get(key, default) if isinstance(item, Mapping) else getattr(item, key, default)


def _chain_joints(joints: Mapping[str, UrdfJoint], root: str, tool: str, where: str) -> list[UrdfJoint]:
    """The joints from `root` to `tool`, root first."""
    chain, link = [], tool
    while link != root:
        if link not in joints:
            raise DescriptionError(where, f"link {link!r} is not connected to the root link {root!r}")
        chain.append(joints[link])
        link = joints[link].parent
        if len(chain) > len(joints):
            raise DescriptionError(where, "the URDF's joints form a loop")
    return chain[::-1]


def _arm(chain_spec, k: int, joints, links, root: str) -> ArmModel:
    """One `ArmModel` from `chains[k]`: its moving joints read from the URDF and checked."""
    where = f"chains[{k}]"
    name, tool = str(_get(chain_spec, "name", "") or ""), str(_get(chain_spec, "tool_frame", "") or "")
    if not name:
        raise DescriptionError(f"{where}.name", "a name is required (poses and arms name it)")
    if tool not in links:
        raise DescriptionError(
            f"{where}.tool_frame", f"no link {tool!r} in the URDF (links: {sorted(links)})"
        )
    moving = [j for j in _chain_joints(joints, root, tool, f"{where}.tool_frame") if j.kind != "fixed"]
    if not moving:
        raise DescriptionError(f"{where}.tool_frame", f"no moving joint between {root!r} and {tool!r}")
    names = tuple(j.name for j in moving)
    stated = tuple(_get(chain_spec, "joints", ()) or ())
    if stated and stated != names:
        raise DescriptionError(
            f"{where}.joints", f"the URDF's chain to {tool!r} is {list(names)}, not {list(stated)}"
        )
    for j in moving:
        if not (np.isfinite(j.lower) and np.isfinite(j.upper) and j.lower < j.upper):
            raise DescriptionError(
                f"{where}.tool_frame",
                f"joint {j.name!r} needs finite position limits "
                f"(lower < upper; a continuous joint has none), got [{j.lower}, {j.upper}]",
            )
        if not (np.isfinite(j.velocity) and j.velocity > 0):
            raise DescriptionError(
                f"{where}.tool_frame",
                f"joint {j.name!r} needs a velocity limit > 0 (<limit velocity=...>), got {j.velocity}",
            )
    by_name = {j.name: j for j in joints.values()}
    grippers = tuple(_get(chain_spec, "gripper_joints", ()) or ())
    for g in grippers:
        if g not in by_name or by_name[g].kind != "prismatic" or g in names:
            raise DescriptionError(
                f"{where}.gripper_joints", f"{g!r} is not a prismatic joint of the URDF off the arm's chain"
            )
    stroke = float(_get(chain_spec, "gripper_stroke", 0.0) or 0.0)
    if grippers and not 0 < stroke <= 0.2:
        raise DescriptionError(
            f"{where}.gripper_stroke", f"must be in (0, 0.2] m with gripper joints, got {stroke}"
        )
    return ArmModel(name, names, tool, grippers, stroke if grippers else 0.0)


def _capsule_around(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """A capsule holding `points` (n, 3): along their principal axis, from the least to the largest
    projection, its radius their largest distance from the axis."""
    centre = points.mean(axis=0)
    _, vectors = np.linalg.eigh(np.cov((points - centre).T) + 1e-12 * np.eye(3))
    axis = vectors[:, -1]
    t = (points - centre) @ axis
    radial = np.linalg.norm(points - centre - np.outer(t, axis), axis=1)
    return centre + t.min() * axis, centre + t.max() * axis, float(radial.max())


def _mesh_points(shape, urdf_folder: Path | None) -> np.ndarray | None:
    """The vertices (n, 3) of a collision mesh's convex hull in the link frame (scaled and posed),
    None when its file cannot be found or read."""
    if shape.kind != "mesh" or urdf_folder is None or not shape.filename:
        return None
    name = shape.filename
    if name.startswith("package://"):
        package, _, rest = name[len("package://") :].partition("/")
        # the folder of that name among the URDF's (a ROS package holding the file)
        folders = [f for f in (urdf_folder, *urdf_folder.parents) if f.name == package]
        if not folders or ".." in rest.split("/"):
            return None
        path = folders[0] / rest
    elif name.startswith("file://"):
        path = Path(name[len("file://") :])
    else:
        path = urdf_folder / name
    vertices = mesh_vertices(path)
    if vertices is None:
        return None
    return (vertices * np.asarray(shape.size)) @ shape.pose[:3, :3].T + shape.pose[:3, 3]


def _shape_capsules(link: UrdfLink, urdf_folder: Path | None = None):
    """(capsules (start, end, radius) in the link frame that contain its collision shapes, the
    shapes it could not read): cylinders and capsules along their axes, spheres as points, boxes
    along their longest side, meshes around their convex hull's vertices."""
    out, unread = [], []
    for k, shape in enumerate(link.collisions):
        R, p = shape.pose[:3, :3], shape.pose[:3, 3]
        if shape.kind in ("cylinder", "capsule"):
            radius, length = shape.size
            half = R[:, 2] * length / 2
            out.append((p - half, p + half, radius))
        elif shape.kind == "sphere":
            out.append((p.copy(), p.copy(), shape.size[0]))
        elif shape.kind == "box":
            half = np.asarray(shape.size) / 2
            axis = int(np.argmax(half))
            others = np.delete(half, axis)
            out.append((p - R[:, axis] * half[axis], p + R[:, axis] * half[axis], float(np.hypot(*others))))
        else:
            points = _mesh_points(shape, urdf_folder)
            if points is None:
                unread.append(
                    f"{shape.kind} {k}" + (f" ({one_line(shape.filename)})" if shape.filename else "")
                )
            else:
                out.append(_capsule_around(points))
    return out, unread


#: a link lighter than this (kg) with no collision shape is a frame (tool0, a flange): no capsule
FRAME_MASS = 0.01


def _child_offsets(joints, name: str) -> list[np.ndarray]:
    """The origins (3,) of the joints whose parent is link `name`, those away from its origin."""
    return [
        j.origin[:3, 3]
        for j in joints.values()
        if j.parent == name and np.linalg.norm(j.origin[:3, 3]) > 1e-6
    ]


def _fitted_capsules(
    joints, links, root: str, radius: float, margin: float = 0.0, urdf_folder: Path | None = None
) -> tuple[list[Capsule], list[str]]:
    """(capsules, claims): every link's collision shapes held by capsules `margin` wider; a link
    without one it can read gets the segments from its origin to its child joints' origins, of
    `radius`, named as a claim when it carries mass (the judge cannot check that size)."""
    capsules, claims = [], []
    for name in sorted(tree_poses(joints, root)):
        fitted, unread = _shape_capsules(links[name], urdf_folder)
        fitted = [(a, b, r + margin) for a, b, r in fitted]
        if unread or not fitted:
            segments = [(np.zeros(3), np.asarray(end, float), radius) for end in _child_offsets(joints, name)]
            if not segments and links[name].mass > FRAME_MASS and not fitted:
                segments = [(np.zeros(3), np.zeros(3), radius)]
            fitted += segments
            if unread:
                claims.append(
                    f"link {name!r}: collision {', '.join(unread)} unread (Drake reads OBJ, VTK and glTF), "
                    f"held by {radius:g} m segments of its joints"
                )
            elif links[name].mass > FRAME_MASS:
                claims.append(
                    f"link {name!r} of {links[name].mass:g} kg has no collision geometry: its "
                    f"capsules are {radius:g} m segments of its joints"
                )
        capsules += [
            Capsule(name, tuple(map(float, a)), tuple(map(float, b)), float(r)) for a, b, r in fitted
        ]
    return capsules, claims


def _given_capsules(specs, links) -> list[Capsule]:
    out = []
    for k, spec in enumerate(specs):
        where = f"capsules[{k}]"
        body = str(_get(spec, "body", "") or "")
        if body not in links:
            raise DescriptionError(f"{where}.body", f"no link {body!r} in the URDF")
        ends = []
        for key in ("start", "end"):
            value = np.asarray(_get(spec, key, (0.0, 0.0, 0.0)), dtype=float).reshape(-1)
            if value.shape != (3,) or not np.all(np.isfinite(value)) or np.max(np.abs(value)) > 5:
                raise DescriptionError(
                    f"{where}.{key}", f"must be 3 finite numbers within 5 m, got {value.tolist()}"
                )
            ends.append(tuple(map(float, value)))
        radius = float(_get(spec, "radius", 0.0))
        if not 0 < radius <= 1.0:
            raise DescriptionError(f"{where}.radius", f"must be in (0, 1] m, got {radius}")
        out.append(Capsule(body, ends[0], ends[1], radius))
    return out


#: how far a collision shape's sampled surface may lie outside the given capsules (m)
CONTAINMENT_TOLERANCE = 0.001


def _surface_points(shape, urdf_folder: Path | None = None) -> np.ndarray | None:
    """Points (n, 3) in the link frame on a collision shape's boundary whose convex hull is (or
    nearly is) the shape: a box's corners, a cylinder's two rims, a sphere's or a capsule's caps
    sampled at 16 x 8 directions, a mesh's convex hull's vertices; None for a shape not read."""
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    if shape.kind == "box":
        local = (
            np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
            * np.asarray(shape.size)
            / 2
        )
    elif shape.kind == "cylinder":
        r, length = shape.size
        rim = np.c_[r * np.cos(angles), r * np.sin(angles)]
        local = np.vstack([np.c_[rim, np.full(16, z)] for z in (-length / 2, length / 2)])
    elif shape.kind in ("sphere", "capsule"):
        r, half = shape.size[0], (shape.size[1] / 2 if shape.kind == "capsule" else 0.0)
        polar = np.linspace(0.0, np.pi, 9)
        unit = np.array(
            [[np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)] for t in polar for a in angles]
        )
        local = np.vstack([r * unit + [0.0, 0.0, z] for z in {-half, half}])
    else:
        return _mesh_points(shape, urdf_folder)  # None: unread
    return local @ shape.pose[:3, :3].T + shape.pose[:3, 3]


def _outside(points: np.ndarray, capsules: Sequence[Capsule]) -> np.ndarray:
    """How far (m) each point lies outside the union of `capsules` (inf with none)."""
    outside = np.full(len(points), np.inf)
    for c in capsules:
        a, b = np.asarray(c.start), np.asarray(c.end)
        t = np.clip((points - a) @ (b - a) / max(float((b - a) @ (b - a)), 1e-12), 0.0, 1.0)
        outside = np.minimum(outside, np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1) - c.radius)
    return outside


def _check_containment(
    capsules: Sequence[Capsule], links, joints, root: str, urdf_folder: Path | None
) -> list[str]:
    """Capsules given for a robot of the scenario's own must hold its URDF's collision shapes and
    the segments between each moving link's joints: the judge measures the robot by them, and a
    scenario must not make its robot thinner. The claims: shapes it could not read."""
    claims = []
    static = _static_links(joints, root)
    for name in tree_poses(joints, root):
        link = links[name]
        mine = [c for c in capsules if c.body == name]
        if name not in static:
            ends = _child_offsets(joints, name)
            # the skeleton: from the link's origin to each child joint (held by it or the child's)
            for child in (j for j in joints.values() if j.parent == name):
                toward = child.origin[:3, 3]
                if np.linalg.norm(toward) <= 1e-6:
                    continue
                points = np.linspace(0.0, 1.0, 6)[:, None] * toward
                theirs = [
                    Capsule(
                        c.body,
                        tuple(child.origin[:3, :3] @ c.start + toward),
                        tuple(child.origin[:3, :3] @ c.end + toward),
                        c.radius,
                    )
                    for c in capsules
                    if c.body == child.child
                ]
                if np.max(_outside(points, [*mine, *theirs])) > CONTAINMENT_TOLERANCE:
                    raise DescriptionError(
                        "capsules",
                        f"link {name!r}: its segment to joint {child.name!r} is not "
                        "inside its capsules (or its child's): every moving link needs a capsule",
                    )
            if not ends and not mine and link.mass > FRAME_MASS and not link.collisions:
                raise DescriptionError(
                    "capsules", f"link {name!r} ({link.mass:g} kg) moves and has no capsule"
                )
        for k, shape in enumerate(link.collisions):
            points = _surface_points(shape, urdf_folder)
            if points is None:
                claims.append(
                    f"link {name!r}: given capsules not checked against its collision {shape.kind} {k} "
                    "(Drake reads OBJ, VTK and glTF)"
                )
                continue
            worst = float(np.max(_outside(points, mine)))
            if worst > CONTAINMENT_TOLERANCE:
                held = (
                    "no capsule is given for it"
                    if not mine
                    else f"its surface reaches {worst:.3f} m outside them"
                )
                raise DescriptionError(
                    "capsules",
                    f"link {name!r}: collision {shape.kind} {k} of the URDF is not inside the given "
                    f"capsules ({held}); the judge measures the robot by its capsules: widen them, or leave "
                    "`capsules:` out to fit them to the collision shapes",
                )
    return claims


def _static_links(joints, root: str) -> frozenset[str]:
    """The links no moving joint moves (welded to the root)."""
    static = set()
    for name in tree_poses(joints, root):
        link = name
        while link != root and joints[link].kind == "fixed":
            link = joints[link].parent
        if link == root:
            static.add(name)
    return frozenset(static)


def default_gains(joints: Mapping[str, UrdfJoint], links: Mapping[str, UrdfLink], root: str) -> dict:
    """(kp, kd) of every moving joint from its load: kp holds the gravity load of the links it
    carries (mass M at lever L) within `DEFAULT_SAG`, kd damps M L^2 critically."""
    poses = tree_poses(joints, root)
    children: dict[str, list[str]] = {}
    for joint in joints.values():
        children.setdefault(joint.parent, []).append(joint.child)
    gains = {}
    for joint in joints.values():
        if joint.kind == "fixed" or joint.child not in poses:
            continue
        carried, stack = [], [joint.child]
        while stack:
            link = stack.pop()
            carried.append(link)
            stack += children.get(link, [])
        mass = sum(links[name].mass for name in carried if name in links)
        at = poses[joint.parent][:3, :3] @ joint.origin[:3, 3] + poses[joint.parent][:3, 3]
        lever = max(float(np.linalg.norm(poses[name][:3, 3] - at)) for name in carried)
        if joint.kind == "prismatic":
            kp = max(50.0, GRAVITY * mass / (DEFAULT_SAG / 5))
            kd = 2 * math.sqrt(kp * max(mass, 1e-3))
        else:
            kp = max(50.0, GRAVITY * mass * lever / DEFAULT_SAG)
            kd = 2 * math.sqrt(kp * max(mass * lever**2, 1e-3))
        gains[joint.name] = (round(kp, 1), round(kd, 2))
    return gains


def _gains(given: Mapping, joints, links, root: str) -> dict:
    gains = default_gains(joints, links, root)
    for joint, value in (given or {}).items():
        if joint not in gains:
            raise DescriptionError(f"pd_gains.{joint}", f"not a moving joint of the URDF ({sorted(gains)})")
        pair = np.asarray(value, dtype=float).reshape(-1)
        if pair.shape != (2,) or not np.all(np.isfinite(pair)) or np.any(pair < 0):
            raise DescriptionError(
                f"pd_gains.{joint}", f"must be [kp, kd], two finite numbers >= 0, got {value!r}"
            )
        gains[joint] = (float(pair[0]), float(pair[1]))
    return gains


def _check_disjoint(arms: Sequence[ArmModel]) -> None:
    """No joint belongs to two arms: each arm's path is its own (a shared waist would be moved by
    two paths at once)."""
    owner: dict[str, str] = {}
    for k, arm in enumerate(arms):
        for joint in (*arm.joints, *arm.gripper_joints):
            if joint in owner:
                raise DescriptionError(
                    f"chains[{k}]",
                    f"joint {joint!r} is also one of arm {owner[joint]!r}: "
                    "arms may not share joints (describe a shared waist as an arm of its own)",
                )
            owner[joint] = arm.name


def _check_carried_mass(joints, links, root: str) -> None:
    """Every moving joint carries some mass (a massless subtree makes the mass matrix singular)."""
    children: dict[str, list[str]] = {}
    for joint in joints.values():
        children.setdefault(joint.parent, []).append(joint.child)
    reachable = tree_poses(joints, root)
    for joint in joints.values():
        if joint.kind == "fixed" or joint.child not in reachable:
            continue
        stack, mass = [joint.child], 0.0
        while stack:
            link = stack.pop()
            mass += links[link].mass if link in links else 0.0
            stack += children.get(link, [])
        if not mass > 0:
            raise DescriptionError(
                "urdf", f"joint {joint.name!r} moves no mass (give its links <inertial> masses)"
            )


#: the density (kg/m^3) below which a robot's moving links are lighter than their capsules allow:
#: under a third of the UR5e's (347) and the Panda's (334 kg/m^3 of their capsules, 0.03 m margin)
MIN_LINK_DENSITY = 100.0


def _mass_claims(capsules: Sequence[Capsule], links, static_links) -> list[str]:
    """The judge's effective mass comes from the URDF's masses: moving links lighter than
    `MIN_LINK_DENSITY` of their capsules' volume are the scenario's claim, named."""
    moving = [c for c in capsules if c.body not in static_links]
    volume = sum(
        math.pi * c.radius**2 * math.dist(c.start, c.end) + 4 / 3 * math.pi * c.radius**3 for c in moving
    )
    mass = sum(links[name].mass for name in {c.body for c in moving})
    if mass < MIN_LINK_DENSITY * volume:
        return [
            f"its moving links weigh {mass:.2f} kg, less than {MIN_LINK_DENSITY:g} kg/m^3 of their capsules "
            f"({MIN_LINK_DENSITY * volume:.2f} kg): the effective mass the judge takes from them is a claim"
        ]
    return []


def build_record(
    description: Description, urdf_text: str, urdf_path: str = "", described_by: str = ""
) -> RobotModel:
    """The `RobotModel` of `description`, its URDF `urdf_text` (DescriptionError naming the field)."""
    try:
        joints, links = read_urdf_joints(urdf_text), read_urdf_links(urdf_text)
    except ValueError as err:
        raise DescriptionError("urdf", str(err)) from None
    if not links:
        raise DescriptionError("urdf", "the URDF has no links")
    try:
        root = description.root_link or root_link(joints, links)
    except ValueError as err:
        raise DescriptionError("root_link", str(err)) from None
    if root not in links:
        raise DescriptionError("root_link", f"no link {root!r} in the URDF")
    if root in joints:
        raise DescriptionError(
            "root_link",
            f"{root!r} is the child of joint {joints[root].name!r}: the root "
            "welded to the world must be no joint's child",
        )
    if not description.chains:
        raise DescriptionError("chains", "name at least one arm: its tool frame (a URDF link)")
    arms = tuple(_arm(spec, k, joints, links, root) for k, spec in enumerate(description.chains))
    _check_disjoint(arms)
    _check_carried_mass(joints, links, root)
    radius = float(description.capsule_radius)
    if not MIN_CAPSULE_RADIUS <= radius <= 0.5:
        raise DescriptionError("capsule_radius", f"must be in [{MIN_CAPSULE_RADIUS:g}, 0.5] m, got {radius}")
    margin = float(description.capsule_margin)
    if not 0 <= margin <= 0.2:
        raise DescriptionError("capsule_margin", f"must be in [0, 0.2] m, got {margin}")
    folder = Path(urdf_path).parent if urdf_path else None
    static_links = _static_links(joints, root)
    if description.capsules:
        capsules = _given_capsules(description.capsules, links)
        claims = _check_containment(capsules, links, joints, root, folder) if urdf_path else []
        static = frozenset(description.static_bodies)
    else:
        capsules, claims = _fitted_capsules(joints, links, root, radius, margin, folder)
        static = frozenset(description.static_bodies) or (static_links & {c.body for c in capsules})
    unknown = sorted(static - set(links))
    if unknown:
        raise DescriptionError("static_bodies", f"no links {unknown} in the URDF")
    moving = sorted(static - static_links)
    if moving:
        raise DescriptionError("static_bodies", f"{moving} are moved by a joint: a static body never moves")
    if urdf_path:
        claims += _mass_claims(capsules, links, static_links)
    decel = description.stopping_deceleration
    decel = DEFAULT_STOPPING_DECELERATION if decel is None else float(decel)
    if not (math.isfinite(decel) and MIN_STOPPING_DECELERATION <= decel <= MAX_STOPPING_DECELERATION):
        raise DescriptionError(
            "stopping_deceleration",
            f"must be in [{MIN_STOPPING_DECELERATION:g}, {MAX_STOPPING_DECELERATION:g}] m/s^2, got "
            f"{description.stopping_deceleration!r}",
        )
    gains = _gains(description.pd_gains, joints, links, root)
    try:
        return RobotModel(
            name=description.name,
            urdf=description.urdf,
            root_link=root,
            arms=arms,
            pd_gains=gains,
            capsules=tuple(capsules),
            static_bodies=static,
            stopping_deceleration=decel,
            urdf_path=urdf_path,
            described_by=described_by,
            claims=tuple(claims),
        )
    except ValueError as err:  # the record's own checks: its capsules' bounds, its arms
        raise DescriptionError("capsules" if "capsule" in str(err) else "chains", str(err)) from None


#: the keys of a shipped description file
_FILE_KEYS = {
    "capsule_margin",
    "name",
    "urdf",
    "root_link",
    "chains",
    "capsules",
    "capsule_radius",
    "static_bodies",
    "pd_gains",
    "stopping_deceleration",
}


def read_description_file(text: str, where: str) -> Description:
    """A `Description` from the YAML text of a `models/<name>.yaml` (ValueError naming `where`)."""
    data = yaml.safe_load(text)
    if not isinstance(data, dict):
        raise ValueError(f"{where}: a robot description is a mapping")
    unknown = sorted(set(data) - _FILE_KEYS)
    if unknown:
        raise ValueError(f"{where}: unknown keys {unknown} (known: {sorted(_FILE_KEYS)})")
    if not data.get("name") or not data.get("urdf"):
        raise ValueError(f"{where}: `name` and `urdf` are required")
    return Description(**data)


def shipped_models() -> dict[str, RobotModel]:
    """Every robot of the package: the records of `models/*.yaml`, by name."""
    out = {}
    for resource in sorted(files(MODELS_PACKAGE).iterdir(), key=lambda r: r.name):
        if not resource.name.endswith(".yaml"):
            continue
        where = f"{MODELS_PACKAGE}/{resource.name}"
        description = read_description_file(resource.read_text(encoding="utf-8"), where)
        text = (files(MODELS_PACKAGE) / description.urdf).read_text(encoding="utf-8")
        try:
            out[description.name] = build_record(description, text, described_by=where)
        except DescriptionError as err:
            raise ValueError(f"{where}: {err}") from None
    return out


@functools.cache
def shipped_robot_models() -> dict[str, RobotModel]:
    """Every shipped robot model a scenario may name, by name (read once from models/*.yaml)."""
    return shipped_models()


def get_robot_model(name: str | RobotModel) -> RobotModel:
    """The record of shipped robot model `name` (ValueError listing the known models); a record as is."""
    if isinstance(name, RobotModel):
        return name
    try:
        return shipped_robot_models()[name]
    except (KeyError, TypeError):
        known = ", ".join(sorted(shipped_robot_models()))
        raise ValueError(f"unknown robot model {name!r}; known models: {known}") from None


def urdf_location(spec: str, scenario_file=None) -> Path:
    """The file of `robots[i].urdf`: `package://<python package>/<path>` or a path relative to
    the scenario's folder (the working folder for a scenario made in code). A package is found
    without importing it (no code of it runs); its path may not climb out of it."""
    if not spec.isprintable():
        # Drake's parser names the file in its own warnings, which reach the terminal unescaped
        raise DescriptionError("urdf", f"{spec!r}: the file name holds a control character; rename the file")
    if spec.startswith("package://"):
        package, _, rest = spec[len("package://") :].partition("/")
        parts = rest.split("/")
        if not package or not rest or ".." in parts:
            raise DescriptionError("urdf", f"{spec!r}: write package://<python package>/<path> (no '..')")
        return _package_folder(spec, package).joinpath(*parts)
    if not spec.lower().endswith(".urdf"):
        raise DescriptionError("urdf", f"{spec!r}: a robot description is a .urdf file")
    base = Path(scenario_file).parent if scenario_file and str(scenario_file) != "<scenario>" else Path.cwd()
    return Path(os.path.abspath(base / spec))


def _package_folder(spec: str, package: str) -> Path:
    """The folder of an importable package: a top-level one found by `find_spec` (which runs none
    of its code), a subpackage only of a package already imported."""
    import importlib.util
    import sys

    top = package.split(".")[0]
    if "." in package and top not in sys.modules:
        raise DescriptionError(
            "urdf",
            f"{spec!r}: a subpackage of {top!r}, which is not imported (name a top-level "
            "package or a file relative to the scenario)",
        )
    try:
        found = importlib.util.find_spec(package)
    except (ImportError, ValueError) as err:
        raise DescriptionError("urdf", f"{spec!r}: no Python package {package!r} ({err})") from None
    if found is None or not found.submodule_search_locations:
        raise DescriptionError("urdf", f"{spec!r}: no Python package {package!r}")
    return Path(next(iter(found.submodule_search_locations)))


#: the fields of `robots[i]` that describe a robot of one's own (refused beside a shipped `model`)
OWN_ROBOT_FIELDS = (
    "root_link",
    "chains",
    "capsules",
    "capsule_radius",
    "capsule_margin",
    "static_bodies",
    "pd_gains",
    "stopping_deceleration",
)


def _check_shipped_model_alone(robot) -> None:
    """A shipped `model` takes its description from the package: the fields of a robot of one's
    own would be ignored, so they are refused."""
    from hrc_drake.robots.config import Robot

    default = Robot()
    given = [name for name in OWN_ROBOT_FIELDS if getattr(robot, name) != getattr(default, name)]
    if given:
        raise DescriptionError(
            given[0],
            f"describes a robot of one's own, but model {robot.model or 'yumi'!r} is "
            "shipped and takes its description from the package: remove it, or give `urdf:`",
        )


def _drake_check(path: Path) -> None:
    """Drake's parser reads the file as the cell will (meshes included): its refusal named here."""
    from pydrake.geometry import SceneGraph
    from pydrake.multibody.plant import MultibodyPlant

    plant, scene_graph = MultibodyPlant(0.0), SceneGraph()
    plant.RegisterAsSourceForSceneGraph(scene_graph)
    try:
        file_parser(plant, path).AddModels(str(path))
    except Exception as err:  # noqa: BLE001 (Drake raises RuntimeError or ValueError: all name the file)
        raise DescriptionError("urdf", f"Drake cannot read it: {str(err)[:500]}") from None


_CACHE: dict[tuple, RobotModel] = {}


def robot_record(robot, scenario_file=None) -> RobotModel:
    """The record of a scenario's `Robot`: the shipped `model` ("" is yumi), or its own `urdf`
    (DescriptionError naming the field of `robots[i]`; ValueError for an unknown model)."""
    if not robot.urdf:
        _check_shipped_model_alone(robot)
        return get_robot_model(robot.model or "yumi")
    if robot.model:
        raise DescriptionError(
            "model", f"give a shipped model or a urdf, not both (model {robot.model!r}, urdf {robot.urdf!r})"
        )
    path = urdf_location(robot.urdf, scenario_file)
    if not path.is_file():
        raise DescriptionError("urdf", f"no such file: {path}")
    stat = path.stat()
    description = Description(
        name=robot.name,
        urdf=robot.urdf,
        root_link=robot.root_link,
        chains=list(robot.chains),
        capsules=list(robot.capsules),
        capsule_radius=robot.capsule_radius,
        capsule_margin=robot.capsule_margin,
        static_bodies=list(robot.static_bodies),
        pd_gains=dict(robot.pd_gains),
        stopping_deceleration=robot.stopping_deceleration,
    )
    key = (str(path), stat.st_mtime_ns, stat.st_size, repr(description))
    if key not in _CACHE:
        if stat.st_size > 5_000_000:
            raise DescriptionError("urdf", f"{path} is larger than 5 MB: not a robot description")
        try:
            text = path.read_text(encoding="utf-8", errors="strict")
        except UnicodeDecodeError as err:
            raise DescriptionError(
                "urdf", f"{path} is not UTF-8 text ({err.reason} at byte {err.start})"
            ) from None
        _drake_check(path)
        _CACHE[key] = build_record(
            description, text, urdf_path=str(path), described_by=str(scenario_file or "")
        )
    return _CACHE[key]
