"""Statistics and plots of finished campaigns: DIR/summary.csv, DIR/tests.csv, DIR/box_*.png
and DIR/ecdf_*.png (box plots and ECDFs per metric, as thesis Figs. 7.19-7.22 and 7.27-7.28).

Groups are (scenario, variant); only `ok` runs count. Tests compare two groups of one scenario
(or one variant across scenarios) on each metric: Wilcoxon signed-rank on their common seeds
(paired) and Wilcoxon rank-sum / Mann-Whitney U (unpaired), two-sided, or one-sided where the
campaign expects one variant to win. Effect sizes are rank-biserial correlations: for the
signed-rank test r = (R+ - R-) / (R+ + R-) of the differences a - b (matched pairs), for the
rank-sum test r = 2 U_a / (n_a n_b) - 1; both are positive when the first group is larger.

A group without values of a metric stays in the results with a note: "no ok runs" (every run
failed), "all NaN" (no run measured it, e.g. no product finished) or "one sample" (no interval, no
test); tests.csv says in its `note` why a test was skipped, and the plots say it in the panel
(a metric without a value in any group has no plot).
"""

from __future__ import annotations

import fnmatch
import itertools
import math
from pathlib import Path

import numpy as np

from hrc_drake.campaign.spec import expand_metrics, larger_is_better
from hrc_drake.campaign.worker import KEY_COLUMNS, RUN_COLUMNS
from hrc_drake.untrusted import csv_cell, file_name_part

#: bootstrap resamples of the 95 % confidence interval of a mean
BOOTSTRAP_RESAMPLES = 2000
GROUP = ("scenario", "variant")
NO_OK_RUNS, ALL_NAN, ONE_SAMPLE = "no ok runs", "all NaN", "one sample"


def bootstrap_ci(
    values, rng: np.random.Generator, resamples: int = BOOTSTRAP_RESAMPLES, level: float = 0.95
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of `values` (nan, nan with fewer than 2)."""
    values = np.asarray(values, float)
    if len(values) < 2:
        return math.nan, math.nan
    means = values[rng.integers(0, len(values), size=(resamples, len(values)))].mean(axis=1)
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(means, [tail, 100 - tail])
    return float(low), float(high)


def metric_columns(runs, patterns: list[str]) -> list[str]:
    """The numeric metric columns of `runs` the patterns name, with those that have no value at all
    (reported as all NaN)."""
    candidates = [c for c in runs.columns if c not in (*KEY_COLUMNS, *RUN_COLUMNS)]
    return [
        c
        for c in expand_metrics(patterns, candidates)
        if runs[c].isna().all() or _numeric(runs[c]).notna().any()
    ]


def _numeric(column):
    """`column` as floats, NaN where a value is missing or not a number."""
    import pandas as pd

    return pd.to_numeric(column, errors="coerce").astype(float)


def _groups(runs) -> list[tuple[tuple[str, str], object]]:
    """((scenario, variant), the group's ok rows) of every group with a row, ok or not."""
    return [(key, rows[rows["status"] == "ok"]) for key, rows in runs.groupby(list(GROUP), sort=True)]


def _values(ok_rows, metric: str) -> np.ndarray:
    """The values of `metric` in `ok_rows`, without NaN."""
    return _numeric(ok_rows[metric]).dropna().to_numpy()


def group_note(n_ok: int, n_values: int) -> str:
    """Why a group has no or few values of a metric: "no ok runs", "all NaN", "one sample" or ""."""
    if n_ok == 0:
        return NO_OK_RUNS
    if n_values == 0:
        return ALL_NAN
    return ONE_SAMPLE if n_values == 1 else ""


def summary_table(runs, metrics: list[str], seed: int = 0):
    """Per scenario, variant and metric: n, median, quartiles, IQR, mean and its 95 % bootstrap CI,
    and a note on a group with no or one value (statistics NaN where they need more)."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    rows = []
    for (scenario, variant), ok_rows in _groups(runs):
        for metric in metrics:
            values = _values(ok_rows, metric)
            row = {"scenario": scenario, "variant": variant, "metric": metric, "n": len(values)}
            row["note"] = group_note(len(ok_rows), len(values))
            rows.append(row | _statistics(values, rng))
    return pd.DataFrame(
        rows,
        columns=[
            "scenario",
            "variant",
            "metric",
            "n",
            "median",
            "q1",
            "q3",
            "iqr",
            "mean",
            "ci95_low",
            "ci95_high",
            "note",
        ],
    )


def _statistics(values, rng) -> dict:
    """Median, quartiles, IQR, mean and its bootstrap CI of `values` (empty without values)."""
    if not len(values):
        return {}
    q1, median, q3 = np.percentile(values, [25, 50, 75])
    low, high = bootstrap_ci(values, rng)
    return {"median": median, "q1": q1, "q3": q3, "iqr": q3 - q1, "mean": float(values.mean()),
            "ci95_low": low, "ci95_high": high}


def _alternative(variant_a: str, variant_b: str, metric: str, expect: list[dict]) -> tuple[str, str]:
    """("less" / "greater" / "two-sided", the claim in words) of a against b on `metric`."""
    for claim in expect:
        patterns = claim.get("metrics") or ["*"]
        if not any(fnmatch.fnmatch(metric, p) for p in patterns):
            continue
        if (claim["better"], claim["than"]) in ((variant_a, variant_b), (variant_b, variant_a)):
            a_better = claim["better"] == variant_a
            a_less = a_better != larger_is_better(metric)
            return ("less" if a_less else "greater"), f"{claim['better']} better than {claim['than']}"
    return "two-sided", ""


def paired_test(a, b, alternative: str = "two-sided") -> tuple[float, float, int]:
    """Wilcoxon signed-rank on pairs: (statistic, p, n pairs) with matched-pairs rank-biserial as
    the effect size returned by `matched_rank_biserial`."""
    from scipy.stats import wilcoxon

    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < 2 or np.all(a == b):
        return math.nan, math.nan, len(a)
    result = wilcoxon(a, b, alternative=alternative)
    return float(result.statistic), float(result.pvalue), len(a)


def matched_rank_biserial(a, b) -> float:
    """(R+ - R-) / (R+ + R-) of the nonzero differences a - b (Kerby 2014)."""
    from scipy.stats import rankdata

    d = np.asarray(a, float) - np.asarray(b, float)
    d = d[d != 0]
    if not len(d):
        return math.nan
    ranks = rankdata(np.abs(d))
    return float((ranks[d > 0].sum() - ranks[d < 0].sum()) / ranks.sum())


def rank_sum_test(a, b, alternative: str = "two-sided") -> tuple[float, float, float]:
    """Mann-Whitney U of a against b: (U_a, p, rank-biserial 2 U_a / (n_a n_b) - 1)."""
    from scipy.stats import mannwhitneyu

    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < 2 or len(b) < 2:
        return math.nan, math.nan, math.nan
    result = mannwhitneyu(a, b, alternative=alternative)
    return float(result.statistic), float(result.pvalue), float(2 * result.statistic / (len(a) * len(b)) - 1)


def tests_table(runs, metrics: list[str], expect: list[dict]):
    """Paired and unpaired tests of every two variants of a scenario (and of every two scenarios
    of a variant) on every metric; a test that cannot run has NaN results and a note why."""
    import pandas as pd

    rows = []
    for fixed, varied in (("scenario", "variant"), ("variant", "scenario")):
        for held, frame in runs.groupby(fixed, sort=True):
            names = sorted(frame[varied].unique())
            ok = frame[frame["status"] == "ok"]
            for first, second in itertools.combinations(names, 2):
                a_rows, b_rows = ok[ok[varied] == first], ok[ok[varied] == second]
                for metric in metrics:
                    alternative, claim = ("two-sided", "")
                    if varied == "variant":
                        alternative, claim = _alternative(first, second, metric, expect)
                    a = _numeric(a_rows[metric])
                    b = _numeric(b_rows[metric])
                    side_notes = [
                        f"{side}: {note}"
                        for side, ok_rows, values in (("a", a_rows, a), ("b", b_rows, b))
                        if (note := group_note(len(ok_rows), int(values.notna().sum())))
                    ]
                    skipped = f"skipped ({'; '.join(side_notes)})" if side_notes else ""
                    paired = (
                        pd.DataFrame({"seed": a_rows["seed"].to_numpy(), "a": a.to_numpy()})
                        .merge(
                            pd.DataFrame({"seed": b_rows["seed"].to_numpy(), "b": b.to_numpy()}), on="seed"
                        )
                        .dropna()
                    )
                    w, p_w, n_pairs = paired_test(paired["a"], paired["b"], alternative)
                    u, p_u, r_u = rank_sum_test(a.dropna(), b.dropna(), alternative)
                    base = {
                        fixed: held,
                        "metric": metric,
                        "a": first,
                        "b": second,
                        "compared": varied,
                        "alternative": alternative,
                        "claim": claim,
                        "median_a": float(a.median()),
                        "median_b": float(b.median()),
                    }
                    rows.append(
                        {
                            **base,
                            "test": "wilcoxon_signed_rank",
                            "n_a": n_pairs,
                            "n_b": n_pairs,
                            "statistic": w,
                            "p": p_w,
                            "effect_size": matched_rank_biserial(paired["a"], paired["b"])
                            if n_pairs and not skipped
                            else math.nan,
                            "note": skipped or _paired_note(paired["a"], paired["b"]),
                        }
                    )
                    rows.append(
                        {
                            **base,
                            "test": "rank_sum",
                            "n_a": int(a.notna().sum()),
                            "n_b": int(b.notna().sum()),
                            "statistic": u,
                            "p": p_u,
                            "effect_size": r_u,
                            "note": skipped,
                        }
                    )
    columns = [
        "scenario",
        "variant",
        "compared",
        "metric",
        "a",
        "b",
        "test",
        "alternative",
        "claim",
        "n_a",
        "n_b",
        "median_a",
        "median_b",
        "statistic",
        "p",
        "effect_size",
        "note",
    ]
    return pd.DataFrame(rows, columns=columns)


def _paired_note(a, b) -> str:
    """Why `paired_test` gives NaN on these pairs, or ""."""
    if len(a) < 2:
        return "skipped (fewer than 2 seeds with values in both)"
    if np.all(np.asarray(a, float) == np.asarray(b, float)):
        return "skipped (every difference is zero)"
    return ""


def metric_label(metric: str) -> str:
    """An axis label: the metric's name with its unit where the name tells it (times in s,
    distances in m; fractions, counts and others have none)."""
    last = metric.split("[", 1)[0].rsplit(".", 1)[-1]  # a pooled metric ends in [:k]
    if last.endswith(("_time", "_s", "_times", "_wait", "_between")) or last in (
            "mean_time_between_products", "cycle_time_median", "cycle_time_p90"):
        return f"{metric} (s)"
    if "distance" in last or last.endswith("_m"):
        return f"{metric} (m)"
    return metric


def plot_metrics(runs, metrics: list[str], out_dir: Path, title: str = "") -> list[Path]:
    """One box plot and one ECDF figure per metric with values, a box / curve per (scenario,
    variant); a group without values is named in the panel with the reason ("no ok runs", "all NaN")."""
    from hrc_drake.untrusted import headless_pyplot

    plt = headless_pyplot()

    groups = [
        (f"{s}\n{v}" if runs["scenario"].nunique() > 1 else str(v), ok_rows)
        for (s, v), ok_rows in _groups(runs)
    ]
    paths = []
    for metric in metrics:
        data = []
        for label, ok_rows in groups:
            values = _values(ok_rows, metric)
            data.append((label, values, group_note(len(ok_rows), len(values))))
        if not any(len(values) for _, values, _ in data):
            continue
        stem = file_name_part(metric.replace(".", "_"))
        fig = box_figure(data, metric, title)
        paths.append(Path(out_dir) / f"box_{stem}.png")
        fig.savefig(paths[-1], dpi=100)
        plt.close(fig)
        fig, ax = plt.subplots(figsize=(6, 4))
        for label, values, note in data:
            if len(values):
                x = np.sort(values)
                name = label.replace("\n", " / ") + (f" ({note})" if note else "")
                marker = "o" if len(x) == 1 else None  # a step of one point draws no line
                ax.step(x, np.arange(1, len(x) + 1) / len(x), where="post", label=name, marker=marker)
        missing = [f"{label}: {note}".replace("\n", " / ") for label, values, note in data if not len(values)]
        if missing:
            box = {"facecolor": "white", "alpha": 0.8, "edgecolor": "none"}
            text = "no values\n" + "\n".join(missing)
            ax.text(0.98, 0.02, text, transform=ax.transAxes, ha="right", va="bottom", fontsize=8, bbox=box)
        ax.set_xlabel(metric_label(metric))
        ax.set_ylabel("fraction of runs")
        ax.set_title(f"{title}: ECDF of {metric}" if title else f"ECDF of {metric}", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        paths.append(Path(out_dir) / f"ecdf_{stem}.png")
        fig.savefig(paths[-1], dpi=100)
        plt.close(fig)
    return paths


def box_figure(data: list[tuple[str, np.ndarray, str]], metric: str, title: str = ""):
    """The box plot of `metric`: a box per (label, values, note) group, a group without values
    named by its note; the legend says which mark is which (the median line, the mean
    triangle, the box's quartiles, the whiskers' reach, outliers)."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig, ax = plt.subplots(figsize=(max(5.5, 1.2 * len(data) + 3.5), 4))
    drawn = [(k, values) for k, (_, values, _) in enumerate(data, start=1) if len(values)]
    parts = ax.boxplot([values for _, values in drawn], positions=[k for k, _ in drawn], showmeans=True)
    for k, (_, _, note) in enumerate(data, start=1):
        if note:
            ax.text(k, 0.97, note, transform=ax.get_xaxis_transform(), ha="center", va="top", fontsize=8)
    ax.set_xlim(0.5, len(data) + 0.5)
    ax.set_xticks(range(1, len(data) + 1), [label for label, _, _ in data])
    ax.set_ylabel(metric_label(metric))
    ax.set_title(f"{title}: {metric}" if title else metric, fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    # the legend's marks are copies of the plotted ones (their colour, marker, line)
    median, mean = parts["medians"][0], parts["means"][0]
    flier = parts["fliers"][0]
    handles = [
        Line2D([], [], color=median.get_color(), lw=median.get_linewidth(), label="median"),
        Line2D([], [], ls="", marker=mean.get_marker(), markerfacecolor=mean.get_markerfacecolor(),
               markeredgecolor=mean.get_markeredgecolor(), label="mean"),
        Patch(facecolor="none", edgecolor=parts["boxes"][0].get_color(), label="box: quartiles (IQR)"),
        Line2D([], [], color=parts["whiskers"][0].get_color(), label="whiskers: within 1.5 IQR"),
        Line2D([], [], ls="", marker=flier.get_marker(), markerfacecolor=flier.get_markerfacecolor(),
               markeredgecolor=flier.get_markeredgecolor(), label="outliers"),
    ]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def pooled_values(ok_rows, metric: str, first: int = 0) -> np.ndarray:
    """The list values of `metric` in `ok_rows` (the first `first` of each run, 0: all), pooled;
    a run without the column's list (NaN, None) adds nothing."""
    pooled = []
    if metric in ok_rows:
        for value in ok_rows[metric]:
            if value is None or (np.ndim(value) == 0 and not isinstance(value, (list, tuple))):
                continue
            values = np.asarray(value, dtype=float).reshape(-1)
            pooled.append(values[:first] if first else values)
    out = np.concatenate(pooled) if pooled else np.zeros(0)
    return out[np.isfinite(out)]


def pooled_tables(runs, pooled: list[dict], expect: list[dict], seed: int = 0):
    """(summary rows, tests rows) of the pooled samples (`spec.PooledSamples`): per group the
    statistics of `summary_table` over the pooled values (n counts samples, not runs), and per two
    variants of a scenario a rank-sum test of the pooled samples ("rank_sum_pooled"; samples of one
    run are not independent, as the thesis's test on per-product waits also takes them)."""
    import pandas as pd

    from hrc_drake.campaign.spec import PooledSamples

    rng = np.random.default_rng(seed)
    summary, tests = [], []
    for item in pooled:
        sample = PooledSamples(**item)
        label = sample.label
        groups = {key: (ok_rows, pooled_values(ok_rows, sample.metric, sample.first))
                  for key, ok_rows in _groups(runs)}
        for (scenario, variant), (ok_rows, values) in groups.items():
            summary.append({"scenario": scenario, "variant": variant, "metric": label, "n": len(values),
                            "note": group_note(len(ok_rows), len(values)), **_statistics(values, rng)})
        for scenario in sorted({key[0] for key in groups}):
            variants = sorted(v for s, v in groups if s == scenario)
            for first, second in itertools.combinations(variants, 2):
                (a_rows, a), (b_rows, b) = groups[(scenario, first)], groups[(scenario, second)]
                alternative, claim = _alternative(first, second, sample.metric, expect)
                notes = [f"{side}: {note}" for side, rows, values in (("a", a_rows, a), ("b", b_rows, b))
                         if (note := group_note(len(rows), len(values)))]
                u, p, r = rank_sum_test(a, b, alternative)
                tests.append({"scenario": scenario, "variant": "", "compared": "variant", "metric": label,
                              "a": first, "b": second, "test": "rank_sum_pooled", "alternative": alternative,
                              "claim": claim, "n_a": len(a), "n_b": len(b),
                              "median_a": float(np.median(a)) if len(a) else math.nan,
                              "median_b": float(np.median(b)) if len(b) else math.nan,
                              "statistic": u, "p": p, "effect_size": r,
                              "note": f"skipped ({'; '.join(notes)})" if notes else ""})
    return pd.DataFrame(summary), pd.DataFrame(tests)


def _formula_free(table):
    """`table` with every text cell that starts like a spreadsheet formula quoted (`csv_cell`):
    scenario, variant and metric names come from the user's files."""
    import pandas as pd

    table = table.copy()
    for column in table.columns:
        if not pd.api.types.is_numeric_dtype(table[column]):
            table[column] = table[column].map(csv_cell)
    return table


def plot_pooled(runs, pooled: list[dict], out_dir: Path, title: str = "") -> list[Path]:
    """A box plot per pooled metric, a box per group (as thesis Fig. 7.27)."""
    from hrc_drake.untrusted import headless_pyplot

    plt = headless_pyplot()

    from hrc_drake.campaign.spec import PooledSamples

    paths = []
    several = runs["scenario"].nunique() > 1 if len(runs) else False
    for item in pooled:
        sample = PooledSamples(**item)
        data = []
        for (s, v), ok_rows in _groups(runs):
            values = pooled_values(ok_rows, sample.metric, sample.first)
            data.append((f"{s}\n{v}" if several else str(v), values, group_note(len(ok_rows), len(values))))
        if not any(len(values) for _, values, _ in data):
            continue
        fig = box_figure(data, sample.label, title)
        paths.append(Path(out_dir) / f"box_{file_name_part(sample.metric.replace('.', '_'))}_pooled.png")
        fig.savefig(paths[-1], dpi=100)
        plt.close(fig)
    return paths


def analyze_campaign(runs, description: dict, out_dir: Path) -> list[Path]:
    """summary.csv, tests.csv and the plots of `runs` in `out_dir`; returns their paths. Without
    ok rows the two tables are still written (only their groups, or empty), so no stale ones stay."""
    import pandas as pd

    out_dir = Path(out_dir)
    if runs.empty:
        runs = pd.DataFrame(columns=[*KEY_COLUMNS, *RUN_COLUMNS])
    metrics = metric_columns(runs, description.get("metrics", []))
    summary = summary_table(runs, metrics)
    tests = tests_table(runs, metrics, description.get("expect", []))
    pooled = description.get("pooled", [])
    if pooled:
        pooled_summary, pooled_tests = pooled_tables(runs, pooled, description.get("expect", []))
        summary = pd.concat([summary, pooled_summary.reindex(columns=summary.columns)], ignore_index=True)
        tests = pd.concat([tests, pooled_tests.reindex(columns=tests.columns)], ignore_index=True)
    summary_path, tests_path = out_dir / "summary.csv", out_dir / "tests.csv"
    _formula_free(summary).to_csv(summary_path, index=False, float_format="%.6g")
    _formula_free(tests).to_csv(tests_path, index=False, float_format="%.6g")
    title = description.get("name", "")
    return [summary_path, tests_path, *plot_metrics(runs, metrics, out_dir, title),
            *plot_pooled(runs, pooled, out_dir, title)]


def compare_campaigns(dirs: list[Path], out_dir: Path) -> list[Path]:
    """Redraw and compare finished campaigns: their rows together (variants named
    `campaign/variant` when there are several), the union of their metrics and claims."""
    import json

    import pandas as pd

    from hrc_drake.campaign.store import read_runs

    frames, metrics, expect, names = [], [], [], []
    for directory in dirs:
        description = json.loads((Path(directory) / "campaign.json").read_text())
        runs = read_runs(directory)
        name = description.get("name", Path(directory).name)
        names.append(name)
        if len(dirs) > 1:
            runs = runs.assign(variant=[f"{name}/{v}" for v in runs["variant"]])
        frames.append(runs)
        metrics += [m for m in description.get("metrics", []) if m not in metrics]
        for claim in description.get("expect", []):
            if len(dirs) > 1:
                claim = {**claim, "better": f"{name}/{claim['better']}", "than": f"{name}/{claim['than']}"}
            expect.append(claim)
    runs = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    return analyze_campaign(runs, {"name": " vs ".join(names), "metrics": metrics, "expect": expect}, out_dir)
