"""The assembly-flow vocabulary of thesis Table 6.1: buffers, actions with agents, inputs,
outputs and resources. The scenario schema composes it; `compiler.compile_flow` turns it into a
pcTPN.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

from dataclasses import dataclass, field
from typing import Optional

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

    The time an action really takes is not set here: the operator's part lasts its
    `operator.actions[..].duration`, a robot's part its motion through the poses plus
    `robots[..].actions[..].dwell` at each. `duration` is only the delay of the action in the
    pcTPN a timed scheduler plans on (`scheduling.config.TIMED_SCHEDULERS`).
    """

    name: str = ""
    agents: list[str] = field(default_factory=list)
    inputs: list[str] = field(default_factory=list)
    outputs: list[str] = field(default_factory=list)
    resources: list[str] = field(default_factory=list)
    #: the timed scheduler's prior of the action's duration, until it has observed the action
    #: (its pcTPN delay); None: the operator's duration for an action of the operator, 1 s
    #: otherwise. Refused where the scheduler reads no delays (`cell.scenario`)
    duration: Optional[Distribution] = None  # noqa: UP045 (the YAML loader needs typing.Optional)
    #: robot agents of the action that leave it before it ends, with the duration of their part
    #: in the timed scheduler's pcTPN (the arm itself leaves when its motion ends)
    #: (thesis Fig. 7.3: YuMi's left arm finishes its subtask of the collaboration first and can
    #: start a new operation while the right arm is still at it)
    early_release: dict[str, Distribution] = field(default_factory=dict)


@dataclass
class Flow:
    actions: list[FlowAction] = field(default_factory=list)
    #: resource name -> number of units
    resources: dict[str, int] = field(default_factory=dict)
