"""Stopping on Ctrl-C (SIGINT) and SIGTERM without losing the run in progress.

Python raises KeyboardInterrupt wherever the main thread happens to be when the signal arrives;
inside a compiled kernel numba then reports `SystemError: ... returned a result with an exception
set`, which no `except KeyboardInterrupt` catches, and the run was lost. While a simulation runs
the handlers here only set a flag, and the simulator's monitor stops at its next step; a second
signal raises at once (a stuck run can still be stopped). Outside a simulation SIGTERM (what a
batch system or `kill` sends) raises `Terminated`, a KeyboardInterrupt, so every `except
KeyboardInterrupt` that saves the finished work serves both signals.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt."""


def interruption(signum: int) -> KeyboardInterrupt:
    """The exception that stands for signal `signum`."""
    return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def signal_of(err: BaseException) -> int:
    """The signal an interruption stands for (SIGINT unless it is a `Terminated`)."""
    return signal.SIGTERM if isinstance(err, Terminated) else signal.SIGINT


def exit_code(err: BaseException) -> int:
    """The shell's exit code of a process ended by the interruption `err`: 128 + the signal."""
    return 128 + int(signal_of(err))


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def sigterm_raises():
    """Within: SIGTERM raises `Terminated` in the main thread (nothing changes elsewhere, or where
    SIGTERM is ignored); the previous handler is back afterwards."""
    previous = signal.getsignal(signal.SIGTERM)
    if not _in_main_thread() or previous is signal.SIG_IGN:
        yield
        return
    signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)


def _raise_terminated(signum, frame):
    raise Terminated()


class StopRequest:
    """Set by the first SIGINT or SIGTERM while `stop_requested_by_signals` is active."""

    def __init__(self):
        self.signum: int | None = None

    def __bool__(self) -> bool:
        return self.signum is not None


@contextmanager
def stop_requested_by_signals():
    """Within: SIGINT and SIGTERM set the yielded `StopRequest` (the first time; a second one
    raises). Signals this process ignores stay ignored (Dask's local workers ignore SIGINT);
    outside the main thread nothing is installed (Python allows handlers there only)."""
    request = StopRequest()
    if not _in_main_thread():
        yield request
        return
    previous = {s: signal.getsignal(s) for s in STOP_SIGNALS}

    def handler(signum, frame):
        if request.signum is not None:
            raise interruption(signum)
        request.signum = signum

    for s in STOP_SIGNALS:
        if previous[s] is not signal.SIG_IGN:
            signal.signal(s, handler)
    try:
        yield request
    finally:
        for s, old in previous.items():
            signal.signal(s, old if old is not None else signal.SIG_DFL)
