"""Ground truth of a cell: parts in buffers and who is doing what (pure Python core).

An action of the assembly flow (thesis Table 6.1) can start when each of its input buffers
holds a part and each of its output buffers has room, counting the room already promised to
actions under way. Starting takes the input parts; finishing puts the output parts.

In a cell the agents do not touch the world: they send `WorldRequest`s (start / finish) and the
world, one system, arbitrates them (`handle_requests`): finishes first, then pending starts in
the order they were asked, each granted as soon as it can start. An agent learns from the
world's snapshot whether its start request was granted, or refused for now (it then waits),
or withdrawn after its patience.

An action of several agents (a collaboration, thesis 6.3.3) starts when every one of them has
asked for it (a rendezvous: the parts are taken once) and ends when the last one finishes its
part; each agent is free again when its own part ends (the left arm of Fig. 7.3 leaves first).
A partner that arrives renews the patience of those already waiting for the action.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, replace

from hrc_drake.messages import WorldRequest, WorldSnapshot, shallow_copy
from hrc_drake.scheduling.flow import Buffer, FlowAction


@dataclass(frozen=True)
class Completion:
    """A finished action, as the world records it."""

    time: float
    agent: str
    action: str
    products: int


class CellWorld:
    """Parts in buffers, reservations of output room, and finished products."""

    def __init__(
        self, buffers: list[Buffer], actions: list[FlowAction], resources: dict[str, int] | None = None
    ):
        self.buffers = {b.name: b for b in buffers}
        self.parts = {b.name: int(b.initial) for b in buffers}
        self.actions = {a.name: a for a in actions}
        self.resource_free = dict(resources or {})
        self.reserved: Counter[str] = Counter()
        self.running: dict[str, str] = {}
        self.finished_products = 0
        self.completions: tuple[Completion, ...] = ()
        self.time = 0.0
        #: start requests not granted yet, by agent (at most one per agent)
        self.pending: dict[str, WorldRequest] = {}
        #: seq of the last start request granted / refused at least once / withdrawn, by agent
        self.granted: dict[str, int] = {}
        self.refused: dict[str, int] = {}
        self.withdrawn: dict[str, int] = {}
        #: action of several agents under way -> the agents still at work on it
        self.joint: dict[str, tuple[str, ...]] = {}

    def clone(self) -> CellWorld:
        """A copy an update may change (`hrc_drake.systems.Frozen`): copies the counters, shares the
        immutable description (buffers, actions) and the completions tuple."""
        other = shallow_copy(self)
        other.parts = dict(self.parts)
        other.resource_free = dict(self.resource_free)
        other.reserved = Counter(self.reserved)
        other.running = dict(self.running)
        other.pending = dict(self.pending)
        other.granted = dict(self.granted)
        other.refused = dict(self.refused)
        other.withdrawn = dict(self.withdrawn)
        other.joint = dict(self.joint)
        return other

    def is_joint(self, agent: str, action: str) -> bool:
        """Whether `action` is a flow action `agent` shares with other agents."""
        spec = self.actions.get(action)
        return spec is not None and len(spec.agents) > 1 and agent in spec.agents

    def next_deadline(self) -> float:
        """When the earliest pending start runs out of patience (inf: none does)."""
        return min((r.time + r.patience for r in self.pending.values()), default=float("inf"))

    def handle_requests(self, requests: list[WorldRequest], now: float | None = None) -> None:
        """Arbitrate the agents' new requests (any order): finishes first, then pending starts
        whose patience ran out by `now` (default: the latest request's time) are withdrawn,
        then every pending start, oldest first (ties by agent name), is granted when it can
        start now; a shared action when all its agents ask for it."""
        for request in sorted(requests, key=lambda r: (r.kind != "finish", r.time, r.agent, r.seq)):
            if request.kind == "finish":
                self.finish(request.agent, request.action, request.time)
            elif request.kind == "start":
                self._renew_partners(request)
                self.pending[request.agent] = request
            else:
                raise ValueError(f"world request of unknown kind {request.kind!r} from {request.agent!r}")
        if now is None:
            now = max((r.time for r in requests), default=self.time)
        for agent, request in list(self.pending.items()):
            if now >= request.time + request.patience:
                self.withdrawn[agent] = request.seq
                del self.pending[agent]
        for request in sorted(self.pending.values(), key=lambda r: (r.time, r.agent, r.seq)):
            if request.agent not in self.pending:  # granted with a partner earlier in this pass
                continue
            if self.is_joint(request.agent, request.action):
                started = self._try_start_joint(request.action)
            else:
                started = self.try_start(request.agent, request.action)
            if not started:
                self.refused[request.agent] = request.seq
            elif not self.is_joint(request.agent, request.action):
                self.granted[request.agent] = request.seq
                del self.pending[request.agent]

    def _renew_partners(self, request: WorldRequest) -> None:
        """An agent that asks with finite patience for a shared action renews the patience of its
        partners already waiting for it with finite patience: their wait counts from its arrival,
        as the net's give-up of a held action counts from the join (6.3.3)."""
        if not (math.isfinite(request.patience) and self.is_joint(request.agent, request.action)):
            return
        for agent, other in list(self.pending.items()):
            if agent != request.agent and other.action == request.action and math.isfinite(other.patience):
                renewed = max(other.patience, request.time + request.patience - other.time)
                self.pending[agent] = replace(other, patience=renewed)

    def _try_start_joint(self, action: str) -> bool:
        """Start a shared action when every one of its agents asks for it (rendezvous)."""
        agents = self.actions[action].agents
        if any(a not in self.pending or self.pending[a].action != action for a in agents):
            return False
        if not self.can_start(action):
            return False
        self._take(self.actions[action])
        for a in agents:
            self.running[a] = action
            self.granted[a] = self.pending.pop(a).seq
        self.joint[action] = tuple(dict.fromkeys(agents))
        return True

    def can_start(self, action: str) -> bool:
        """Whether `action`'s inputs are present, its outputs have room, its resources are free."""
        spec = self.actions[action]
        for name, needed in Counter(spec.inputs).items():
            if self.buffers[name].kind != "raw" and self.parts[name] < needed:
                return False
        for name, added in Counter(spec.outputs).items():
            buf = self.buffers[name]
            if buf.kind == "intermediate" and self.parts[name] + self.reserved[name] + added > buf.capacity:
                return False
        return all(self.resource_free.get(r, 0) > 0 for r in spec.resources)

    def try_start(self, agent: str, action: str) -> bool:
        """Start `action` by `agent` if it can start now; take its inputs and reserve its outputs."""
        if action not in self.actions:
            # Actions outside the flow (e.g. a robot's repositioning move) need no parts.
            self.running[agent] = action
            return True
        if self.is_joint(agent, action):
            raise ValueError(f"'{action}' is shared by {self.actions[action].agents}: it starts through "
                             "requests (handle_requests), when all of them ask for it")
        if not self.can_start(action):
            return False
        self._take(self.actions[action])
        self.running[agent] = action
        return True

    def _take(self, spec: FlowAction) -> None:
        for name in spec.inputs:
            if self.buffers[name].kind != "raw":
                self.parts[name] -= 1
        for name in spec.outputs:
            self.reserved[name] += 1
        for r in spec.resources:
            self.resource_free[r] -= 1

    def finish(self, agent: str, action: str, time: float | None = None) -> None:
        """Finish `agent`'s part of `action`: when no agent is left on it, put its output parts
        and free its reservations and resources."""
        if time is not None:
            self.time = time
        self.running.pop(agent, None)
        if action not in self.actions:
            return
        if action in self.joint:
            left = tuple(a for a in self.joint[action] if a != agent)
            if left:
                self.joint[action] = left
                return
            del self.joint[action]
        spec = self.actions[action]
        products = 0
        for name in spec.outputs:
            self.reserved[name] -= 1
            if self.buffers[name].kind == "product":
                products += 1
            else:
                self.parts[name] += 1
        for r in spec.resources:
            self.resource_free[r] += 1
        self.finished_products += products
        self.completions = self.completions + (Completion(self.time, agent, action, products),)

    def snapshot(self, time: float, activity: dict[str, str] | None = None) -> WorldSnapshot:
        return WorldSnapshot(
            time=time,
            buffers=dict(self.parts),
            activity=dict(activity if activity is not None else self.running),
            finished_products=self.finished_products,
            granted=dict(self.granted),
            refused=dict(self.refused),
            withdrawn=dict(self.withdrawn),
            joint=dict(self.joint),
        )
