"""Drake systems of the robots: task executor and path follower.

Both tick their pure core (`TaskExecutor`, `JointPathFollower`) with a periodic update and keep
it in the Context as an immutable value (`hrc_drake.systems.Frozen`): an update that changes the
core works on a copy, so one built diagram can be simulated again and two contexts never share.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from hrc_drake.messages import AgentActivity, EventLog, Immutable, PathStatus, ProactivePaths, WorldSnapshot
from hrc_drake.robots.executor import TaskExecutor
from hrc_drake.robots.path import ArmPath, JointPathFollower, make_arm_path
from hrc_drake.systems import (
    Frozen,
    declare_state,
    get_state,
    input_or,
    set_state,
    state_ticket,
)

EVENT_WINDOW = 400


class PathFollower(LeafSystem):
    """Joint path following with velocity limits and a speed override (see `robots.path`).

    Input "path_requests": abstract tuple of `messages.PathRequest` (the latest per channel).
    Input "speed_override": vector (1,) in [-1, 1] (a negative one backs the arms off along their
    paths, a safety controller's retreat after a contact); unconnected means 1.
    Outputs "positions" (nq,), "velocities" (nq,), "velocities_full" (nq,: at override 1, for a
    safety controller's approach speeds), "path_done" (`messages.PathStatus`),
    "speed_override_applied" (1,), "positions_ahead" (nq,): where the arms would be `lookahead` s
    later at full speed, so that a speed rule can tell motion toward the operator from motion away;
    "velocities_full_ahead" (nq,): the velocities at full speed `lookahead` s of path time after
    now (a path accelerating from rest: what a safety controller's reaction time may reach);
    "positions_full_next" and "velocities_full_next" (nq,): where the arms are, and their velocities
    at full speed, one period of full-speed path time after now (a safety controller keeps its
    separation at the next tick too, where the path may have turned toward the operator);
    "path_preview" (preview_steps x 2 nq): the positions and the full-speed velocities at
    `preview_step`, 2 `preview_step`, ... of full-speed path time after now, stacked per sample (a
    predictive safety controller plans its speed over them; 0 steps: an empty port).
    hold_new_paths: a path starts moving one tick after it was requested, so that a safety
    controller's override has seen it (else its first period runs at an override computed without
    it: the robot accelerates from rest within the reaction time). Each tick advances the paths by
    the time since the last tick at the override applied then, and applies the new override to
    the next period: positions are continuous in time.
    Positions are evaluated at the context time, extrapolated from the last tick with the
    override then applied, so they stay smooth between ticks.

    Discrete state (all numbers): [applied override, last tick time, q (nq), per arm
    (requested seq, done seq, segment, phase), the start of each arm's path (nq)]. A path's
    geometry is the request itself (the input) from that start: `robots.path.ArmPath`, memoised.

    The tick is a Drake discrete update: at one time Drake applies the unrestricted updates of
    the other systems first, so the follower starts a path in the tick the executor requests
    it and applies the speed override computed at that tick; and a tick changes no abstract
    state (it is the one update that succeeds at every tick: as an unrestricted update it made
    Drake copy every abstract state of the diagram at each tick).
    """

    def __init__(self, follower: JointPathFollower, period: float = 0.02, lookahead: float = 0.1,
                 hold_new_paths: bool = False, preview_steps: int = 0, preview_step: float = 0.1):
        super().__init__()
        self.period = float(period)
        self.preview_steps = int(preview_steps)
        self.preview_step = float(preview_step)
        self.hold_new_paths = bool(hold_new_paths)
        self.lookahead = float(lookahead)
        self.arm_indices = [np.asarray(i, dtype=int) for i in follower.arm_indices]
        self.v_max = [np.asarray(v, dtype=float) for v in follower.v_max]
        self.fraction = follower.fraction
        self._nq = nq = len(follower.q)
        self._arms = len(self.arm_indices)
        self._q = slice(2, 2 + nq)
        self._arm0 = 2 + nq
        self._start = slice(2 + nq + 4 * self._arms, 2 + 2 * nq + 4 * self._arms)
        initial = np.zeros(2 + 2 * nq + 4 * self._arms)
        initial[0] = 1.0
        initial[self._q] = follower.q
        initial[self._start] = follower.q
        self._state = self.DeclareDiscreteState(initial)
        self._paths: dict = {}
        self._requests = self.DeclareAbstractInputPort("path_requests", AbstractValue.Make(()))
        self._override = self.DeclareVectorInputPort("speed_override", 1)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._tick)
        smooth = {self.time_ticket(), self.xd_ticket(), self._requests.ticket()}
        self.DeclareVectorOutputPort("positions", nq, self._calc_q, smooth)
        self.DeclareVectorOutputPort("velocities", nq, self._calc_v, smooth)
        self.DeclareVectorOutputPort("velocities_full", nq, self._calc_v_full, smooth)
        self.DeclareVectorOutputPort("velocities_full_ahead", nq, self._calc_v_full_ahead, smooth)
        self.DeclareVectorOutputPort("positions_ahead", nq, self._calc_q_ahead, smooth)
        self.DeclareVectorOutputPort("positions_full_next", nq, self._calc_q_next, smooth)
        self.DeclareVectorOutputPort("velocities_full_next", nq, self._calc_v_full_next, smooth)
        self.DeclareVectorOutputPort("path_preview", 2 * nq * self.preview_steps, self._calc_preview, smooth)
        self.DeclareAbstractOutputPort(
            "path_done", lambda: AbstractValue.Make(PathStatus()), self._calc_done, {self.xd_ticket()}
        )
        self.DeclareVectorOutputPort("speed_override_applied", 1, self._calc_applied, {self.xd_ticket()})

    def _path(self, request, start: np.ndarray) -> ArmPath:
        """The path of `request` from `start` (a pure function of both, memoised).

        The memo is shared by every context of the system, so it is keyed on the request object
        itself (held by the entry, so its id is not reused while cached) and checked against
        the start: two contexts asking different paths never share one."""
        entry = self._paths.get(id(request))
        # the start has the cached one's shape (the arm's joints): an element test suffices
        if entry is not None and entry[0] is request and bool((entry[1] == start).all()):
            return entry[2]
        if len(self._paths) > 256:
            self._paths.clear()
        waypoints = np.atleast_2d(np.asarray(request.waypoints, dtype=float))
        dwells = np.broadcast_to(np.asarray(request.dwells, dtype=float), len(waypoints))
        path = make_arm_path(start, waypoints, dwells, self.v_max[request.channel], self.fraction,
                             request.blended)
        self._paths[id(request)] = (request, start.copy(), path)
        return path

    def _active(self, x: np.ndarray, requests):
        """(arm, path, segment, phase) of every arm following a path in state x."""
        out = []
        for request in requests:
            k = self._arm0 + 4 * request.channel
            if x[k] == request.seq and x[k + 1] < x[k]:
                start = x[self._start][self.arm_indices[request.channel]]
                out.append((request.channel, self._path(request, start), int(x[k + 2]), x[k + 3]))
        return out

    def _tick(self, context, discrete_state):
        x = np.array(context.get_discrete_state(self._state).get_value())
        requests = self._requests.Eval(context) if self._requests.HasValue(context) else ()
        q = x[self._q]
        started = set()
        for request in requests:
            k = self._arm0 + 4 * request.channel
            if request.seq > x[k]:
                started.add(request.channel)
                if np.shape(request.waypoints)[-1] != len(self.arm_indices[request.channel]):
                    raise ValueError(
                        f"PathFollower: request for arm {request.channel} has waypoints of "
                        f"{np.shape(request.waypoints)[-1]} joints, expected "
                        f"{len(self.arm_indices[request.channel])}"
                    )
                idx = self.arm_indices[request.channel]
                start = x[self._start]
                start[idx] = q[idx]
                x[self._start] = start
                # a held path starts a period before its start: it moves from the next tick, under an
                # override that has seen it
                x[k], x[k + 2], x[k + 3] = request.seq, 0.0, -self.period if self.hold_new_paths else 0.0
        override = self._override.Eval(context)[0] if self._override.HasValue(context) else 1.0
        override = float(override)
        # a negative override backs the arms off along their paths (a safety controller's retreat)
        applied = min(max(override, -1.0), 1.0) if math.isfinite(override) else 0.0
        # the motion since the last tick, at the override applied then: the arms' positions are
        # continuous in time (the outputs extrapolate from the last tick at that override)
        elapsed = max(context.get_time() - x[1], 0.0) * x[0]
        for arm, path, segment, phase in self._active(x, requests):
            if arm in started:
                continue  # nothing of a path started now has elapsed
            k = self._arm0 + 4 * arm
            segment, phase, finished = path.progress_after(segment, phase, elapsed)
            q[self.arm_indices[arm]] = path.position_at(segment, phase)
            x[k + 2], x[k + 3] = segment, phase
            if finished:
                x[k + 1] = x[k]
        x[self._q] = q
        x[0], x[1] = applied, context.get_time()
        discrete_state.get_mutable_vector(self._state).SetFromVector(x)
        return EventStatus.Succeeded()

    def _positions(self, context, ahead: float) -> np.ndarray:
        """q `ahead` seconds of full-speed time after the last tick."""
        x = context.get_discrete_state(self._state).get_value()
        q = x[self._q].copy()
        if ahead != 0.0:
            requests = self._requests.Eval(context) if self._requests.HasValue(context) else ()
            for arm, path, segment, phase in self._active(x, requests):
                if ahead < 0.0:  # backing off (a negative override): over the waypoints passed
                    segment, phase, _ = path.progress_after(segment, phase, ahead)
                    q[self.arm_indices[arm]] = path.position_at(segment, phase)
                else:
                    q[self.arm_indices[arm]] = path.position_at(segment, phase + ahead)
        return q

    def _calc_q(self, context, output: BasicVector):
        output.SetFromVector(self._positions(context, self._elapsed(context)))

    def _calc_q_ahead(self, context, output: BasicVector):
        output.SetFromVector(self._positions(context, self._elapsed(context) + self.lookahead))

    def _velocities(self, context, override: float, ahead: float = 0.0) -> np.ndarray:
        """Joint velocities at `override`, `ahead` seconds of full-speed path time after the last tick."""
        x = context.get_discrete_state(self._state).get_value()
        v = np.zeros(self._nq)
        requests = self._requests.Eval(context) if self._requests.HasValue(context) else ()
        for arm, path, segment, phase in self._active(x, requests):
            if ahead != 0.0:
                segment, phase, _ = path.progress_after(segment, phase, ahead)
            v[self.arm_indices[arm]] = path.velocity_at(segment, phase) * override
        return v

    def _elapsed(self, context) -> float:
        """Path time since the last tick (s): the time since it at the override applied then."""
        x = context.get_discrete_state(self._state).get_value()
        return max(context.get_time() - x[1], 0.0) * x[0]

    # the velocities are the path's at the positions' path time: a safety controller updating at a
    # tick reads the state of the tick before (unrestricted updates go first), and a velocity from
    # a period ago misses a path turning toward the operator within that period
    def _calc_v(self, context, output: BasicVector):
        applied = context.get_discrete_state(self._state).get_value()[0]
        output.SetFromVector(self._velocities(context, applied, self._elapsed(context)))

    def _calc_v_full(self, context, output: BasicVector):
        output.SetFromVector(self._velocities(context, 1.0, self._elapsed(context)))

    def _calc_v_full_ahead(self, context, output: BasicVector):
        output.SetFromVector(self._velocities(context, 1.0, self._elapsed(context) + self.lookahead))

    def _calc_q_next(self, context, output: BasicVector):
        output.SetFromVector(self._positions(context, self._elapsed(context) + self.period))

    def _calc_v_full_next(self, context, output: BasicVector):
        output.SetFromVector(self._velocities(context, 1.0, self._elapsed(context) + self.period))

    def _calc_preview(self, context, output: BasicVector):
        elapsed = self._elapsed(context)
        samples = [np.concatenate([self._positions(context, elapsed + k * self.preview_step),
                                   self._velocities(context, 1.0, elapsed + k * self.preview_step)])
                   for k in range(1, self.preview_steps + 1)]
        output.SetFromVector(np.concatenate(samples) if samples else np.zeros(0))

    def _calc_done(self, context, output):
        x = context.get_discrete_state(self._state).get_value()
        output.set_value(PathStatus(tuple(int(x[self._arm0 + 4 * k + 1]) for k in range(self._arms))))

    def _calc_applied(self, context, output: BasicVector):
        output.SetAtIndex(0, context.get_discrete_state(self._state).get_value()[0])


@dataclass(frozen=True)
class ExecutorRun(Immutable):
    """The executor's run state: its core and the logs it emitted."""

    executor: Frozen
    robot_events: EventLog = EventLog()
    world_requests: EventLog = EventLog()
    #: the outputs that are functions of the core alone, computed once per change
    path_requests: tuple = ()
    activity: AgentActivity = AgentActivity()

    @staticmethod
    def of(executor: TaskExecutor, robot_events: EventLog, world_requests: EventLog) -> ExecutorRun:
        requests = executor.path_requests
        return ExecutorRun(
            Frozen(executor),
            robot_events,
            world_requests,
            tuple(requests[k] for k in sorted(requests)),
            AgentActivity(tuple(executor.activity().items())),
        )


class RobotTaskExecutor(LeafSystem):
    """Runs the arm agents' programs (or scheduler commands) against the cell's truth.

    Inputs "path_done" (`PathStatus` from `PathFollower`), optional "robot_commands" (EventLog
    of RobotCommand), optional "world" (`WorldSnapshot`: the request protocol of `cell.world`;
    unconnected, every action starts at once). Outputs "path_requests" (tuple of PathRequest,
    to `PathFollower`), "robot_events" (EventLog of RobotEvent), "world_requests" (EventLog of
    WorldRequest), "activity" (`AgentActivity`: agent -> current action / wait / idle).
    Optional input "proactive_paths" (`ProactivePaths`): motions that replace an action's own.
    """

    def __init__(self, executor: TaskExecutor, period: float = 0.02):
        super().__init__()
        if executor.world is not None:
            raise ValueError("RobotTaskExecutor: the executor must not hold a world (use the 'world' input)")
        self.period = float(period)
        self._channels = max((a.channel for a in executor.agents), default=-1) + 1
        self._initial = ExecutorRun.of(executor.clone(), EventLog(), EventLog())
        self._run = declare_state(self, lambda context: self._initial)
        self._done = self.DeclareAbstractInputPort("path_done", AbstractValue.Make(PathStatus()))
        self._commands = self.DeclareAbstractInputPort("robot_commands", AbstractValue.Make(EventLog()))
        self._world = self.DeclareAbstractInputPort("world", AbstractValue.Make(WorldSnapshot()))
        self._paths = self.DeclareAbstractInputPort("proactive_paths", AbstractValue.Make(ProactivePaths()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self.period, 0.0, self._tick)
        ticket = state_ticket(self, self._run)
        self.DeclareAbstractOutputPort(
            "path_requests", lambda: AbstractValue.Make(()), self._calc_requests, ticket
        )
        self.DeclareAbstractOutputPort(
            "robot_events", lambda: AbstractValue.Make(EventLog()), self._calc_events, ticket
        )
        self.DeclareAbstractOutputPort(
            "world_requests", lambda: AbstractValue.Make(EventLog()), self._calc_world_requests, ticket
        )
        self.DeclareAbstractOutputPort(
            "activity", lambda: AbstractValue.Make(AgentActivity()), self._calc_activity, ticket
        )

    def executor(self, context) -> TaskExecutor:
        """The executor core of `context` (read only)."""
        return get_state(context, self._run).executor.core

    def _tick(self, context, state):
        run = get_state(context, self._run)
        done = input_or(self._done, context, PathStatus()).done_seq or (0,) * self._channels
        commands = input_or(self._commands, context, EventLog()).since(run.executor.core._last_command_seq)
        core = run.executor.core
        view = input_or(self._world, context, None) if core.needs_world() else None
        if not core.will_change(done, commands, view):
            return EventStatus.DidNothing()
        executor = run.executor.thaw()
        before = len(executor.events)
        paths = input_or(self._paths, context, ProactivePaths()).by_action()
        executor.update(context.get_time(), list(done), commands, view, paths)
        set_state(
            state,
            self._run,
            ExecutorRun.of(
                executor,
                run.robot_events.appended(executor.events[before:], EVENT_WINDOW),
                run.world_requests.appended(executor.new_requests, EVENT_WINDOW),
            ),
        )
        return EventStatus.Succeeded()

    def _calc_requests(self, context, output):
        output.set_value(get_state(context, self._run).path_requests)

    def _calc_events(self, context, output):
        output.set_value(get_state(context, self._run).robot_events)

    def _calc_world_requests(self, context, output):
        output.set_value(get_state(context, self._run).world_requests)

    def _calc_activity(self, context, output):
        output.set_value(get_state(context, self._run).activity)

