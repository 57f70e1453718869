"""The campaign analysis on groups without enough values (issue 42): hand-made rows, no simulation."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib.axes
import pandas as pd
import pytest

from hrc_drake.campaign.analysis import analyze_campaign, compare_campaigns
from hrc_drake.campaign.worker import KEY_COLUMNS, RUN_COLUMNS

NAN = math.nan
DESCRIPTION = {"name": "issue42", "metrics": ["mean_time_between_products", "products_finished"],
               "expect": []}


def _rows(cycle_times: dict[tuple[str, str], list]) -> pd.DataFrame:
    """Rows of a 20 s campaign: per (scenario, variant) the mean cycle time of seeds 1, 2, ...
    (NaN: no product finished; None: the run failed)."""
    rows = []
    for (scenario, variant), values in cycle_times.items():
        for seed, value in enumerate(values, start=1):
            row = dict(zip(KEY_COLUMNS, (scenario, variant, seed, 20.0), strict=True))
            row.update(status="ok", error="", config_hash="h", worker="w")
            row.update(run_wall_time=1.0, run_cpu_time=1.0)
            if value is None:
                row.update(status="failed", error="RuntimeError: boom")
            else:
                row.update(mean_time_between_products=value,
                           products_finished=0 if math.isnan(value) else 20 // value)
            rows.append(row)
    return pd.DataFrame(rows)


@pytest.fixture
def panel_texts(monkeypatch) -> list[str]:
    """The texts the plots write into their panels."""
    texts = []
    draw = matplotlib.axes.Axes.text

    def text(self, x, y, s, *args, **kwargs):
        texts.append(s)
        return draw(self, x, y, s, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "text", text)
    return texts


def _read(path: Path) -> pd.DataFrame:
    """summary.csv or tests.csv, an empty note as ""."""
    return pd.read_csv(path, dtype={"note": str}).fillna({"note": ""})


def _summary_row(summary: pd.DataFrame, scenario: str, variant: str,
                 metric: str = "mean_time_between_products"):
    key = summary[["scenario", "variant", "metric"]].apply(tuple, axis=1)
    chosen = summary[key == (scenario, variant, metric)]
    assert len(chosen) == 1, chosen
    return chosen.iloc[0]


def test_a_metric_all_nan_in_one_group_is_noted_in_summary_tests_and_plots(tmp_path, panel_texts):
    runs = _rows({("torch_clock", "rr"): [NAN, NAN, NAN], ("assembly", "rr"): [4.0, 5.0, 6.0]})
    paths = analyze_campaign(runs, DESCRIPTION, tmp_path)

    summary = _read(tmp_path / "summary.csv")
    empty = _summary_row(summary, "torch_clock", "rr")
    assert (empty["n"], empty["note"]) == (0, "all NaN") and math.isnan(empty["median"])
    full = _summary_row(summary, "assembly", "rr")
    assert (full["n"], full["median"], full["note"]) == (3, 5.0, "")
    assert _summary_row(summary, "torch_clock", "rr", "products_finished")["n"] == 3  # zeros are values

    tests = _read(tmp_path / "tests.csv")
    cycle = tests[tests["metric"] == "mean_time_between_products"]
    assert set(cycle["test"]) == {"wilcoxon_signed_rank", "rank_sum"}
    assert cycle["p"].isna().all() and (cycle["note"] == "skipped (b: all NaN)").all()

    assert tmp_path / "box_mean_time_between_products.png" in paths
    assert tmp_path / "ecdf_mean_time_between_products.png" in paths
    assert "all NaN" in panel_texts  # the box plot marks the empty group's place
    assert any("torch_clock / rr: all NaN" in text for text in panel_texts)  # the ECDF lists it


def test_a_single_sample_group_has_statistics_but_no_interval_and_no_test(tmp_path):
    runs = _rows({("assembly", "rr"): [4.0, 5.0, 6.0], ("assembly", "none"): [7.0]})
    analyze_campaign(runs, DESCRIPTION, tmp_path)

    summary = _read(tmp_path / "summary.csv")
    single = _summary_row(summary, "assembly", "none")
    assert (single["n"], single["median"], single["mean"], single["note"]) == (1, 7.0, 7.0, "one sample")
    assert math.isnan(single["ci95_low"]) and math.isnan(single["ci95_high"])
    assert _summary_row(summary, "assembly", "rr")["note"] == ""

    tests = _read(tmp_path / "tests.csv")
    cycle = tests[tests["metric"] == "mean_time_between_products"]
    assert len(cycle) == 2 and (cycle["note"] == "skipped (a: one sample)").all()
    assert cycle[["statistic", "p", "effect_size"]].isna().all().all()


def test_a_group_whose_runs_all_failed_is_reported_with_no_ok_runs(tmp_path):
    runs = _rows({("assembly", "rr"): [4.0, 5.0], ("assembly", "broken"): [None, None]})
    analyze_campaign(runs, DESCRIPTION, tmp_path)

    summary = _read(tmp_path / "summary.csv")
    broken = _summary_row(summary, "assembly", "broken")
    assert (broken["n"], broken["note"]) == (0, "no ok runs")
    tests = _read(tmp_path / "tests.csv")
    assert (tests[tests["a"] == "broken"]["note"] == "skipped (a: no ok runs)").all()
    assert len(tests) == 4  # 2 metrics x 2 tests, none dropped


@pytest.mark.parametrize(
    "runs",
    [
        pd.DataFrame(columns=[*KEY_COLUMNS, *RUN_COLUMNS]),  # what read_runs gives without runs.parquet
        pd.DataFrame(),
    ],
)
def test_an_empty_table_writes_empty_tables_and_no_plots(tmp_path, runs):
    (tmp_path / "summary.csv").write_text("stale\n")
    paths = analyze_campaign(runs, DESCRIPTION, tmp_path)

    assert paths == [tmp_path / "summary.csv", tmp_path / "tests.csv"]
    summary, tests = pd.read_csv(paths[0]), pd.read_csv(paths[1])
    assert summary.empty and {"n", "median", "note"} <= set(summary.columns)
    assert tests.empty and {"test", "p", "note"} <= set(tests.columns)


def _campaign_folder(path: Path, name: str, runs: pd.DataFrame) -> Path:
    path.mkdir()
    (path / "campaign.json").write_text(json.dumps({**DESCRIPTION, "name": name}))
    runs.to_parquet(path / "runs.parquet", index=False)
    return path


def test_compare_of_two_campaigns_where_one_has_an_all_nan_group(tmp_path, panel_texts):
    short = _campaign_folder(tmp_path / "short", "short", _rows({("torch_clock", "rr"): [NAN, NAN]}))
    long = _campaign_folder(tmp_path / "long", "long", _rows({("torch_clock", "rr"): [9.0, 11.0]}))
    paths = compare_campaigns([short, long], tmp_path / "out")

    summary = _read(tmp_path / "out" / "summary.csv")
    assert _summary_row(summary, "torch_clock", "short/rr")["note"] == "all NaN"
    assert _summary_row(summary, "torch_clock", "long/rr")["median"] == 10.0
    tests = _read(tmp_path / "out" / "tests.csv")
    cycle = tests[tests["metric"] == "mean_time_between_products"]
    assert (cycle["a"] == "long/rr").all() and (cycle["note"] == "skipped (b: all NaN)").all()
    assert tmp_path / "out" / "box_mean_time_between_products.png" in paths
    assert "all NaN" in panel_texts


def test_pooled_per_run_samples_are_tested_as_one_sample_per_variant(tmp_path):
    """`pooled`: the first k values of a list column of every run, pooled per group, tested with a
    one-sided rank sum where the campaign expects a winner (the thesis's test of 7.5.3)."""
    from scipy.stats import mannwhitneyu

    waits = {"fuzzy": [[1.0, 2.0, 9.0], [0.5, 1.5], None],
             "uniform": [[3.0, 4.0, 0.1], [5.0, 2.5, 7.0], [6.0]]}
    rows = _rows({("cell", v): [20.0] * len(w) for v, w in waits.items()})
    rows["per_product.operator_wait"] = [w for v in waits for w in waits[v]]
    rows.loc[rows["per_product.operator_wait"].isna(), "status"] = "failed"
    description = {"name": "pooled", "metrics": ["mean_time_between_products"],
                   "extra_metrics": ["per_product"],
                   "pooled": [{"metric": "per_product.operator_wait", "first": 2}],
                   "expect": [{"better": "fuzzy", "than": "uniform",
                               "metrics": ["per_product.operator_wait"]}]}
    paths = analyze_campaign(rows, description, tmp_path)
    tests = _read(tmp_path / "tests.csv")
    pooled = tests[tests["test"] == "rank_sum_pooled"]
    assert len(pooled) == 1
    row = pooled.iloc[0]
    fuzzy, uniform = [1.0, 2.0, 0.5, 1.5], [3.0, 4.0, 5.0, 2.5, 6.0]  # the first 2 of each ok run
    assert row["metric"] == "per_product.operator_wait[:2]" and (row["a"], row["b"]) == ("fuzzy", "uniform")
    assert row["alternative"] == "less" and (row["n_a"], row["n_b"]) == (4, 5)
    assert row["p"] == pytest.approx(mannwhitneyu(fuzzy, uniform, alternative="less").pvalue)
    summary = _read(tmp_path / "summary.csv")
    assert _summary_row(summary, "cell", "uniform", "per_product.operator_wait[:2]")["median"] == 4.0
    assert tmp_path / "box_per_product_operator_wait_pooled.png" in paths
