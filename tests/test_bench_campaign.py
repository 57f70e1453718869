"""tools/bench_campaign.py runs end to end on a smoke setting (issue 55, item 12: `--quick` crashed
on a store in a folder never made, and no test noticed)."""

from __future__ import annotations

from tests.conftest import load_tool


def test_the_campaign_bench_runs_and_reports_its_keys(capsys):
    bench = load_tool("bench_campaign")
    result = bench.main(["--runs", "2", "--duration", "2"])
    assert result["runs"] == 2 and result["failed"] == 0 and result["same_rows"] is True
    assert result["runs_per_min_1_worker"] > 0 and result["runs_per_min_2_workers"] > 0
