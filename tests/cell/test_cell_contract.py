"""Every scenario in diagrams/ is a description: one built cell simulated twice, and a freshly
built cell, give identical metrics and events (the Drake-native issue)."""

import json
import warnings

import pytest

from hrc_drake.cell.build import build_cell
from hrc_drake.cell.metrics import write_events_csv
from hrc_drake.cell.run import simulate
from hrc_drake.cell.scenario import load_scenario
from tests.conftest import DIAGRAMS

SCENARIOS = sorted(DIAGRAMS.glob("*.yaml"))
#: long enough for every cell to finish robot and human actions
SECONDS = 20.0


def _run(cell, tmp_path, name):
    result = simulate(cell, SECONDS, progress=None)
    metrics = {k: v for k, v in result.metrics.items() if k not in ("wall_time", "realtime_factor")}
    events = tmp_path / f"{name}.csv"
    write_events_csv(events, result.log.events)
    return json.dumps(metrics, sort_keys=True), events.read_text()


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_a_cell_simulated_twice_and_a_fresh_cell_agree(path, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cell = build_cell(load_scenario(path), path)
        first = _run(cell, tmp_path, "first")
        again = _run(cell, tmp_path, "again")
        fresh = _run(build_cell(load_scenario(path), path), tmp_path, "fresh")
    assert "begin" in first[1], "the run did nothing: it cannot tell runs apart"
    assert again == first
    assert fresh == first
