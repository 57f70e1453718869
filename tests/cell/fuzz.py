"""Scenario mutations for the fuzz test: every leaf of a scenario file changed in type, sign,
to NaN, huge, empty or an unknown name, written back as YAML with its `!Kind` tags."""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from hrc_drake.cell.scenario import Tagged, _raw_document
from hrc_drake.cell.scenario import TaggedDumper as _Dumper

NUMBER_MUTATIONS = (("negative", lambda v: -abs(v) - 1), ("nan", lambda v: math.nan),
                    ("huge", lambda v: 1e12), ("zero", lambda v: 0), ("text", lambda v: "x"),
                    ("empty", lambda v: None))
TEXT_MUTATIONS = (("unknown", lambda v: "no_such_name"), ("empty", lambda v: ""), ("number", lambda v: 7),
                  ("list", lambda v: [v]))
LIST_MUTATIONS = (("empty", lambda v: []),)


def leaves(node, path=()):
    """(path, value) of every leaf and of every list (a list can be emptied), depth first."""
    if isinstance(node, dict):
        for key, value in node.items():
            yield from leaves(value, (*path, key))
    elif isinstance(node, list):
        yield path, node
        for k, value in enumerate(node):
            yield from leaves(value, (*path, k))
    else:
        yield path, node


def mutations(value):
    """(name, new value) of every mutation that applies to `value`."""
    if isinstance(value, bool):
        return [("text", "x"), ("number", 3)]
    if isinstance(value, (int, float)):
        return [(name, f(value)) for name, f in NUMBER_MUTATIONS]
    if isinstance(value, str):
        return [(name, f(value)) for name, f in TEXT_MUTATIONS]
    if isinstance(value, list):
        return [(name, f(value)) for name, f in LIST_MUTATIONS] if value else []
    return []


def _copy(node):
    if isinstance(node, Tagged):
        return Tagged(node.tag, {k: _copy(v) for k, v in node.items()})
    if isinstance(node, dict):
        return {k: _copy(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_copy(v) for v in node]
    return node


def _set(node, path, value):
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


def mutation_sites(path: Path) -> list[tuple[str, tuple, object]]:
    """(label, leaf path, new value) of every mutation of every leaf of the scenario at `path`."""
    document = _raw_document(Path(path).read_text())
    return [(f"{Path(path).name}:{'.'.join(map(str, where))}:{name}", where, new)
            for where, value in leaves(document) if where for name, new in mutations(value)]


def mutant_text(path: Path, where: tuple, new) -> str:
    """The scenario at `path` with the leaf at `where` set to `new`, as YAML."""
    mutant = _copy(_raw_document(Path(path).read_text()))
    _set(mutant, where, new)
    return yaml.dump(mutant, Dumper=_Dumper, sort_keys=False)
