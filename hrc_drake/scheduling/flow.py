"""The assembly-flow vocabulary of thesis Table 6.1: buffers, actions with agents, inputs,
outputs and resources. The scenario schema composes it; `compiler.compile_flow` turns it into a
pcTPN.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

from dataclasses import dataclass, field

from hrc_drake.distributions import Distribution


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
    #: mass of one part held here (kg): an arm that takes parts from or puts parts into this
    #: buffer carries up to this payload, m_L of ISO/TS 15066 eq. (A.5)
    part_mass: float = 0.0


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
    #: robot agents of the action that leave it before it ends, with the duration of their part
    #: (thesis Fig. 7.3: YuMi's left arm finishes its subtask of the collaboration first and can
    #: start a new operation while the right arm is still at it)
    early_release: dict[str, Distribution] = field(default_factory=dict)


@dataclass
class Flow:
    actions: list[FlowAction] = field(default_factory=list)
    #: resource name -> number of units
    resources: dict[str, int] = field(default_factory=dict)
