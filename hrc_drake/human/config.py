"""Configs of the human model: anthropometrics, the synthetic operator and its actions,
the depth camera and the occluders that hide points from it.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

from dataclasses import dataclass, field

from hrc_drake.config_common import Pose
from hrc_drake.distributions import Distribution


@dataclass
class Segments:
    """Operator anthropometrics (m)."""

    torso: float = 0.50
    neck: float = 0.25
    shoulder_width: float = 0.40
    upper_arm: float = 0.30
    forearm: float = 0.27


@dataclass
class OperatorAction:
    """A human action: the hand(s) reach the goals in order, taking `duration` in total.

    hand: left | right | both.
    """

    name: str = ""
    goals: list[str] = field(default_factory=list)
    hand: str = "right"
    duration: Distribution = field(default_factory=Distribution)
    #: the goal sphere G_a whose entry by a hand marks this action for an action detector
    #: (thesis Ch. 2); "" means the action's first goal, which must then be a goal sphere
    region: str = ""


@dataclass
class Operator:
    """The simulated operator, or a recorded skeleton file (CSV) to replay."""

    name: str = "human"
    segments: Segments = field(default_factory=Segments)
    base: Pose = field(default_factory=lambda: Pose(xyz=[1.05, 0.0, 0.0], rpy=[0.0, 0.0, 3.14159]))
    pattern: list[str] = field(default_factory=list)
    actions: list[OperatorAction] = field(default_factory=list)
    #: optional CSV of recorded skeleton frames (time + 8x3 points + 8 flags), relative to the scenario
    recorded: str = ""


@dataclass
class Occluder:
    """A box that hides what is behind it from the camera."""

    name: str = ""
    center: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    size: list[float] = field(default_factory=lambda: [0.1, 0.1, 0.1])


@dataclass
class Camera:
    """The depth camera that tracks the skeleton."""

    position: list[float] = field(default_factory=lambda: [1.6, 0.0, 1.6])
    target: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    rate: float = 30.0
    noise_std: float = 0.01
    #: points whose line of sight passes within this distance of an occluder are lost
    margin: float = 0.0
    #: the gaze flag F is invalid when the face turns more than this from the camera (rad)
    gaze_valid_angle: float = 1.2
