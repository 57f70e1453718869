"""Robot task execution: each arm agent runs its program, or the scheduler's commands.

Pure Python core. An arm picks its next action (the next one of its fixed program in
round-robin order, or the action a scheduler commanded), starts it as soon as the world
says its input parts are there (waiting, recorded as idle, until then), moves through the
action's poses, and on arrival at the last pose finishes it in the world.

The world is either a synchronous object (`try_start`, `finish`) or, in a cell, the request
protocol of `cell.world`: `update(..., view=WorldSnapshot)` leaves start/finish
`WorldRequest`s in `new_requests` and starts an action once its request is granted.

An action shared with other agents (a collaboration, thesis 6.3.3) starts when all of them
have asked for it; a commanded one is revoked after the command's `give_up_after` (T_wait,
Fig. 7.3) and the arm is ready again. At the end of its motion the arm holds the last pose
until the whole action is done (`holds`), unless the flow releases it early (`early_release`,
the left arm of Fig. 7.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hrc_drake.messages import PathRequest, RobotCommand, RobotEvent, WorldRequest, shallow_copy


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
    mode: str = "choose"  # choose | ready | requesting | waiting | moving | holding | pausing
    action: str | None = None
    program_index: int = 0
    path_seq: int = 0
    pause_until: float = 0.0
    command_seq: int = 0
    pending: tuple = ()
    request_seq: int = 0
    patience: float = float("inf")


class TaskExecutor:
    """Round-robin programs, or scheduler commands when `use_commands` is set.

    world: an object with `try_start(agent, action) -> bool` and `finish(agent, action, time)`,
    or None. requests: use the request protocol instead (see the module docstring); with
    neither, every action starts at once.
    The motions to start are `path_requests` (channel -> `PathRequest`, the latest per arm).
    moves: action name -> its motion, or (agent, action name) -> the motion of that agent's part
    (an action of two arms has one per arm). holds: (agent, action) pairs of shared actions
    whose agent stays on the action until all its agents are done (request protocol only);
    the others leave it when their own motion ends.
    """

    def __init__(
        self,
        agents: list[ArmAgent],
        moves: dict,
        world=None,
        use_commands: bool = False,
        requests: bool = False,
        holds=frozenset(),
    ):
        if world is not None and requests:
            raise ValueError("TaskExecutor: give a synchronous world or use requests, not both")
        self.moves = moves
        for a in agents:
            if not use_commands and not a.program:
                raise ValueError(f"agent '{a.agent}' has an empty program")
            for name in a.program:
                if not self.has_move(a.agent, name):
                    raise ValueError(f"agent '{a.agent}': program names unknown robot action '{name}'")
        self.agents = agents
        self.holds = frozenset(holds)
        self.world = world
        self.requests = requests
        self.use_commands = use_commands
        self.state = {a.agent: _ArmState() for a in agents}
        self.events: tuple[RobotEvent, ...] = ()
        self.path_requests: dict[int, PathRequest] = {}
        self.new_requests: tuple[WorldRequest, ...] = ()
        self._requests: list[WorldRequest] = []
        self._seq = 0
        self._world_seq = 0
        self._last_command_seq = 0
        self._view = None

    def clone(self) -> TaskExecutor:
        """A copy an update may change; shares the agents, moves and the events tuple."""
        other = shallow_copy(self)
        other.state = {agent: shallow_copy(st) for agent, st in self.state.items()}
        other.path_requests = dict(self.path_requests)
        return other

    def has_move(self, agent: str, action: str) -> bool:
        return (agent, action) in self.moves or action in self.moves

    def move(self, agent: str, action: str) -> RobotMove:
        """The motion of `agent`'s part of `action`."""
        return self.moves.get((agent, action)) or self.moves[action]

    def _emit(self, time: float, agent: str, action: str, kind: str) -> None:
        self._seq += 1
        event = RobotEvent(time=time, agent=agent, action=action, kind=kind, seq=self._seq)
        self.events = self.events + (event,)

    def _world_request(self, time: float, agent: str, action: str, kind: str) -> None:
        self._world_seq += 1
        patience = self.state[agent].patience if kind == "start" else float("inf")
        request = WorldRequest(time=time, agent=agent, action=action, kind=kind, seq=self._world_seq,
                               patience=patience)
        self._requests.append(request)
        if kind == "start":
            self.state[agent].request_seq = self._world_seq

    def needs_world(self) -> bool:
        """Whether an update may read the world's answer (an arm is asking or waiting)."""
        asking = ("requesting", "waiting", "holding")
        return self.requests and any(st.mode in asking for st in self.state.values())

    def will_change(self, done_seq, commands, view) -> bool:
        """Whether `update` would change anything (cheap; lets a system skip a copy)."""
        if commands and commands[-1].seq > self._last_command_seq:
            return True
        for arm in self.agents:
            st = self.state[arm.agent]
            if st.mode in ("choose", "pausing"):
                return True
            if st.mode == "moving" and done_seq[arm.channel] >= st.path_seq:
                return True
            if st.mode in ("requesting", "waiting") and view is not None:
                if view.granted.get(arm.agent, 0) >= st.request_seq:
                    return True
                if view.withdrawn.get(arm.agent, 0) >= st.request_seq:
                    return True
                if st.mode == "requesting" and view.refused.get(arm.agent, 0) >= st.request_seq:
                    return True
            if st.mode == "holding" and view is not None and st.action not in view.joint:
                return True
            if st.mode == "waiting" and self.world is not None:
                return True
        return False

    def activity(self) -> dict[str, str]:
        out = {}
        for agent, st in self.state.items():
            if st.mode in ("moving", "holding"):
                out[agent] = st.action
            elif st.mode == "waiting":
                out[agent] = f"wait:{st.action}"
            elif st.mode == "requesting":
                out[agent] = f"request:{st.action}"
            else:
                out[agent] = "idle"
        return out

    def update(
        self, time: float, done_seq: list[int], commands: tuple[RobotCommand, ...] = (), view=None,
        paths: dict | None = None,
    ) -> None:
        """Advance every arm's state machine to `time` (view: the world's snapshot, request protocol).

        paths: (agent, action) -> joint waypoints (n, dof) that replace the action's motion when
        it begins (a proactive path, thesis 8.2.3), followed as one blended move.
        """
        self._requests = []
        self._view = view
        self._paths = paths or {}
        for command in commands:
            if command.seq <= self._last_command_seq:
                continue
            self._last_command_seq = command.seq
            if command.agent not in self.state:
                raise ValueError(f"command for unknown robot agent '{command.agent}'")
            if command.action is not None and not self.has_move(command.agent, command.action):
                raise ValueError(f"command for unknown robot action '{command.action}' of '{command.agent}'")
            st = self.state[command.agent]
            st.pending = st.pending + (command,)
        for arm in self.agents:
            st = self.state[arm.agent]
            if st.mode == "moving" and done_seq[arm.channel] >= st.path_seq:
                if self.world is not None:
                    self.world.finish(arm.agent, st.action, time)
                else:
                    self._world_request(time, arm.agent, st.action, "finish")
                if self.requests and (arm.agent, st.action) in self.holds:
                    st.mode = "holding"  # until the other agents are done too
                else:
                    self._emit(time, arm.agent, st.action, "end")
                    st.mode, st.action = "choose", None
            if st.mode == "holding" and view is not None and st.action not in view.joint:
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
                command, st.pending = st.pending[0], st.pending[1:]
                if command.action is None:
                    st.mode, st.pause_until = "pausing", time + max(command.wait, 0.0)
                else:
                    st.action, st.patience = command.action, command.give_up_after
                    self._try_begin(time, arm, st, first=True)
                    st.patience = float("inf")
            elif st.mode in ("waiting", "requesting"):
                self._try_begin(time, arm, st, first=False)
        self.new_requests = tuple(self._requests)
        self._view = None
        self._paths = {}

    def _try_begin(self, time: float, arm: ArmAgent, st: _ArmState, first: bool) -> None:
        if self.world is not None:
            granted = self.world.try_start(arm.agent, st.action)
            refused = not granted
        elif not self.requests:  # no world at all: every action can start
            granted, refused = True, False
        elif first:
            self._world_request(time, arm.agent, st.action, "start")
            st.mode = "requesting"
            return
        else:
            view = self._view
            granted = view is not None and view.granted.get(arm.agent, 0) >= st.request_seq
            refused = view is not None and view.refused.get(arm.agent, 0) >= st.request_seq
            if not granted and view is not None and view.withdrawn.get(arm.agent, 0) >= st.request_seq:
                # the command is revoked (T_wait passed): ready for the next one
                if st.mode == "waiting":
                    self._emit(time, arm.agent, st.action, "wait_end")
                self._emit(time, arm.agent, "", "ready")
                st.mode, st.action = "ready", None
                return
        if granted:
            if st.mode == "waiting":
                self._emit(time, arm.agent, st.action, "wait_end")
            self._emit(time, arm.agent, st.action, "begin")
            move = self.move(arm.agent, st.action)
            st.path_seq += 1
            path = self._paths.get((arm.agent, st.action))
            if path is None:
                request = PathRequest(arm.channel, st.path_seq, move.waypoints, move.dwells)
            else:
                dwells = np.zeros(len(path))
                dwells[-1] = move.dwells[-1]
                request = PathRequest(arm.channel, st.path_seq, path, dwells, blended=True)
            self.path_requests[arm.channel] = request
            st.mode = "moving"
        elif refused and st.mode != "waiting":
            self._emit(time, arm.agent, st.action, "wait_begin")
            st.mode = "waiting"
