"""Goal layouts for training and benchmarking the intention estimator (thesis 3.1.3).

All goal positions live here. `box_usb_layout()` reads the goals of diagrams/box_usb.yaml
(the box-with-USB-pen cell of Fig. 3.4, goals 1-5) when that file exists, and otherwise uses
a stand-in: 5 goal spheres on the table in front of the operator, 0.25-0.6 m apart.

The operator stands at `OPERATOR_BASE` facing -x (yaw pi): its left is -y in the world.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[2]
BOX_USB_SCENARIO = REPO_ROOT / "diagrams" / "box_usb.yaml"
OPERATOR_BASE = (1.05, 0.0)
OPERATOR_YAW = np.pi
#: A camera facing the operator from behind the robot, so that the face is usually seen.
CAMERA_POSITION = (-0.1, 0.0, 1.35)
CAMERA_TARGET = (1.05, 0.0, 1.2)


@dataclass(frozen=True)
class GoalLayout:
    """Named goal spheres and which hand usually reaches each (left|right)."""

    name: str
    goal_names: tuple[str, ...]
    centers: np.ndarray  # (G, 3)
    hands: tuple[str, ...]
    radius: float = 0.05

    def __post_init__(self):
        centers = np.asarray(self.centers, dtype=float)
        if centers.shape != (len(self.goal_names), 3) or len(self.hands) != len(self.goal_names):
            raise ValueError(
                f"GoalLayout {self.name!r}: {len(self.goal_names)} names, {len(self.hands)} hands and "
                f"centres of shape {centers.shape} do not match"
            )
        object.__setattr__(self, "centers", centers)


def _operator_frame(forward: float, left: float, height: float) -> list[float]:
    """World point `forward` m ahead of the operator's hips, `left` m to its left, at `height`."""
    c, s = np.cos(OPERATOR_YAW), np.sin(OPERATOR_YAW)
    return [OPERATOR_BASE[0] + c * forward - s * left, OPERATOR_BASE[1] + s * forward + c * left, height]


#: Stand-in for Fig. 3.4: 1 home, 2-3 foam feeders, 4 collaborative station, 5 boxes and pens.
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


def layout_from_scenario(path) -> GoalLayout:
    """Goals of a scenario YAML (layout.goals); the hand is the side of the goal as seen by the operator."""
    import yaml

    path = Path(path)
    data = yaml.safe_load(path.read_text())
    try:
        goals = data["layout"]["goals"]
        names = tuple(str(g["name"]) for g in goals)
        centers = np.array([[float(v) for v in g["center"]] for g in goals])
        radius = float(np.mean([float(g.get("radius", 0.05)) for g in goals]))
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{path}: layout.goals must be a list of {{name, center, radius}}: {err}") from err
    if centers.ndim != 2 or centers.shape[1] != 3 or len(names) == 0:
        raise ValueError(f"{path}: layout.goals centres must be 3 numbers each")
    # left of the operator is -y when it faces -x
    left_offset = -(centers[:, 1] - OPERATOR_BASE[1]) * np.cos(OPERATOR_YAW - np.pi)
    hands = tuple("left" if off >= -0.05 else "right" for off in left_offset)
    return GoalLayout(path.stem, names, centers, hands, radius)


def box_usb_layout() -> GoalLayout:
    """Goals 1-5 of thesis 3.1.3: from diagrams/box_usb.yaml if present, else the stand-in."""
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
