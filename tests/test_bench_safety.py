"""tools/bench_safety.py's modes, PFL speeds and layout check, and every shipped cell saying how it
is kept safe."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import load_tool

REPO = Path(__file__).resolve().parents[1]
DIAGRAMS = sorted((REPO / "diagrams").glob("*.yaml"))


@pytest.fixture(scope="module")
def bench():
    module = load_tool("bench_safety")
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


#: how a header names each mode
MODE_WORDS = {"ssm": "speed and separation monitoring", "pfl": "power and force limiting", "hybrid": "hybrid"}


@pytest.mark.parametrize("path", DIAGRAMS, ids=lambda p: p.stem)
def test_every_cell_header_says_how_it_is_kept_safe(path):
    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.safety.config import mode_name

    header = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        header.append(line)
    safety = [line for line in header if line.startswith("# Safety:")]
    assert safety, f"{path.name}: no '# Safety:' line"
    mode = mode_name(load_scenario(path).safety)
    assert MODE_WORDS[mode] in safety[0].lower(), f"{path.name}: its '# Safety:' line does not name {mode}"


def test_the_bench_puts_a_cell_under_each_mode(bench):
    from hrc_drake.cell.scenario import load_scenario_with
    from hrc_drake.safety.config import mode_name

    torch = str(REPO / "diagrams" / "torch_clock.yaml")
    for mode in ("none", "ssm", "pfl", "hybrid"):
        assert mode_name(load_scenario_with(torch, bench.mode_overrides(torch, mode)).safety) == mode
    assert bench.mode_overrides(torch, "declared") == {}
    # a cell without zones gets one sphere over its table for the hybrid mode
    coexistence = str(REPO / "diagrams" / "box_pcb_coexistence.yaml")
    scenario = load_scenario_with(coexistence, bench.mode_overrides(coexistence, "hybrid"))
    zones = scenario.layout.collaborative_zones
    assert len(zones) == 1 and zones[0].radius > 0.5


def test_the_bench_reports_eq_a6_per_region(bench):
    transient, quasi = bench.pfl_speeds(3.0)
    assert transient["hand_fingers"] == pytest.approx(1.4459, abs=1e-4)
    assert quasi["hand_fingers"] == pytest.approx(0.7230, abs=1e-4)
    assert transient["face"] == 0.0


def test_the_kept_percentage_and_the_products_plot(bench, tmp_path):
    assert bench.kept_percentage({"none": 8.0, "declared": 6.0}) == 75.0
    assert bench.kept_percentage({"none": 0.0, "declared": 0.0}) is None
    assert bench.kept_percentage({"declared": 3.0}) is None
    products = {"a": {"none": 8.0, "declared": 6.0, "ssm": 0.0}, "b": {"declared": 2.0}}
    out = {"duration_s": 300.0, "products": products,
           "verdict": {"a": "safe", "b": "unsafe"}, "kept_pct": {"a": 75.0, "b": None}}
    path = tmp_path / "products.png"
    bench.plot_products(out, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000


def test_a_cell_that_plans_its_speed_reports_its_declared_figures_as_predictive(bench):
    out = {key: {"a": {"declared": 6.0, "none": 8.0}, "b": {"declared": 2.0, "predictive": 3.0},
                 "c": {"declared": 1.0}} for key in ("products", "cycle_s", "stops", "slowed_s")}
    bench.add_predictive_figures(out, {"a": "predictive", "b": "predictive", "c": "reactive"})
    assert out["products"]["a"]["predictive"] == 6.0 and out["slowed_s"]["a"]["predictive"] == 6.0
    assert out["stops"]["b"]["predictive"] == 3.0  # run itself: kept
    assert "predictive" not in out["cycle_s"]["c"]


def test_the_predictive_and_reactive_modes_are_the_declared_mode_with_that_profile(bench):
    from hrc_drake.cell.scenario import load_scenario_with

    pcb_ic = str(REPO / "diagrams" / "pcb_ic.yaml")
    declared = load_scenario_with(pcb_ic, {}).safety
    for profile in ("reactive", "predictive"):
        safety = load_scenario_with(pcb_ic, bench.mode_overrides(pcb_ic, profile)).safety
        assert type(safety) is type(declared) and safety.speed_profile == profile
        assert safety.contact_reaction == declared.contact_reaction and safety.limits == declared.limits


def test_the_other_modes_keep_the_declared_speed_profile(bench):
    from hrc_drake.cell.scenario import load_scenario_with

    pcb_ic = str(REPO / "diagrams" / "pcb_ic.yaml")
    assert load_scenario_with(pcb_ic, {}).safety.speed_profile == "predictive"
    for mode in ("ssm", "pfl", "hybrid"):
        safety = load_scenario_with(pcb_ic, bench.mode_overrides(pcb_ic, mode)).safety
        assert safety.speed_profile == "predictive"


def test_a_plot_from_earlier_outputs_with_the_before_bars(bench, tmp_path):
    """`--figures LOG --before LOG --plot PNG` runs nothing; a file whose last line is not the bench's
    JSON is refused with its name."""
    import json

    now = {"duration_s": 300.0, "products": {"a": {"none": 8.0, "declared": 7.0}},
           "verdict": {"a": "safe"}, "kept_pct": {"a": 87.5}}
    earlier = {"products": {"a": {"declared": 5.0}}}
    (tmp_path / "now.log").write_text("a row\n" + json.dumps(now) + "\n")
    (tmp_path / "before.log").write_text(json.dumps(earlier))
    assert bench.last_json(tmp_path / "before.log")["products"]["a"]["declared"] == 5.0
    path = tmp_path / "cost.png"
    bench.plot_products(bench.last_json(tmp_path / "now.log"), path,
                        bench.last_json(tmp_path / "before.log")["products"])
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (tmp_path / "bad.log").write_text("run 1 of 3\n")
    with pytest.raises(SystemExit, match="bad.log"):
        bench.last_json(tmp_path / "bad.log")
