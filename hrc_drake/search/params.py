"""Parameters of a search applied to a scenario document (the raw YAML of `cell.scenario`).

A path names one value of the document: keys joined by dots, a list element by its index
(`operator.base.xyz[0]`) or by its `name` (or `agent`) field (`layout.buffers[fused].position[1]`,
`robots[yumi].arms[yumi_left].program`). A candidate's values are written at their paths in a copy
of the document; its overrides (`cell.scenario.merge_raw`) are the top-level fields that changed,
each whole, so the scenario a run loads is exactly the document with the values written in.

A permutation (of a list of action names, e.g. `operator.pattern`) is encoded by random keys
(Bean 1994): one number in [0, 1) per element, decoded by a topological sort of the precedence
that takes, among the elements whose predecessors are placed, the one with the smallest key.
Every order that respects the precedence is the decoding of some keys, and no other is; the keys
are plain floats, so every Optuna sampler (TPE, CMA-ES, random) searches them.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass

from hrc_drake.cell.scenario import Tagged

_SEGMENT = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[[^\[\]]+\])*)$")
_INDEX = re.compile(r"\[([^\[\]]+)\]")


@dataclass(frozen=True)
class Step:
    """One step of a path: a mapping key (str) or a list element (int index, or a name)."""

    key: str | int
    by_name: bool = False

    def __str__(self) -> str:
        if isinstance(self.key, int) or self.by_name:
            return f"[{self.key}]"
        return f".{self.key}"


def parse_path(text: str) -> tuple[Step, ...]:
    """`a.b[2].c[name]` -> steps; ValueError naming the part that is not a path."""
    if not isinstance(text, str) or not text.strip():
        raise ValueError("a path is a non-empty text such as operator.base.xyz[0]")
    steps: list[Step] = []
    for part in text.split("."):
        match = _SEGMENT.match(part)
        if not match:
            raise ValueError(f"'{part}' is not a key with optional [index] or [name] parts")
        steps.append(Step(match.group(1)))
        for index in _INDEX.findall(match.group(2)):
            index = index.strip()
            if re.fullmatch(r"-?\d+", index):
                steps.append(Step(int(index)))
            else:
                steps.append(Step(index, by_name=True))
    return tuple(steps)


def format_path(steps) -> str:
    return "".join(str(s) for s in steps).lstrip(".")


def _child(node, step: Step, where: str):
    """(container, key) of `step` in `node`; KeyError naming what is missing."""
    if isinstance(step.key, int):
        if not isinstance(node, list):
            raise KeyError(f"{where} is not a list")
        if not -len(node) <= step.key < len(node):
            raise KeyError(f"{where} has {len(node)} elements, no [{step.key}]")
        return node, step.key % len(node)
    if step.by_name:
        if not isinstance(node, list):
            raise KeyError(f"{where} is not a list")
        for i, item in enumerate(node):
            if isinstance(item, dict) and step.key in (item.get("name"), item.get("agent")):
                return node, i
        names = [item.get("name", item.get("agent")) for item in node if isinstance(item, dict)]
        raise KeyError(f"{where} has no element named '{step.key}' (names: {names})")
    if not isinstance(node, dict):
        raise KeyError(f"{where} is not a mapping")
    return node, step.key


def get_value(document, steps, allow_missing_last: bool = False):
    """The value at `steps` in `document`; KeyError naming the first step that is not there.
    allow_missing_last: a last mapping key the document does not write gives None (the schema's
    default applies; the typed load checks that the key is a field)."""
    node = document
    where = "the scenario"
    for n, step in enumerate(steps):
        container, key = _child(node, step, where)
        where = format_path(steps[: n + 1])
        if isinstance(container, dict) and key not in container:
            if allow_missing_last and n == len(steps) - 1:
                return None
            raise KeyError(f"the scenario has no '{where}'")
        node = container[key]
    return node


def set_value(document, steps, value):
    """A copy of `document` with `value` at `steps` (the last mapping key may be new)."""
    out = copy.deepcopy(document)
    node = out
    where = "the scenario"
    for n, step in enumerate(steps):
        container, key = _child(node, step, where)
        where = format_path(steps[: n + 1])
        if n == len(steps) - 1:
            container[key] = copy.deepcopy(value)
            return out
        if isinstance(container, dict) and key not in container:
            raise KeyError(f"the scenario has no '{where}'")
        node = container[key]
    return out


def overrides_of(base: dict, document: dict) -> dict:
    """The top-level fields of `document` that differ from `base`, each whole (lists and tagged
    systems replace, so `merge_raw(base, overrides) == document`)."""
    return {
        key: copy.deepcopy(value)
        for key, value in document.items()
        if key not in base or not _same(base[key], value)
    }


def _same(a, b) -> bool:
    if isinstance(a, Tagged) or isinstance(b, Tagged):
        return isinstance(a, Tagged) and isinstance(b, Tagged) and a.tag == b.tag and dict(a) == dict(b)
    return type(a) is type(b) and a == b if not isinstance(a, (dict, list)) else a == b


def flow_precedence(document: dict, elements) -> set[tuple[str, str]]:
    """(a, b) pairs of `elements` (action names) where the flow makes b wait for a: a's outputs
    are b's inputs, directly or through other flow actions (the transitive closure)."""
    actions = ((document.get("flow") or {}).get("actions")) or []
    outputs = {a.get("name"): set(a.get("outputs") or []) for a in actions if isinstance(a, dict)}
    inputs = {a.get("name"): set(a.get("inputs") or []) for a in actions if isinstance(a, dict)}
    feeds = {a: {b for b in inputs if b != a and outputs[a] & inputs[b]} for a in outputs}
    wanted = set(elements)
    out = set()
    for a in wanted & set(feeds):
        seen, frontier = set(), list(feeds[a])
        while frontier:
            b = frontier.pop()
            if b in seen:
                continue
            seen.add(b)
            frontier += feeds.get(b, ())
        out |= {(a, b) for b in seen & wanted if b != a}
    return out


def acyclic(elements, precedence) -> bool:
    """Whether `precedence` over `elements` has an order (no cycle)."""
    return decode_permutation(elements, precedence, [0.0] * len(elements)) is not None


def decode_permutation(elements, precedence, keys):
    """The order of `elements` that respects `precedence` ({(a, b): a before b}), taking at each
    step the placeable element with the smallest key (ties: the listed order); None on a cycle."""
    elements = list(elements)
    key_of = dict(zip(elements, keys, strict=True))
    before = {e: {a for a, b in precedence if b == e} for e in elements}
    placed: list[str] = []
    left = list(elements)
    while left:
        ready = [e for e in left if before[e] <= set(placed)]
        if not ready:
            return None
        best = min(ready, key=lambda e: (key_of[e], elements.index(e)))
        placed.append(best)
        left.remove(best)
    return placed


def respects(order, precedence) -> bool:
    position = {e: i for i, e in enumerate(order)}
    return all(position[a] < position[b] for a, b in precedence if a in position and b in position)
