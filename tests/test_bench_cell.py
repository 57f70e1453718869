"""The pure helpers of tools/bench_cell.py (no subprocess, no timing assertions)."""

from __future__ import annotations

import json

import pytest

from tests.conftest import load_tool


@pytest.fixture(scope="module")
def bench():
    module = load_tool("bench_cell")
    return module


def run(wall, cpu, products=1, dist=0.2):
    return {"wall_s": wall, "cpu_s": cpu, "products": products, "min_distance": dist,
            "robot_modes": ["kinematic"]}


def test_last_json_line(bench):
    assert bench.last_json_line('noise\n{"a": 1}\n\n') == {"a": 1}
    with pytest.raises(ValueError):
        bench.last_json_line("\n")


def test_change_percent_sign(bench):
    assert bench.change_percent(2.0, 1.0) == pytest.approx(100.0)  # current slower: positive
    assert bench.change_percent(1.0, 2.0) == pytest.approx(-50.0)


def test_summarize_runs_medians_wall_and_cpu_separately(bench):
    s = bench.summarize_runs([run(1.0, 3.0), run(2.0, 1.0), run(4.0, 2.0)], duration=20.0)
    assert s["wall_s"] == 2.0 and s["cpu_s"] == 2.0
    assert s["rtf"] == pytest.approx(10.0) and s["rtf_cpu"] == pytest.approx(10.0)


def test_largest_states(bench):
    states = [
        {"system": "a", "deepcopy_us": 5.0, "clone_us": None},
        {"system": "b", "deepcopy_us": 1.0, "clone_us": 30.0},
        {"system": "c", "deepcopy_us": 2.0, "clone_us": 10.0},
    ]
    by_copy, by_clone = bench.largest_states(states)
    assert by_copy["system"] == "a" and by_clone["system"] == "b"
    assert bench.largest_states([]) == (None, None)


def test_figures_json_keys_and_table(bench):
    names = ["torch_clock"]
    current = {"torch_clock": bench.summarize_runs([run(1.0, 1.0, products=3)], 20.0)}
    baseline = {"torch_clock": bench.summarize_runs([run(2.0, 2.0, products=2)], 20.0)}
    states = [{"system": "torch_clock:world", "deepcopy_us": 1.0, "clone_us": 4.0}]
    startup = {"current": {"help_s": 0.08, "import_s": 0.5}, "baseline": {"help_s": 0.2}}
    fig = bench.figures_json(names, current, baseline, states, 20.0, 1, "3b262b1", 1.0, 1.5, startup)
    assert fig["rtf_torch_clock"] == 20.0 and fig["rtf_wall_torch_clock"] == 20.0
    assert fig["baseline_rtf_torch_clock"] == 10.0
    assert fig["help_s"] == 0.08 and fig["import_s"] == 0.5 and fig["baseline_help_s"] == 0.2
    assert fig["below_goal"] == ["torch_clock"]  # 20x < 50x
    assert fig["cpu_change_percent_torch_clock"] == -50.0
    assert fig["products_torch_clock"] == 3 and fig["baseline_products_torch_clock"] == 2
    assert fig["clone_largest_state_system"] == "torch_clock:world"
    json.dumps(fig)
    no_base = bench.figures_json(names, current, None, states, 20.0, 1, None, 1.0, 1.5)
    assert "baseline_rtf_torch_clock" not in no_base and "help_s" not in no_base
    assert "torch_clock" in bench.format_table(names, current, baseline)
    assert "torch_clock" in bench.format_table(names, current, None)


def test_startup_figures_keep_each_group_and_the_first_run_and_prefix_the_baseline(bench):
    current = {"import_s": 0.012345, "kernel_compile_s.motion": 3.21234, "first_run_s.torch_clock": 7.0}
    startup = {"current": current, "baseline": {"import_s": 0.5}}
    fig = bench.startup_figures(startup, 1.0, 2.0)
    assert fig == {"import_s": 0.0123, "kernel_compile_s.motion": 3.2123, "first_run_s.torch_clock": 7.0,
                   "baseline_import_s": 0.5, "load_average_1min": {"start": 1.0, "end": 2.0}}
    json.dumps(fig)


def test_collected_instructions_reads_the_callgrind_report(bench):
    report = ("==12== Events    : Ir\n==12== Collected : 1680278510\n==12==\n"
              "==12== I   refs:      1,680,278,510\n")
    assert bench.collected_instructions(report) == 1680278510
    with pytest.raises(ValueError):
        bench.collected_instructions("==12== no count here\n")


def test_instruction_figures_keys_and_change(bench):
    counts = {"current": {"torch_clock": 1_500_000_000}, "baseline": {"torch_clock": 1_200_000_000}}
    fig = bench.instruction_figures(["torch_clock"], counts, 30.0)
    assert fig["instructions_g_torch_clock"] == 1.5
    assert fig["baseline_instructions_g_torch_clock"] == 1.2
    assert fig["instructions_change_percent_torch_clock"] == pytest.approx(25.0)
    assert fig["instructions_duration_s"] == 30.0
    only = bench.instruction_figures(["torch_clock"], {"current": counts["current"]}, 30.0)
    assert "instructions_change_percent_torch_clock" not in only


def test_a_scenario_new_since_the_baseline_is_reported_on_the_current_code_only(bench):
    names = ["pcb_ic", "torch_clock"]
    current = {n: bench.summarize_runs([run(1.0, 1.0)], 20.0) for n in names}
    baseline = {"torch_clock": bench.summarize_runs([run(2.0, 2.0)], 20.0)}
    fig = bench.figures_json(names, current, baseline, [], 20.0, 1, "3b262b1", 1.0, 1.0)
    assert fig["rtf_pcb_ic"] == 20.0 and "cpu_change_percent_pcb_ic" not in fig
    assert fig["cpu_change_percent_torch_clock"] == pytest.approx(-50.0)
    assert "pcb_ic" in bench.format_table(names, current, baseline)


def test_each_cell_has_its_goal_of_issue_41_in_cpu_time(bench):
    """>= 50x CPU, >= 20x with a GP motion predictor, >= 10x with the rendered camera."""
    names = ["fast", "slow", "gp", "gp_slow", "pcb_occlusion_rendered"]
    gp = dict(run(1.0, 0.8), gp_predictor=True)  # 25x CPU
    gp_slow = dict(run(1.0, 1.2), gp_predictor=True)  # 16.7x CPU
    current = {"fast": bench.summarize_runs([run(1.0, 0.1)], 20.0),        # 200x CPU
               "slow": bench.summarize_runs([run(0.1, 1.0)], 20.0),        # 200x wall, 20x CPU
               "gp": bench.summarize_runs([gp], 20.0), "gp_slow": bench.summarize_runs([gp_slow], 20.0),
               "pcb_occlusion_rendered": bench.summarize_runs([run(2.0, 2.0)], 20.0)}  # 10x
    fig = bench.figures_json(names, current, None, [], 20.0, 1, None, 1.0, 1.0)
    assert fig["below_goal"] == ["slow", "gp_slow"]
    assert [fig[f"goal_rtf_{n}"] for n in names] == [50.0, 50.0, 20.0, 20.0, 10.0]


def test_breakdown_shares_name_the_largest_systems_the_others_and_drake(bench):
    run = {"total_s": 10.0, "systems_s": {"a": 1.0, "b": 4.0, "c": 0.5, "d": 2.0}}
    shares = bench.breakdown_shares(run, top=2)
    assert list(shares) == ["b", "d", "other systems", "drake and glue"]
    assert shares == {"b": 40.0, "d": 20.0, "other systems": 15.0, "drake and glue": 25.0}
