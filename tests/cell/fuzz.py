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


def alias_bomb(levels: int = 9, width: int = 9) -> list:
    """A "billion laughs": lists sharing their items, `width ** levels` values once expanded;
    dumped as YAML, a few hundred bytes of anchors (`&id001`) and aliases (`*id001`)."""
    node = ["lol"] * width
    for _ in range(levels - 1):
        node = [node] * width
    return node


def alias_cycle() -> list:
    """A list holding itself twice: as YAML, aliases inside their own anchor."""
    node = []
    node += [node, node]
    return node


def alias_sites(path: Path) -> list[tuple[str, tuple, object]]:
    """(label, path, new value) of the alias mutants of the scenario at `path`: a bomb as each
    top-level field and as its deepest leaf, and a self-referring list."""
    document = _raw_document(Path(path).read_text())
    deepest = max((where for where, _ in leaves(document)), key=len)
    sites = [((key,), "alias_bomb", alias_bomb()) for key in document]
    sites += [(deepest, "alias_bomb", alias_bomb()), (deepest, "alias_cycle", alias_cycle())]
    name = Path(path).name
    return [(f"{name}:{'.'.join(map(str, where))}:{kind}", where, new) for where, kind, new in sites]


def campaign_mutants(path: Path) -> list[tuple[str, str]]:
    """(label, YAML text) of mutants of the campaign file at `path` that a campaign must refuse:
    bad seeds, run counts past MAX_RUNS, unknown or missing scenarios, wrong types, bad variants
    and metrics, and alias bombs as the spec and in a variant override. Its scenarios are named by
    absolute paths, so the text can be written anywhere."""
    from hrc_drake.campaign.spec import MAX_RUNS  # campaigns are not needed by scenario mutants

    document = _raw_document(Path(path).read_text())
    document["scenarios"] = [str((Path(path).parent / name).resolve()) for name in document["scenarios"]]
    variant = next(iter(document["variants"]))
    changes = {
        "seeds_negative": ("seeds", [-1]), "seeds_fraction": ("seeds", [1.5]),
        "seeds_2^32": ("seeds", [2**32]), "seeds_twice": ("seeds", [3, 3]), "seeds_empty": ("seeds", []),
        "seeds_text": ("seeds", "x"),
        "seeds_count_zero": ("seeds", {"count": 0}), "seeds_count_huge": ("seeds", {"count": 10**12}),
        "seeds_past_2^32": ("seeds", {"count": 5, "first": 2**32 - 2}),
        "runs_past_max": ("seeds", {"count": MAX_RUNS}),
        "seeds_unknown_key": ("seeds", {"count": 2, "step": 1}),
        "scenario_unknown": ("scenarios", ["no_such_scenario.yaml"]), "scenarios_empty": ("scenarios", []),
        "scenarios_text": ("scenarios", "x"), "scenarios_twice": ("scenarios", document["scenarios"] * 2),
        "duration_zero": ("duration", 0), "duration_nan": ("duration", math.nan),
        "duration_huge": ("duration", 1e12), "duration_text": ("duration", "x"),
        "name_empty": ("name", ""), "name_spaces": ("name", "a b"), "name_number": ("name", 7),
        "variants_empty": ("variants", {}), "variants_list": ("variants", [variant]),
        "variant_bad_name": ("variants", {"a b": {}}),
        "variant_sets_seed": ("variants", {variant: {"seed": 3}}),
        "variant_unknown_field": ("variants", {variant: {"no_such_field": 1}}),
        "variant_unknown_kind": ("variants", {variant: {"tracker": Tagged("NoSuchTracker", {})}}),
        "variant_text": ("variants", {variant: "x"}),
        "variant_alias_bomb": ("variants", {variant: {"operator": {"pattern": alias_bomb()}}}),
        "variant_alias_cycle": ("variants", {variant: {"operator": {"pattern": alias_cycle()}}}),
        "spec_alias_bomb": ("description", alias_bomb()),
        "metrics_unknown": ("metrics", ["no_such_metric"]), "metrics_mapping": ("metrics", {"a": 1}),
        "expect_unknown_variant": ("expect", [{"better": "no_such_variant", "than": variant}]),
        "replays_unknown_seed": ("replays", [{"variant": variant, "seed": 2**31}]),
        "replay_fps_zero": ("replay_fps", 0), "unknown_key": ("no_such_key", 1),
    }
    mutants = []
    for name, (key, value) in changes.items():
        mutant = _copy(document)
        mutant[key] = value
        mutants.append((f"{Path(path).name}:{name}", yaml.dump(mutant, Dumper=_Dumper, sort_keys=False)))
    return mutants
