"""Load and check scenario files (DESIGN.md "Scenario files").

The YAML is read with pydrake's typed loader into the dataclasses of `schema`. Before that, a
walk over the raw document names the path of any unknown key; after it, semantic checks name
the field at fault. Every problem raises `ScenarioError(file, field path, reason)`.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
import re
import types
import typing
from pathlib import Path

import numpy as np
import yaml
from pydrake.common.yaml import yaml_load_typed

from hrc_drake.cell import schema
from hrc_drake.cell.schema import SYSTEM_FIELDS, Scenario
from hrc_drake.config_common import (
    MAX_ACTION_DURATION,
    MAX_ANGLE,
    MAX_CAMERA_NOISE,
    MAX_CELL_COORDINATE,
    MAX_GOAL_RADIUS,
    MAX_OBJECT_SIZE,
    MAX_PART_MASS,
    MAX_PARTS,
    MAX_SAFETY_DISTANCE,
    MAX_SEGMENT_LENGTH,
    MAX_SIMULATED_DURATION,
    MAX_TIME_STEP,
    MIN_TIME_STEP,
)
from hrc_drake.distributions import Distribution, validate_distribution
from hrc_drake.errors import (
    ConfigError,
    ScenarioError,
    check_input_file,
    yaml_syntax_error,
)
from hrc_drake.human.config import HIP_HEIGHT_RANGE
from hrc_drake.untrusted import UniqueKeyLoader, unique_key_mapping

BUFFER_KINDS = ("raw", "intermediate", "product")
ROBOT_MODES = ("kinematic", "dynamic")
HANDS = ("left", "right", "both")
#: The largest scenario file read (bytes): scenarios are a few kB, and PyYAML takes minutes
#: and gigabytes on a file of tens of MB.
MAX_SCENARIO_BYTES = 2_000_000
#: the sources of the human events the predictor and the scheduler read
HUMAN_EVENT_SOURCES = ("auto", "perceived", "truth")


#: longest recording of the operator for the segmenter's library (s of simulated work)
SEGMENTER_LIBRARY_SECONDS = 1800.0
#: m/s, the fastest a synthetic operator's wrist may reach (its peak): fast human reaching peaks
#: near 3-4 m/s; ISO 13855's 2.0 m/s is the approach speed S_p assumes, not a bound on the hand
MAX_WRIST_SPEED = 4.0
#: the operator's wrist stops this far above a buffer's base when picking or placing a part
HAND_ABOVE_BUFFER = np.array([0.0, 0.0, 0.06])


def operator_places(scenario: Scenario) -> dict[str, np.ndarray]:
    """Where the operator's wrist goes for each goal sphere and buffer."""
    places = {g.name: np.asarray(g.center, float) for g in scenario.layout.goals}
    places.update(
        {b.name: np.asarray(b.position, float) + HAND_ABOVE_BUFFER for b in scenario.layout.buffers}
    )
    return places


def scenario_relative(scenario_path: str | Path, name: str) -> Path:
    """A file named in a scenario: relative to the scenario's folder (the working folder for a
    scenario built in code)."""
    base = Path(scenario_path).parent if str(scenario_path) != "<scenario>" else Path.cwd()
    return (base / name).resolve()


class Tagged(dict):
    """A YAML mapping written with a tag (`!ClassName {...}`): the tag chooses a Union member."""

    def __init__(self, tag: str, mapping: dict):
        super().__init__(mapping)
        self.tag = tag


class _ScenarioYamlLoader(UniqueKeyLoader):
    """Safe YAML that keeps `!Tag` mappings as `Tagged` and refuses duplicate keys
    (`untrusted.UniqueKeyLoader`: libyaml's C parser where PyYAML has it, about ten times faster
    than the pure-Python one)."""


def _tagged(loader, suffix, node):
    if isinstance(node, yaml.MappingNode):
        return Tagged(suffix, unique_key_mapping(loader, node, deep=True))
    if isinstance(node, yaml.ScalarNode) and node.value == "":
        return Tagged(suffix, {})
    raise yaml.constructor.ConstructorError(
        None, None, f"the tag !{suffix} must mark a mapping", node.start_mark
    )


_ScenarioYamlLoader.add_multi_constructor("!", _tagged)


def _raw_document(text: str, file: str | Path = "<scenario>", marks: dict | None = None):
    """The document as plain mappings, lists and scalars, only to name the field at fault in
    errors (safe constructors only: `_ScenarioYamlLoader` is a SafeLoader). The scenario itself
    is read by pydrake's typed loader. Checked by `_check_shape` before it is built, so
    `ScenarioError(file, ...)` when it nests too deeply or its aliases expand it too far.
    `marks`, when given, gets each field path's (line, column) in the text (`_node_marks`)."""
    loader = _ScenarioYamlLoader(text)
    try:
        try:
            node = loader.get_single_node()
        except yaml.YAMLError as err:
            # libyaml >= 0.2.5 (PyYAML 6.0.4) stops at its own depth limit, which lies beyond ours
            if "nesting depth" in str(err):
                raise ScenarioError(file, "", f"nested too deeply (more than {MAX_NESTING} levels of lists "
                                              "and mappings)") from None
            raise
        if node is None:
            return None
        _check_shape(node, file)
        if marks is not None:
            _node_marks(node, "", marks, set())
        return loader.construct_document(node)
    finally:
        loader.dispose()


#: Deepest nesting of mappings and lists a scenario may have (the shipped ones have 6).
MAX_NESTING = 50
#: Most nodes (scalars, lists, mappings) the aliases (`*name`) of a document may add when expanded:
#: 100x the largest shipped file (about 1,100 nodes, no aliases). pydrake's typed loader expands
#: aliases and reads 100,000 nodes in about 0.4 s; a "billion laughs" of a few hundred bytes adds
#: 10^9. The nodes written out in the file are bounded by MAX_SCENARIO_BYTES instead.
MAX_EXPANDED_NODES = 100_000


def _children(node) -> list:
    """The nodes directly under a composed YAML node (a mapping's keys and values, in order)."""
    if isinstance(node, yaml.MappingNode):
        return [child for pair in node.value for child in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def _field_path(stack: list) -> str:
    """The field path (`layout.buffers[0]`) of the node on top of `_check_shape`'s stack."""
    parts = []
    for parent, children, k in stack[:-1]:  # k - 1: the child being walked
        if isinstance(parent, yaml.SequenceNode):
            parts.append(f"[{k - 1}]")
        else:
            key = children[(k - 1) // 2 * 2]
            name = key.value if isinstance(key, yaml.ScalarNode) else "<key>"
            parts.append(("." if parts else "") + str(name))
    return "".join(parts)


def _node_marks(node, path: str, marks: dict, seen: set) -> None:
    """Each field path under `node` (`layout.buffers[0].capacity`, as errors name them) -> its
    (line, column), 1-based: a value's where it starts on its key's line, else the key's. An
    aliased node is walked once (`_check_shape` bounds the rest)."""
    if id(node) in seen:
        return
    seen.add(id(node))
    if isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            if not isinstance(key, yaml.ScalarNode):
                continue
            sub = f"{path}.{key.value}" if path else str(key.value)
            mark = value.start_mark if value.start_mark.line == key.start_mark.line else key.start_mark
            marks.setdefault(sub, (mark.line + 1, mark.column + 1))
            _node_marks(value, sub, marks, seen)
    elif isinstance(node, yaml.SequenceNode):
        for k, item in enumerate(node.value):
            sub = f"{path}[{k}]"
            marks.setdefault(sub, (item.start_mark.line + 1, item.start_mark.column + 1))
            _node_marks(item, sub, marks, seen)


def located(err: ScenarioError, file, marks: dict) -> ScenarioError:
    """`err` with the line and column of its field in `file` (`_node_marks`), when it names that
    file and the field (or, for a value left at its default, its parent) is written there."""
    if err.line is None and err.field and err.file == str(file):
        field = err.field.split(" ", 1)[0]
        cut = max(field.rfind("."), field.rfind("["))
        mark = marks.get(field) or (marks.get(field[:cut]) if cut > 0 else None)
        if mark is not None:
            err.at(*mark)
    return err


def _check_shape(root, file) -> None:
    """Refuse a composed YAML document nesting deeper than MAX_NESTING, or whose aliases add more
    than MAX_EXPANDED_NODES values when expanded or refer to what holds them; name the field.

    An alias is its anchor's node object, so each node is visited once and its expanded size and
    depth memoised: the cost is the file's size, never the expansion (no recursion either)."""
    shape: dict[int, tuple[int, int]] = {}  # id(node) -> (nodes with aliases expanded, depth)
    added = 0  # values the aliases met so far add when expanded
    open_nodes = {id(root)}
    stack = [[root, _children(root), 0]]  # node, its children, the next child to walk
    while stack:
        frame = stack[-1]
        node, children, k = frame
        if k < len(children):
            frame[2] += 1
            child = children[k]
            if id(child) in open_nodes:
                raise ScenarioError(file, _field_path(stack),
                                    "an alias (*name) refers to the list or mapping that holds it")
            if id(child) in shape:  # seen before: an alias
                added += shape[id(child)][0]
                if added > MAX_EXPANDED_NODES:
                    raise ScenarioError(file, _field_path([*stack, None]),
                                        f"the aliases (*name) up to this one expand to {added:,} values, "
                                        f"more than {MAX_EXPANDED_NODES:,}: write the values out or use "
                                        "fewer aliases")
            else:
                open_nodes.add(id(child))
                stack.append([child, _children(child), 0])
            continue
        sizes = [shape[id(c)] for c in children]
        depth = (1 + max((d for _, d in sizes), default=0)) if isinstance(node, yaml.CollectionNode) else 0
        if depth > MAX_NESTING:
            raise ScenarioError(file, "", f"nested too deeply (more than {MAX_NESTING} levels of lists "
                                          "and mappings)")
        shape[id(node)] = (1 + sum(n for n, _ in sizes), depth)
        open_nodes.discard(id(node))
        stack.pop()


def _union_members(tp) -> tuple:
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return tuple(a for a in typing.get_args(tp) if a is not type(None))
    return ()


def _unwrap_optional(tp):
    members = _union_members(tp)
    return members[0] if len(members) == 1 else tp


def _check_union(node, members: tuple, path: str, file: str) -> None:
    """A system field: a `!Kind {...}` mapping naming one of `members`."""
    names = {m.__name__: m for m in members}
    tags = ", ".join(f"!{n}" for n in names)
    if isinstance(node, Tagged):
        if node.tag not in names:
            raise ScenarioError(file, path, f"unknown kind !{node.tag} (one of {tags})")
        _check_keys(dict(node), names[node.tag], path, file)
        return
    if isinstance(node, dict) and "kind" in node:
        from hrc_drake.cell.legacy import new_spelling

        raise ScenarioError(
            file,
            path,
            "the old spelling {kind: ..., params: ...} is no longer read; write instead:  "
            + new_spelling(path, node),
        )
    raise ScenarioError(
        file, path, f"choose a kind with a tag, e.g. {path}: !{next(iter(names))} {{}} ({tags})"
    )


def _reads_as_number(text: str) -> bool:
    """Whether `text` is a number in exponent form that YAML 1.1 leaves a string (1e3, 1.0e12)."""
    return re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+", text.strip()) is not None


def _check_keys(node, cls, path: str, file: str) -> None:
    """Walk the raw YAML against the dataclass tree; raise on unknown keys and wrong shapes."""
    members = _union_members(cls)
    if len(members) > 1 and all(dataclasses.is_dataclass(m) for m in members):
        _check_union(node, members, path, file)
        return
    if node is None and type(None) in typing.get_args(cls):
        return  # an optional field left unset (null)
    cls = _unwrap_optional(cls)
    if dataclasses.is_dataclass(cls):
        if node is None:
            return
        if isinstance(node, Tagged) and node.tag != cls.__name__:
            raise ScenarioError(
                file, path or "<top>", f"unexpected tag !{node.tag} (expected a {cls.__name__})"
            )
        if not isinstance(node, dict):
            raise ScenarioError(file, path or "<top>", f"expected a mapping, got {type(node).__name__}")
        hints = typing.get_type_hints(cls)
        for key, value in node.items():
            sub = f"{path}.{key}" if path else str(key)
            if key not in hints:
                known = ", ".join(sorted(hints))
                raise ScenarioError(file, sub, f"unknown key '{key}' (known keys: {known})")
            _check_keys(value, hints[key], sub, file)
    elif typing.get_origin(cls) is list:
        if node is None:
            return
        if not isinstance(node, list):
            # a patch by name whose list no base holds (this file extends none, or gives it whole)
            hint = (": a mapping by item name patches a list only in a file that `extends:` one "
                    "holding it" if isinstance(node, dict) and not isinstance(node, Tagged) else "")
            raise ScenarioError(file, path, f"expected a list, got {type(node).__name__}{hint}")
        (item,) = typing.get_args(cls)
        for i, value in enumerate(node):
            _check_keys(value, item, f"{path}[{i}]", file)
    elif typing.get_origin(cls) is dict:
        if not isinstance(node, dict):
            raise ScenarioError(file, path, f"expected a mapping, got {type(node).__name__}")
        _, value_type = typing.get_args(cls)
        for key, value in node.items():
            _check_keys(value, value_type, f"{path}.{key}", file)
    elif cls in (float, int):
        if isinstance(node, str) and _reads_as_number(node):
            raise ScenarioError(file, path, f"expected a number, got the text {node!r}: YAML 1.1 reads an "
                                            "exponent as a number only with a dot and a sign (1.0e+12)")
        if isinstance(node, bool) or not isinstance(node, (int, float)):
            raise ScenarioError(file, path, f"expected a number, got {node!r}")
        if cls is int and isinstance(node, float) and not node.is_integer():
            raise ScenarioError(file, path, f"expected an integer, got {node!r}")
        if isinstance(node, float) and not math.isfinite(node):
            raise ScenarioError(file, path, f"expected a finite number, got {node!r}")
    elif cls is str:
        if not isinstance(node, str):
            raise ScenarioError(file, path, f"expected a string, got {node!r}")
    elif cls is bool:
        if not isinstance(node, bool):
            raise ScenarioError(file, path, f"expected true or false, got {node!r}")


#: How many files a chain of `extends` may have.
MAX_EXTENDS = 8


def load_scenario(path: str | Path, check_reachability: bool = False, _chain: tuple = ()) -> Scenario:
    """Read, type and check a scenario file; raise `ScenarioError` on any problem.

    `path` is a file, or the bare name of a shipped example (`load_scenario("torch_clock")`,
    `shipped.resolve`: an existing file of that name wins). The scenario remembers the file it was
    read from (`Scenario.source_path`), so that `build_cell(load_scenario(path))` reads the files
    it names from that file's folder."""
    path = resolve_scenario(path) if not _chain else Path(path)
    check_input_file(path)
    size = path.stat().st_size
    if size > MAX_SCENARIO_BYTES:
        raise ScenarioError(path, "", f"{size / 1e6:.1f} MB is too large for a scenario (at most "
                                      f"{MAX_SCENARIO_BYTES / 1e6:g} MB; data go in their own files)")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as err:
        raise ScenarioError(path, "", f"not UTF-8 text (byte {err.start}): save the file as UTF-8") from None
    return _load_text(path, text, check_reachability, _chain)


def _load_text(path: Path, text: str, check_reachability: bool = False, _chain: tuple = (),
               _unwritten: frozenset = frozenset(), _locate: bool = True) -> Scenario:
    """`load_scenario`'s steps on `text`, read as the file `path` (relative names from its folder);
    files in `_unwritten` (resolved paths a command has yet to write) are not opened. An error
    of a field written in the text names its line and column (`located`) unless `_locate` is
    false (a text made from the file, whose lines are not the file's)."""
    marks: dict = {}
    try:
        return _load_marked(path, text, marks, check_reachability, _chain, _unwritten)
    except ScenarioError as err:
        if _locate:
            located(err, path, marks)
        raise


def _load_marked(path: Path, text: str, marks: dict, check_reachability: bool = False, _chain: tuple = (),
                 _unwritten: frozenset = frozenset()) -> Scenario:
    """`_load_text`'s steps, filling `marks` (`_node_marks`) as it reads the text."""
    try:
        raw = _raw_document(text, path, marks)
    except yaml.YAMLError as err:
        raise yaml_syntax_error(path, err) from None
    except RecursionError:
        raise ScenarioError(path, "", "nested too deeply to be a scenario") from None
    if not isinstance(raw, dict):
        raise ScenarioError(path, "", "the top level must be a mapping of scenario fields")
    lists = _ListsOfExtends()
    base = None
    if isinstance(raw.get("extends"), str):  # else _check_keys names what it is
        base = _extended(path, raw["extends"], _chain)
        if base is not None:
            # before the key check: a mapping by name stands for a list until it is patched in
            try:
                raw = _resolve_patches(raw, base, Scenario, "", lists)
            except ConfigError as err:
                raise ScenarioError(path, err.field, err.reason) from None
            if lists.patched:
                text = dump_raw(raw)
    _check_keys(raw, Scenario, "", str(path))
    if base is not None:
        # a tagged system given here replaces the base's whole (the loader would merge into an
        # instance of a parent type, e.g. !WorstCaseMotionModel into a GPMotionModel)
        defaults = Scenario()
        for name in SYSTEM_FIELDS:
            if name in raw:
                setattr(base, name, getattr(defaults, name))
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text, defaults=base)
    except (RuntimeError, ValueError, TypeError) as err:
        raise ScenarioError(path, "", f"cannot be read as a scenario: {err}") from err
    scenario.extends = ""  # the fields are merged in: the result stands alone
    # not a field (a file cannot set it): the file read, whatever the base it extends
    scenario.source_path = Path(os.path.abspath(path))
    try:
        check_scenario(scenario, path)
        check_referenced_files(scenario, path, _unwritten)
        if check_reachability:
            from hrc_drake.robots.poses import solve_named_poses  # IK: pydrake's solvers, only when asked

            solve_named_poses(scenario.robots, path)
    except ScenarioError as err:
        # a list given whole may have left out what the error misses: say how to patch instead
        note = lists.note(err.field, raw.get("extends"))
        if not note:
            raise
        raise ScenarioError(err.file, err.field, err.reason + note) from None
    return scenario


def check_scenario_text(text: str, path: str | Path, unwritten=()) -> Scenario:
    """The scenario the YAML `text` would be as the file `path`, read, typed and checked as
    `load_scenario` would, before anything is written (`hrc-drake import --cell`); relative names
    resolve from `path`'s folder, which need not exist yet. Files in `unwritten` (outputs the
    caller has yet to write, such as the recorded skeleton) are not opened. ScenarioError on any
    problem, naming `path` (or the file `extends` names, for its own)."""
    path = Path(path)
    pending = frozenset(Path(os.path.abspath(p)).resolve() for p in unwritten)
    return _load_text(path, text, _unwritten=pending)


def resolve_scenario(name: str | Path) -> Path:
    """The scenario file `name` means: itself, or the shipped example of that bare name
    (`shipped.resolve`); ScenarioError naming where it looked and the examples there are."""
    from hrc_drake.cell.shipped import resolve

    return resolve(name, "scenario")


def load_typed(schema, text: str):
    """`text` read into the dataclass `schema` by pydrake's typed YAML loader (the one scenarios
    use), for other typed files such as campaign specs; raises its RuntimeError / ValueError."""
    return yaml_load_typed(schema=schema, data=text)


class TaggedDumper(yaml.SafeDumper):
    """Safe YAML out, with `Tagged` mappings as `!Kind {...}` (the inverse of `_raw_document`)."""


TaggedDumper.add_representer(Tagged, lambda d, t: d.represent_mapping("!" + t.tag, dict(t)))


def dump_raw(document) -> str:
    """A raw document (mappings, lists, scalars, `Tagged`) as YAML text."""
    return yaml.dump(document, Dumper=TaggedDumper, sort_keys=False)


def _plain_mapping(node) -> bool:
    return isinstance(node, dict) and not isinstance(node, Tagged)


def merge_raw(base, overrides, path: str = ""):
    """`overrides` merged into a copy of the raw document `base`: a plain mapping merges key by key
    (recursively), and into a list of named items patches the items it names (`patch_items`); a
    tagged mapping (a system chosen by `!Kind`), a list or a scalar replaces. ConfigError naming
    the field (under `path`) for a patch that names no item or several."""
    if _plain_mapping(overrides) and _plain_mapping(base):
        out = dict(base)
        for key, value in overrides.items():
            sub = f"{path}.{key}" if path else str(key)
            out[key] = merge_raw(base[key], value, sub) if key in base else copy.deepcopy(value)
        return out
    if _plain_mapping(overrides) and isinstance(base, list):
        return patch_items(base, overrides, path)
    return copy.deepcopy(overrides)


#: the fields that name the items of a list, in the order tried (a robot's arms go by `agent`)
ITEM_NAMES = ("name", "agent")


def patch_items(items: list, patch: dict, path: str) -> list:
    """The raw list `items` with each entry of `patch` (item name -> fields to change) merged into
    the one item of that name (`merge_raw`), the other items kept as they are. ConfigError naming
    the field for a name no item or several items have, a list of plain values or a rename."""
    key = next((k for k in ITEM_NAMES if items and all(_plain_mapping(i) and k in i for i in items)), None)
    if key is None and items:
        if not all(_plain_mapping(i) for i in items):
            shown = ", ".join(repr(i) for i in items[:4]) + (", ..." if len(items) > 4 else "")
            raise ConfigError(path, f"a mapping patches the items of a list by name, and {path} is a list of "
                                    f"plain values [{shown}]: give the whole list (a list replaces the "
                                    "parent's)")
        raise ConfigError(path, f"a mapping patches the items of a list by name, and the items of {path} "
                                "have no name: give the whole list (a list replaces the parent's)")
    key = key or "name"
    names = [item[key] for item in items]
    out = list(items)
    for name, fields in patch.items():
        where = f"{path}.{name}"
        hits = [k for k, n in enumerate(names) if n == name]
        if not hits:
            known = ", ".join(map(str, names)) if names else "none, the list is empty"
            raise ConfigError(where, f"no item of {path} is named '{name}' (its {key}s: {known}); a mapping "
                                     "patches existing items: to add or remove one, give the whole list")
        if len(hits) > 1:
            raise ConfigError(where, f"'{name}' names {len(hits)} items of {path} "
                                     f"({', '.join(f'[{k}]' for k in hits)}): a mapping patches one item by "
                                     "a name of its own; give the whole list instead")
        if not _plain_mapping(fields):
            raise ConfigError(where, f"expected a mapping of the fields of {path}[{hits[0]}] to change, got "
                                     f"{fields!r}")
        if fields.get(key, name) != name:
            raise ConfigError(f"{where}.{key}", f"a patch by name cannot rename its item ('{name}' -> "
                                                f"'{fields[key]}'): give the whole list")
        out[hits[0]] = merge_raw(items[hits[0]], fields, where)
    return out


class _ListsOfExtends:
    """What `_resolve_patches` did to the lists of an extending file: whether it patched one by
    name, and the lists of named items it gave whole (path, the parent's names it left out)."""

    def __init__(self):
        self.patched = False
        self.replaced: list[tuple[str, list, list]] = []  # path, the parent's names left out, names given

    def note(self, field: str, parent) -> str:
        """What to add to an error at `field`: the replaced lists that left out items of the
        parent or hold the field, and how to patch an item instead; "" for none."""
        def holds(p):
            return field == p or field.startswith((p + "[", p + "."))

        lists = [entry for entry in self.replaced if entry[1] or holds(entry[0])]
        if not lists:
            return ""
        said = "; ".join(f"{p} (without the parent's {', '.join(map(str, dropped))})" if dropped else p
                         for p, dropped, _ in lists)
        p, dropped, given = lists[0]
        example = "{" + str((given or dropped)[0]) + ": {...}}"
        for part in reversed(p.split(".")):
            example = f"{{{part}: {example}}}"
        return (f" [note: this file gives the whole list {said}, which replaced the one of {parent}: "
                f"`extends:` replaces a list given as a list; a mapping by name patches the items it "
                f"names and keeps the others, e.g. {example[1:-1]}]")


def _raw_of(value, tp):
    """A typed scenario value as the raw document that reads back to it (a system's kind tagged)."""
    members = _union_members(tp)
    if len(members) > 1 and all(dataclasses.is_dataclass(m) for m in members):
        return Tagged(type(value).__name__, _raw_of(value, type(value)))
    if value is None:
        return None
    if dataclasses.is_dataclass(value):
        hints = typing.get_type_hints(type(value))
        return {f.name: _raw_of(getattr(value, f.name), hints[f.name]) for f in dataclasses.fields(value)}
    args = typing.get_args(_unwrap_optional(tp))
    if isinstance(value, list):
        return [_raw_of(v, args[0] if args else object) for v in value]
    if isinstance(value, dict):
        return {k: _raw_of(v, args[1] if len(args) == 2 else object) for k, v in value.items()}
    return value


def _resolve_patches(node, base, tp, path: str, lists: _ListsOfExtends):
    """The extending file's raw `node` (of schema type `tp`) where each plain mapping given for a
    list of `base` (the typed value it extends) is that list with the items it names patched
    (`patch_items`); the rest as written, for the typed loader to merge into `base`. Records in
    `lists` the patches and the lists of named items given whole."""
    if len(_union_members(tp)) > 1:  # a tagged system replaces the base's whole
        return node
    tp = _unwrap_optional(tp)
    if dataclasses.is_dataclass(tp):
        if not _plain_mapping(node) or not dataclasses.is_dataclass(base):
            return node
        hints = typing.get_type_hints(tp)
        return {key: _resolve_patches(value, getattr(base, key, None), hints[key],
                                      f"{path}.{key}" if path else str(key), lists) if key in hints else value
                for key, value in node.items()}
    if typing.get_origin(tp) is list and isinstance(base, list):
        (item,) = typing.get_args(tp)
        if _plain_mapping(node):
            lists.patched = True
            return patch_items([_raw_of(v, item) for v in base], node, path)
        fields = typing.get_type_hints(item) if dataclasses.is_dataclass(item) else {}
        key = next((k for k in ITEM_NAMES if k in fields), None)
        if isinstance(node, list) and base and key:
            given = [i.get(key) for i in node if _plain_mapping(i)]
            left_out = [getattr(b, key) for b in base if getattr(b, key) not in given]
            lists.replaced.append((path, left_out, given))
        return node
    if typing.get_origin(tp) is dict and _plain_mapping(node) and isinstance(base, dict):
        value_type = typing.get_args(tp)[1]
        return {key: _resolve_patches(value, base.get(key), value_type, f"{path}.{key}", lists)
                for key, value in node.items()}
    return node


def load_scenario_with(
    path: str | Path, overrides: dict, check_reachability: bool = False, check_file_alone: bool = True
) -> Scenario:
    """The scenario file `path` with `overrides` (a raw document, `merge_raw`) applied before the
    typed load and the checks, as if the file said so; relative names resolve from its folder.

    check_file_alone: load the file without the overrides first, so that its own problems are
    named as its own; a caller that has just loaded it (a campaign) skips that second load.
    `path` may be the bare name of a shipped example, as for `load_scenario`."""
    path = resolve_scenario(path)
    if not overrides:
        return load_scenario(path, check_reachability)
    if not isinstance(overrides, dict) or isinstance(overrides, Tagged):
        raise ScenarioError(path, "", f"overrides must be a mapping of scenario fields, got {overrides!r}")
    if check_file_alone:
        load_scenario(path)  # the file alone first: its own problems are named as its own
    raw = _raw_document(path.read_bytes().decode("utf-8"), path)
    try:
        merged = merge_raw(raw, overrides)
    except ConfigError as err:
        raise ScenarioError(path, err.field, f"{err.reason} (in the overrides)") from None
    # the merged text's lines are not the file's: its errors name no line
    return _load_text(path, dump_raw(merged), check_reachability, _locate=False)


def _extended(path: Path, extends, chain: tuple) -> Scenario | None:
    """The scenario `path` extends (loaded and checked on its own), or None."""
    if extends is None or extends == "":
        return None
    if not isinstance(extends, str):
        raise ScenarioError(path, "extends", f"must be the name of a scenario file, got {extends!r}")
    base = scenario_relative(path, extends)
    chain = (*chain, path.resolve())
    if base.resolve() in chain:
        raise ScenarioError(path, "extends", f"{base} extends itself through {[str(p) for p in chain]}")
    if len(chain) >= MAX_EXTENDS:
        raise ScenarioError(path, "extends", f"more than {MAX_EXTENDS} files extend one another")
    if not base.is_file():
        raise ScenarioError(path, "extends", f"no such file: {base}")
    # relative file names of the base (recorded data, models) stay relative to this file's folder
    return copy.deepcopy(load_scenario(base, _chain=chain))


def check_referenced_files(sc: Scenario, file: str | Path, unwritten=frozenset()) -> None:
    """Open the files a scenario names and check their contents as the build would: the
    recorded skeleton CSV (`human.recorded.load_skeleton_csv`) and the intention model
    (`IntentionModel.load`), each relative to the scenario's folder. A file in `unwritten`
    (resolved paths a command is about to write, `check_scenario_text`) is not opened."""
    if sc.operator.recorded and scenario_relative(file, sc.operator.recorded) not in unwritten:
        from hrc_drake.human.recorded import load_skeleton_csv

        recorded = scenario_relative(file, sc.operator.recorded)
        if not recorded.is_file():
            raise ScenarioError(file, "operator.recorded", f"no such file: {recorded}")
        try:
            load_skeleton_csv(recorded)
        except ValueError as err:
            raise ScenarioError(file, "operator.recorded", str(err)) from None
    model = getattr(sc.intention, "model", "")
    if model and scenario_relative(file, model) not in unwritten:
        from hrc_drake.intention.likelihood import IntentionModel

        try:
            IntentionModel.load(scenario_relative(file, model))
        except ValueError as err:
            raise ScenarioError(file, "intention.model", str(err)) from None


def _check_vec(file, field, values, n=3, bound=MAX_CELL_COORDINATE, unit="m"):
    """`n` finite numbers of magnitude at most `bound` (a plausibility range, config_common)."""
    if len(values) != n:
        raise ScenarioError(file, field, f"expected {n} numbers, got {len(values)}")
    for k, value in enumerate(values):
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise ScenarioError(file, f"{field}[{k}]", f"must be a finite number, got {value!r}")
        if abs(value) > bound:
            raise ScenarioError(file, f"{field}[{k}]", f"{value:g} {unit} is implausible (at most "
                                                       f"{bound:g} {unit} in magnitude)")


def _check_pose(file, field, pose):
    _check_vec(file, f"{field}.xyz", pose.xyz)
    _check_vec(file, f"{field}.rpy", pose.rpy, bound=MAX_ANGLE, unit="rad")


def _in_range(file, field, value, low, high, unit=""):
    """A finite number in [low, high] (a plausibility range where it bounds a physical quantity)."""
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            and low <= value <= high):
        raise ScenarioError(file, field, f"must be in [{low:g}, {high:g}]{' ' + unit if unit else ''}, got "
                                         f"{value!r}")


def check_distribution(file, field: str, dist: Distribution) -> None:
    """A duration distribution: a known kind and only positive durations (`distributions`)."""
    try:
        validate_distribution(dist, field, positive=True)
    except ScenarioError as err:
        raise ScenarioError(file, err.field, err.reason) from None


def _robot_record(robot, file, field):
    """The `RobotModel` of `robots[i]` (a shipped model or its own URDF; ScenarioError naming the field)."""
    from hrc_drake.robots.description import DescriptionError, robot_record

    try:
        return robot_record(robot, None if str(file) == "<scenario>" else file)
    except DescriptionError as err:
        raise ScenarioError(file, f"{field}.{err.field}", err.reason) from None
    except ValueError as err:
        raise ScenarioError(file, f"{field}.model", f"{err} (or give `urdf:`, your own robot)") from None


def _check_own_robot(robot, model, file, field) -> None:
    """A robot of the scenario's own URDF can run in its mode: a dynamic plant needs an actuator
    (a URDF <transmission>) on every joint of its arms and grippers."""
    from hrc_drake.robots.urdf import read_urdf_transmissions

    if not robot.urdf or robot.mode != "dynamic":
        return
    driven = read_urdf_transmissions(model.urdf_text())
    missing = [j for a in model.arms for j in (*a.joints, *a.gripper_joints) if j not in driven]
    if missing:
        raise ScenarioError(file, f"{field}.mode", "a dynamic plant drives joints through actuators; the "
                            f"URDF declares no <transmission> for {missing} (add them, or mode: kinematic)")


def _unique(file, field, names):
    seen = set()
    for i, name in enumerate(names):
        if not name:
            raise ScenarioError(file, f"{field}[{i}].name", "a name is required")
        if name in seen:
            raise ScenarioError(file, f"{field}[{i}].name", f"duplicate name '{name}'")
        seen.add(name)
    return seen


def _kind(file, field, value, allowed):
    if value not in allowed:
        raise ScenarioError(file, field, f"unknown kind '{value}' (one of {', '.join(allowed)})")


def check_scenario(sc: Scenario, file: str | Path = "<scenario>") -> None:
    """Semantic checks: names resolve, durations positive, the flow can supply every action."""
    if not (math.isfinite(sc.duration) and 0 < sc.duration <= MAX_SIMULATED_DURATION):
        raise ScenarioError(file, "duration", f"must be a finite number of seconds in (0, "
                                              f"{MAX_SIMULATED_DURATION:g}], got {sc.duration}")
    if isinstance(sc.seed, bool) or not isinstance(sc.seed, int) or not 0 <= sc.seed < 2**32:
        raise ScenarioError(file, "seed", f"must be an integer in [0, 2^32), got {sc.seed!r}")
    _in_range(file, "safety_distance", sc.safety_distance, 0.0, MAX_SAFETY_DISTANCE, "m")
    m = sc.metrics
    if isinstance(m.warmup_products, bool) or not isinstance(m.warmup_products, int) or not (
            0 <= m.warmup_products <= 1000):
        raise ScenarioError(file, "metrics.warmup_products", f"must be an integer in [0, 1000], got "
                                                             f"{m.warmup_products!r}")
    if not (math.isfinite(m.warmup_time) and 0 <= m.warmup_time < sc.duration):
        raise ScenarioError(file, "metrics.warmup_time", f"must be in [0, duration = {sc.duration:g}) s, got "
                                                         f"{m.warmup_time}")
    lay = sc.layout
    goals = _unique(file, "layout.goals", [g.name for g in lay.goals])
    for i, g in enumerate(lay.goals):
        _check_vec(file, f"layout.goals[{i}].center", g.center)
        if not 0 < g.radius <= MAX_GOAL_RADIUS:
            raise ScenarioError(file, f"layout.goals[{i}].radius",
                                f"must be in (0, {MAX_GOAL_RADIUS:g}] m, got {g.radius}")
    buffers = _unique(file, "layout.buffers", [b.name for b in lay.buffers])
    for i, b in enumerate(lay.buffers):
        _kind(file, f"layout.buffers[{i}].kind", b.kind, BUFFER_KINDS)
        _check_vec(file, f"layout.buffers[{i}].position", b.position)
        if b.kind == "intermediate" and b.capacity < 1:
            raise ScenarioError(file, f"layout.buffers[{i}].capacity", f"must be >= 1, got {b.capacity}")
        _in_range(file, f"layout.buffers[{i}].capacity", b.capacity, 0, MAX_PARTS, "parts")
        _in_range(file, f"layout.buffers[{i}].part_mass", b.part_mass, 0.0, MAX_PART_MASS, "kg")
        if b.initial < 0 or b.initial > MAX_PARTS or (b.kind == "intermediate" and b.initial > b.capacity):
            raise ScenarioError(
                file, f"layout.buffers[{i}].initial", f"must be in 0..capacity, got {b.initial}"
            )
    for i, g in enumerate(lay.goals):
        if g.name in buffers:
            raise ScenarioError(file, f"layout.goals[{i}].name", f"'{g.name}' names a goal and a buffer: "
                                                                 "an operator goal would be ambiguous")
    places = goals | buffers
    for i, o in enumerate(lay.occluders):
        _check_vec(file, f"layout.occluders[{i}].center", o.center)
        _check_vec(file, f"layout.occluders[{i}].size", o.size, bound=MAX_OBJECT_SIZE)
        if min(o.size) <= 0:
            raise ScenarioError(file, f"layout.occluders[{i}].size", "sizes must be positive")
    _check_vec(file, "layout.table.center", lay.table.center)
    _check_vec(file, "layout.table.size", lay.table.size, bound=MAX_OBJECT_SIZE)
    _check_vec(file, "layout.workspace_center", lay.workspace_center)
    _check_vec(file, "layout.workspace_size", lay.workspace_size, bound=MAX_OBJECT_SIZE)
    if min(lay.workspace_size) <= 0:
        raise ScenarioError(file, "layout.workspace_size",
                            f"sizes must be positive, got {lay.workspace_size}")
    if not all(math.isfinite(x) for x in (*lay.table.center, *lay.table.size, lay.table.height)):
        raise ScenarioError(file, "layout.table", "center, size and height must be finite")
    if min(lay.table.size) <= 0:
        raise ScenarioError(file, "layout.table.size", f"sizes must be positive, got {lay.table.size}")
    if not 0 < lay.table.height <= 3.0:
        raise ScenarioError(file, "layout.table.height", f"must be in (0, 3] m, got {lay.table.height}")
    _check_vec(file, "layout.camera.position", lay.camera.position)
    _check_vec(file, "layout.camera.target", lay.camera.target)
    if not all(math.isfinite(x) for x in (*lay.camera.position, *lay.camera.target)):
        raise ScenarioError(file, "layout.camera", "position and target must be finite")
    if math.dist(lay.camera.position, lay.camera.target) < 1e-3:
        raise ScenarioError(file, "layout.camera.target", "must differ from the camera's position (the "
                                                          "camera looks from its position at the target)")
    if not 0 < lay.camera.rate <= 120:
        raise ScenarioError(file, "layout.camera.rate", f"must be in (0, 120] Hz, got {lay.camera.rate}")
    _in_range(file, "layout.camera.noise_std", lay.camera.noise_std, 0.0, MAX_CAMERA_NOISE, "m")
    _check_camera_sensor(sc, file)

    agents: set[str] = set()
    _unique(file, "robots", [r.name for r in sc.robots])
    for i, robot in enumerate(sc.robots):
        field = f"robots[{i}]"
        model = _robot_record(robot, file, field)
        _kind(file, f"{field}.mode", robot.mode, ROBOT_MODES)
        _check_own_robot(robot, model, file, field)
        _check_pose(file, f"{field}.base", robot.base)
        if robot.mode == "dynamic":
            _in_range(file, f"{field}.time_step", robot.time_step, MIN_TIME_STEP, MAX_TIME_STEP, "s")
        elif not robot.time_step > 0:
            raise ScenarioError(file, f"{field}.time_step", "must be positive")
        arm_names = model.arm_names
        poses = _unique(file, f"{field}.poses", [p.name for p in robot.poses])
        pose_arm = {}
        for j, pose in enumerate(robot.poses):
            pf = f"{field}.poses[{j}]"
            if pose.arm not in arm_names:
                raise ScenarioError(
                    file, f"{pf}.arm", f"unknown arm '{pose.arm}' of {model.name} ({arm_names})"
                )
            if bool(pose.joints) == (pose.target is not None):
                raise ScenarioError(file, pf, "give exactly one of 'joints' or 'target'")
            if pose.joints:
                n = model.num_joints(pose.arm)
                if len(pose.joints) != n:
                    raise ScenarioError(
                        file, f"{pf}.joints", f"expected {n} joint values, got {len(pose.joints)}"
                    )
            else:
                _check_pose(file, f"{pf}.target", pose.target)
                # IK tolerances (m): below 0.1 mm the solver's own precision, above 10 cm no target
                _in_range(file, f"{pf}.tolerance", pose.tolerance, 1e-4, 0.1, "m")
            pose_arm[pose.name] = pose.arm
        # one action name per arm: an action of two arms has a part (a motion) for each
        actions_of_arm: dict[str, set[str]] = {}
        for j, action in enumerate(robot.actions):
            if not action.name:
                raise ScenarioError(file, f"{field}.actions[{j}].name", "a name is required")
            if action.name in actions_of_arm.get(action.arm, set()):
                raise ScenarioError(file, f"{field}.actions[{j}].name",
                                    f"duplicate name '{action.name}' on arm '{action.arm}'")
            actions_of_arm.setdefault(action.arm, set()).add(action.name)
        for j, action in enumerate(robot.actions):
            af = f"{field}.actions[{j}]"
            if action.arm not in arm_names:
                raise ScenarioError(file, f"{af}.arm", f"unknown arm '{action.arm}' ({arm_names})")
            if not action.poses:
                raise ScenarioError(file, f"{af}.poses", "an action needs at least one pose")
            for k, pose_name in enumerate(action.poses):
                if pose_name not in poses:
                    raise ScenarioError(file, f"{af}.poses[{k}]", f"unknown pose '{pose_name}'")
                if pose_arm[pose_name] != action.arm:
                    raise ScenarioError(
                        file, f"{af}.poses[{k}]", f"pose '{pose_name}' belongs to another arm"
                    )
            _in_range(file, f"{af}.dwell", action.dwell, 0.0, MAX_ACTION_DURATION, "s")
        for j, arm in enumerate(robot.arms):
            af = f"{field}.arms[{j}]"
            if arm.arm not in arm_names:
                raise ScenarioError(file, f"{af}.arm", f"unknown arm '{arm.arm}' ({arm_names})")
            if not arm.agent:
                raise ScenarioError(file, f"{af}.agent", "an agent name is required")
            if arm.agent in agents:
                raise ScenarioError(file, f"{af}.agent", f"duplicate agent '{arm.agent}'")
            agents.add(arm.agent)
            if arm.home and arm.home not in poses:
                raise ScenarioError(file, f"{af}.home", f"unknown pose '{arm.home}'")
            for k, name in enumerate(arm.program):
                if name not in actions_of_arm.get(arm.arm, set()):
                    other = [a for a, names in actions_of_arm.items() if name in names]
                    reason = (f"'{name}' is an action of the {other[0]} arm, not of the {arm.arm} arm"
                              if other
                              else f"unknown robot action '{name}'")
                    raise ScenarioError(file, f"{af}.program[{k}]", reason)

    op = sc.operator
    if op.name in agents:
        raise ScenarioError(file, "operator.name", f"'{op.name}' is also a robot agent")
    agents.add(op.name)
    seg = op.segments
    _check_pose(file, "operator.base", op.base)
    for name in ("torso", "neck", "shoulder_width", "upper_arm", "forearm"):
        if not 0 < getattr(seg, name) <= MAX_SEGMENT_LENGTH:
            raise ScenarioError(file, f"operator.segments.{name}",
                                f"must be in (0, {MAX_SEGMENT_LENGTH:g}] m, got {getattr(seg, name)}")
    low, high = HIP_HEIGHT_RANGE
    if seg.hip_height != 0 and not low <= seg.hip_height <= high:  # NaN fails here too
        raise ScenarioError(file, "operator.segments.hip_height",
                            f"must be 0 (standing) or in [{low:g}, {high:g}] m, got {seg.hip_height}")
    op_actions = _unique(file, "operator.actions", [a.name for a in op.actions])
    for i, a in enumerate(op.actions):
        af = f"operator.actions[{i}]"
        _kind(file, f"{af}.hand", a.hand, HANDS)
        if not a.goals:
            raise ScenarioError(file, f"{af}.goals", "an action needs at least one goal")
        for k, g in enumerate(a.goals):
            if g not in places:
                raise ScenarioError(file, f"{af}.goals[{k}]", f"unknown goal or buffer '{g}'")
        check_distribution(file, f"{af}.duration", a.duration)
    if not op.recorded:
        if not op.pattern:
            raise ScenarioError(file, "operator.pattern", "the operator needs a pattern of actions")
        for k, name in enumerate(op.pattern):
            if name not in op_actions:
                raise ScenarioError(file, f"operator.pattern[{k}]", f"unknown operator action '{name}'")
        _check_operator_reach_speeds(sc, file)
    _check_operator_behaviour(sc, file)

    _check_flow(sc, file, agents, buffers)
    _check_names_apart(sc, file, places)
    _check_programs_cover_the_flow(sc, file)
    _check_flow_durations(sc, file)
    _check_systems(sc, file)


def shortest_likely_duration(dist: Distribution) -> float:
    """The shortest duration (s) `dist` gives but rarely: fixed its mean; normal its truncation
    `low` or mean - 3 std, the larger; uniform and triangular `low`; lognormal its 0.13 %
    quantile (-3 sigma); empirical its smallest sample."""
    if dist.kind == "fixed" or (dist.kind == "normal" and dist.std == 0):
        return float(dist.mean)
    if dist.kind == "normal":
        return max(float(dist.low), dist.mean - 3.0 * dist.std)
    if dist.kind in ("uniform", "triangular"):
        return float(dist.low)
    if dist.kind == "lognormal":
        sigma2 = math.log1p((dist.std / dist.mean) ** 2)
        return math.exp(math.log(dist.mean) - 0.5 * sigma2 - 3.0 * math.sqrt(sigma2))
    return float(min(dist.samples))


def _check_operator_reach_speeds(sc: Scenario, file) -> None:
    """No reach of the synthetic operator's pattern is faster than MAX_WRIST_SPEED at its peak:
    each phase of an action of duration D and n goals reaches its goal from the previous one in
    REACH_FRACTION (D / n - head lead) (`human.operator`), along a minimum-jerk motion whose peak
    speed is 1.875 x distance / time; D is the duration's shortest likely value."""
    from hrc_drake.human.operator import HEAD_LEAD, REACH_FRACTION

    places = operator_places(sc)
    actions = {a.name: (i, a) for i, a in enumerate(sc.operator.actions)}
    sequence = [(name, goal) for name in sc.operator.pattern for goal in actions[name][1].goals]
    for k, (name, goal) in enumerate(sequence):
        i, action = actions[name]
        distance = float(np.linalg.norm(places[goal] - places[sequence[k - 1][1]]))
        phase = shortest_likely_duration(action.duration) / len(action.goals)
        reach = REACH_FRACTION * (phase - min(HEAD_LEAD, 0.2 * phase))
        peak = 1.875 * distance / reach if reach > 0 else math.inf
        if peak > MAX_WRIST_SPEED:
            raise ScenarioError(file, f"operator.actions[{i}].duration",
                                f"{name}'s reach to {goal} ({distance:.2f} m from {sequence[k - 1][1]}) in "
                                f"{reach:.3g} s peaks at {peak:.3g} m/s (a duration of "
                                f"{shortest_likely_duration(action.duration):.3g} s, its shortest likely); a "
                                f"person's wrist moves at most {MAX_WRIST_SPEED:g} m/s: a longer duration")


def _check_operator_behaviour(sc: Scenario, file) -> None:
    """`operator.behaviour` validates itself; it moves the synthetic operator, not a recording."""
    from hrc_drake.human.config import IdealBehaviour

    behaviour = sc.operator.behaviour
    try:
        behaviour.validate("operator.behaviour")
    except ScenarioError as err:
        raise ScenarioError(file, err.field, err.reason) from None
    if sc.operator.recorded and not isinstance(behaviour, IdealBehaviour):
        raise ScenarioError(file, "operator.behaviour", "a recorded operator replays its file: a "
                                                        "behaviour applies to the synthetic operator only")


def _check_camera_sensor(sc: Scenario, file) -> None:
    """The camera's sensor config validates itself (`human.config.RenderedDepthCamera`); a
    rendered camera measures a synthetic operator (a recorded skeleton is already measured)."""
    from hrc_drake.human.config import RenderedDepthCamera

    sensor = sc.layout.camera.sensor
    try:
        sensor.validate("layout.camera.sensor")
    except ScenarioError as err:
        raise ScenarioError(file, err.field, err.reason) from None
    if isinstance(sensor, RenderedDepthCamera) and sc.operator.recorded:
        raise ScenarioError(file, "layout.camera.sensor", "a recorded skeleton is already a measurement: "
                                                          "the rendered camera needs a synthetic operator")


def _check_robot_parts(sc: Scenario, file) -> None:
    """Every robot agent of a flow action has a motion of that name on its arm (a scheduler may
    command it); without a scheduler an action shared by several agents is in the program of
    each of its robot agents, or the rendezvous never happens; an agent released early is a
    robot agent of the action."""
    from hrc_drake.scheduling.config import NoScheduler

    arm_of = {arm.agent: (robot, arm) for robot in sc.robots for arm in robot.arms}
    for i, action in enumerate(sc.flow.actions):
        af = f"flow.actions[{i}]"
        for k, agent in enumerate(action.agents):
            if agent not in arm_of:
                continue
            robot, arm = arm_of[agent]
            if not any(a.name == action.name and a.arm == arm.arm for a in robot.actions):
                raise ScenarioError(file, f"{af}.agents[{k}]",
                                    f"'{agent}' has no motion for '{action.name}' (no action of that name on "
                                    f"the {arm.arm} arm of robot '{robot.name}')")
            if len(action.agents) > 1 and isinstance(sc.scheduler, NoScheduler) and \
                    action.name not in arm.program:
                raise ScenarioError(file, f"{af}.agents[{k}]",
                                    f"'{action.name}' is shared by {action.agents} but is not in the program "
                                    f"of '{agent}': it would never start (add it, or add a scheduler)")
        for agent, part in action.early_release.items():
            if agent not in arm_of or agent not in action.agents or len(action.agents) < 2:
                raise ScenarioError(file, f"{af}.early_release.{agent}",
                                    f"'{agent}' is not a robot agent of '{action.name}' shared with others")
            check_distribution(file, f"{af}.early_release.{agent}", part)


def _check_names_apart(sc: Scenario, file, places: set[str]) -> None:
    """Agents, places (goals and buffers) and actions have names of their own."""
    agents = [(f"robots[{i}].arms[{j}].agent", arm.agent) for i, r in enumerate(sc.robots)
              for j, arm in enumerate(r.arms)] + [("operator.name", sc.operator.name)]
    seen: dict[str, str] = {}
    for where, name in agents:
        if name in seen:
            raise ScenarioError(file, where, f"agent '{name}' is also {seen[name]}")
        seen[name] = where
    actions = {a.name for a in sc.flow.actions} | {a.name for a in sc.operator.actions} | {
        a.name for r in sc.robots for a in r.actions}
    for where, name in agents:
        if name in places:
            raise ScenarioError(file, where, f"'{name}' names an agent and a goal or buffer")
        if name in actions:
            raise ScenarioError(file, where, f"'{name}' names an agent and an action")
    for i, a in enumerate(sc.flow.actions):
        if a.name in places:
            raise ScenarioError(file, f"flow.actions[{i}].name",
                                f"'{a.name}' names an action and a goal or buffer")


def _check_programs_cover_the_flow(sc: Scenario, file) -> None:
    """Without a scheduler the arms follow their programs: a flow action assigned only to robot
    agents must be in the program of one of them, or it never runs."""
    from hrc_drake.scheduling.config import NoScheduler

    if not isinstance(sc.scheduler, NoScheduler):
        return
    for r_index, robot in enumerate(sc.robots):
        for a_index, arm in enumerate(robot.arms):
            if not arm.program:
                raise ScenarioError(file, f"robots[{r_index}].arms[{a_index}].program",
                                    f"'{arm.agent}' has an empty program and there is no scheduler to "
                                    "command it (leave the arm out of `arms` to keep it still)")
    programs = {arm.agent: set(arm.program) for r in sc.robots for arm in r.arms}
    for i, a in enumerate(sc.flow.actions):
        if a.agents and all(agent in programs for agent in a.agents) and not any(
                a.name in programs[agent] for agent in a.agents):
            raise ScenarioError(file, f"flow.actions[{i}].agents",
                                f"'{a.name}' is assigned to {a.agents}, but no program of theirs lists it: "
                                "it would never run (add it to a program, or add a scheduler)")


def _check_flow_durations(sc: Scenario, file) -> None:
    """A flow action's `duration` is only a timed scheduler's prior (`FlowAction`): refused where
    the cell's scheduler reads none, as it would change nothing. The refusal says where the
    action's time comes from."""
    from hrc_drake.scheduling.config import TIMED_SCHEDULERS, NoScheduler

    if isinstance(sc.scheduler, TIMED_SCHEDULERS):
        return
    reads = ("the cell has no scheduler" if isinstance(sc.scheduler, NoScheduler)
             else f"!{type(sc.scheduler).__name__} reads none")
    timed = ", ".join(f"!{kind.__name__}" for kind in TIMED_SCHEDULERS)
    human = sc.operator.name
    own = {a.name: i for i, a in enumerate(sc.operator.actions)}
    motions = {(arm.agent, a.name): (i, j) for i, robot in enumerate(sc.robots) for arm in robot.arms
               for j, a in enumerate(robot.actions) if a.arm == arm.arm}
    for k, action in enumerate(sc.flow.actions):
        if action.duration is None:
            continue
        times = []
        for agent in action.agents:
            if agent == human:
                times.append(f"operator.actions[{own[action.name]}].duration" if action.name in own
                             else "the operator's recording")
            elif (agent, action.name) in motions:
                i, j = motions[agent, action.name]
                times.append(f"{agent}'s motion through robots[{i}].actions[{j}].poses plus "
                             f"robots[{i}].actions[{j}].dwell at each")
        if human not in action.agents:
            what, fix = "a robot action", "remove this duration, or set the dwell"
        else:
            what = "an operator action" if len(action.agents) == 1 else "an action of the operator and robots"
            fix = "remove this duration"
        clear = f"flow: {{actions: {{{action.name}: {{duration: null}}}}}}"
        raise ScenarioError(file, f"flow.actions[{k}].duration",
                            f"'{action.name}' is {what}: its time is {' and '.join(times)}. A flow duration "
                            f"is only the prior of a timed scheduler ({timed}) and {reads}: {fix} (a file "
                            f"that extends the one giving it clears it with {clear})")


def _check_systems(sc: Scenario, file) -> None:
    """Each optional system's config validates itself; the names it refers to exist."""
    for name in (*SYSTEM_FIELDS, "speed_scaling", "judge"):
        try:
            getattr(sc, name).validate(name)
        except ScenarioError as err:
            raise ScenarioError(file, err.field, err.reason) from None
    goal_names = {g.name for g in sc.layout.goals}
    for k, name in enumerate(getattr(sc.intention, "feedback_sequence", [])):
        if name not in goal_names:
            raise ScenarioError(file, f"intention.feedback_sequence[{k}]", f"unknown goal '{name}'")
    model = getattr(sc.intention, "model", "")
    if model and str(file) != "<scenario>" and not scenario_relative(file, model).is_file():
        raise ScenarioError(file, "intention.model", f"no such file: {scenario_relative(file, model)}")
    _check_perceived_events(sc, file)
    _check_proactive_planner(sc, file)
    _check_safety(sc, file)
    _check_collaboration_scheduler(sc, file)
    _check_best_scenario_scheduler(sc, file)
    robot_agents = {arm.agent for robot in sc.robots for arm in robot.arms}
    for agent in getattr(sc.scheduler, "agent_costs", {}):
        if agent not in robot_agents:
            raise ScenarioError(file, f"scheduler.agent_costs.{agent}",
                                f"'{agent}' is not a robot agent ({sorted(robot_agents)})")
    _check_scheduler_net(sc, file)  # last: the fields it reads are checked above, by name


def safety_limits(sc: Scenario, file):
    """The limits table of the scenario's safety mode (its `limits` file relative to the
    scenario, or the packaged ISO/TS 15066 one); `ScenarioError` naming the entry at fault."""
    from hrc_drake.safety.limits import load_limits

    name = getattr(sc.safety, "limits", "")
    path = None if not name else (scenario_relative(file, name) if str(file) != "<scenario>" else Path(name))
    try:
        return load_limits(path)
    except ScenarioError as err:
        field = "safety.limits" if name else "safety"
        raise ScenarioError(file, field, f"{err.field}: {err.reason}") from None


def reaction_time(sc: Scenario) -> float:
    """T_r of the cell's sensing and control chain (s): a camera frame, a safety-controller period
    and a path-follower period (`CELL_RATE`); a cell without a controller as if it ran at 30 Hz."""
    from hrc_drake.safety.config import NoSafety

    controller_rate = 30.0 if isinstance(sc.safety, NoSafety) else sc.safety.rate
    return 1.0 / sc.layout.camera.rate + 1.0 / controller_rate + 1.0 / 30.0


def judge_values(sc: Scenario, file):
    """(the standard judge's `JudgeValues` of this cell, the scenario's changed judge or None):
    T_r from the cell's chain (`reaction_time`), the stop of its robots' models (the slowest);
    `ScenarioError` naming a bad `judge.limits` table.

    A robot of the scenario's own URDF is judged with at most the shipped robots' assumed
    deceleration: a faster stop it declares is the scenario's claim, a changed judge (the verdict
    NON-CONFORMING names it), never the standard's."""
    from dataclasses import replace

    from hrc_drake.robots.description import DEFAULT_STOPPING_DECELERATION
    from hrc_drake.safety.judge import standard_values
    from hrc_drake.safety.limits import load_limits

    records = [_robot_record(r, file, f"robots[{i}]") for i, r in enumerate(sc.robots)]
    declared = min((r.stopping_deceleration for r in records), default=DEFAULT_STOPPING_DECELERATION)
    deceleration = min((r.stopping_deceleration if r.shipped else
                        min(r.stopping_deceleration, DEFAULT_STOPPING_DECELERATION) for r in records),
                       default=DEFAULT_STOPPING_DECELERATION)
    standard = standard_values(reaction_time(sc), deceleration)
    changes = sc.judge
    if not changes.changed() and declared == deceleration:
        return standard, None
    values = replace(standard, deceleration=declared)
    if changes.limits:
        path = scenario_relative(file, changes.limits) if str(file) != "<scenario>" else Path(changes.limits)
        try:
            values = replace(values, limits=load_limits(path))
        except ScenarioError as err:
            raise ScenarioError(file, "judge.limits", f"{err.field}: {err.reason}") from None
    renamed = {"human_speed": "limb_speed"}
    for name in ("reaction_time", "deceleration", "human_speed", "body_speed", "approach_tolerance",
                 "transient_duration"):
        value = getattr(changes, name)
        if value is not None:
            values = replace(values, **{renamed.get(name, name): float(value)})
    return standard, values


def arm_payloads(sc: Scenario) -> dict[str, float]:
    """m_L of each agent (kg): the heaviest part (`Buffer.part_mass`) among the buffers its flow
    actions take parts from or put parts into (ISO/TS 15066 eq. A.5: the payload the arm carries)."""
    masses = {b.name: float(b.part_mass) for b in sc.layout.buffers}
    out: dict[str, float] = {}
    for action in sc.flow.actions:
        handled = [masses.get(name, 0.0) for name in (*action.inputs, *action.outputs)]
        for agent in action.agents:
            out[agent] = max(out.get(agent, 0.0), *handled, 0.0)
    return out


def robot_claims(sc: Scenario, file) -> tuple[str, ...]:
    """What the judge takes from the scenario's own robots without a check (`RobotModel.claims`,
    e.g. capsules of collision meshes it cannot read): each a departure of the verdict."""
    records = [_robot_record(robot, file, f"robots[{i}]") for i, robot in enumerate(sc.robots)]
    claims = [f"robot {robot.name!r}: {claim}" for robot, record in zip(sc.robots, records, strict=True)
              for claim in record.claims]
    # the judge has one stop model for the cell, the slowest robot's: a robot of the scenario's own
    # that stops slower than a shipped one would let the shipped robot's stops pass more leniently
    shipped = [r.stopping_deceleration for r in records if r.shipped]
    own = [(r.stopping_deceleration, robot.name) for robot, r in zip(sc.robots, records, strict=True)
           if not r.shipped]
    if shipped and own and min(own)[0] < min(shipped):
        a, name = min(own)
        claims.append(f"robot {name!r} stops at {a:g} m/s^2, slower than the shipped robots' "
                      f"{min(shipped):g}: the judge's one stop model would judge their stops by it")
    return tuple(claims)


def safety_departures(sc: Scenario, file) -> list[str]:
    """Every way a scenario departs from the standard's judging (a changed judge, a controller
    whose S_h is not ISO 13855's): its verdict will be NON-CONFORMING."""
    from hrc_drake.safety.judge import deviations
    from hrc_drake.safety.systems import controller_departures

    standard, changed = judge_values(sc, file)
    out = [] if changed is None else [f"judge changed: {d}" for d in deviations(changed, standard)]
    return out + list(controller_departures(sc.safety)) + list(robot_claims(sc, file))


def _check_safety(sc: Scenario, file) -> None:
    """The safety mode can run in this cell: Z_d from a tracker needs one, swept volumes a motion
    model, a hybrid mode collaborative zones, the limits table and its regions exist."""
    from hrc_drake.motion.config import NoMotionModel
    from hrc_drake.perception.config import NoTracker
    from hrc_drake.safety.config import Hybrid, NoSafety, PowerForceLimiting

    for k, zone in enumerate(sc.layout.collaborative_zones):
        field = f"layout.collaborative_zones[{k}]"
        if not zone.name:
            raise ScenarioError(file, f"{field}.name", "a name is required")
        _check_vec(file, f"{field}.center", zone.center)
        _in_range(file, f"{field}.radius", zone.radius, 0.01, MAX_OBJECT_SIZE, "m")
    judge_values(sc, file)
    config = sc.safety
    if isinstance(config, NoSafety):
        return
    if config.position_uncertainty == "tracker" and isinstance(sc.tracker, NoTracker):
        raise ScenarioError(file, "safety.position_uncertainty",
                            "'tracker' takes Z_d from a tracker's spread, but the cell has no tracker: add "
                            "one, or say 'camera' (the camera's noise) or 'fixed' (safety.fixed_uncertainty)")
    if config.human_motion == "swept_volumes" and isinstance(sc.motion_model, NoMotionModel):
        raise ScenarioError(file, "safety.human_motion",
                            "'swept_volumes' needs the swept volumes of a motion_model (8.1); "
                            "the cell has none")
    if config.preview_human == "swept_volumes" and isinstance(sc.motion_model, NoMotionModel):
        raise ScenarioError(file, "safety.preview_human",
                            "'swept_volumes' needs the swept volumes of a motion_model (8.1); "
                            "the cell has none")
    if isinstance(config, Hybrid) and not sc.layout.collaborative_zones:
        raise ScenarioError(file, "safety", "!Hybrid applies PFL inside layout.collaborative_zones, and the "
                                            "layout declares none")
    if isinstance(config, PowerForceLimiting):
        limits = safety_limits(sc, file)
        for k, name in enumerate(getattr(config, "pfl_regions", [])):
            if name not in limits.regions:
                raise ScenarioError(file, f"safety.pfl_regions[{k}]",
                                    f"unknown body region '{name}' "
                                    f"(known: {', '.join(sorted(limits.regions))})")


def _check_proactive_planner(sc: Scenario, file) -> None:
    """The proactive planner's robot action, start pose (same robot and arm) and one-arm
    operator actions exist."""
    from hrc_drake.motion.config import ProactivePlanner

    config = sc.proactive_planner
    if not isinstance(config, ProactivePlanner):
        return
    found = [(robot, action) for robot in sc.robots for action in robot.actions
             if action.name == config.robot_action]
    if not found:
        raise ScenarioError(file, "proactive_planner.robot_action",
                            f"unknown robot action '{config.robot_action}'")
    robot, action = found[0]
    poses = {pose.name: pose.arm for pose in robot.poses}
    if poses.get(config.start_pose) != action.arm:
        raise ScenarioError(file, "proactive_planner.start_pose",
                            f"'{config.start_pose}' is not a pose of robot '{robot.name}' for the "
                            f"{action.arm} arm of '{action.name}'")
    hands = {a.name: a.hand for a in sc.operator.actions}
    for k, name in enumerate(config.human_actions):
        if name not in hands:
            raise ScenarioError(file, f"proactive_planner.human_actions[{k}]",
                                f"unknown operator action '{name}'")
        if hands[name] not in ("left", "right"):
            raise ScenarioError(file, f"proactive_planner.human_actions[{k}]",
                                f"'{name}' moves {hands[name]!r} hands; an action of A_S moves one arm "
                                "(8.2.2)")


def _check_scheduler_net(sc: Scenario, file) -> None:
    """A scheduler of Ch. 6-7 runs on the pcTPN compiled from the flow and the operator's pattern:
    compile it here, so that a flow or pattern the compiler refuses fails validation too."""
    from hrc_drake.scheduling.compiler import FlowError, net_from_scenario
    from hrc_drake.scheduling.config import COLLABORATION_SCHEDULERS, NoScheduler

    if isinstance(sc.scheduler, (NoScheduler, *COLLABORATION_SCHEDULERS)):
        return
    try:
        net_from_scenario(sc, sc.scheduler)
    except FlowError as err:
        raise ScenarioError(file, "scheduler", f"its Petri net cannot be compiled from the flow and the "
                                               f"operator's pattern: {err}") from None


def _check_collaboration_scheduler(sc: Scenario, file) -> None:
    """A use case a scheduler names a robot agent, robot actions of its arm's program and an
    operator action; the predictive one reads the activity predictor's forecast."""
    from hrc_drake.prediction.config import NoPredictor
    from hrc_drake.scheduling.config import COLLABORATION_SCHEDULERS, PredictiveRobotScheduler

    config = sc.scheduler
    if not isinstance(config, COLLABORATION_SCHEDULERS):
        return
    programs = {arm.agent: list(arm.program) for robot in sc.robots for arm in robot.arms}
    if config.agent not in programs:
        raise ScenarioError(file, "scheduler.agent",
                            f"unknown robot agent '{config.agent}' ({sorted(programs)})")
    for name, value in [("autonomous_action", config.autonomous_action)] + [
            (f"assist_actions[{k}]", a) for k, a in enumerate(config.assist_actions)]:
        if value not in programs[config.agent]:
            raise ScenarioError(file, f"scheduler.{name}", f"'{value}' is not in the program of "
                                                             f"'{config.agent}' {programs[config.agent]}")
    if config.request_action not in {a.name for a in sc.operator.actions}:
        raise ScenarioError(file, "scheduler.request_action",
                            f"unknown operator action '{config.request_action}'")
    if isinstance(config, PredictiveRobotScheduler) and isinstance(sc.predictor, NoPredictor):
        raise ScenarioError(file, "scheduler", "the predictive robot reads a forecast: the cell needs a "
                                               "predictor (e.g. predictor: !HigherOrderMarkovPredictor {})")
    levels = getattr(sc.predictor, "percentile_levels", None)
    if isinstance(config, PredictiveRobotScheduler) and levels and not (
            min(levels) <= config.percentile <= max(levels)):
        # outside the forecast's levels t_p is unknown (inf): the robot would always work, as the
        # reactive one does
        raise ScenarioError(file, "scheduler.percentile",
                            f"{config.percentile} is outside the predictor's percentile_levels {levels}: "
                            "add it to predictor.percentile_levels")


def _check_best_scenario_scheduler(sc: Scenario, file) -> None:
    """The best-scenario scheduler (7.2) names a collaboration of the human with robots and,
    for case 1, a human action and a robot action; it reads the predictor's forecast at its
    two percentile levels."""
    from hrc_drake.prediction.config import NoPredictor
    from hrc_drake.scheduling.config import BestScenarioScheduler

    config = sc.scheduler
    if not isinstance(config, BestScenarioScheduler):
        return
    human, flow = sc.operator.name, {a.name: a for a in sc.flow.actions}
    action = flow.get(config.collaboration)
    if action is None or human not in action.agents or len(action.agents) < 2:
        raise ScenarioError(file, "scheduler.collaboration", f"'{config.collaboration}' is not a flow action "
                                                              f"of '{human}' with robots")
    if config.human_action and (config.human_action not in flow
                                or list(flow[config.human_action].agents) != [human]):
        raise ScenarioError(file, "scheduler.human_action",
                            f"'{config.human_action}' is not a flow action of '{human}' alone")
    if config.feed_action and (config.feed_action not in flow or human in flow[config.feed_action].agents):
        raise ScenarioError(file, "scheduler.feed_action", f"'{config.feed_action}' is not a robot action of "
                                                            "the flow")
    if isinstance(sc.predictor, NoPredictor):
        raise ScenarioError(file, "scheduler", "the best-scenario scheduler reads a forecast: the cell needs "
                                               "a predictor (e.g. !HigherOrderMarkovPredictor {})")
    levels = [float(x) for x in getattr(sc.predictor, "percentile_levels", [])]
    for k, level in enumerate(config.percentiles):
        if not any(math.isclose(level, x) for x in levels):
            raise ScenarioError(file, f"scheduler.percentiles[{k}]", f"{level} is not one of the predictor's "
                                                                      f"percentile_levels {levels}")


def _check_perceived_events(sc: Scenario, file) -> None:
    """`human_events` names a known source; an action detector needs a synthetic operator whose
    every action has its own goal sphere (one region per action, thesis Ch. 2)."""
    from hrc_drake.intention.config import NoActionDetector, SegmenterActionDetector

    _kind(file, "human_events", sc.human_events, HUMAN_EVENT_SOURCES)
    has_detector = not isinstance(sc.action_detector, NoActionDetector)
    if sc.human_events == "perceived" and not has_detector:
        raise ScenarioError(file, "human_events", "'perceived' needs an action_detector (e.g. "
                                                  "action_detector: !GoalRegionActionDetector {})")
    if not has_detector:
        return
    if sc.operator.recorded:
        raise ScenarioError(file, "action_detector", "a recorded skeleton has no true actions to perceive")
    if isinstance(sc.action_detector, SegmenterActionDetector):
        # the segmenter learns from the operator's own actions (4.1.5), not from goal regions
        if len(set(sc.operator.pattern)) < 2:
            raise ScenarioError(file, "operator.pattern", "the segmenter needs a pattern of at least two "
                                                          "different actions to learn from")
        from hrc_drake.distributions import mean_duration

        means = {a.name: mean_duration(a.duration) for a in sc.operator.actions}
        cycle = sum(means.get(name, 0.0) for name in sc.operator.pattern)
        budget = SEGMENTER_LIBRARY_SECONDS / 1.5  # room for durations longer than their means
        work = sc.action_detector.training_cycles * cycle
        if work > budget:
            raise ScenarioError(file, "action_detector.training_cycles",
                                f"the segmenter's library would take {work:.0f} s of the operator's work "
                                f"(at most {budget:.0f} s): fewer cycles")
        return
    goals = {g.name for g in sc.layout.goals}
    owner: dict[str, str] = {}
    for i, action in enumerate(sc.operator.actions):
        region, where = (action.region, f"operator.actions[{i}].region") if action.region else (
            action.goals[0], f"operator.actions[{i}].goals[0]")
        if region not in goals:
            raise ScenarioError(file, where, f"'{region}' is not a goal sphere of layout.goals: the "
                                             "action detector needs one (set region)")
        if region in owner:
            raise ScenarioError(file, where, f"goal '{region}' already marks action '{owner[region]}': "
                                             "each action needs its own region")
        owner[region] = action.name


def action_regions(sc: Scenario) -> list[tuple[str, str]]:
    """(action, goal sphere) of every operator action, for the action detector."""
    return [(a.name, a.region or a.goals[0]) for a in sc.operator.actions]


def _check_flow(sc: Scenario, file, agents: set[str], buffers: set[str]) -> None:
    flow = sc.flow
    names = _unique(file, "flow.actions", [a.name for a in flow.actions])
    kinds = {b.name: b.kind for b in sc.layout.buffers}
    for i, action in enumerate(flow.actions):
        af = f"flow.actions[{i}]"
        if not action.agents:
            raise ScenarioError(file, f"{af}.agents", "an action needs at least one agent")
        for k, agent in enumerate(action.agents):
            if agent not in agents:
                raise ScenarioError(file, f"{af}.agents[{k}]", f"unknown agent '{agent}'")
        for key in ("inputs", "outputs"):
            for k, b in enumerate(getattr(action, key)):
                if b not in buffers:
                    raise ScenarioError(file, f"{af}.{key}[{k}]", f"unknown buffer '{b}'")
        for k, b in enumerate(action.outputs):
            if kinds[b] == "raw":
                raise ScenarioError(
                    file, f"{af}.outputs[{k}]", f"'{b}' is a raw buffer: nothing can be put in it"
                )
        for k, r in enumerate(action.resources):
            if r not in flow.resources:
                raise ScenarioError(file, f"{af}.resources[{k}]", f"unknown resource '{r}'")
        if action.duration is not None:
            check_distribution(file, f"{af}.duration", action.duration)
    for r, units in flow.resources.items():
        if isinstance(units, bool) or not isinstance(units, int) or not 1 <= units <= MAX_PARTS:
            raise ScenarioError(file, f"flow.resources.{r}", f"needs an integer number of units in [1, "
                                                             f"{MAX_PARTS}], got {units!r}")
    # An action is live when every input buffer is raw, starts with parts, or is fed by a live action.
    live_buffers = {b.name for b in sc.layout.buffers if b.kind == "raw" or b.initial > 0}
    live_actions: set[str] = set()
    changed = True
    while changed:
        changed = False
        for action in flow.actions:
            if action.name not in live_actions and all(b in live_buffers for b in action.inputs):
                live_actions.add(action.name)
                live_buffers.update(action.outputs)
                changed = True
    for i, action in enumerate(flow.actions):
        if action.name not in live_actions:
            missing = sorted(b for b in action.inputs if b not in live_buffers)
            raise ScenarioError(
                file,
                f"flow.actions[{i}].inputs",
                f"action '{action.name}' can never start: no action or raw buffer ever supplies {missing}",
            )
    _check_robot_parts(sc, file)
    # A flow action in a program or pattern must be assigned to that agent.
    for i, robot in enumerate(sc.robots):
        for j, arm in enumerate(robot.arms):
            for k, name in enumerate(arm.program):
                if name in names:
                    spec = next(a for a in flow.actions if a.name == name)
                    if arm.agent not in spec.agents:
                        raise ScenarioError(
                            file,
                            f"robots[{i}].arms[{j}].program[{k}]",
                            f"flow action '{name}' is assigned to {spec.agents}, not to '{arm.agent}'",
                        )
    for k, name in enumerate(sc.operator.pattern):
        if name in names:
            spec = next(a for a in flow.actions if a.name == name)
            if sc.operator.name not in spec.agents:
                raise ScenarioError(
                    file,
                    f"operator.pattern[{k}]",
                    f"flow action '{name}' is not assigned to '{sc.operator.name}'",
                )


__all__ = ["ScenarioError", "load_scenario", "load_scenario_with", "check_scenario", "schema"]
