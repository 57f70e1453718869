"""Ground truth of a cell: parts in buffers and who is doing what (pure Python core).

An action of the assembly flow (thesis Table 6.1) can start when each of its input buffers
holds a part and each of its output buffers has room, counting the room already promised to
actions under way. Starting takes the input parts; finishing puts the output parts.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from hrc_drake.messages import WorldSnapshot
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
        self.completions: list[Completion] = []
        self.time = 0.0

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
        self.completions.append(Completion(self.time, agent, action, products))

    def snapshot(self, time: float, activity: dict[str, str] | None = None) -> WorldSnapshot:
        return WorldSnapshot(
            time=time,
            buffers=dict(self.parts),
            activity=dict(activity if activity is not None else self.running),
            finished_products=self.finished_products,
        )
