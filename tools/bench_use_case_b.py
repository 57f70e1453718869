"""Benchmark: use case b of thesis 7.5.2 in the Drake cell, Scheduler A (Monte Carlo on the
observed delays, 7.3) against Scheduler B (Monte Carlo on uniform delays between the smallest and
the largest observed ones), patterns 1 and 2, on `diagrams/carts.yaml`.

As in 7.5.2: c_R = 0.5, c_H = 1.0 (the carts 0), T_sch = 30 s, t_w = 3 s, N = 150 trials, 9
products per run; a cycle is the time between two successive products (Fig. 7.19: the ends of
Storing). Each scheduler runs the same seeds (the operator's durations); the round robin (the
flow order of each agent's actions, a reference the thesis does not have) runs them too. The
thesis reports A below B on both patterns ("p = 0.9971", "p = 0.9926", Wilcoxon; these read as
1 - p of a one-sided test); here `scipy.stats.mannwhitneyu(alternative="less")`, A < B, on the
pooled cycles and on the runs' mean cycles.

Prints a line per run and, as its last line, one JSON object: `use_case_b.<pattern1|pattern2>.<A|B|RR>`
with `cycle_median`, `cycle_mean`, `products`, `human_wait_per_product`, and
`use_case_b.<pattern>.wilcoxon_p` (cycles), `.wilcoxon_p_runs`.

Usage:
    python3 tools/bench_use_case_b.py [--seeds N] [--quick] [--workers W]
--quick: 2 seeds, A and B only (about a minute on 2 cores).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu

ROOT = Path(__file__).resolve().parents[1]
#: products per run (7.5.2) and the simulated time allowed for them (s)
N_PRODUCTS, DURATION = 9, 560.0
PATTERNS = {"pattern1": "[pad, trim, label]", "pattern2": "[pad, pad, trim, trim, label, label]"}
SCHEDULERS = {
    "A": "!MonteCarloScheduler {n_trials: 150, horizon: 30.0, wait_quantum: 3.0, cost_robot: 0.5, "
         "cost_human: 1.0, agent_costs: {cart1: 0.0, cart2: 0.0}}",
    "B": "!MonteCarloScheduler {n_trials: 150, horizon: 30.0, wait_quantum: 3.0, cost_robot: 0.5, "
         "cost_human: 1.0, agent_costs: {cart1: 0.0, cart2: 0.0}, durations: uniform_support}",
    "RR": "!RoundRobinScheduler {wait_quantum: 3.0}",
}


def scenario_text(base: Path, pattern: str, scheduler: str, seed: int) -> str:
    """`base` with the operator's pattern, a scheduler and the seed (`extends`)."""
    return (f"extends: {base}\nseed: {seed}\noperator: {{pattern: {pattern}}}\nscheduler: {scheduler}\n")


def run_cell(base: Path, pattern: str, pattern_name: str, arm: str, scheduler: str, seed: int,
             n_products: int, duration: float) -> dict:
    """One seeded run of `base` with the pattern and the scheduler: the first `n_products`
    products' cycles and the operator's blocked time until the last of them."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{base.stem}_{pattern_name}_{arm}.yaml"
        path.write_text(scenario_text(base, pattern, scheduler, seed))
        scenario = load_scenario(path)
        cell = build_cell(scenario, path)
    start = time.perf_counter()
    result = simulate(cell, duration, progress=None)
    wall = time.perf_counter() - start
    times = result.metrics["product_times"][:n_products]
    end = times[-1] if times else duration
    waits = _waits(result.log.events, end)
    return {"pattern": pattern_name, "arm": arm, "seed": seed, "products": len(times),
            "cycles": [float(c) for c in np.diff(times)], "human_wait": waits,
            "wall_s": round(wall, 1)}


def run_one(job) -> dict:
    pattern, arm, seed = job
    return run_cell(ROOT / "diagrams" / "carts.yaml", PATTERNS[pattern], pattern, arm, SCHEDULERS[arm], seed,
                    N_PRODUCTS, DURATION)


def _waits(events, until: float) -> float:
    """The operator's time blocked (wait_begin to wait_end) before `until`."""
    total, start = 0.0, None
    for e in sorted(events, key=lambda e: (e.time, e.seq)):
        if getattr(e, "agent", "human") != "human":
            continue
        if e.kind == "wait_begin":
            start = e.time
        elif e.kind == "wait_end" and start is not None:
            total += max(0.0, min(e.time, until) - start)
            start = None
    if start is not None and start < until:
        total += until - start
    return round(total, 3)


def summarize(rows: list[dict], arms: list[str], patterns=PATTERNS, test=("A", "B")) -> dict:
    """Per pattern and arm: cycle median and mean, products, the operator's blocked time per
    product; one-sided rank sums that arm test[0] has shorter cycles than test[1]."""
    out: dict = {}
    for pattern in patterns:
        block: dict = {}
        for arm in arms:
            mine = [r for r in rows if r["pattern"] == pattern and r["arm"] == arm]
            cycles = [c for r in mine for c in r["cycles"]]
            products = sum(r["products"] for r in mine)
            block[arm] = {"cycle_median": _round(np.median(cycles)) if cycles else None,
                          "cycle_mean": _round(np.mean(cycles)) if cycles else None,
                          "products": products, "runs": len(mine),
                          "human_wait_per_product": _round(sum(r["human_wait"] for r in mine) / products)
                          if products else None,
                          "run_mean_cycles": [_round(np.mean(r["cycles"])) for r in mine if r["cycles"]]}
        first, second = ([c for r in rows if r["pattern"] == pattern and r["arm"] == arm for c in r["cycles"]]
                         for arm in test)
        block["wilcoxon_p"] = _one_sided(first, second)
        block["wilcoxon_p_runs"] = _one_sided(block[test[0]]["run_mean_cycles"],
                                              block[test[1]]["run_mean_cycles"])
        out[pattern] = block
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="seeded runs per arm and pattern")
    parser.add_argument("--quick", action="store_true", help="2 seeds, A and B only")
    parser.add_argument("--workers", type=int, default=1, help="runs at once (processes)")
    args = parser.parse_args(argv)
    seeds = 2 if args.quick else args.seeds
    arms = ["A", "B"] if args.quick else ["A", "B", "RR"]
    jobs = [(p, a, 100 + s) for p in PATTERNS for s in range(seeds) for a in arms]
    print(f"{len(jobs)} runs ({seeds} seeds x {len(arms)} arms x 2 patterns), {args.workers} workers",
          flush=True)
    rows = run_jobs(run_one, jobs, args.workers)
    out = summarize(rows, arms)
    for pattern, block in out.items():
        print(f"{pattern}: median cycle A {block['A']['cycle_median']} s, B {block['B']['cycle_median']} s"
              + (f", RR {block['RR']['cycle_median']} s" if "RR" in block else "")
              + f"; one-sided rank sum A < B p = {block['wilcoxon_p']} (cycles), {block['wilcoxon_p_runs']} "
              "(runs' mean cycles); thesis: A below B", flush=True)
    result = {"use_case_b": out, "seeds": seeds}
    print(json.dumps(result))
    return result


def run_jobs(function, jobs: list, workers: int, print_row=None) -> list[dict]:
    """`function` on every job, in `workers` processes, printing a line per run as it ends."""
    print_row = print_row or _print_row
    rows = []
    if workers > 1:
        with multiprocessing.get_context("spawn").Pool(workers) as pool:
            for row in pool.imap(function, jobs):
                rows.append(row)
                print_row(row)
    else:
        for job in jobs:
            rows.append(function(job))
            print_row(rows[-1])
    return rows


def _print_row(row: dict) -> None:
    mean = np.mean(row["cycles"]) if row["cycles"] else float("nan")
    print(f"  {row['pattern']} {row['arm']:2s} seed {row['seed']}: {row['products']} products, mean cycle "
          f"{mean:.2f} s, human waits {row['human_wait']} s, wall {row['wall_s']} s", flush=True)


def _round(x) -> float:
    return round(float(x), 3)


def _one_sided(a, b) -> float | None:
    """One-sided rank-sum p that `a` is smaller than `b`."""
    return float(mannwhitneyu(a, b, alternative="less").pvalue) if len(a) > 1 and len(b) > 1 else None


if __name__ == "__main__":
    main()
