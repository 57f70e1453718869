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
    """A robot action: the arm moves through `poses`, dwelling `dwell` s at each one. Its time is
    that motion (as fast as the path follower and the safety layer let it) plus the dwells: set
    `dwell` to make it longer (a flow action's `duration` is only a timed scheduler's prior)."""

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
class ArmChain:
    """One arm of a robot described by its URDF: the chain from the root link to `tool_frame`.

    joints: the chain's moving joints, base to tool, as a check (empty: read from the URDF);
    gripper_joints: prismatic finger joints (0 closed, `gripper_stroke` m open per finger)."""

    name: str = ""
    tool_frame: str = ""
    joints: list[str] = field(default_factory=list)
    gripper_joints: list[str] = field(default_factory=list)
    gripper_stroke: float = 0.0


@dataclass
class CapsuleSpec:
    """A distance capsule in a link's frame: segment start -> end (m) swept by radius (m)."""

    body: str = ""
    start: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    end: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    radius: float = 0.0


@dataclass
class Robot:
    """A robot in the cell: a shipped `model` (yumi, irb140, cart, ur5e, panda; "" is yumi) or a
    robot of your own from `urdf` (a file relative to the scenario, or `package://<python
    package>/<path>`) with its `chains`.

    mode: kinematic (positions imposed) | dynamic (discrete plant, PD).
    """

    name: str = ""
    model: str = ""
    #: your own robot: its URDF; then `chains` names its arm(s) and `model` stays empty
    urdf: str = ""
    #: the URDF link welded to the world at `base`; "": the URDF's root
    root_link: str = ""
    chains: list[ArmChain] = field(default_factory=list)
    #: distance capsules; empty: fitted to each link's collision geometry (cylinders, capsules,
    #: spheres, boxes), or to the segment between its joint origins with `capsule_radius`
    capsules: list[CapsuleSpec] = field(default_factory=list)
    capsule_radius: float = 0.06
    #: added to the radius of every capsule fitted to a collision shape (m): a shape tighter than
    #: the robot's housings (e.g. cylinders of the links' nominal radii)
    capsule_margin: float = 0.0
    #: links welded to the base (their capsules never move); empty with fitted capsules: the root's
    static_bodies: list[str] = field(default_factory=list)
    #: (kp, kd) per actuated joint of a dynamic plant; a joint not named: from its load (docs)
    pd_gains: dict[str, list[float]] = field(default_factory=dict)
    #: a of the robot's protective stop (m/s^2) for the judge; null: the shipped robots' 5.0.
    #: Above 5.0 the verdict is NON-CONFORMING (a faster stop than assumed is the integrator's claim)
    stopping_deceleration: float | None = None
    base: Pose = field(default_factory=Pose)
    mode: str = "kinematic"
    time_step: float = 0.01
    poses: list[NamedPose] = field(default_factory=list)
    actions: list[RobotAction] = field(default_factory=list)
    arms: list[Arm] = field(default_factory=list)
