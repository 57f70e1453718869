"""Drake systems of the robots: task executor and path follower.

Both keep their pure core (`TaskExecutor`, `JointPathFollower`) on the system and tick it with
a periodic discrete update; a one-number discrete state counts the ticks, so that output
ports computed from the core are invalidated exactly when the core changes.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector

from hrc_drake.cell.ticked import TickedSystem
from hrc_drake.messages import EventLog
from hrc_drake.robots.executor import TaskExecutor
from hrc_drake.robots.path import JointPathFollower

EVENT_WINDOW = 400


class PathFollower(TickedSystem):
    """Joint path following with velocity limits and a speed override (see `robots.path`).

    Input "path_requests": abstract tuple of (channel, seq, waypoints, dwells) requests.
    Input "speed_override": vector (1,) in [0, 1]; unconnected means 1.
    Outputs "positions" (nq,), "velocities" (nq,), "path_done" (abstract tuple of seq per channel),
    "speed_override_applied" (1,), "positions_ahead" (nq,): where the arms would be `lookahead` s
    later at full speed, so that a speed rule can tell motion toward the operator from motion away.
    Positions are evaluated at the context time, extrapolated from the last tick with the
    override then applied, so they stay smooth between ticks.
    """

    def __init__(self, follower: JointPathFollower, period: float = 0.02, lookahead: float = 0.1):
        super().__init__(period)
        self.follower = follower
        self._nq = len(follower.q)
        self._requests = self.DeclareAbstractInputPort("path_requests", AbstractValue.Make(()))
        self._override = self.DeclareVectorInputPort("speed_override", 1)
        self._seen = [0] * len(follower.arm_indices)
        self._applied = 1.0
        self._last_tick_time = 0.0
        self.DeclareVectorOutputPort(
            "positions", self._nq, self._calc_q, prerequisites_of_calc={self.time_ticket(), self.xd_ticket()}
        )
        self.DeclareVectorOutputPort(
            "velocities", self._nq, self._calc_v, prerequisites_of_calc=self.ticket()
        )
        self.lookahead = lookahead
        self.DeclareVectorOutputPort(
            "positions_ahead",
            self._nq,
            self._calc_q_ahead,
            prerequisites_of_calc={self.time_ticket(), self.xd_ticket()},
        )
        self.DeclareAbstractOutputPort(
            "path_done", lambda: AbstractValue.Make(()), self._calc_done, prerequisites_of_calc=self.ticket()
        )
        self.DeclareVectorOutputPort(
            "speed_override_applied", 1, self._calc_applied, prerequisites_of_calc=self.ticket()
        )

    def tick(self, context) -> None:
        for channel, seq, waypoints, dwells in (
            self._requests.Eval(context) if self._requests.HasValue(context) else ()
        ):
            if seq > self._seen[channel]:
                self._seen[channel] = seq
                self.follower.request(channel, seq, waypoints, dwells)
        override = self._override.Eval(context)[0] if self._override.HasValue(context) else 1.0
        self._applied = float(np.clip(override, 0.0, 1.0)) if np.isfinite(override) else 0.0
        self.follower.step(self.period, self._applied)
        self._last_tick_time = context.get_time()

    def _calc_q_ahead(self, context, output: BasicVector):
        ahead = max(context.get_time() - self._last_tick_time, 0.0) * self._applied + self.lookahead
        output.SetFromVector(self.follower.positions_ahead(ahead, 1.0))

    def _calc_q(self, context, output: BasicVector):
        ahead = context.get_time() - self._last_tick_time
        if ahead <= 0.0:
            output.SetFromVector(self.follower.q)
        else:
            output.SetFromVector(self.follower.positions_ahead(ahead, self._applied))

    def _calc_v(self, context, output: BasicVector):
        output.SetFromVector(self.follower.velocities(self._applied))

    def _calc_done(self, context, output):
        output.set_value(tuple(self.follower.done_seq))

    def _calc_applied(self, context, output: BasicVector):
        output.SetAtIndex(0, self._applied)


class RobotTaskExecutor(TickedSystem):
    """Runs the arm agents' programs (or scheduler commands) against the cell's truth.

    Inputs "path_done" (from `PathFollower`), optional "robot_commands" (EventLog of RobotCommand).
    Outputs "path_requests" (to `PathFollower`), "robot_events" (EventLog of RobotEvent),
    "activity" (abstract dict agent -> current action / wait / idle).
    """

    def __init__(self, executor_factory, period: float = 0.02):
        super().__init__(period)
        self._requests: dict[int, tuple] = {}
        self.executor: TaskExecutor = executor_factory(self._request_path)
        self._done = self.DeclareAbstractInputPort("path_done", AbstractValue.Make(()))
        self._commands = self.DeclareAbstractInputPort("robot_commands", AbstractValue.Make(EventLog()))
        self._last_command = 0
        self.DeclareAbstractOutputPort(
            "path_requests",
            lambda: AbstractValue.Make(()),
            self._calc_requests,
            prerequisites_of_calc=self.ticket(),
        )
        self.DeclareAbstractOutputPort(
            "robot_events",
            lambda: AbstractValue.Make(EventLog()),
            self._calc_events,
            prerequisites_of_calc=self.ticket(),
        )
        self.DeclareAbstractOutputPort(
            "activity",
            lambda: AbstractValue.Make({}),
            self._calc_activity,
            prerequisites_of_calc=self.ticket(),
        )

    def _request_path(self, channel, seq, waypoints, dwells):
        self._requests[channel] = (channel, seq, waypoints, dwells)

    def tick(self, context) -> None:
        done = self._done.Eval(context)
        commands = ()
        if self._commands.HasValue(context):
            commands = self._commands.Eval(context).since(self._last_command)
            if commands:
                self._last_command = commands[-1].seq
        self.executor.update(context.get_time(), list(done), commands)

    def _calc_requests(self, context, output):
        output.set_value(tuple(self._requests.values()))

    def _calc_events(self, context, output):
        output.set_value(EventLog(tuple(self.executor.events[-EVENT_WINDOW:])))

    def _calc_activity(self, context, output):
        output.set_value(self.executor.activity())
