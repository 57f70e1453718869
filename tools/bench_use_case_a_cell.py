"""Benchmark: use case a of thesis 7.2.1 / 7.5.1 in the Drake cell (`diagrams/pcb_collab.yaml`):
the best-scenario scheduler of 7.2 against the round robin of 7.5.1 (left arm: fuse, check) and
the Monte Carlo scheduler of 7.3 (T_sch = 15 s), patterns 1 (IC, collaboration) and 2 (IC, IC,
collaboration, collaboration), 10 products per run, the time per product as 7.5.1 reports it
(thesis: 35.80 -> 27.63 s and 33.35 -> 30.10 s, round robin -> best scenario).

The cell's durations are its robots' motions and the operator's (not the net's priors): the
event-level benchmark of the same flow is `bench_scheduling.py --only use_case_a`.

Prints a line per run and, as its last line, one JSON object:
`use_case_a_cell.<pattern1|pattern2>.<best_scenario|round_robin|monte_carlo>` with `cycle_median`,
`cycle_mean` (= time per product after the first), `products`, `human_wait_per_product`, and
`.wilcoxon_p` (one-sided rank sum, best scenario < round robin, cycles), `.wilcoxon_p_runs`.

The runs go through the campaign API, as `bench_use_case_b.py`'s (`run_patterns`).

Usage:
    python3 tools/bench_use_case_a_cell.py [--seeds N] [--quick | --smoke] [--arms A,B] [--no-safety]
        [--workers W] [--address A] [--out DIR]
--smoke: one seed of the best scenario and the round robin, 1 s runs (figures meaningless; the
tests run it).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_use_case_b import SMOKE_DURATION, add_campaign_arguments, run_patterns, summarize  # noqa: E402

N_PRODUCTS, DURATION = 10, 600.0
PATTERNS = {"pattern1": "[ic, collab]", "pattern2": "[ic, ic, collab, collab]"}
SCHEDULERS = {
    "best_scenario": "!BestScenarioScheduler {collaboration: collab, human_action: ic, feed_action: fuse, "
                     "horizon: 60.0, wait_quantum: 3.0}",
    # like with like: the round robin on the best-scenario scheduler's net (its arms start a
    # joint action together; `joint_actions: hold`, the 6.3.3 model, is the round robin's default)
    "round_robin": "!RoundRobinScheduler {programs: {yumi_left: [fuse, check]}, wait_quantum: 3.0, "
                   "joint_actions: simultaneous}",
    # Algorithm 4 as written (waits of t_w), joint actions held as 6.3.3 builds them
    "monte_carlo": "!MonteCarloScheduler {n_trials: 100, horizon: 15.0, wait_quantum: 3.0}",
}
THESIS = {"pattern1": (35.80, 27.63), "pattern2": (33.35, 30.10)}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="seeded runs per arm and pattern")
    parser.add_argument("--quick", action="store_true", help="2 seeds, best scenario and round robin only")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--no-safety", action="store_true",
                        help="without the ISO/TS 15066 layer (safety: !NoSafety), as the thesis's Ch. 7 ran")
    parser.add_argument("--arms", default=None,
                        help=f"comma-separated arms to run (of {', '.join(SCHEDULERS)}; default: all)")
    add_campaign_arguments(parser)
    args = parser.parse_args(argv)
    seeds = 1 if args.smoke else 2 if args.quick else args.seeds
    arms = ["best_scenario", "round_robin"] if args.quick or args.smoke else list(SCHEDULERS)
    if args.arms:
        arms = [a.strip() for a in args.arms.split(",")]
        unknown = [a for a in arms if a not in SCHEDULERS]
        if unknown:
            parser.error(f"--arms: unknown {unknown}; choose from {list(SCHEDULERS)}")
    n_runs = len(PATTERNS) * seeds * len(arms)
    print(f"{n_runs} runs ({seeds} seeds x {len(arms)} arms x 2 patterns), {args.address or args.workers} "
          "workers", flush=True)
    rows = run_patterns("use_case_a_cell", ROOT / "diagrams" / "pcb_collab.yaml", PATTERNS, SCHEDULERS, arms,
                        seeds, N_PRODUCTS, SMOKE_DURATION if args.smoke else DURATION, args,
                        extra="safety: !NoSafety {}" if args.no_safety else "")
    out = summarize(rows, arms, PATTERNS, test=("best_scenario", "round_robin"))
    for pattern, block in out.items():
        if "wilcoxon_p" not in block:  # not both arms of the thesis's comparison
            means = ", ".join(f"{arm} {block[arm]['cycle_mean']} s per product" for arm in arms)
            print(f"{pattern}: {means}", flush=True)
            continue
        bs, rr = block["best_scenario"]["cycle_mean"], block["round_robin"]["cycle_mean"]
        gain = 100 * (1 - bs / rr) if bs and rr else None
        thesis = THESIS[pattern]
        block["gain_percent"] = round(gain, 2) if gain is not None else None
        block["thesis_gain_percent"] = round(100 * (1 - thesis[1] / thesis[0]), 2)
        print(f"{pattern}: per product best scenario {bs} s, round robin {rr} s"
              + (f", Monte Carlo {block['monte_carlo']['cycle_mean']} s" if "monte_carlo" in block else "")
              + f"; gain {block['gain_percent']} % (thesis {block['thesis_gain_percent']} %: {thesis[0]} -> "
              f"{thesis[1]} s); one-sided rank sum p = {block['wilcoxon_p']} (cycles), "
              f"{block['wilcoxon_p_runs']} (runs)", flush=True)
    result = {"use_case_a_cell": out, "seeds": seeds}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
