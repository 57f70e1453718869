"""The example scenarios, campaign specs and search specs shipped with the package, found by their
bare names: one place that `load_scenario`, `hrc-drake simulate / validate / campaign / search`
and `import --cell` all use, so a name means the same file everywhere.

A name is a file when one is there (an existing file wins over a shipped example of that name);
else only a *bare name* (`torch_clock`: letters, digits, '_' and '-', no folder, no suffix, no
leading dot, nothing a terminal would not print) is looked up among the shipped examples, and
only an example the package lists is ever returned, so no name reaches a file of the package by
'..', a separator or a control character. A name that is neither an existing file nor a shipped
example is refused with `ScenarioError` ("no such file") saying where it was looked for and
which examples there are. No pydrake here.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from hrc_drake.errors import ScenarioError

#: the package holding the examples (diagrams/ of the repository, shipped as package data: a
#: namespace package, no __init__.py; in a source tree hrc_drake/diagrams links to ../diagrams)
EXAMPLES_PACKAGE = "hrc_drake.diagrams"
#: the kinds of shipped example: the folder under diagrams/ each lives in
KINDS = {"scenario": "", "campaign": "campaigns", "search": "searches"}
#: what each kind is called in messages
LABELS = {"scenario": "example scenario", "campaign": "example campaign", "search": "search spec"}
#: what a bare name may hold
_BARE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")


def examples_folder(kind: str = "scenario") -> Path | None:
    """The folder of the shipped examples of `kind` (`KINDS`) on disk, None when not installed."""
    from importlib.resources import files

    sub = KINDS[kind]
    try:
        # the entries of a namespace package's MultiplexedPath are file-system paths
        entry = next(iter(files(EXAMPLES_PACKAGE).iterdir()), None)
    except (ModuleNotFoundError, TypeError, OSError):
        return None
    if entry is None:
        return None
    folder = Path(str(entry)).parent
    folder = folder / sub if sub else folder
    return folder if folder.is_dir() else None


def example_names(kind: str = "scenario") -> list[str]:
    """The bare names of the shipped examples of `kind`, sorted."""
    folder = examples_folder(kind)
    if folder is None:
        return []
    return sorted(p.stem for p in folder.glob("*.yaml") if _BARE_NAME.fullmatch(p.stem) and p.is_file())


def is_bare_name(name: str) -> bool:
    """Whether `name` can name a shipped example: letters, digits, '_' and '-' only, starting with
    a letter or digit (no folder, no suffix, no leading dot, no '..', no control character)."""
    return isinstance(name, str) and _BARE_NAME.fullmatch(name) is not None


def example_path(name: str, kind: str = "scenario") -> Path | None:
    """The shipped example of `kind` called `name` (a bare name, no suffix), None if there is none."""
    if not is_bare_name(name) or name not in example_names(kind):
        return None
    return examples_folder(kind) / f"{name}.yaml"


def resolve(name: str | os.PathLike, kind: str = "scenario") -> Path:
    """The file `name` means: `name` itself when something is there (an existing file wins over a
    shipped example of that name; a folder or a dangling link is left to the loader to name); else
    the shipped example of `kind` when `name` is the bare name of one. Else `ScenarioError` "no
    such file", saying the folder looked in (for a relative name) and listing the examples."""
    text = os.fspath(name)
    if not isinstance(text, str):
        text = os.fsdecode(text)
    if _present(text):
        return Path(text)
    if is_bare_name(text):
        found = example_path(text, kind)
        if found is not None:
            return found
    label = LABELS[kind]
    names = ", ".join(example_names(kind)) or "none installed"
    if is_bare_name(text):
        reason = f"no such file{_where(text)}, and no shipped {label} of that name (examples: {names})"
    else:
        reason = f"no such file{_where(text)} (or give the bare name of a shipped {label}: {names})"
    from hrc_drake.untrusted import one_line

    raise ScenarioError(one_line(text) or "''", "", reason)


def _present(text: str) -> bool:
    """Whether anything is at the path `text` (a broken link counts: the loader says what it is);
    False for a name no file can have (empty, a NUL byte)."""
    if not text or "\x00" in text:
        return False
    try:
        os.lstat(text)
    except (FileNotFoundError, NotADirectoryError):
        return False
    except (OSError, ValueError):
        return True  # there, or not knowable here (permission): the loader names the reason
    return True


def _where(text: str) -> str:
    """' in FOLDER' for a relative name (where it was looked for), '' for an absolute one."""
    if not text or "\x00" in text or os.path.isabs(text):
        return ""
    from hrc_drake.untrusted import one_line

    return f" in {one_line(os.getcwd())}"
