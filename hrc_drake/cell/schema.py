"""Scenario schema: the typed dataclasses a scenario YAML is read into.

No `from __future__ import annotations` here: pydrake's typed YAML loader reads the annotations
as real types at run time.

The scenario composes the configs each area owns (`human.config`, `robots.config`,
`scheduling.flow`, and the per-kind configs of the optional systems); `hrc_drake.cell.scenario`
loads and validates it.
"""

from dataclasses import dataclass, field
from typing import Union

from hrc_drake.human.config import Camera, Occluder, Operator
from hrc_drake.intention.config import (
    GmmBayesIntention,
    GoalRegionActionDetector,
    NoActionDetector,
    NoIntention,
    SegmenterActionDetector,
)
from hrc_drake.motion.config import (
    GPMotionModel,
    NoMotionModel,
    NoProactivePlanner,
    ProactivePlanner,
    SeparationSpeedScaling,
    WorstCaseMotionModel,
)
from hrc_drake.perception.config import HoldLastSeenTracker, KalmanTracker, NoTracker, ParticleFilterTracker
from hrc_drake.prediction.config import NoPredictor, PredictorConfig
from hrc_drake.robots.config import Robot
from hrc_drake.safety.config import (
    Hybrid,
    JudgeChanges,
    NoSafety,
    PowerForceLimiting,
    SpeedSeparationMonitoring,
)
from hrc_drake.scheduling.config import NoScheduler, SchedulerConfig
from hrc_drake.scheduling.flow import Buffer, Flow


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
class CollaborativeZone:
    """A collaborative workspace (ISO/TS 15066 3.2) where a `!Hybrid` safety mode lets the robot
    touch hands and arms under power and force limiting: a named sphere, e.g. around a hand-over
    buffer."""

    name: str = ""
    center: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    radius: float = 0.2


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
    #: collaborative zones of a `!Hybrid` safety mode (spheres around the hand-over places)
    collaborative_zones: list[CollaborativeZone] = field(default_factory=list)


@dataclass
class Metrics:
    """The report's warm-up (docs/usage.md "Metrics"; `metrics.DEFINITIONS`).

    The times between products (of a type, or of any) leave out products finished before
    `warmup_time`, and the first `warmup_products` of the rest only start the clock (1: the
    lead time to the first product is not an interval; 0: it is, counted from `warmup_time`).
    A product's own cycle time (its start to its completion) leaves out those finished before
    `warmup_time` only.
    """

    warmup_products: int = 1
    #: s of simulated time whose products are warm-up
    warmup_time: float = 0.0


#: Each optional system's kinds, as scenario field types (one dataclass per kind, owned by its
#: area, chosen in YAML by tag: ``tracker: !ParticleFilterTracker {particles: 500}``).
Tracker = Union[NoTracker, HoldLastSeenTracker, ParticleFilterTracker, KalmanTracker]  # noqa: UP007 (the YAML loader needs it)
Intention = Union[NoIntention, GmmBayesIntention]  # noqa: UP007
ActionDetector = Union[NoActionDetector, GoalRegionActionDetector, SegmenterActionDetector]  # noqa: UP007
MotionModel = Union[NoMotionModel, GPMotionModel, WorstCaseMotionModel]  # noqa: UP007
Proactive = Union[NoProactivePlanner, ProactivePlanner]  # noqa: UP007
Safety = Union[NoSafety, SpeedSeparationMonitoring, PowerForceLimiting, Hybrid]  # noqa: UP007


@dataclass
class Scenario:
    """A cell: its seed, layout, robots, operator, assembly flow and optional systems."""

    #: a scenario file (relative to this one) this one starts from: the fields given here
    #: replace its fields (a mapping merges key by key, a list or a tagged system is replaced;
    #: a mapping given for a list of named items patches the items it names, `scenario.patch_items`);
    #: the file names it holds are read from this file's folder
    extends: str = ""
    #: the one seed of every random choice of a run (same seed, same run)
    seed: int = 0
    #: default simulated time of `hrc-drake simulate` (s)
    duration: float = 600.0
    description: str = ""
    layout: Layout = field(default_factory=Layout)
    #: a robot action takes its motion through its poses plus `actions[j].dwell` at each pose
    robots: list[Robot] = field(default_factory=list)
    #: an operator action takes `actions[i].duration`, the one place of the operator's times
    operator: Operator = field(default_factory=Operator)
    #: what each action needs and makes; its `duration` is a timed scheduler's prior only
    flow: Flow = field(default_factory=Flow)
    #: minimum human-robot distance the cell must keep (m), for reports
    safety_distance: float = 0.1
    #: the warm-up rule of the cycle times
    metrics: Metrics = field(default_factory=Metrics)
    #: the skeleton tracker (thesis Ch. 9); none: the estimate is the measurement
    tracker: Tracker = field(default_factory=NoTracker)
    #: the intended-goal estimator (thesis 3.1)
    intention: Intention = field(default_factory=NoIntention)
    #: the detector of the operator's actions from the skeleton estimate (thesis Ch. 2 goal regions)
    action_detector: ActionDetector = field(default_factory=NoActionDetector)
    #: which human events the predictor and the scheduler read: "perceived" (the action
    #: detector's), "truth" (the simulated operator's own) or "auto" (perceived where the cell
    #: has an action detector, truth otherwise); metrics always use the truth
    human_events: str = "auto"
    #: the activity predictor (thesis Ch. 5)
    predictor: PredictorConfig = field(default_factory=NoPredictor)
    #: the robots' scheduler (thesis Ch. 6-7); none: every arm runs its program in order
    scheduler: SchedulerConfig = field(default_factory=NoScheduler)
    #: the human motion model of the swept volumes (thesis 8.1); none: no speed scaling
    motion_model: MotionModel = field(default_factory=NoMotionModel)
    #: the speed and separation rule applied to the swept volumes (8.1.3), with a motion model
    speed_scaling: SeparationSpeedScaling = field(default_factory=SeparationSpeedScaling)
    #: proactive paths of one robot action around the predicted human motion (thesis 8.2)
    proactive_planner: Proactive = field(default_factory=NoProactivePlanner)
    #: the ISO/TS 15066 safety mode (`safety.config`); none: the verdict says the cell has none
    safety: Safety = field(default_factory=NoSafety)
    #: a changed ISO/TS 15066 judge (`safety.config.JudgeChanges`); unset: the standard's values.
    #: Any change makes the verdict NON-CONFORMING
    judge: JudgeChanges = field(default_factory=JudgeChanges)

    #: Not a field (no annotation: the loaders know only the annotated fields, so a file that
    #: says `source_path:` is refused as an unknown key): the file `load_scenario` read this
    #: scenario from, absolute (not the base it `extends`); None for one made in code.
    #: `build_cell` reads the files it names from that file's folder.
    source_path = None


#: the scenario fields that choose a system by tag
SYSTEM_FIELDS = ("tracker", "intention", "action_detector", "predictor", "scheduler", "motion_model",
                 "proactive_planner", "safety")
