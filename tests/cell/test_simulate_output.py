"""`cell.run.simulate` from Python is quiet unless its caller asks for progress (issue "One way to
name things", item 4: a 5 s run printed ten progress lines); `hrc-drake simulate` asks."""

from __future__ import annotations

import io

import pytest

from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate
from hrc_drake.cell.scenario import load_scenario
from tests.conftest import DIAGRAMS


@pytest.fixture(scope="module")
def cell():
    return build_cell(load_scenario(DIAGRAMS / "torch_clock.yaml"))  # the fastest shipped cell


def test_simulate_prints_nothing_unless_progress_is_asked_for(cell, capfd):
    simulate(cell, 1.0, progress=True)  # asked: stderr (a first run's kernel notice lands here too)
    asked = capfd.readouterr()
    assert asked.err.count("simulating") == 10 and asked.out == ""
    result = simulate(cell, 1.0)  # the default: nothing on stdout or stderr, from Python or Drake
    assert capfd.readouterr() == ("", "")
    assert result.simulated_time == pytest.approx(1.0)
    simulate(cell, 1.0, progress=False)
    assert capfd.readouterr() == ("", "")


def test_progress_goes_to_the_stream_given(cell, capfd):
    stream = io.StringIO()
    simulate(cell, 1.0, progress=stream)
    assert stream.getvalue().count("simulating") == 10 and "100%" in stream.getvalue()
    assert capfd.readouterr() == ("", "")
