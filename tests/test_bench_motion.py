"""The pure helpers of tools/bench_motion.py that carry the safety judge's figures (no simulation)."""

from __future__ import annotations

import pytest

from tests.conftest import load_tool


@pytest.fixture(scope="module")
def bench():
    module = load_tool("bench_motion")
    return module


def metrics(code, violations, stops, own=None, slowed=2.5, products=3):
    safety = {"verdict_code": code, "verdict": code.upper(), "violations_total": violations,
              "violations": {"ssm_breach": violations}, "ssm_breach_s": 0.033 * violations,
              "protective_stops": stops, "closest_approach_m": 0.1,
              "own_model": None if own is None else {"violations_total": own}}
    return {"safety": safety, "time_slowed_s": slowed, "products_finished": products}


def test_judge_figures_reads_the_judge_and_the_own_model(bench):
    row = bench.judge_figures(metrics("non_conforming", 4, 7, own=1))
    assert (row["verdict_code"], row["violations_total"], row["protective_stops"]) == ("non_conforming", 4, 7)
    assert row["own_model_violations"] == 1 and row["products"] == 3 and row["time_slowed_s"] == 2.5
    assert bench.judge_figures(metrics("safe", 0, 2))["own_model_violations"] is None
    empty = bench.judge_figures({"safety": None, "products_finished": None})
    assert empty["verdict_code"] is None and empty["violations_total"] is None and empty["products"] == 0


def test_judge_summary_counts_safe_runs_and_sums_violations(bench):
    runs = [bench.judge_figures(m) for m in (metrics("safe", 0, 2), metrics("unsafe", 3, 4),
                                             metrics("safe", 0, 6, products=5))]
    s = bench.judge_summary(runs)
    assert s["runs"] == 3 and s["safe_runs"] == 2 and s["verdict_codes"] == {"safe": 2, "unsafe": 1}
    assert s["violations_total"] == 3 and s["protective_stops_per_run"] == pytest.approx(4.0)
    assert s["own_model_violations_total"] is None and s["products_total"] == 11
    assert "SAFE 2 of 3" in bench.judge_line(s)
    own = bench.judge_summary([bench.judge_figures(metrics("non_conforming", 5, 1, own=2))])
    assert own["safe_runs"] == 0 and own["own_model_violations_total"] == 2


def test_same_runs_names_the_seeds_that_differ(bench):
    base = {"store_ends": [10.0, 20.0], **{k: 1 for k in bench.SAME_KEYS if k != "store_ends"}}
    runs = [{"kind": "gp_c", "seed": 5, **base}, {"kind": "worst_case", "seed": 5, **base},
            {"kind": "gp_c", "seed": 6, **base}, {"kind": "worst_case", "seed": 6, **base}]
    assert bench.same_runs(runs) == {"seeds_paired": 2, "seeds_differing": [], "identical": True}
    runs[3] = {**runs[3], "store_ends": [10.0, 21.0]}
    assert bench.same_runs(runs) == {"seeds_paired": 2, "seeds_differing": [6], "identical": False}


def proactive_run(bench, proactive, seed, level, nominal_cost=1.0):
    import numpy as np

    times = np.arange(0.0, 20.0, 0.1)
    distances = np.full(times.shape, level)
    overrides = np.where(times < 5.0, 0.0, 1.0)
    plans = [{"time": 10.0, "weights": [1.0], "nominal_cost": nominal_cost, "proactive_cost": 0.5,
              "cloud_points": 10, "cloud_ms": 1.0, "stomp_ms": 2.0, "gpdm_ms": 3.0}] if proactive else []
    return {"proactive": proactive, "seed": seed, "wall_s": 1.0, "min_distance_m": level,
            "median_distance_m": level, "robot_idle_pct": 25.0, "replannings": plans,
            "_trace": (times, distances, overrides),
            **bench.judge_figures(metrics("safe", 0, 1))}


def test_summarise_proactive_survives_a_nominal_cost_of_zero(bench, capsys):
    import json

    runs = [proactive_run(bench, True, 1, 0.5, nominal_cost=0.0), proactive_run(bench, True, 2, 0.6),
            proactive_run(bench, False, 1, 0.4), proactive_run(bench, False, 2, 0.3)]
    out = bench.summarise_proactive(runs, (1, 2), 20.0)
    assert out["replannings"] == 2 and out["zero_nominal_cost"] == 1
    assert out["stomp_cost_ratio_median"] == 0.5
    assert out["proactive"]["judge"]["safe_runs"] == 2 and out["nominal"]["runs"] == 2
    assert out["proactive"]["after_first_plan"]["seeds"] == 2
    assert all("_trace" not in r for r in out["runs"])
    bench.print_proactive(out)
    assert "SAFE 2 of 2" in capsys.readouterr().out
    json.dumps(out)
