"""Benchmark: use case c of thesis 7.5.3 in the Drake cell, the fuzzy scheduler (7.4) against
the uniform one (eq. 7.21-7.23), Experiments A and B on `diagrams/torch_clock.yaml`.

Experiment A: the operator makes torches only (pattern H1, H2, H3; the clock's actions are
removed from the flow and the programs); B: the file's pattern H1, H4, H2, H5, H3. As in 7.5.3:
T_sch = 50 s, t_w = 5 s, 5 torches (A) or 5 torches and 5 clocks (B) per run; the robots are
slowed while a hand is in their workspace (`tracker: !KalmanTracker {}`, the slow-down rule of
9.1.3 on the layout's workspace box: our stand-in for "slowed in the green areas"). Each
scheduler runs the same seeds (the operator's durations); a round-robin arm (the arms'
programs in order) is a reference the thesis does not have.

The runs go through the campaign API (`hrc_drake.campaign`): Experiment B is the shipped campaign
`diagrams/campaigns/use_case_c_schedulers.yaml` (its variants, seeds and duration), Experiment A
the same variants with the torch-only overrides (lists replace) and 420 s; the per-product
samples come from the `per_product` extra metrics (`campaign.extras`). The net has no resource
for the robots' shared area (the thesis's footnote 7 to 7.5.3).

Idle time: as Fig. 7.27, one sample per product, the operator's waiting time (blocked, from
wait_begin to wait_end) within the interval from the previous product (or t = 0) to this one.
Cycle time: the interval between consecutive products (Fig. 7.28). The thesis's claims are
one-sided Wilcoxon rank-sum tests, fuzzy < uniform: idle p = 0.0023 (A), 0.0251 (B); cycle
p = 0.065 (A), 0.122 (B); here `scipy.stats.mannwhitneyu(alternative="less")`.

Prints a line per run and, as its last line, one JSON object: `use_case_c.<A|B>.<arm>.idle_median`,
`.idle_mean`, `.cycle_median`, `.products`, `.runs`, `.idle_samples`, and `use_case_c.<A|B>.wilcoxon_p`
(idle), `.wilcoxon_p_cycle`; `seeds`. (The scheduler's decision time is not measured here.)

The cell's operator has stationary normal durations and the arms share seeds; the thesis had 5
different people per scheduler, learning as they went. `use_case_c.volunteers` is that design at
event level (`tools/volunteer_study.py`, `hrc_drake.scheduling.volunteers`): 60 simulated people
per scheduler and experiment (10 in --quick), each with their own learning curve;
`.<A|B>.<idle|cycle>.between_subjects.p_less` (5 vs 5 people, the thesis's pooled test),
`.power.groups_of_5`, `.people_needed_p05`, and the same per person (`_people`).

Usage:
    PYTHONPATH=. python3 tools/bench_use_case_c.py [--seeds N] [--quick | --smoke] [--workers W]
        [--address tcp://HOST:PORT] [--out DIR] [--volunteers-only]
--quick: 2 seeds, fuzzy and uniform only (about a minute on 2 cores); --smoke: one seed of fuzzy
and uniform, 1 s runs (figures meaningless; the tests run it). --workers 1 (default): in this
process, one run after the other; W > 1: a Dask `LocalCluster` of W processes. --out keeps the
campaigns' runs.parquet (a rerun skips the runs done); default: a temporary folder.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_use_case_b import SMOKE_DURATION, _one_sided, add_campaign_arguments, run_campaigns  # noqa: E402

from hrc_drake.campaign.spec import make_campaign  # noqa: E402
from hrc_drake.cell.scenario import _raw_document, merge_raw  # noqa: E402

SCENARIO = ROOT / "diagrams" / "torch_clock.yaml"
#: the shipped campaign of Experiment B (its variants are the arms)
CAMPAIGN = ROOT / "diagrams" / "campaigns" / "use_case_c_schedulers.yaml"
#: products per run (7.5.3) and the simulated time allowed for them (s; B's is the campaign's)
EXPERIMENTS = {"A": (5, 420.0), "B": (10, 900.0)}
TORCH_ONLY = {"R1", "H1", "L1", "H2", "R2", "H3"}


def experiment_overrides(experiment: str, variant: dict) -> dict:
    """The overrides of torch_clock.yaml's raw document that make Experiment A (B is the file),
    the flow's durations (the timed schedulers' priors) as `variant` patches them in."""
    if experiment == "B":
        return {}
    raw = merge_raw(_raw_document(SCENARIO.read_text()), variant)
    robots = copy.deepcopy(raw["robots"])
    for arm in robots[0]["arms"]:
        arm["program"] = [a for a in arm["program"] if a in TORCH_ONLY]
    return {
        "operator": {
            "pattern": ["H1", "H2", "H3"],
            "actions": [a for a in raw["operator"]["actions"] if a["name"] in TORCH_ONLY],
        },
        "flow": {"actions": [a for a in raw["flow"]["actions"] if a["name"] in TORCH_ONLY]},
        "robots": robots,  # a list: replaced whole, so every robot is given
    }


def shipped_variants() -> dict:
    """The arms of the shipped campaign (variant name -> overrides, tags kept as `Tagged`)."""
    return _raw_document(CAMPAIGN.read_text())["variants"]


def scheduler_overrides(arm: str) -> dict:
    """The arm's scheduler (T_sch 50 s, t_w 5 s) and the tracker that slows the robots, as the
    shipped campaign has them."""
    return copy.deepcopy(shipped_variants()[arm])


def experiment_campaign(experiment: str, arms: list[str], seeds: int, duration: float | None = None):
    """Experiment A or B as a campaign: the shipped campaign's variants (B: as shipped; A: with
    the torch-only overrides), seeds 100, 101, ...; `duration` (s) replaces the experiment's."""
    raw = _raw_document(CAMPAIGN.read_text())
    if duration is None:
        duration = float(raw["duration"]) if experiment == "B" else EXPERIMENTS[experiment][1]
    # A's whole lists replace the variant's patch of the flow (which names clock actions too)
    variants = {arm: scheduler_overrides(arm) for arm in arms}
    document = {
        "name": f"use_case_c_{experiment}",
        "duration": duration,
        "seeds": {"count": seeds, "first": raw["seeds"]["first"]},
        "scenarios": [str(SCENARIO)],
        "variants": {arm: {**v, **experiment_overrides(experiment, v)} for arm, v in variants.items()},
        "metrics": ["mean_time_between_products", "agents.human.idle_time"],
        "extra_metrics": ["per_product"],
    }
    return make_campaign(document, ROOT / "tools" / f"use_case_c_{experiment}.campaign")


def run_rows(seeds: int, arms: list[str], workers: int, address: str | None, out: Path,
             duration: float | None = None) -> list[dict]:
    """Every experiment x arm x seed through the campaign API: a row per run as the old loop's
    (experiment, arm, seed, products, idle, cycles, wall_s, simulated_s); `duration` (s) replaces
    the experiments' own."""
    campaigns = [experiment_campaign(experiment, arms, seeds, duration) for experiment in EXPERIMENTS]
    frames = run_campaigns(campaigns, workers, address, out)
    rows = []
    for campaign, (experiment, (n_products, _)), frame in zip(campaigns, EXPERIMENTS.items(), frames,
                                                               strict=True):
        duration = campaign.duration
        for run in frame.to_dict("records"):
            times = list(run["per_product.times"])[:n_products]
            rows.append({
                "experiment": experiment,
                "arm": run["variant"],
                "seed": int(run["seed"]),
                "products": len(times),
                "idle": [float(x) for x in run["per_product.operator_wait"][:n_products]],
                "cycles": [float(x) for x in run["per_product.cycle_times"][: max(len(times) - 1, 0)]],
                "wall_s": round(float(run["wall_time"]), 1),
                "simulated_s": duration,
            })
            _print_row(rows[-1])
    return rows


#: simulated people per scheduler and experiment in the volunteers' study (smoke, quick, full)
VOLUNTEER_POOLS = {"smoke": 5, "quick": 10, "full": 60}


def volunteers_study(size: str) -> dict:
    """The between-subjects study of 7.5.3 with simulated volunteers (`volunteer_study`), at event
    level on the shipped campaign's cell (torch_clock.yaml with each arm's scheduler and flow
    priors; Experiment A with the torch-only overrides): fuzzy against uniform, 5 (A) or 10 (B)
    products per person, on the operator's waiting time per product (Fig. 7.27) and the cycle
    times (Fig. 7.28), as the thesis tests them."""
    from volunteer_study import compare, run_pool, summary_line

    from hrc_drake.cell.scenario import load_scenario_with
    from hrc_drake.scheduling.systems import make_policy, net_from_scenario
    from hrc_drake.scheduling.volunteers import VolunteerPopulation

    people = VOLUNTEER_POOLS[size]
    population = VolunteerPopulation()
    out: dict = {"people_per_pool": people}
    print(f"Simulated volunteers (event level, {people} people per scheduler and experiment; learning "
          "curve, skewed durations; no slow-down near the operator at event level)", flush=True)
    for experiment, (n_products, _) in EXPERIMENTS.items():
        pools = {}
        for offset, arm in enumerate(("fuzzy", "uniform")):
            variant = scheduler_overrides(arm)
            scenario = load_scenario_with(SCENARIO, {**variant, **experiment_overrides(experiment, variant)})
            config = scenario.scheduler
            if size == "smoke":
                config.max_nodes = 30
            net = net_from_scenario(scenario, config)
            human = {a.name: a.duration for a in scenario.operator.actions}

            def policy(net, seed, config=config):
                return make_policy(net, config, seed)

            seed = 9000 + 100 * ord(experiment) + offset  # each arm and experiment its own people
            pools[arm] = run_pool(net, policy, human, people, n_products, seed, population, 3000.0,
                                  f"{experiment} {arm}")
        block = {"idle": compare(pools, "fuzzy", "uniform", "human_wait", seed=ord(experiment)),
                 "cycle": compare(pools, "fuzzy", "uniform", "cycles", seed=ord(experiment) + 1)}
        thesis = {"A": ("0.0023", "0.065"), "B": ("0.0251", "0.122")}[experiment]
        print(summary_line(f"Experiment {experiment}, idle fuzzy < uniform", block["idle"], thesis[0]),
              flush=True)
        print(summary_line(f"Experiment {experiment}, cycle fuzzy < uniform", block["cycle"], thesis[1]),
              flush=True)
        out[experiment] = block
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeded runs per arm and experiment")
    parser.add_argument("--quick", action="store_true", help="2 seeds, fuzzy and uniform only")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--volunteers-only", action="store_true",
                        help="only the simulated volunteers' study (event level), not the Drake cell's runs")
    add_campaign_arguments(parser)
    args = parser.parse_args(argv)
    if args.volunteers_only:
        size = "smoke" if args.smoke else "quick" if args.quick else "full"
        result = {"use_case_c": {"volunteers": volunteers_study(size)}}
        print(json.dumps(result))
        return result
    seeds = 1 if args.smoke else 2 if args.quick else args.seeds
    arms = ["fuzzy", "uniform"] if args.quick or args.smoke else ["fuzzy", "uniform", "round_robin"]
    n_runs = len(EXPERIMENTS) * seeds * len(arms)
    where = args.address or f"{args.workers} workers"
    print(f"{n_runs} runs ({seeds} seeds x {len(arms)} arms x 2 experiments), {where}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        rows = run_rows(seeds, arms, args.workers, args.address, Path(args.out or tmp),
                        SMOKE_DURATION if args.smoke else None)
    out: dict = {}
    for experiment in EXPERIMENTS:
        block: dict = {}
        for arm in arms:
            mine = [r for r in rows if r["experiment"] == experiment and r["arm"] == arm]
            idle = [x for r in mine for x in r["idle"]]
            cycles = [x for r in mine for x in r["cycles"]]
            block[arm] = {"idle_median": _median(idle), "idle_mean": _mean(idle),
                          "cycle_median": _median(cycles), "products": sum(r["products"] for r in mine),
                          "runs": len(mine),
                          "idle_samples": [round(x, 2) for x in idle]}
        block["wilcoxon_p"] = _one_sided(block["fuzzy"]["idle_samples"], block["uniform"]["idle_samples"])
        fuzzy_cycles, uniform_cycles = ([x for r in rows if r["experiment"] == experiment and r["arm"] == arm
                                         for x in r["cycles"]] for arm in ("fuzzy", "uniform"))
        block["wilcoxon_p_cycle"] = _one_sided(fuzzy_cycles, uniform_cycles)
        out[experiment] = block
        thesis = {"A": 0.0023, "B": 0.0251}[experiment]
        print(f"Experiment {experiment}: idle median fuzzy {block['fuzzy']['idle_median']} s, uniform "
              f"{block['uniform']['idle_median']} s, p = {block['wilcoxon_p']} (thesis {thesis}); cycle p = "
              f"{block['wilcoxon_p_cycle']}", flush=True)
    out["volunteers"] = volunteers_study("smoke" if args.smoke else "quick" if args.quick else "full")
    result = {"use_case_c": out, "seeds": seeds}
    print(json.dumps(result))
    return result


def _print_row(row: dict) -> None:
    print(f"  {row['experiment']} {row['arm']:11s} seed {row['seed']}: {row['products']} products, idle "
          f"{np.round(row['idle'], 1).tolist()} s, wall {row['wall_s']} s", flush=True)


def _median(values) -> float | None:
    return round(float(np.median(values)), 3) if len(values) else None


def _mean(values) -> float | None:
    return round(float(np.mean(values)), 3) if len(values) else None


if __name__ == "__main__":
    main()
