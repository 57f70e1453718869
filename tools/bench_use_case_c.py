"""Benchmark: use case c of thesis 7.5.3 in the Drake cell, the fuzzy scheduler (7.4) against
the uniform one (eq. 7.21-7.23), Experiments A and B on `diagrams/torch_clock.yaml`.

Experiment A: the operator makes torches only (pattern H1, H2, H3; the clock's actions are
removed from the flow and the programs); B: the file's pattern H1, H4, H2, H5, H3. As in 7.5.3:
T_sch = 50 s, t_w = 5 s, 5 torches (A) or 5 torches and 5 clocks (B) per run; the robots are
slowed while a hand is in their workspace (`tracker: !KalmanTracker {}`, the slow-down rule of
9.1.3 on the layout's workspace box: our stand-in for "slowed in the green areas"). Each
scheduler runs the same seeds (the operator's durations); a round-robin arm (the arms'
programs in order) is a reference the thesis does not have.

Idle time: as Fig. 7.27, one sample per product, the operator's waiting time (blocked, from
wait_begin to wait_end) within the interval from the previous product (or t = 0) to this one.
Cycle time: the interval between consecutive products (Fig. 7.28). The thesis's claims are
one-sided Wilcoxon rank-sum tests, fuzzy < uniform: idle p = 0.0023 (A), 0.0251 (B); cycle
p = 0.065 (A), 0.122 (B); here `scipy.stats.mannwhitneyu(alternative="less")`.

Prints a line per run and, as its last line, one JSON object: `use_case_c.<A|B>.<arm>.idle_median`,
`.idle_mean`, `.cycle_median`, `.products`, `.decision_ms_median`, and `use_case_c.<A|B>.wilcoxon_p`
(idle), `.wilcoxon_p_cycle`.

Usage:
    PYTHONPATH=. python3 tools/bench_use_case_c.py [--seeds N] [--quick] [--workers W]
--quick: 2 seeds, fuzzy and uniform only (about a minute on 2 cores).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_use_case_b import _one_sided, run_jobs  # noqa: E402

from hrc_drake.cell.scenario import Tagged, _raw_document  # noqa: E402
from tests.cell.fuzz import _Dumper  # noqa: E402

#: products per run (7.5.3) and the simulated time allowed for them (s)
EXPERIMENTS = {"A": (5, 420.0), "B": (10, 900.0)}
TORCH_ONLY = {"R1", "H1", "L1", "H2", "R2", "H3"}
ARMS = {"fuzzy": "FuzzyScheduler", "uniform": "UniformScheduler", "round_robin": "RoundRobinScheduler"}


def scenario_text(experiment: str, arm: str) -> str:
    """torch_clock.yaml made into Experiment A or B with the arm's scheduler (T_sch 50 s, t_w 5 s)."""
    raw = _raw_document((ROOT / "diagrams" / "torch_clock.yaml").read_text())
    if experiment == "A":
        raw["operator"]["pattern"] = ["H1", "H2", "H3"]
        raw["operator"]["actions"] = [a for a in raw["operator"]["actions"] if a["name"] in TORCH_ONLY]
        raw["flow"]["actions"] = [a for a in raw["flow"]["actions"] if a["name"] in TORCH_ONLY]
        for arm_ in raw["robots"][0]["arms"]:
            arm_["program"] = [a for a in arm_["program"] if a in TORCH_ONLY]
    fields = {"wait_quantum": 5.0}
    if arm != "round_robin":
        fields["horizon"] = 50.0
    raw["scheduler"] = Tagged(ARMS[arm], fields)
    raw["tracker"] = Tagged("KalmanTracker", {})
    return yaml.dump(raw, Dumper=_Dumper, sort_keys=False)


def per_product(events, product_times: list[float]) -> tuple[list[float], list[float]]:
    """Idle (the human's waits) within each product's interval, and the cycle times."""
    waits, start = [], None
    for e in sorted(events, key=lambda e: (e.time, e.seq)):
        if getattr(e, "agent", "human") != "human":
            continue
        if e.kind == "wait_begin":
            start = e.time
        elif e.kind == "wait_end" and start is not None:
            waits.append((start, e.time))
            start = None
    if start is not None:
        waits.append((start, np.inf))
    idle, previous = [], 0.0
    for t in product_times:
        idle.append(sum(max(0.0, min(b, t) - max(a, previous)) for a, b in waits))
        previous = t
    return idle, [float(c) for c in np.diff(product_times)]


def run_one(job) -> dict:
    experiment, arm, seed = job
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario

    n_products, duration = EXPERIMENTS[experiment]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"torch_clock_{experiment}_{arm}.yaml"
        path.write_text(scenario_text(experiment, arm))
        scenario = load_scenario(path)
    scenario.seed = seed
    cell = build_cell(scenario, path)
    start = time.perf_counter()
    result = simulate(cell, duration, progress=None)
    wall = time.perf_counter() - start
    times = result.metrics["product_times"][:n_products]
    idle, cycles = per_product(result.log.events, times)
    return {"experiment": experiment, "arm": arm, "seed": seed, "products": len(times), "idle": idle,
            "cycles": cycles, "wall_s": round(wall, 1), "simulated_s": duration}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeded runs per arm and experiment")
    parser.add_argument("--quick", action="store_true", help="2 seeds, fuzzy and uniform only")
    parser.add_argument("--workers", type=int, default=1, help="runs at once (processes)")
    args = parser.parse_args(argv)
    seeds = 2 if args.quick else args.seeds
    arms = ["fuzzy", "uniform"] if args.quick else ["fuzzy", "uniform", "round_robin"]
    jobs = [(e, a, 100 + s) for e in EXPERIMENTS for s in range(seeds) for a in arms]
    print(f"{len(jobs)} runs ({seeds} seeds x {len(arms)} arms x 2 experiments), {args.workers} workers",
          flush=True)
    rows = run_jobs(run_one, jobs, args.workers, _print_row)
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
