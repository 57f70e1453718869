"""Scenario schema: the typed dataclasses a scenario YAML is read into.

No `from __future__ import annotations` here: pydrake's typed YAML loader reads the annotations
as real types at run time.

Plain dataclasses (no pydrake import) so that algorithm cores, e.g. the flow compiler of
`hrc_drake.scheduling`, can use them. `hrc_drake.cell.scenario` loads and validates them.
"""

from dataclasses import dataclass, field


@dataclass
class Pose:
    """A rigid pose: translation (m) and roll-pitch-yaw (rad), world frame unless stated."""

    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


@dataclass
class Distribution:
    """A duration distribution (s).

    kind: fixed (mean) | normal (mean, std, truncated at `low`) | uniform (low, high) |
    triangular (low, mode, high) | lognormal (mean, std of the duration itself) |
    empirical (samples).
    """

    kind: str = "fixed"
    mean: float = 1.0
    std: float = 0.0
    low: float = 0.0
    high: float = 0.0
    mode: float = 0.0
    samples: list[float] = field(default_factory=list)


@dataclass
class Table:
    center: list[float] = field(default_factory=lambda: [0.45, 0.0, 0.0])
    size: list[float] = field(default_factory=lambda: [0.9, 1.6, 0.04])
    #: height of the top surface above the floor
    height: float = 0.75


@dataclass
class Goal:
    """A goal region G_a (thesis Ch. 2): a named sphere."""

    name: str = ""
    center: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    radius: float = 0.05


@dataclass
class Buffer:
    """A place where parts wait between actions.

    kind: raw (never runs out), intermediate (capacity-limited), product (finished products
    leave the cell; every part put here is one finished product).
    """

    name: str = ""
    kind: str = "intermediate"
    capacity: int = 1
    initial: int = 0
    position: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


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


@dataclass
class Layout:
    table: Table = field(default_factory=Table)
    goals: list[Goal] = field(default_factory=list)
    buffers: list[Buffer] = field(default_factory=list)
    occluders: list[Occluder] = field(default_factory=list)
    camera: Camera = field(default_factory=Camera)
    #: the robot workspace box used by the slow-down rules: center and size
    workspace_center: list[float] = field(default_factory=lambda: [0.45, 0.0, 1.0])
    workspace_size: list[float] = field(default_factory=lambda: [0.5, 0.8, 0.6])


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
class FlowAction:
    """An action of the assembly flow (thesis Table 6.1).

    agent: the operator name or a robot arm's agent name; a list of several agents makes it
    a collaborative action. inputs/outputs: buffer names (one part each). resources: names
    of shared resources held for the action's duration.
    """

    name: str = ""
    agents: list[str] = field(default_factory=list)
    inputs: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    resources: list[str] = field(default_factory=list)
    #: nominal duration for planners; the robot's real one comes from its motion
    duration: Distribution = field(default_factory=Distribution)


@dataclass
class Flow:
    actions: list[FlowAction] = field(default_factory=list)
    #: resource name -> number of units
    resources: dict[str, int] = field(default_factory=dict)


@dataclass
class SystemOptions:
    """Which implementation of a subsystem to use, and its parameters."""

    kind: str = "none"
    params: dict[str, float] = field(default_factory=dict)
    #: optional data file (model weights, training data) relative to the scenario
    model: str = ""
    #: names the system needs, e.g. the goal sequence of the intention feedback (Fig. 3.6)
    names: list[str] = field(default_factory=list)


@dataclass
class Scenario:
    seed: int = 0
    duration: float = 600.0
    description: str = ""
    layout: Layout = field(default_factory=Layout)
    robots: list[Robot] = field(default_factory=list)
    operator: Operator = field(default_factory=Operator)
    flow: Flow = field(default_factory=Flow)
    #: minimum human-robot distance the cell must keep (m), for reports
    safety_distance: float = 0.1
    tracker: SystemOptions = field(default_factory=SystemOptions)
    intention: SystemOptions = field(default_factory=SystemOptions)
    predictor: SystemOptions = field(default_factory=SystemOptions)
    scheduler: SystemOptions = field(default_factory=SystemOptions)
    motion_model: SystemOptions = field(default_factory=SystemOptions)
