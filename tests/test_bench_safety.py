"""tools/bench_safety.py's layout check, and every shipped cell saying how it is kept safe."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DIAGRAMS = sorted((REPO / "diagrams").glob("*.yaml"))


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_safety", REPO / "tools" / "bench_safety.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_coexistence_layout_keeps_its_targets_beyond_the_worst_case_reach(bench):
    layout = bench.separation_at_rest(str(REPO / "diagrams" / "box_pcb_coexistence.yaml"))
    assert 0.6 < layout["rest_reach_m"] < layout["nearest_robot_target_m"]


def test_a_hand_over_layout_has_targets_inside_the_worst_case_reach(bench):
    layout = bench.separation_at_rest(str(REPO / "diagrams" / "torch_clock.yaml"))
    assert layout["nearest_robot_target_m"] < 0.3 < layout["rest_reach_m"]


def test_a_longer_horizon_reaches_farther(bench):
    path = str(REPO / "diagrams" / "torch_clock.yaml")
    assert bench.separation_at_rest(path, horizon=0.5)["rest_reach_m"] > \
        bench.separation_at_rest(path, horizon=0.3)["rest_reach_m"] + 0.1


@pytest.mark.parametrize("path", DIAGRAMS, ids=lambda p: p.stem)
def test_every_cell_header_says_how_it_is_kept_safe(path):
    header = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        header.append(line)
    assert any(line.startswith("# Safety:") for line in header), f"{path.name}: no '# Safety:' line"
