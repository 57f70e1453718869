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

The cell's operator has stationary normal durations and the arms share seeds (paired); the
thesis had 5 different people per group, learning as they went. `use_case_b.volunteers` is that
design at event level (`tools/volunteer_study.py`, `hrc_drake.scheduling.volunteers`): 60
simulated people per scheduler and pattern (10 in --quick), each with their own learning curve;
`.pattern<k>.between_subjects.p_less` (5 vs 5 people, the thesis's pooled test),
`.power.groups_of_5`, `.people_needed_p05`, and the same per person (`_people`).

The runs go through the campaign API (`hrc_drake.campaign`): one campaign, a variant per pattern
and scheduler (`pattern1-A`, ...), the per-product samples from the `per_product` extra metrics.

Usage:
    python3 tools/bench_use_case_b.py [--seeds N] [--quick | --smoke] [--workers W]
        [--address tcp://HOST:PORT] [--out DIR] [--volunteers-only]
--quick: 2 seeds, A and B only (about a minute on 2 cores); --smoke: one seed of A and B, 1 s
runs (figures meaningless; the tests run it). --workers 1 (default): in this
process; W > 1: a Dask `LocalCluster` of W processes. --out keeps the campaign's runs.parquet (a
rerun skips the runs done); default: a temporary folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from contextlib import nullcontext
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hrc_drake.campaign.engine import ClusterClient, run_campaign  # noqa: E402
from hrc_drake.campaign.spec import make_campaign  # noqa: E402
from hrc_drake.cell.scenario import _raw_document, load_scenario  # noqa: E402

#: products per run (7.5.2) and the simulated time allowed for them (s)
N_PRODUCTS, DURATION = 9, 560.0
#: the simulated time of a --smoke run (s): the whole path, no product expected
SMOKE_DURATION = 1.0
PATTERNS = {"pattern1": "[pad, trim, label]", "pattern2": "[pad, pad, trim, trim, label, label]"}
SCHEDULERS = {
    "A": "!MonteCarloScheduler {n_trials: 150, horizon: 30.0, wait_quantum: 3.0, cost_robot: 0.5, "
         "cost_human: 1.0, agent_costs: {cart1: 0.0, cart2: 0.0}}",
    "B": "!MonteCarloScheduler {n_trials: 150, horizon: 30.0, wait_quantum: 3.0, cost_robot: 0.5, "
         "cost_human: 1.0, agent_costs: {cart1: 0.0, cart2: 0.0}, durations: uniform_support}",
    "RR": "!RoundRobinScheduler {wait_quantum: 3.0}",
}


def untimed_flow(base: Path, scheduler: str) -> dict:
    """The overrides that clear the flow durations of `base` (the timed schedulers' priors) for
    `scheduler` (a YAML text) when it reads none, as validation asks; {} otherwise."""
    from hrc_drake.scheduling import config

    kind = getattr(config, _raw_document(f"scheduler: {scheduler}")["scheduler"].tag)
    if issubclass(kind, config.TIMED_SCHEDULERS):
        return {}
    priors = [a.name for a in load_scenario(base).flow.actions if a.duration is not None]
    return {"flow": {"actions": {name: {"duration": None} for name in priors}}} if priors else {}


def pattern_campaign(name: str, base: Path, patterns: dict[str, str], schedulers: dict[str, str],
                     arms: list[str], seeds: int, duration: float, extra: str = ""):
    """`base` as a campaign: a variant `<pattern>-<arm>` per operator pattern and scheduler (the
    YAML texts above, overrides of the scenario), seeds 100, 101, ...; per-product samples.
    extra: YAML text of further overrides every variant takes (e.g. the safety mode)."""
    variants = {
        f"{p}-{arm}": {**_raw_document(f"operator: {{pattern: {patterns[p]}}}\nscheduler: {schedulers[arm]}"),
                       **untimed_flow(base, schedulers[arm]), **(_raw_document(extra) if extra else {})}
        for p in patterns
        for arm in arms
    }
    document = {
        "name": name,
        "duration": duration,
        "seeds": {"count": seeds, "first": 100},
        "scenarios": [str(base)],
        "variants": variants,
        "metrics": ["mean_time_between_products", "agents.*.idle_time"],
        "extra_metrics": ["per_product"],
    }
    return make_campaign(document, ROOT / "tools" / f"{name}.campaign")


def run_campaigns(campaigns: list, workers: int, address: str | None, out: Path) -> list:
    """Each campaign through the campaign API, in this process one run after the other
    (`workers` <= 1, no address) or on one Dask client shared by all (a LocalCluster of `workers`
    processes, or the scheduler at `address`); the rows (a DataFrame) of each, its failed runs
    printed and left out."""
    frames = []
    in_process = address is None and workers <= 1
    with nullcontext(None) if in_process else ClusterClient(address, workers) as client:
        for campaign in campaigns:
            outcome = run_campaign(
                campaign, out / campaign.name, workers=0, client=client, progress=sys.stderr, analyze=False
            )
            rows = outcome.rows
            for failed in rows[rows["status"] != "ok"].to_dict("records"):
                print(f"  {failed['variant']} seed {failed['seed']} FAILED: {failed['error']}", flush=True)
            frames.append(rows[rows["status"] == "ok"])
    return frames


def pattern_rows(frame, n_products: int) -> list[dict]:
    """A campaign's rows as the benchmarks use them: per run the first `n_products` products'
    cycles and the operator's blocked time until the last of them (until the end without one)."""
    rows = []
    for run in frame.to_dict("records"):
        pattern, _, arm = run["variant"].partition("-")
        times = list(run["per_product.times"])[:n_products]
        wait = sum(run["per_product.operator_wait"][:n_products]) if times else run[
            "per_product.operator_wait_after_last"]
        rows.append({"pattern": pattern, "arm": arm, "seed": int(run["seed"]), "products": len(times),
                     "cycles": [float(c) for c in run["per_product.cycle_times"][: max(len(times) - 1, 0)]],
                     "human_wait": round(float(wait), 3), "wall_s": round(float(run["wall_time"]), 1)})
    return rows


def run_patterns(name: str, base: Path, patterns: dict[str, str], schedulers: dict[str, str], arms: list[str],
                 seeds: int, n_products: int, duration: float, args, extra: str = "") -> list[dict]:
    """Every pattern x arm x seed of `base` as one campaign (`pattern_campaign`); a row per run, printed."""
    campaign = pattern_campaign(name, base, patterns, schedulers, arms, seeds, duration, extra)
    with tempfile.TemporaryDirectory() as tmp:
        (frame,) = run_campaigns([campaign], args.workers, args.address, Path(args.out or tmp))
    rows = pattern_rows(frame, n_products)
    for row in rows:
        _print_row(row)
    return rows


def add_campaign_arguments(parser: argparse.ArgumentParser) -> None:
    """--workers, --address, --out of the benchmarks that run whole cells over seeds."""
    parser.add_argument("--workers", type=int, default=1, help="runs at once (1: this process, W: processes)")
    parser.add_argument("--address", default=None, help="a Dask scheduler (tcp://HOST:PORT) instead")
    parser.add_argument("--out", default=None, help="keep the campaign's rows here (default: a temp folder)")


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
        out[pattern] = block
        if not all(arm in arms for arm in test):  # a run of some arms only: no test
            continue
        first, second = ([c for r in rows if r["pattern"] == pattern and r["arm"] == arm for c in r["cycles"]]
                         for arm in test)
        block["wilcoxon_p"] = _one_sided(first, second)
        block["wilcoxon_p_runs"] = _one_sided(block[test[0]]["run_mean_cycles"],
                                              block[test[1]]["run_mean_cycles"])
    return out


#: simulated people per scheduler and pattern in the volunteers' study (smoke, quick, full)
VOLUNTEER_POOLS = {"smoke": 5, "quick": 10, "full": 60}


def volunteers_study(size: str) -> dict:
    """The between-subjects study of 7.5.2 with simulated volunteers (`volunteer_study`), at event
    level on `thesis_cells.use_case_b` (the cell's flow): Scheduler A against B per pattern, 9
    products per person, on the pooled cycle times as the thesis's Fig. 7.19 test."""
    from volunteer_study import compare, run_pool, summary_line

    from hrc_drake.scheduling import thesis_cells as tc
    from hrc_drake.scheduling.compiler import compile_flow
    from hrc_drake.scheduling.montecarlo import MonteCarloPolicy
    from hrc_drake.scheduling.volunteers import VolunteerPopulation

    people = VOLUNTEER_POOLS[size]
    trials = 20 if size == "smoke" else 150
    arms = {"A": "empirical", "B": "uniform_support"}
    population = VolunteerPopulation()
    out: dict = {"people_per_pool": people, "population": {
        "learning_rates": list(population.learning_rates), "speed_cv": population.speed_cv,
        "reference_execution": population.reference}}
    print(f"Simulated volunteers (event level, {people} people per scheduler and pattern, 9 products each; "
          "learning curve, skewed durations)", flush=True)
    for number in (1, 2):
        flow, buffers, pattern, robots = tc.use_case_b(number)
        net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0, cost_robot=0.5,
                           cost_human=1.0, agent_costs=tc.USE_CASE_B_AGENT_COSTS)
        human = {a.name: a.duration for a in flow.actions if "human" in a.agents}
        pools = {}
        for offset, (arm, durations) in enumerate(arms.items()):
            def make_policy(net, seed, durations=durations):
                return MonteCarloPolicy(net, n_trials=trials, horizon=30.0, random_state=seed,
                                        durations=durations)

            # each arm its own people: seeds differ by arm and pattern (between subjects)
            pools[arm] = run_pool(net, make_policy, human, people, N_PRODUCTS, 7000 + 100 * number + offset,
                                  population, 3000.0, f"pattern {number} {arm}")
        result = compare(pools, "A", "B", "cycles", seed=number)
        print(summary_line(f"pattern {number}, cycle times A < B", result, "1 - 0.9971" if number == 1
                           else "1 - 0.9926"), flush=True)
        out[f"pattern{number}"] = result
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="seeded runs per arm and pattern")
    parser.add_argument("--quick", action="store_true", help="2 seeds, A and B only")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--volunteers-only", action="store_true",
                        help="only the simulated volunteers' study (event level), not the Drake cell's runs")
    add_campaign_arguments(parser)
    args = parser.parse_args(argv)
    if args.volunteers_only:
        size = "smoke" if args.smoke else "quick" if args.quick else "full"
        result = {"use_case_b": {"volunteers": volunteers_study(size)}}
        print(json.dumps(result))
        return result
    seeds = 1 if args.smoke else 2 if args.quick else args.seeds
    arms = ["A", "B"] if args.quick or args.smoke else ["A", "B", "RR"]
    n_runs = len(PATTERNS) * seeds * len(arms)
    print(f"{n_runs} runs ({seeds} seeds x {len(arms)} arms x 2 patterns), {args.address or args.workers} "
          "workers", flush=True)
    rows = run_patterns("use_case_b", ROOT / "diagrams" / "carts.yaml", PATTERNS, SCHEDULERS, arms, seeds,
                        N_PRODUCTS, SMOKE_DURATION if args.smoke else DURATION, args)
    out = summarize(rows, arms)
    for pattern, block in out.items():
        print(f"{pattern}: median cycle A {block['A']['cycle_median']} s, B {block['B']['cycle_median']} s"
              + (f", RR {block['RR']['cycle_median']} s" if "RR" in block else "")
              + f"; one-sided rank sum A < B p = {block['wilcoxon_p']} (cycles), {block['wilcoxon_p_runs']} "
              "(runs' mean cycles); thesis: A below B", flush=True)
    size = "smoke" if args.smoke else "quick" if args.quick else "full"
    out["volunteers"] = volunteers_study(size)
    result = {"use_case_b": out, "seeds": seeds}
    print(json.dumps(result))
    return result


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
