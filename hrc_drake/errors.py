"""Errors of bad input, shared by every layer (the bottom layer, beside `messages`)."""

from __future__ import annotations

import errno
import os
import stat
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: `hrc-drake --help` imports this module
    from pathlib import Path


class ScenarioError(ValueError):
    """A scenario that cannot be used: names the file, the field path and the reason, and where
    the file has it, its line and column (1-based): `file:line:column: field: reason`."""

    def __init__(self, file: str | Path, field: str, reason: str, line: int | None = None,
                 column: int | None = None):
        self.file = str(file)
        self.field = field
        self.reason = reason
        self.line, self.column = line, column
        super().__init__(self._message())

    def _message(self) -> str:
        file = self.file
        if file and self.line is not None:
            file = f"{file}:{self.line}" + (f":{self.column}" if self.column is not None else "")
        where = f"{file}: {self.field}" if self.field and file else (self.field or file)
        return f"{where}: {self.reason}"

    def at(self, line: int, column: int | None = None) -> ScenarioError:
        """This error, located at `line` and `column` of its file (1-based); returns it."""
        self.line, self.column = line, column
        self.args = (self._message(),)
        return self


class ConfigError(ScenarioError):
    """A config value that cannot be used, found before the file is known: the field path
    (e.g. "tracker.particles") and the reason. The scenario loader adds the file name."""

    def __init__(self, field: str, reason: str):
        super().__init__("", field, reason)


def check(condition: bool, field: str, reason: str) -> None:
    """Raise `ConfigError(field, reason)` unless `condition` holds."""
    if not condition:
        raise ConfigError(field, reason)


class EnvironmentFailure(RuntimeError):
    """The machine, not the input, failed the command: a lost Dask scheduler, a table that cannot
    be written, a folder another campaign holds. Says what happened and what to do."""


def check_input_folder(path: Path, kind: str) -> None:
    """`path` is a readable folder (a recording stored as one, e.g. the KTH hand-over); else
    `ScenarioError` saying what it is instead."""
    if not os.path.exists(path):
        raise ScenarioError(path, "", f"no such folder: give the {kind}'s folder")
    if not os.path.isdir(path):
        raise ScenarioError(path, "", f"is a file, not a folder: give the {kind}'s folder")
    if not os.access(path, os.R_OK | os.X_OK):
        raise ScenarioError(path, "", "cannot be read (permission denied)")


def check_input_file(path: Path, kind: str = "scenario") -> None:
    """`path` is a readable regular file; else `ScenarioError` saying what it is instead: missing,
    a dangling link or a link loop, a folder, a FIFO or device (which reading would block on)."""
    try:
        mode = os.stat(path).st_mode
    except OSError as err:
        if err.errno == errno.ELOOP:
            raise ScenarioError(path, "", "is a symbolic link loop: point it at the YAML file") from None
        if os.path.islink(path):
            target = os.readlink(path)
            raise ScenarioError(path, "", f"is a symbolic link to {target}, which does not exist") from None
        if err.errno == errno.ENOENT:
            raise ScenarioError(path, "", "no such file") from None
        raise ScenarioError(path, "", f"cannot be read: {err.strerror or err}") from None
    if stat.S_ISDIR(mode):
        raise ScenarioError(path, "", f"is a folder, not a {kind} file: give the YAML file's path")
    if not stat.S_ISREG(mode):
        what = "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
        raise ScenarioError(path, "", f"is {what}, not a {kind} file: give the YAML file's path")
    if not os.access(path, os.R_OK):
        raise ScenarioError(path, "", "cannot be read (permission denied)")


def yaml_error_reason(err, where: bool = True) -> str:
    """A YAML error's problem and, with `where`, its place (line, column), without PyYAML's
    snippet of the text: the file may be anything (`extends: /etc/shadow` printed its first line)."""
    mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
    problem = getattr(err, "problem", None) or getattr(err, "context", None) or type(err).__name__
    place = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None and where else ""
    from hrc_drake.untrusted import one_line

    return one_line(str(problem)) + place


def yaml_syntax_error(file: str | Path, err, what: str = "not valid YAML") -> ScenarioError:
    """`ScenarioError` for a YAML error of `file` (a `yaml.MarkedYAMLError` has a mark): located at
    the problem's line and column (`file:line:column: what: problem`)."""
    mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
    error = ScenarioError(file, "", f"{what}: {yaml_error_reason(err, where=mark is None)}")
    return error.at(mark.line + 1, mark.column + 1) if mark is not None else error
