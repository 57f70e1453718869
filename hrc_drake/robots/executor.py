"""Robot task execution: each arm agent runs its program, or the scheduler's commands.

Pure Python core. An arm picks its next action (the next one of its fixed program in
round-robin order, or the action a scheduler commanded), starts it as soon as `CellWorld`
says its input parts are there (waiting, recorded as idle, until then), moves through the
action's poses, and on arrival at the last pose finishes it in the world.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hrc_drake.messages import RobotCommand, RobotEvent


@dataclass
class ArmAgent:
    """One arm agent: its channel in the path follower and its fixed program."""

    agent: str
    channel: int
    program: list[str]


@dataclass
class RobotMove:
    """A robot action's motion: joint waypoints (n, dof) and the dwell at each."""

    waypoints: np.ndarray
    dwells: np.ndarray


@dataclass
class _ArmState:
    mode: str = "choose"  # choose | ready | waiting | moving | pausing
    action: str | None = None
    program_index: int = 0
    path_seq: int = 0
    pause_until: float = 0.0
    command_seq: int = 0
    pending: list = field(default_factory=list)


class TaskExecutor:
    """Round-robin programs, or scheduler commands when `use_commands` is set.

    world: an object with `try_start(agent, action) -> bool` and `finish(agent, action, time)`.
    request_path: callback (channel, seq, waypoints, dwells) that starts a motion.
    """

    def __init__(
        self,
        agents: list[ArmAgent],
        moves: dict[str, RobotMove],
        world,
        request_path,
        use_commands: bool = False,
    ):
        for a in agents:
            if not use_commands and not a.program:
                raise ValueError(f"agent '{a.agent}' has an empty program")
            for name in a.program:
                if name not in moves:
                    raise ValueError(f"agent '{a.agent}': program names unknown robot action '{name}'")
        self.agents = agents
        self.moves = moves
        self.world = world
        self.request_path = request_path
        self.use_commands = use_commands
        self.state = {a.agent: _ArmState() for a in agents}
        self.events: list[RobotEvent] = []
        self._seq = 0
        self._last_command_seq = 0

    def _emit(self, time: float, agent: str, action: str, kind: str) -> None:
        self._seq += 1
        self.events.append(RobotEvent(time=time, agent=agent, action=action, kind=kind, seq=self._seq))

    def activity(self) -> dict[str, str]:
        out = {}
        for agent, st in self.state.items():
            if st.mode == "moving":
                out[agent] = st.action
            elif st.mode == "waiting":
                out[agent] = f"wait:{st.action}"
            else:
                out[agent] = "idle"
        return out

    def update(self, time: float, done_seq: list[int], commands: tuple[RobotCommand, ...] = ()) -> None:
        """Advance every arm's state machine to `time`."""
        for command in commands:
            if command.seq <= self._last_command_seq:
                continue
            self._last_command_seq = command.seq
            if command.agent not in self.state:
                raise ValueError(f"command for unknown robot agent '{command.agent}'")
            if command.action is not None and command.action not in self.moves:
                raise ValueError(f"command for unknown robot action '{command.action}'")
            self.state[command.agent].pending.append(command)
        for arm in self.agents:
            st = self.state[arm.agent]
            if st.mode == "moving" and done_seq[arm.channel] >= st.path_seq:
                self.world.finish(arm.agent, st.action, time)
                self._emit(time, arm.agent, st.action, "end")
                st.mode, st.action = "choose", None
            if st.mode == "pausing" and time >= st.pause_until:
                st.mode = "choose"
            if st.mode == "choose":
                if self.use_commands:
                    self._emit(time, arm.agent, "", "ready")
                    st.mode = "ready"
                else:
                    st.action = arm.program[st.program_index % len(arm.program)]
                    st.program_index += 1
                    self._try_begin(time, arm, st, first=True)
            if st.mode == "ready" and st.pending:
                command = st.pending.pop(0)
                if command.action is None:
                    st.mode, st.pause_until = "pausing", time + max(command.wait, 0.0)
                else:
                    st.action = command.action
                    self._try_begin(time, arm, st, first=True)
            elif st.mode == "waiting":
                self._try_begin(time, arm, st, first=False)

    def _try_begin(self, time: float, arm: ArmAgent, st: _ArmState, first: bool) -> None:
        if self.world.try_start(arm.agent, st.action):
            if not first:
                self._emit(time, arm.agent, st.action, "wait_end")
            self._emit(time, arm.agent, st.action, "begin")
            move = self.moves[st.action]
            st.path_seq += 1
            self.request_path(arm.channel, st.path_seq, move.waypoints, move.dwells)
            st.mode = "moving"
        elif first:
            self._emit(time, arm.agent, st.action, "wait_begin")
            st.mode = "waiting"
