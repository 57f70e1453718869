"""Reading a URDF's kinematic tree in plain numpy: joints (origins, axes, limits), links (masses,
collision geometry) and poses at q = 0. URDF conventions as Drake's parser: X_P_C(q) =
X_P_J(origin) X_J(q), rpy as R = Rz(yaw) Ry(pitch) Rx(roll).

A URDF may come from a user (`robots[i].urdf`): it is read with a size limit and refused when it
declares entities (an XML bomb's tool); every error names the element at fault."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

#: the largest URDF read (bytes): a robot's description is kilobytes; meshes live in other files
MAX_URDF_BYTES = 5_000_000
#: the most links (and joints) a robot description may have: a robot has tens
MAX_LINKS = 500
#: the largest offset (m) of an origin and the largest dimension (m) of a collision shape
MAX_OFFSET, MAX_SIZE = 100.0, 10.0
#: the largest collision mesh read (bytes)
MAX_MESH_BYTES = 50_000_000


def rpy_matrix(rpy) -> np.ndarray:
    """Rotation matrix (3, 3) of URDF roll-pitch-yaw angles: Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def pose_matrix(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Homogeneous transform (4, 4) of a translation xyz (m) and URDF rpy angles (rad)."""
    X = np.eye(4)
    X[:3, :3] = rpy_matrix(rpy)
    X[:3, 3] = np.asarray(xyz, dtype=float).reshape(3)
    return X


def _floats(
    text: str | None, default: str, where: str, count: int | None = None, limit: float = MAX_OFFSET
) -> np.ndarray:
    try:
        values = np.array([float(v) for v in (text or default).split()], dtype=float)
    except ValueError:
        raise ValueError(f"{where}: not numbers: {text!r}") from None
    if (count is not None and values.size != count) or not np.all(np.isfinite(values)):
        raise ValueError(f"{where}: expected {count or 'finite'} finite numbers, got {text!r}")
    if np.any(np.abs(values) > limit):
        raise ValueError(f"{where}: {text!r} is beyond {limit:g} m, not a robot's dimension")
    return values


def _origin(element, where: str) -> np.ndarray:
    origin = element.find("origin")
    xyz = _floats(origin.get("xyz") if origin is not None else None, "0 0 0", f"{where} origin xyz", 3)
    rpy = _floats(origin.get("rpy") if origin is not None else None, "0 0 0", f"{where} origin rpy", 3)
    return pose_matrix(xyz, rpy)


@dataclass(frozen=True)
class UrdfJoint:
    """One URDF joint: kind 'fixed' / 'revolute' / 'prismatic', X_PJ (4, 4), unit axis (3,), limits."""

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float
    velocity: float = np.inf


@dataclass(frozen=True)
class CollisionShape:
    """A link's collision geometry: kind 'cylinder' | 'capsule' | 'sphere' | 'box' | 'mesh' | other,
    X_LG (4, 4) in the link frame, and its dimensions (radius, length; or box sizes)."""

    kind: str
    pose: np.ndarray
    size: tuple[float, ...]
    #: a mesh's file name as the URDF writes it ("" for a primitive)
    filename: str = ""


@dataclass(frozen=True)
class UrdfLink:
    """One URDF link: its mass (0 without an inertial) and collision shapes."""

    name: str
    mass: float
    collisions: tuple[CollisionShape, ...]


def parse_urdf(text: str) -> ET.Element:
    """The `<robot>` element of a URDF document (ValueError for one too large, with entity
    declarations, not XML or not a robot)."""
    if len(text.encode("utf-8", "surrogatepass")) > MAX_URDF_BYTES:
        raise ValueError(f"larger than {MAX_URDF_BYTES} bytes: not a robot description")
    if "<!ENTITY" in text.upper() or "<!DOCTYPE" in text.upper():
        # entities expand, and a DTD's attribute defaults would make this reader see other values
        # than Drake's parser: a robot description needs neither
        raise ValueError(
            "declares a DOCTYPE or XML entities, which a robot description never needs (refused)"
        )
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise ValueError(f"not valid XML: {err}") from None
    if root.tag != "robot":
        raise ValueError(f"the root element is <{root.tag}>, not <robot>")
    if len(root.findall("link")) > MAX_LINKS or len(root.findall("joint")) > MAX_LINKS:
        raise ValueError(f"more than {MAX_LINKS} links or joints: not a robot description")
    return root


def read_urdf_joints(text: str) -> dict[str, UrdfJoint]:
    """The joints of a URDF document, by child link ('continuous' counts as revolute)."""
    joints = {}
    for element in parse_urdf(text).findall("joint"):
        name = element.get("name") or "?"
        where = f"joint {name!r}"
        kind = element.get("type")
        kind = "revolute" if kind == "continuous" else kind
        if kind not in ("fixed", "revolute", "prismatic"):
            raise ValueError(
                f"URDF {where}: unsupported type {element.get('type')!r} (fixed, revolute, "
                f"continuous, prismatic)"
            )
        parent, child = element.find("parent"), element.find("child")
        if parent is None or child is None or not parent.get("link") or not child.get("link"):
            raise ValueError(f"URDF {where}: needs <parent link=...> and <child link=...>")
        axis, limit = element.find("axis"), element.find("limit")
        a = _floats(axis.get("xyz") if axis is not None else None, "1 0 0", f"URDF {where} axis", 3)
        if kind != "fixed" and not np.linalg.norm(a) > 0:
            raise ValueError(f"URDF {where}: the axis must not be zero")
        limits = [
            float(limit.get(key, default)) if limit is not None else float(default)
            for key, default in (("lower", "-inf"), ("upper", "inf"), ("velocity", "inf"))
        ]
        if element.get("type") == "continuous":
            limits[:2] = [-np.inf, np.inf]
        if child.get("link") in joints:
            raise ValueError(f"URDF {where}: link {child.get('link')!r} is the child of two joints")
        joints[child.get("link")] = UrdfJoint(
            name,
            kind,
            parent.get("link"),
            child.get("link"),
            _origin(element, f"URDF {where}"),
            a / (np.linalg.norm(a) or 1.0),
            *limits,
        )
    return joints


def _shape(geometry, where: str) -> tuple[str, tuple[float, ...], str]:
    """(kind, dimensions, mesh file name) of a <geometry> element; a mesh's dimensions: its scale."""
    for element in geometry:
        tag = element.tag.split("}")[-1]
        if tag in ("cylinder", "capsule"):
            size = _floats(
                f"{element.get('radius', 'nan')} {element.get('length', 'nan')}",
                "",
                f"{where} {tag}",
                2,
                MAX_SIZE,
            )
            return tag, tuple(size), ""
        if tag == "sphere":
            return tag, tuple(_floats(element.get("radius"), "nan", f"{where} sphere", 1, MAX_SIZE)), ""
        if tag == "box":
            return tag, tuple(_floats(element.get("size"), "", f"{where} box size", 3, MAX_SIZE)), ""
        if tag == "mesh":
            scale = _floats(element.get("scale"), "1 1 1", f"{where} mesh scale", 3, MAX_SIZE)
            return tag, tuple(scale), element.get("filename") or ""
        return tag, (), ""
    return "none", (), ""


def read_urdf_links(text: str) -> dict[str, UrdfLink]:
    """The links of a URDF document by name, with their masses and collision shapes."""
    links = {}
    for element in parse_urdf(text).findall("link"):
        name = element.get("name") or "?"
        mass_element = element.find("inertial/mass")
        mass = (
            float(_floats(mass_element.get("value"), "0", f"URDF link {name!r} mass", 1, 1e4)[0])
            if mass_element is not None
            else 0.0
        )
        if mass < 0:
            raise ValueError(f"URDF link {name!r}: a negative mass {mass}")
        shapes = []
        for k, collision in enumerate(element.findall("collision")):
            where = f"URDF link {name!r} collision {k}"
            geometry = collision.find("geometry")
            kind, size, filename = _shape(geometry if geometry is not None else [], where)
            if any(v < 0 for v in size):
                raise ValueError(f"{where}: bad {kind} dimensions {size}")
            shapes.append(CollisionShape(kind, _origin(collision, where), size, filename))
        links[name] = UrdfLink(name, mass, tuple(shapes))
    return links


def root_link(joints: dict[str, UrdfJoint], links) -> str:
    """The URDF's root: the one link that is no joint's child (ValueError naming the candidates)."""
    roots = sorted(set(links) - set(joints))
    if len(roots) != 1:
        raise ValueError(f"the URDF's links form {len(roots)} trees (roots {roots}); name `root_link`")
    return roots[0]


def tree_poses(joints: dict[str, UrdfJoint], root: str) -> dict[str, np.ndarray]:
    """Pose (4, 4) of every link reachable from `root` in the root's frame, all joints at zero."""
    children: dict[str, list[UrdfJoint]] = {}
    for joint in joints.values():
        children.setdefault(joint.parent, []).append(joint)
    poses, stack = {root: np.eye(4)}, [root]
    while stack:
        link = stack.pop()
        for joint in children.get(link, ()):
            if joint.child not in poses:
                poses[joint.child] = poses[link] @ joint.origin
                stack.append(joint.child)
    return poses


def read_urdf_transmissions(text: str) -> set[str]:
    """The joints a URDF drives through a <transmission> (Drake's parser makes them actuators)."""
    return {
        joint.get("name") for joint in parse_urdf(text).findall("transmission/joint") if joint.get("name")
    }


def mesh_vertices(path) -> np.ndarray | None:
    """The vertices (n, 3) of a collision mesh's convex hull (Drake's, of the formats its
    collision geometry reads: OBJ, VTK, glTF); None for a file it cannot read or one over
    `MAX_MESH_BYTES`."""
    from pathlib import Path

    from pydrake.geometry import Convex

    path = Path(path)
    if not path.is_file() or path.stat().st_size > MAX_MESH_BYTES:
        return None
    try:
        hull = Convex(str(path)).GetConvexHull()
    except Exception:  # noqa: BLE001 (Drake raises RuntimeError or ValueError for a file it cannot read)
        return None
    points = np.array([hull.vertex(i) for i in range(hull.num_vertices())], dtype=float).reshape(-1, 3)
    return points if len(points) and np.all(np.isfinite(points)) else None


def file_parser(plant, urdf_path):
    """A Drake `Parser` for a URDF file of the user's: auto-renaming (two robots may share one
    file), and a ROS package around the file (package.xml up to three folders above it) mapped so
    that its meshes' package:// names resolve."""
    from pathlib import Path

    from pydrake.multibody.parsing import Parser

    parser = Parser(plant)
    parser.SetAutoRenaming(True)
    folder = Path(urdf_path).parent
    for candidate in (folder, *folder.parents[:3]):
        if (candidate / "package.xml").is_file():
            parser.package_map().PopulateFromFolder(str(candidate))
            break
    return parser
