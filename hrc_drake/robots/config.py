"""Configs of the robots of a cell: named poses, actions, arms (agents with programs) and
the robot itself.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

from dataclasses import dataclass, field

from hrc_drake.config_common import Pose


@dataclass
class NamedPose:
    """A named robot configuration of one arm (or the whole robot when arm is empty).

    Either `joints` (rad, one per joint of the arm) or `target` (a Cartesian pose of the
    arm's tool frame in the world, solved by inverse kinematics).
    """

    name: str = ""
    arm: str = ""
    joints: list[float] = field(default_factory=list)
    target: Pose | None = None
    #: position tolerance of the IK solution (m)
    tolerance: float = 0.005
    #: whether `target` constrains orientation too (otherwise the tool z axis only points down)
    orient: bool = False
    #: the direction (world, any length) in which the tool moves toward a person at this pose (a
    #: hand-over): of the IK postures that reach `target`, the one of the lowest effective mass
    #: along it (ISO/TS 15066 Annex A: the highest permissible PFL speed); empty: the first found
    approach: list[float] = field(default_factory=list)


@dataclass
class RobotAction:
    """A robot action: the arm moves through `poses`, dwelling `dwell` s at each one."""

    name: str = ""
    arm: str = ""
    poses: list[str] = field(default_factory=list)
    dwell: float = 0.5


@dataclass
class Arm:
    """One arm of a robot: an agent of the cell with its own program."""

    agent: str = ""
    arm: str = ""
    home: str = ""
    program: list[str] = field(default_factory=list)


@dataclass
class Robot:
    """A robot in the cell.

    model: yumi | irb140. mode: kinematic (positions imposed) | dynamic (discrete plant, PD).
    """

    name: str = ""
    model: str = "yumi"
    base: Pose = field(default_factory=Pose)
    mode: str = "kinematic"
    time_step: float = 0.01
    poses: list[NamedPose] = field(default_factory=list)
    actions: list[RobotAction] = field(default_factory=list)
    arms: list[Arm] = field(default_factory=list)
