"""Which code made a result: the package version and, in a git checkout, the commit."""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """e.g. "hrc_drake 0.1.0 (git 3f2a1bc, modified)"; without git or a checkout, the version."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        text = f"hrc_drake {version('hrc_drake')}"
    except PackageNotFoundError:
        text = "hrc_drake (not installed)"
    root = Path(__file__).resolve().parents[1]
    if not (root / ".git").exists():
        return text
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=5, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "diff", "--quiet", "HEAD", "--", "hrc_drake"],
                               capture_output=True, timeout=5).returncode != 0
    except (OSError, subprocess.SubprocessError):
        return text
    return f"{text} (git {commit}{', modified' if dirty else ''})"
