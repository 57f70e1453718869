"""Free text (names in scenarios, recordings' file names) made harmless where it is written: a CSV
cell a spreadsheet would run as a formula, a YAML comment a line break would end, a plot label
matplotlib would parse as mathtext, a file name a path separator would move; and YAML read safely
with no key given twice (`UniqueKeyLoader`)."""

from __future__ import annotations

import hashlib
import re

import yaml

#: a spreadsheet runs a cell that starts with one of these as a formula (OWASP, "CSV injection")
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
_FILE_NAME_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


def csv_cell(value):
    """`value` for a CSV cell: a string that starts like a formula gets a leading apostrophe (shown,
    never run); numbers and other strings are unchanged."""
    if isinstance(value, str) and value.startswith(FORMULA_STARTS):
        return "'" + value
    return value


def one_line(text: str) -> str:
    """`text` with every character that is not printable (line breaks of any kind, controls)
    shown as its escape: safe inside a YAML comment or a terminal line."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def file_name_part(text: str, limit: int = 80) -> str:
    """`text` as part of a file name: letters, digits, '.', '_' and '-' kept, anything else '_';
    when something was replaced (or it is too long), a short hash of the original keeps two names
    that differ only there apart."""
    clean = _FILE_NAME_UNSAFE.sub("_", text).lstrip(".")
    if clean == text and len(text) <= limit:
        return text
    digest = hashlib.sha1(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return f"{clean[:limit]}-{digest}"


def headless_pyplot():
    """matplotlib's pyplot on the Agg backend with mathtext off: a name with '$' in it is drawn
    as written (`text.parse_math`), not parsed (where `$\\frac{a}$` raised after the run)."""
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["text.parse_math"] = False
    import matplotlib.pyplot as plt

    return plt


def unique_key_mapping(loader, node, deep=False) -> dict:
    """A YAML mapping whose keys are all different: a repeated key would silently replace the first
    one, so it is refused with its line and column."""
    loader.flatten_mapping(node)
    out = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in out:
            raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
        out[key] = loader.construct_object(value_node, deep=deep)
    return out


class UniqueKeyLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
    """PyYAML's safe loader (libyaml's where PyYAML has it) refusing repeated mapping keys."""


UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, unique_key_mapping)


def load_unique_yaml(text: str):
    """The one document of YAML `text` through `UniqueKeyLoader` (safe constructors only)."""
    loader = UniqueKeyLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()
