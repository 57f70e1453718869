"""Ground truth of a cell: parts in buffers and who is doing what (pure Python core).

An action of the assembly flow (thesis Table 6.1) can start when each of its input buffers
holds a part and each of its output buffers has room, counting the room already promised to
actions under way. Starting takes the input parts; finishing puts the output parts.

In a cell the agents do not touch the world: they send `WorldRequest`s (start / finish) and the
world, one system, arbitrates them (`handle_requests`): finishes first, then pending starts in
the order they were asked, each granted as soon as it can start. An agent learns from the
world's snapshot whether its start request was granted, or refused for now (it then waits).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

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
        #: seq of the last start request granted / refused at least once, by agent
        self.granted: dict[str, int] = {}
        self.refused: dict[str, int] = {}

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
        return other

    def handle_requests(self, requests: list[WorldRequest]) -> None:
        """Arbitrate the agents' new requests (any order): finishes first, then every pending
        start, oldest first (ties by agent name), granted when it can start now."""
        for request in sorted(requests, key=lambda r: (r.kind != "finish", r.time, r.agent, r.seq)):
            if request.kind == "finish":
                self.finish(request.agent, request.action, request.time)
            elif request.kind == "start":
                self.pending[request.agent] = request
            else:
                raise ValueError(f"world request of unknown kind {request.kind!r} from {request.agent!r}")
        for request in sorted(self.pending.values(), key=lambda r: (r.time, r.agent, r.seq)):
            if self.try_start(request.agent, request.action):
                self.granted[request.agent] = request.seq
                del self.pending[request.agent]
            else:
                self.refused[request.agent] = request.seq

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
        if not self.can_start(action):
            return False
        spec = self.actions[action]
        for name in spec.inputs:
            if self.buffers[name].kind != "raw":
                self.parts[name] -= 1
        for name in spec.outputs:
            self.reserved[name] += 1
        for r in spec.resources:
            self.resource_free[r] -= 1
        self.running[agent] = action
        return True

    def finish(self, agent: str, action: str, time: float | None = None) -> None:
        """Finish `action`: put its output parts, free its reservations and resources."""
        if time is not None:
            self.time = time
        self.running.pop(agent, None)
        if action not in self.actions:
            return
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
        )
