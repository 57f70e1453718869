"""A progress line on a terminal that warnings do not break.

A progress line is rewritten in place ("\\r"); a Python warning or a log record printed to stderr
meanwhile landed in the middle of it (the fuzzy scheduler's "the tree was cut" inside the bar).
`ProgressLine.note` prints such a text on a line of its own above the progress line and redraws
it; `notes_to` sends warnings and the log records that would go to stderr to such a function.
"""

from __future__ import annotations

import logging
import re
import warnings
from contextlib import contextmanager


class ProgressLine:
    """One line rewritten in place on `stream` (a terminal), with `note`s printed above it."""

    def __init__(self, stream):
        self.stream = stream
        self.text = ""

    def show(self, text: str) -> None:
        """Rewrite the line with `text` (blanks clear what a longer earlier text left)."""
        pad = " " * max(len(self.text) - len(text), 0)
        print(f"\r{text}{pad}", end="", file=self.stream, flush=True)
        self.text = text

    def note(self, text: str) -> None:
        """`text` on a line of its own, then the progress line again below it."""
        if self.text:
            print("\r" + " " * len(self.text) + "\r", end="", file=self.stream)
        print(text, file=self.stream)
        if self.text:
            print(self.text, end="", file=self.stream)
        self.stream.flush()

    def end(self) -> None:
        """End the line (a newline after the last text shown)."""
        if self.text:
            print(file=self.stream, flush=True)
            self.text = ""


class _ToFunction(logging.Handler):
    def __init__(self, write):
        super().__init__(logging.WARNING)
        self.write = write

    def emit(self, record) -> None:
        try:
            self.write(self.format(record))
        except Exception:  # noqa: BLE001 - logging's own rule: a handler never raises
            self.handleError(record)


@contextmanager
def notes_to(write):
    """While active, Python warnings (as `warnings.formatwarning` words them) and the log
    records of WARNING and above that would reach stderr through logging's last resort (the root
    logger has no handler: nobody configured logging) go to `write(text)` instead. A logging
    configuration of the caller's own is left alone."""
    handler = None
    if not logging.root.handlers:
        handler = _ToFunction(write)
        logging.root.addHandler(handler)

    def show(message, category, filename, lineno, file=None, line=None):
        write(warnings.formatwarning(message, category, filename, lineno, line).rstrip())

    try:
        with warnings.catch_warnings():
            warnings.showwarning = show
            yield
    finally:
        if handler is not None:
            logging.root.removeHandler(handler)


class WarningTally:
    """Runs' warnings by kind (their words, figures left out): `first` says whether a text is the
    first of its kind, the rest are counted for `repeats`."""

    def __init__(self):
        self._kinds: dict[str, list] = {}

    def first(self, text: str) -> bool:
        kind = re.sub(r"\d+(\.\d+)?", "#", text)
        if kind in self._kinds:
            self._kinds[kind][1] += 1
            return False
        self._kinds[kind] = [text, 0]
        return True

    def repeats(self) -> list[str]:
        """A line per kind that more runs gave: how many, and the first text's first line."""
        return [f"(and {more} more run(s) gave this warning, with their own figures: "
                f"{first.splitlines()[0][:100]})" for first, more in self._kinds.values() if more]
