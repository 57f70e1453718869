"""Warnings do not break a progress line (issue 54, item 6): they print on lines of their own
above it, and the line is drawn again below them."""

from __future__ import annotations

import io
import logging
import warnings
from contextlib import contextmanager

import pytest

from hrc_drake.console import ProgressLine, notes_to


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def screen(text: str) -> list[str]:
    """What a terminal shows of `text`: each line as its last carriage return leaves it."""
    return [line.rsplit("\r", 1)[-1] for line in text.split("\n")]


@contextmanager
def unconfigured_logging():
    """The root logger without handlers, as in `hrc-drake` (pytest's own capture adds some)."""
    kept = logging.root.handlers[:]
    logging.root.handlers.clear()
    try:
        yield
    finally:
        logging.root.handlers[:] = kept


def test_a_note_prints_above_the_progress_line_and_the_line_comes_back():
    stream = Terminal()
    line = ProgressLine(stream)
    line.show("  simulating  10%")
    line.note("FuzzyPolicy: the tree was cut")
    line.show("  simulating  20%")
    line.end()
    assert screen(stream.getvalue()) == ["FuzzyPolicy: the tree was cut", "  simulating  20%", ""]


def test_warnings_and_log_records_go_to_the_note_and_not_to_stderr(capfd):
    stream = Terminal()
    line = ProgressLine(stream)
    line.show("bar 1/4")
    with unconfigured_logging(), notes_to(line.note):
        logging.getLogger("hrc_drake.scheduling.fuzzy_scheduler").warning("the tree was cut at %d", 300)
        warnings.warn("goal out of reach", UserWarning, stacklevel=1)
        logging.getLogger("hrc_drake.x").info("not shown: below WARNING, as logging's last resort")
    line.end()
    shown = screen(stream.getvalue())
    assert shown[0] == "the tree was cut at 300"
    assert shown[1].endswith("UserWarning: goal out of reach") and shown[-2:] == ["bar 1/4", ""]
    assert "not shown" not in stream.getvalue()
    assert capfd.readouterr().err == ""
    assert not any(type(h).__name__ == "_ToFunction" for h in logging.root.handlers)  # removed after
    notes = []
    with unconfigured_logging():
        with notes_to(notes.append):
            pass
        assert logging.root.handlers == []


def test_a_logging_configuration_of_the_callers_own_is_left_alone():
    records = []
    handler = logging.Handler()
    handler.emit = records.append
    logging.root.addHandler(handler)
    try:
        notes = []
        with notes_to(notes.append):
            logging.getLogger("hrc_drake.y").warning("to the caller's handler")
        assert notes == [] and [r.getMessage() for r in records] == ["to the caller's handler"]
    finally:
        logging.root.removeHandler(handler)


def test_the_campaign_bar_prints_the_first_warning_of_each_kind_and_counts_the_rest():
    from hrc_drake.campaign.engine import Progress

    stream = Terminal()
    bar = Progress(3, stream, label="c")
    bar.note("torch_clock/fuzzy seed 1", "FuzzyPolicy: the tree was cut at max_nodes = 300, reaching 14.0 s")
    bar.update(True)
    bar.note("torch_clock/fuzzy seed 2", "FuzzyPolicy: the tree was cut at max_nodes = 300, reaching 11.5 s")
    bar.update(True)
    bar.update(True)
    bar.repeats()
    shown = screen(stream.getvalue())
    assert shown[0] == ("warning from torch_clock/fuzzy seed 1: FuzzyPolicy: the tree was cut at max_nodes "
                        "= 300, reaching 14.0 s")
    assert shown[1].startswith("c [########################] 3/3 done")
    assert shown[2].startswith("(and 1 more run(s) gave this warning, with their own figures: FuzzyPolicy: "
                               "the tree was cut at max_nodes = 300, reaching 14.0 s")


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_the_fuzzy_schedulers_tree_cut_warning_does_not_break_the_simulation_progress(capfd):
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario
    from tests.conftest import DIAGRAMS

    stream = Terminal()
    cell = build_cell(load_scenario(DIAGRAMS / "torch_clock_fuzzy.yaml"))
    with unconfigured_logging():
        simulate(cell, 2.0, progress=stream)
    shown = screen(stream.getvalue())
    cut = [s for s in shown if "the tree was cut" in s]
    assert cut and all(s.startswith("FuzzyPolicy: the tree was cut") for s in cut), shown
    assert shown[-2].startswith("  simulating 100%") and shown[-1] == ""
    assert "the tree was cut" not in capfd.readouterr().err
