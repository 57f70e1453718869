"""tools/bench_use_case_a.py's sweep of the percentile p of Fig. 5.14 (5.4.1 never gives p)."""

from __future__ import annotations

import pytest

from tests.conftest import load_tool


@pytest.fixture(scope="module")
def bench():
    module = load_tool("bench_use_case_a")
    return module


def test_the_percentile_sweep_spans_both_sides_of_the_median_and_every_arm_is_a_valid_scenario(bench):
    levels = bench.SWEEP_PERCENTILES
    assert min(levels) <= 0.1 and max(levels) >= 0.95 and sum(p < 0.5 for p in levels) >= 3
    assert levels == sorted(set(levels))
    for p in levels:
        scenario = bench.arm_scenario(bench.Arm("predictive", percentile=p), seed=101)
        # the robot reads t_p at p, and the predictor's forecast carries that level
        assert scenario.scheduler.percentile == p and p in scenario.predictor.percentile_levels
