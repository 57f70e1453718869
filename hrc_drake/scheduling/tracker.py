"""The scheduler's belief of the cell's net, kept in step with observed events (thesis 7.1,
Fig. 7.1: incoming events fire uncontrollable transitions, commands fire controllable ones,
and the observed delays update the duration models)."""

from __future__ import annotations

import numpy as np

from hrc_drake.messages import shallow_copy
from hrc_drake.scheduling.petri import PcTPN
from hrc_drake.scheduling.slowdown import OperatorActivities


class NetTracker:
    """Belief marking of a compiled net plus the time each transition became enabled.

    Events that do not match the belief (a human action out of pattern, a part the belief
    thinks is missing) are applied anyway: the marking is forced (negative counts clipped to 0)
    so the belief follows the real cell.
    """

    def __init__(self, net: PcTPN, policy=None):
        self.net = net
        self.policy = policy
        self.m = net.m0.copy()
        self.enabled_since = np.where(net.enabled(self.m), 0.0, np.nan)
        self.now = 0.0
        #: with a policy that learns robot durations per operator activity (`durations_by_operator`):
        #: the operator's activity when each transition was enabled (scheduling.slowdown)
        by_operator = getattr(policy, "durations_by_operator", False)
        self.activities = OperatorActivities.of(net) if by_operator else None
        self.activity_since: list[str | None] = [None] * net.n_transitions

    def clone(self, policy=None) -> NetTracker:
        """A copy whose marking and clocks may change without touching this one, observing
        into `policy` (default: the same policy object)."""
        new = shallow_copy(self)
        new.m = self.m.copy()
        new.enabled_since = self.enabled_since.copy()
        new.activity_since = list(self.activity_since)
        if policy is not None:
            new.policy = policy
        return new

    def _fire(self, j: int, t: float, observe: bool = True):
        net = self.net
        if (
            observe
            and self.policy is not None
            and not net.controllable[j]
            and net.role[j] in ("end", "intent")
        ):
            since = self.enabled_since[j]
            if np.isfinite(since) and t >= since:
                if self.activities is None:
                    self.policy.observe(j, t - since)
                else:
                    self.policy.observe(j, t - since, operator=self.activity_since[j])
        before = net.enabled(self.m)
        self.m = np.maximum(self.m + net.incidence[:, j], 0)
        after = net.enabled(self.m)
        newly = after & ~before
        newly[j] = after[j]
        self.enabled_since[after & ~before] = t
        self.enabled_since[~after] = np.nan
        self.enabled_since[j] = t if after[j] else np.nan
        if self.activities is not None and newly.any():
            activity = self.activities.name_of_marking(self.m)
            for k in np.flatnonzero(newly):
                self.activity_since[k] = activity
        self.now = t

    def elapsed(self, t: float) -> np.ndarray:
        return np.where(np.isnan(self.enabled_since), 0.0, t - self.enabled_since)

    def _find(self, role: str, action: str, pre_marked_prefix: str | None = None) -> int | None:
        net = self.net
        for j in range(net.n_transitions):
            if net.role[j] != role or net.action[j] != action or net.controllable[j]:
                continue
            pres = np.flatnonzero(net.pre[:, j])
            if pre_marked_prefix is None or any(
                net.places[i].startswith(pre_marked_prefix) and self.m[i] > 0 for i in pres
            ):
                return j
        return None

    def _human_step_to(self, action: str, t: float):
        """Move the human's token to a step of `action` (resynchronising the pattern)."""
        net = self.net
        marked = [
            i for i in range(net.n_places) if self.m[i] > 0 and net.places[i].startswith(("step:", "hwait:"))
        ]
        for j in range(net.n_transitions):
            if net.role[j] == "intent" and net.action[j] == action:
                src = int(np.flatnonzero(net.pre[:, j])[0])
                if self.m[src] > 0:
                    return
        for j in range(net.n_transitions):
            if net.role[j] == "intent" and net.action[j] == action:
                for i in marked:
                    self.m[i] -= 1
                self.m[int(np.flatnonzero(net.pre[:, j])[0])] += 1
                self.enabled_since[j] = t
                return

    def _collaboration_under_way(self, action: str) -> bool:
        """Whether `action` is a collaboration with robots that the belief has begun already
        (its robots' "begin" came before the human's)."""
        net = self.net
        if f"cwait:{action}" not in net.place_index:
            return False
        return any(self.m[i] > 0 and (p == f"busy:{action}" or p.startswith(f"busy:{action}#"))
                   for i, p in enumerate(net.places))

    def _settle_holds(self, action: str, t: float):
        """The cell shows `action` beginning: an arm the belief still has holding for it (6.3.3
        hold model) has been joined by its partner, so fire that join (forced; the Scheduler
        commands a join without firing it, as the cell may never start the action)."""
        net = self.net
        for k in range(net.n_transitions):
            if net.role[k] == "join" and net.action[k] == action and any(
                net.places[i].startswith("held:") and self.m[i] > 0 for i in np.flatnonzero(net.pre[:, k])
            ):
                self._fire(k, t, observe=False)
                return

    def human_event(self, action: str, kind: str, t: float):
        """Apply a HumanEvent (begin | end | wait_begin | wait_end) to the belief."""
        if kind == "begin":
            self._settle_holds(action, t)
        if kind in ("begin", "wait_begin"):
            if self._collaboration_under_way(action):
                return  # a collaboration its robots' begin has started already
            if self._find("begin", action, "hwait:") is None:
                self._human_step_to(action, t)
                j = self._find("intent", action, "step:")
                if j is None:  # (not `or`: transition 0 is a real index)
                    j = self._find("intent", action, "human:idle")
                if j is not None:
                    self._fire(j, t)
            if kind == "begin":
                j = self._find("begin", action, "hwait:")
                if j is not None:
                    self._fire(j, t)
        elif kind == "end":
            j = self._find("end", action, "busy:")
            if j is not None:
                self._fire(j, t)
                # an intention with a fixed zero delay: the human wants the next step at once
                en = self.net.enabled(self.m)
                for k in range(self.net.n_transitions):
                    d = self.net.delays[k]
                    if en[k] and self.net.role[k] == "intent" and d.kind == "fixed" and d.mean == 0.0:
                        self._fire(k, t, observe=False)
                        break

    def robot_event(self, agent: str, action: str, kind: str, t: float):
        """Apply a RobotEvent: "begin" of a collaboration starts it (human side included),
        "end" ends the action, "ready" makes the agent available (ending whatever the belief
        still has it doing)."""
        net = self.net
        if kind == "begin":
            self._settle_holds(action, t)
            j = self._find("begin", action, "cwait:")
            if j is not None:
                if self._find("begin", action, "hwait:") is None:
                    self.human_event(action, "wait_begin", t)
                j = self._find("begin", action, "hwait:")
                if j is not None:
                    self._fire(j, t)
        elif kind == "end":
            for j in range(net.n_transitions):
                if net.role[j] == "end" and net.action[j] == action and agent in net.agents[j]:
                    if any(self.m[i] > 0 for i in np.flatnonzero(net.pre[:, j])):
                        self._fire(j, t)
                        return
        elif kind == "ready":
            avail = net.place_index[f"avail:{agent}"]
            if self.m[avail] > 0:
                return
            for j in range(net.n_transitions):
                if net.controllable[j] or agent not in net.agents[j]:
                    continue
                if net.role[j] in ("wait_end", "end", "giveup") and all(
                    self.m[i] >= net.pre[i, j] for i in np.flatnonzero(net.pre[:, j])
                ):
                    self._fire(j, t, observe=net.role[j] == "end")
                    if self.m[avail] > 0:
                        return
            self.m[avail] = 1

    def command(self, j: int, t: float):
        """Fire the controllable transition the scheduler commanded."""
        self._fire(j, t)
