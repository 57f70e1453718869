"""Errors of bad input, shared by every layer (the bottom layer, beside `messages`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: `hrc-drake --help` imports this module
    from pathlib import Path


class ScenarioError(ValueError):
    """A scenario that cannot be used: names the file, the field path and the reason."""

    def __init__(self, file: str | Path, field: str, reason: str):
        self.file = str(file)
        self.field = field
        self.reason = reason
        where = f"{self.file}: {field}" if field and self.file else (field or self.file)
        super().__init__(f"{where}: {reason}")


class ConfigError(ScenarioError):
    """A config value that cannot be used, found before the file is known: the field path
    (e.g. "tracker.particles") and the reason. The scenario loader adds the file name."""

    def __init__(self, field: str, reason: str):
        super().__init__("", field, reason)


def check(condition: bool, field: str, reason: str) -> None:
    """Raise `ConfigError(field, reason)` unless `condition` holds."""
    if not condition:
        raise ConfigError(field, reason)
