"""Scenario schema: the typed dataclasses a scenario YAML is read into.

No `from __future__ import annotations` here: pydrake's typed YAML loader reads the annotations
as real types at run time.

The scenario composes the configs each area owns (`human.config`, `robots.config`,
`scheduling.flow`, and the per-kind configs of the optional systems); `hrc_drake.cell.scenario`
loads and validates it.
"""

from dataclasses import dataclass, field

from hrc_drake.human.config import Camera, Occluder, Operator
from hrc_drake.robots.config import Robot
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
