"""Goal layouts for training and benchmarking the intention estimator (thesis 3.1.3).

All goal positions live here. `box_usb_layout()` reads diagrams/box_usb.yaml (the
box-with-USB-pen cell of Fig. 3.4: goals 1-5 = home, foam feeders 1 and 2, collaborative
station, feeder of boxes and pens), with its operator base, camera and operator actions; a
stand-in table is used only when that file is missing. `second_layout()` is a cell no shipped
model was trained on.

Operators of the built-in tables stand at `OPERATOR_BASE` facing -x (yaw pi): their left is -y.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[2]
BOX_USB_SCENARIO = REPO_ROOT / "diagrams" / "box_usb.yaml"
OPERATOR_BASE = (1.05, 0.0)
OPERATOR_YAW = np.pi
#: A camera facing the operator from behind the robot, so that the face is usually seen.
CAMERA_POSITION = (-0.1, 0.0, 1.35)
CAMERA_TARGET = (1.05, 0.0, 1.2)
#: the cell's operator puts the wrist this far above a buffer's base (hrc_drake.cell.build)
HAND_ABOVE_BUFFER = np.array([0.0, 0.0, 0.06])


@dataclass(frozen=True)
class LayoutTask:
    """An operator action of a scenario: `hand` (left|right|both) reaches `targets` (n, 3) in order.

    labels (n,): index of the goal of each target (-1: a place that is no goal, e.g. a buffer);
    duration: (mean, std, low) of the whole action's normal duration (s).
    """

    name: str
    targets: np.ndarray
    labels: tuple[int, ...]
    hand: str
    duration: tuple[float, float, float]


@dataclass(frozen=True)
class GoalLayout:
    """Named goal spheres, which hand usually reaches each (left|right), and the cell around them.

    operator_base: (x, y, yaw) of the operator; camera_position / camera_target: the depth
    camera; tasks / pattern: the scenario's operator actions and their cyclic order (empty for
    the built-in tables, whose reaches are single goals in random order).
    """

    name: str
    goal_names: tuple[str, ...]
    centers: np.ndarray  # (G, 3)
    hands: tuple[str, ...]
    radius: float = 0.05
    operator_base: tuple[float, float, float] = (OPERATOR_BASE[0], OPERATOR_BASE[1], OPERATOR_YAW)
    camera_position: tuple[float, float, float] = CAMERA_POSITION
    camera_target: tuple[float, float, float] = CAMERA_TARGET
    tasks: tuple[LayoutTask, ...] = field(default_factory=tuple)
    pattern: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self):
        centers = np.asarray(self.centers, dtype=float)
        if centers.shape != (len(self.goal_names), 3) or len(self.hands) != len(self.goal_names):
            raise ValueError(
                f"GoalLayout {self.name!r}: {len(self.goal_names)} names, {len(self.hands)} hands and "
                f"centres of shape {centers.shape} do not match"
            )
        if not np.all(np.isfinite(centers)):
            raise ValueError(f"GoalLayout {self.name!r}: goal centres contain NaN or inf")
        object.__setattr__(self, "centers", centers)
        known = {t.name for t in self.tasks}
        unknown = [p for p in self.pattern if p not in known]
        if unknown:
            raise ValueError(f"GoalLayout {self.name!r}: pattern names unknown tasks {unknown}")

    def index(self, goal_name: str) -> int:
        """Index of a goal by name (ValueError naming the known goals)."""
        if goal_name not in self.goal_names:
            raise ValueError(f"GoalLayout {self.name!r}: no goal {goal_name!r}; goals: {self.goal_names}")
        return self.goal_names.index(goal_name)


def _operator_frame(forward: float, left: float, height: float) -> list[float]:
    """World point `forward` m ahead of the operator's hips, `left` m to its left, at `height`."""
    c, s = np.cos(OPERATOR_YAW), np.sin(OPERATOR_YAW)
    return [OPERATOR_BASE[0] + c * forward - s * left, OPERATOR_BASE[1] + s * forward + c * left, height]


#: Stand-in for Fig. 3.4 when diagrams/box_usb.yaml is missing.
_BOX_USB_STANDIN = (
    ("G1", _operator_frame(0.30, 0.05, 0.85), "left"),
    ("G2", _operator_frame(0.35, 0.45, 0.85), "left"),
    ("G3", _operator_frame(0.55, 0.30, 0.90), "left"),
    ("G4", _operator_frame(0.55, -0.10, 0.90), "left"),
    ("G5", _operator_frame(0.35, -0.40, 0.85), "right"),
)

#: An unseen second cell: goals on a shelf-like arc, higher and wider than the box cell.
_SECOND = (
    ("S1", _operator_frame(0.40, 0.35, 1.05), "left"),
    ("S2", _operator_frame(0.50, 0.05, 1.10), "left"),
    ("S3", _operator_frame(0.30, -0.10, 0.95), "right"),
    ("S4", _operator_frame(0.45, -0.40, 1.00), "right"),
    ("S5", _operator_frame(0.25, 0.35, 0.90), "left"),
)


def _from_table(name: str, table) -> GoalLayout:
    return GoalLayout(
        name, tuple(t[0] for t in table), np.array([t[1] for t in table]), tuple(t[2] for t in table)
    )


def _vector(node, n: int, where: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in node])
    except (TypeError, ValueError) as err:
        raise ValueError(f"{where}: {n} numbers expected, got {node!r}") from err
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise ValueError(f"{where}: {n} finite numbers expected, got {node!r}")
    return values


def layout_from_scenario(path) -> GoalLayout:
    """Goals, operator base, camera and operator actions of a scenario YAML (read with safe_load).

    The usual hand of a goal is the side of the goal as seen by the operator.
    """
    import yaml

    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"{path}: cannot read the scenario: {err}") from err
    if not isinstance(data, dict) or not isinstance(data.get("layout"), dict):
        raise ValueError(f"{path}: no 'layout' mapping")
    goals = data["layout"].get("goals")
    if not isinstance(goals, list) or not goals:
        raise ValueError(f"{path}: layout.goals must be a non-empty list of {{name, center, radius}}")
    try:
        names = tuple(str(g["name"]) for g in goals)
        radius = float(np.mean([float(g.get("radius", 0.05)) for g in goals]))
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{path}: layout.goals must be a list of {{name, center, radius}}: {err}") from err
    centers = np.array(
        [_vector(g.get("center"), 3, f"{path}: layout.goals[{k}].center") for k, g in enumerate(goals)]
    )

    operator = data.get("operator") or {}
    base = operator.get("base") or {}
    xyz = _vector(base.get("xyz", [OPERATOR_BASE[0], OPERATOR_BASE[1], 0.0]), 3, f"{path}: operator.base.xyz")
    rpy = _vector(base.get("rpy", [0.0, 0.0, OPERATOR_YAW]), 3, f"{path}: operator.base.rpy")
    yaw = float(rpy[2])
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    side = (centers[:, :2] - xyz[:2]) @ left
    hands = tuple("left" if s >= -0.05 else "right" for s in side)

    camera = data["layout"].get("camera") or {}
    where = f"{path}: layout.camera"
    camera_position = tuple(float(v) for v in _vector(camera.get("position", CAMERA_POSITION), 3, where))
    camera_target = tuple(float(v) for v in _vector(camera.get("target", CAMERA_TARGET), 3, where))

    places = {name: (centers[k], k) for k, name in enumerate(names)}
    for k, b in enumerate(data["layout"].get("buffers") or []):
        position = _vector(b.get("position"), 3, f"{path}: layout.buffers[{k}].position")
        places.setdefault(str(b.get("name")), (position + HAND_ABOVE_BUFFER, -1))
    tasks = []
    for k, action in enumerate(operator.get("actions") or []):
        where = f"{path}: operator.actions[{k}]"
        try:
            targets = [places[str(g)] for g in action["goals"]]
            hand = str(action.get("hand", "right"))
            dist = action.get("duration") or {}
            mean = float(dist.get("mean", 1.0))
            duration = (mean, float(dist.get("std", 0.0)), float(dist.get("low", 0.1 * mean)))
        except KeyError as err:
            raise ValueError(f"{where}: unknown goal or missing key {err}") from err
        if hand not in ("left", "right", "both"):
            raise ValueError(f"{where}: hand must be left|right|both, got {hand!r}")
        tasks.append(
            LayoutTask(
                str(action["name"]), np.array([t[0] for t in targets]), tuple(int(t[1]) for t in targets),
                hand, duration,
            )
        )
    pattern = tuple(str(p) for p in operator.get("pattern") or [])
    return GoalLayout(
        path.stem, names, centers, hands, radius, (float(xyz[0]), float(xyz[1]), yaw),
        camera_position, camera_target, tuple(tasks), pattern,
    )


def box_usb_layout() -> GoalLayout:
    """Goals 1-5 of thesis 3.1.3 (goal 1 = g1_home, goal 4 = g4_station) from diagrams/box_usb.yaml."""
    if BOX_USB_SCENARIO.exists():
        return layout_from_scenario(BOX_USB_SCENARIO)
    return _from_table("box_usb_standin", _BOX_USB_STANDIN)


def second_layout() -> GoalLayout:
    """A layout no shipped model was trained on (benchmark of layout independence)."""
    return _from_table("shelf_arc", _SECOND)


def random_layout(rng: np.random.Generator, n_goals: int = 5, min_spacing: float = 0.25) -> GoalLayout:
    """Goals sampled in the operator's reach (forward 0.25-0.6 m, +/-0.5 m sideways, 0.8-1.1 m high)."""
    centers: list[list[float]] = []
    hands = []
    for _ in range(2000):
        forward, left, height = rng.uniform(0.25, 0.6), rng.uniform(-0.5, 0.5), rng.uniform(0.8, 1.1)
        point = np.array(_operator_frame(forward, left, height))
        if all(np.linalg.norm(point - c) >= min_spacing for c in centers):
            centers.append(point.tolist())
            hands.append("left" if left >= 0 else "right")
            if len(centers) == n_goals:
                break
    if len(centers) < n_goals:
        raise ValueError(f"random_layout: cannot place {n_goals} goals {min_spacing} m apart")
    return GoalLayout("random", tuple(f"R{i + 1}" for i in range(n_goals)), np.array(centers), tuple(hands))
