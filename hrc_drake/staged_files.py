"""Outputs of one command written all or nothing, and never over the command's inputs."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from hrc_drake.errors import ScenarioError


def same_file(a: Path, b: Path) -> bool:
    """Whether two paths name one file: the same resolved path, or (both existing) the same inode
    (a hard link, a link through another folder)."""
    if Path(os.path.abspath(a)).resolve() == Path(os.path.abspath(b)).resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_outputs_apart(inputs: dict[str, Path | None], outputs: dict[str, Path | None]) -> None:
    """ScenarioError naming the output and the option at fault when an output would overwrite an
    input or another output of the same command (None: not used)."""
    used_inputs = {name: path for name, path in inputs.items() if path is not None}
    used_outputs = [(name, path) for name, path in outputs.items() if path is not None]
    for k, (name, path) in enumerate(used_outputs):
        for input_name, input_path in used_inputs.items():
            if same_file(path, input_path):
                raise ScenarioError(path, name, f"is {input_name} ({input_path}): nothing read is "
                                                "overwritten; choose another file name")
        for other_name, other_path in used_outputs[:k]:
            if same_file(path, other_path):
                raise ScenarioError(path, name, f"is also {other_name}: each output needs its own file")


class StagedFiles:
    """Temporary files beside their targets, renamed into place together by `commit`. Leaving
    the `with` block without a commit (an error, Ctrl-C) removes every temporary file and every
    folder made for them, so that a refused command leaves nothing behind."""

    def __init__(self):
        self._staged: list[tuple[Path, Path]] = []
        self._made: list[Path] = []
        self._committed = False

    def __enter__(self) -> StagedFiles:
        return self

    def path_for(self, final: Path) -> Path:
        """A new empty temporary file in `final`'s folder (made, and remembered, if missing)."""
        folder = Path(os.path.abspath(final)).parent
        missing = []
        while not folder.exists():
            missing.append(folder)
            folder = folder.parent
        for made in reversed(missing):
            made.mkdir()
            self._made.append(made)
        handle, name = tempfile.mkstemp(prefix=f".{Path(final).name[:40]}.", suffix=".part",
                                        dir=Path(os.path.abspath(final)).parent)
        os.close(handle)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(name, 0o666 & ~mask)  # as a plain open() would make it, not mkstemp's 0600
        self._staged.append((Path(name), Path(final)))
        return Path(name)

    def discard(self, temporary: Path) -> None:
        """Remove a temporary file that is not to be kept (a draft checked and replaced)."""
        self._staged = [(t, f) for t, f in self._staged if t != temporary]
        temporary.unlink(missing_ok=True)

    def commit(self) -> None:
        """Rename every temporary file to its target (each rename atomic)."""
        for temporary, final in self._staged:
            os.replace(temporary, final)
        self._committed = True

    def __exit__(self, *exc) -> None:
        if self._committed:
            return
        for temporary, _ in self._staged:
            temporary.unlink(missing_ok=True)
        for folder in reversed(self._made):
            try:
                folder.rmdir()
            except OSError:  # something else was put there meanwhile: keep it
                break
