"""Bench of `hrc-drake search` (docs/search.md): falsification by TPE against random search at
the same budget, repeated over sampler seeds, on two cells; the optimise preset on use case a
(pcb_ic); the search's own overhead per candidate (a trivial evaluator: Optuna's ask/tell, the
record, the store).

Falsification: each cell is searched `R` times (TPE seeded 0..R-1, random search beside it with a
seed of its own, `spec.random_search_seed`), each search `budget` runs, more than TPE's
`n_startup_trials` (its random start). Per repeat and search: the worst margin found and the runs
spent to the first violation (a margin below 0 or a violation the judge holds; null when none).
The one-sided Mann-Whitney U test (scipy) over the R repeats asks whether TPE's worst margins are
lower than random search's. Cells: `falsify_pcb_ic` (the hand-over cell under PFL, whose mode
holds for the nominal operator: contact margin 0.81) and `falsify_coexistence` (SSM: the margin is
below 0 already for the nominal operator, so the first candidate of either search is a violation).

Optimise: `optimise_pcb_ic`; the best feasible layout and the shipped scenario over fresh seeds
(1,000,000 on, never the search's), and DIR/best_scenario.yaml run by `hrc-drake simulate` as it is.

Prints a table, then as its last line one JSON object:
falsify.<cell>.worst_margin.optimizer / .random (median over the repeats),
falsify.<cell>.worst_margin_per_repeat.optimizer / .random, falsify.<cell>.worst_margin.p_less
(one-sided Mann-Whitney U, TPE lower), falsify.<cell>.runs_to_first_violation.optimizer / .random
(median over the repeats; a repeat with none counts as never; null when half or more found none),
falsify.<cell>.runs_to_first_violation_per_repeat.optimizer / .random (a margin below 0: a contact
the person made counts too), falsify.<cell>.runs_to_first_mode_violation_per_repeat.optimizer /
.random (a violation held against the robot, `safety.violations_total` > 0), falsify.<cell>.worst (the
worst candidate over every repeat: its search, margin and parameters), optimise.<cell>.cycle_s.best
(fresh seeds), .shipped, .differences (best - shipped per fresh seed), .wilcoxon_p (one-sided
signed-rank, best shorter), optimise.<cell>.violations.best / .shipped (fresh seeds),
optimise.<cell>.best_scenario_simulates, optimise.<cell>.best (its parameters) / .shipped_values,
overhead_per_candidate_ms, overhead_pct_of_candidate (of the mean candidate's runs, falsify_pcb_ic),
sections (`--only falsify|optimise` runs one).

    python tools/bench_search.py --quick      # under 5 minutes on 2 cores (2.7-4.3 min measured)
    python tools/bench_search.py --workers 2  # the full bench (51 min on 2 cores shared with other jobs)
    python tools/bench_search.py --only optimise
    python tools/bench_search.py --smoke      # seconds, in this process; figures meaningless (the tests)
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from contextlib import nullcontext
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SEARCHES = REPO / "diagrams" / "searches"

#: per cell: repeats, and the spec's changes (smoke, quick, full)
FALSIFY = {
    "falsify_pcb_ic": {
        "smoke": (1, {"budget": 1, "batch": 1, "duration": 1.0, "optimizer": ("TPE", 1)}),
        "quick": (3, {"budget": 8, "batch": 4, "duration": 30.0, "optimizer": ("TPE", 4)}),
        "full": (5, {"budget": 24, "batch": 4, "duration": 60.0, "optimizer": ("TPE", 8)}),
    },
    "falsify_coexistence": {
        "smoke": (1, {"budget": 1, "batch": 1, "duration": 1.0, "optimizer": ("TPE", 1)}),
        "quick": (2, {"budget": 4, "batch": 2, "duration": 15.0, "optimizer": ("TPE", 2)}),
        "full": (4, {"budget": 12, "batch": 4, "duration": 20.0, "optimizer": ("TPE", 4)}),
    },
}
#: the optimise preset's changes (full: longer runs than the shipped spec's 120 s, so that a mean
#: cycle time averages about 7 products, and 6 fresh seeds per side)
OPTIMISE = {
    "smoke": {"budget": 1, "batch": 1, "duration": 1.0, "seeds": [1], "fresh_seeds": 1, "constraints": []},
    "quick": {"budget": 4, "batch": 2, "duration": 100.0, "seeds": [1], "fresh_seeds": 2, "constraints": []},
    "full": {"budget": 40, "duration": 240.0, "fresh_seeds": 6},
}


def _load(name: str, **changes):
    from hrc_drake.campaign.spec import _read_raw
    from hrc_drake.cell.scenario import Tagged
    from hrc_drake.search.spec import make_search

    path = SEARCHES / f"{name}.yaml"
    document = _read_raw(path)
    optimizer = changes.pop("optimizer", None)
    seed = changes.pop("seed", None)
    if optimizer is not None or seed is not None:
        node = document.get("optimizer")
        fields = dict(node) if isinstance(node, Tagged) else {}
        tag = node.tag if isinstance(node, Tagged) else "TPE"
        if optimizer is not None:
            tag, startup = optimizer
            fields["n_startup_trials"] = startup
        if seed is not None:
            fields["seed"] = seed
        document["optimizer"] = Tagged(tag, fields)
    document.update(changes)
    return make_search(document, path)


def overhead_ms(candidates: int = 40, repetitions: int = 3) -> float:
    """Median wall time per candidate of a search whose runs cost nothing."""
    from hrc_drake.search.engine import FunctionEvaluator, run_search

    search = _load(
        "falsify_coexistence",
        budget=candidates,
        batch=4,
        preset="",
        compare_random=False,
        objective={"metric": "mean_time_between_products", "direction": "minimize"},
    )
    times = []
    for _ in range(repetitions):
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            run_search(
                search,
                Path(out),
                evaluator=FunctionEvaluator(lambda v, s: {"mean_time_between_products": 1.0}),
                progress=None,
            )
            times.append((time.perf_counter() - start) / candidates * 1e3)
    return statistics.median(times)


def _median_runs(values: list):
    """Median of runs to the first violation, a repeat with none counting as never (null when the
    median is never)."""
    ranked = sorted(math.inf if v is None else v for v in values)
    median = statistics.median(ranked)
    return None if math.isinf(median) else median


def falsify(name: str, repeats: int, changes: dict, evaluator, tmp: Path, figures: dict, log) -> dict:
    """Repeat a falsification over sampler seeds 0..repeats-1; figures for the JSON."""
    import pandas as pd
    from scipy.stats import mannwhitneyu

    from hrc_drake.search.engine import run_search
    from hrc_drake.search.report import finish_search, is_mode_violation, runs_to_first_violation

    per = {label: {"worst": [], "first": [], "mode": []} for label in ("optimizer", "random")}
    worst = None
    cell = None
    candidate_ms = []
    for r in range(repeats):
        search = _load(name, seed=r, **changes)
        cell = search.scenario.stem
        out = tmp / f"{name}_{r}"
        start = time.perf_counter()
        # the first repeat writes the whole report (the worst candidate replayed); the others the table
        outcome = run_search(
            search, out, evaluator=evaluator, progress=None, finish=finish_search if r == 0 else None
        )
        results = outcome.results
        runs = pd.read_parquet(out / "runs.parquet")
        candidate_ms.append(float(runs["run_wall_time"].mean()) * len(search.seeds) * 1e3)
        for label in ("optimizer", "random"):
            part = results[(results["search"] == label) & (results["status"] == "ok")]
            value = float(part["objective"].min()) if len(part) else math.nan
            per[label]["worst"].append(value)
            per[label]["first"].append(runs_to_first_violation(results, search, label))
            per[label]["mode"].append(runs_to_first_violation(results, search, label, is_mode_violation))
            if len(part) and (worst is None or value < worst["margin"]):
                row = part.loc[part["objective"].idxmin()]
                worst = {
                    "search": label,
                    "repeat": r,
                    "variant": row["variant"],
                    "margin": round(value, 4),
                    "seeds": list(search.seeds),
                    "parameters": {
                        p.name: _plain(row[f"param.{p.name}"]) for p in search.parameters
                    },
                }
        print(
            f"{name} repeat {r} (TPE seed {r}): worst {search.objective.metric} TPE "
            f"{per['optimizer']['worst'][-1]:.4f} random {per['random']['worst'][-1]:.4f}; runs to the "
            f"first violation TPE {per['optimizer']['first'][-1]} random {per['random']['first'][-1]} "
            f"({time.perf_counter() - start:.0f} s)",
            file=log,
            flush=True,
        )
    key = f"falsify.{cell}"
    for label in ("optimizer", "random"):
        figures[f"{key}.worst_margin.{label}"] = round(statistics.median(per[label]["worst"]), 4)
    for label in ("optimizer", "random"):
        figures[f"{key}.worst_margin_per_repeat.{label}"] = [round(v, 4) for v in per[label]["worst"]]
    test = mannwhitneyu(per["optimizer"]["worst"], per["random"]["worst"], alternative="less")
    figures[f"{key}.worst_margin.p_less"] = round(float(test.pvalue), 4)
    for label in ("optimizer", "random"):
        figures[f"{key}.runs_to_first_violation.{label}"] = _median_runs(per[label]["first"])
        figures[f"{key}.runs_to_first_violation_per_repeat.{label}"] = per[label]["first"]
        figures[f"{key}.runs_to_first_mode_violation_per_repeat.{label}"] = per[label]["mode"]
    figures[f"{key}.repeats"] = repeats
    figures[f"{key}.budget"] = search.budget
    figures[f"{key}.objective"] = search.objective.metric
    figures[f"{key}.worst"] = worst
    return {"candidate_ms": statistics.mean(candidate_ms)}


def _plain(value):
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float):
        return round(value, 4) if math.isfinite(value) else None
    return value


def optimise(changes: dict, evaluator, tmp: Path, figures: dict, log) -> None:
    from hrc_drake.search import params as P
    from hrc_drake.search.report import search_and_report

    search = _load("optimise_pcb_ic", **changes)
    cell = search.scenario.stem
    out = tmp / search.name
    start = time.perf_counter()
    search_and_report(search, out, evaluator=evaluator, progress=log)
    report = json.loads((out / "report.json").read_text())
    key = f"optimise.{cell}"
    best = report.get("best_scenario") or {}
    for variant, label in (("best_fresh", "best"), ("shipped_fresh", "shipped")):
        fresh = best.get(variant) or {}
        figures[f"{key}.cycle_s.{label}"] = _plain(fresh.get("objective"))
    for variant, label in (("best_fresh", "best"), ("shipped_fresh", "shipped")):
        metrics = (best.get(variant) or {}).get("metrics", {})
        figures[f"{key}.violations.{label}"] = _plain(metrics.get("safety.violations_total"))
        figures[f"{key}.products.{label}"] = _plain(metrics.get("products_finished"))
    figures[f"{key}.fresh_seeds"] = best.get("fresh_seeds")
    paired = best.get("paired") or {}
    figures[f"{key}.cycle_s.differences"] = paired.get("differences")
    figures[f"{key}.cycle_s.wilcoxon_p"] = paired.get("wilcoxon_p")
    top = (report["searches"].get("optimizer") or {}).get("top") or []
    figures[f"{key}.best"] = (
        {"variant": top[0]["variant"], "search_objective": top[0]["objective"], **top[0]["parameters"]}
        if top and top[0]["feasible"]
        else None
    )
    figures[f"{key}.shipped_values"] = {
        p.name: (" ".join(v) if isinstance(v, list) and p.kind == "permutation" else v)
        for p in search.parameters
        for v in [P.get_value(search.document, p.steps, allow_missing_last=True)]
    }
    simulates = None
    scenario = out / "best_scenario.yaml"
    if scenario.is_file():  # `hrc-drake simulate` runs the file as it is
        import contextlib

        from hrc_drake.cli import main as cli

        with contextlib.redirect_stdout(log):
            simulates = cli(["simulate", str(scenario), "--out", str(out / "simulated")]) == 0
    figures[f"{key}.best_scenario_simulates"] = simulates
    print(f"{search.name}: {time.perf_counter() - start:.0f} s", file=log, flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", choices=("falsify", "optimise"), default=None,
                        help="run one of the two sections (the overhead share then has no candidate run)")
    args = parser.parse_args(argv)
    from hrc_drake.campaign.engine import ClusterClient
    from hrc_drake.search.engine import CampaignEvaluator

    mode = "smoke" if args.smoke else "quick" if args.quick else "full"
    figures: dict = {}
    start = time.perf_counter()
    log = sys.stderr
    # smoke: the runs one after the other in this process (no Dask cluster to start)
    cluster = nullcontext(None) if args.smoke else ClusterClient(None, args.workers)
    with tempfile.TemporaryDirectory() as tmp, cluster as client:
        evaluator = CampaignEvaluator(client)
        timing = {}
        if args.only in (None, "falsify"):
            for name, modes in FALSIFY.items():
                repeats, changes = modes[mode]
                timing[name] = falsify(name, repeats, dict(changes), evaluator, Path(tmp), figures, log)
        if args.only in (None, "optimise"):
            optimise(dict(OPTIMISE[mode]), evaluator, Path(tmp), figures, log)
    overhead = overhead_ms(4, 1) if args.smoke else overhead_ms()
    figures["overhead_per_candidate_ms"] = round(overhead, 2)
    if "falsify_pcb_ic" in timing:
        candidate_ms = timing["falsify_pcb_ic"]["candidate_ms"]
        figures["candidate_run_ms"] = round(candidate_ms, 1)
        figures["overhead_pct_of_candidate"] = round(100 * overhead / candidate_ms, 3)
    figures["sections"] = args.only or "all"
    figures["wall_s"] = round(time.perf_counter() - start, 1)
    figures["mode"] = mode
    for key, value in figures.items():
        print(f"{key:60s} {value}")
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
