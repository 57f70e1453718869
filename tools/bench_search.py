"""Bench of `hrc-drake search` (docs/search.md): falsification of the coexistence cell by TPE
against random search at the same budget, the optimise preset on use case a (pcb_ic), and the
search's own overhead per candidate (a trivial evaluator: Optuna's ask/tell, the record, the store).

Prints a table, then as its last line one JSON object:
falsify.<cell>.worst_margin.optimizer / .random, falsify.<cell>.runs_to_first_violation.optimizer /
.random (null when none), optimise.<cell>.cycle_s.best (fresh seeds), .shipped, overhead_per_candidate_ms.

    python tools/bench_search.py --quick      # tiny budgets and short runs (2 workers)
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SEARCHES = REPO / "diagrams" / "searches"


def _load(name: str, **changes):
    from hrc_drake.campaign.spec import _read_raw
    from hrc_drake.search.spec import make_search

    path = SEARCHES / f"{name}.yaml"
    document = {**_read_raw(path), **changes}
    return make_search(document, path)


def overhead_ms(candidates: int = 40) -> float:
    """Median wall time per candidate of a search whose runs cost nothing (3 repetitions)."""
    from hrc_drake.search.engine import FunctionEvaluator, run_search

    search = _load(
        "falsify_coexistence",
        budget=candidates,
        batch=4,
        preset="",
        compare_random=False,
        objective={"metric": "mean_cycle_time", "direction": "minimize"},
    )
    times = []
    for _ in range(3):
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            run_search(
                search,
                Path(out),
                evaluator=FunctionEvaluator(lambda v, s: {"mean_cycle_time": 1.0}),
                progress=None,
            )
            times.append((time.perf_counter() - start) / candidates * 1e3)
    return statistics.median(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    from hrc_drake.search.report import search_and_report

    figures: dict = {}
    falsify = _load(
        "falsify_coexistence", **({"budget": 6, "duration": 20.0} if args.quick else {"budget": 40})
    )
    optimise = _load(
        "optimise_pcb_ic",
        **(
            {"budget": 4, "duration": 60.0, "seeds": [1], "fresh_seeds": 2, "batch": 2, "constraints": []}
            if args.quick
            else {}
        ),
    )
    with tempfile.TemporaryDirectory() as tmp:
        for search, kind in ((falsify, "falsify"), (optimise, "optimise")):
            out = Path(tmp) / search.name
            start = time.perf_counter()
            search_and_report(search, out, workers=args.workers, progress=sys.stderr)
            report = json.loads((out / "report.json").read_text())
            cell = search.scenario.stem
            print(f"{search.name}: {time.perf_counter() - start:.0f} s wall")
            if kind == "falsify":
                for label in ("optimizer", "random"):
                    s = report["searches"].get(label, {})
                    figures[f"falsify.{cell}.worst_margin.{label}"] = s.get("best")
                    figures[f"falsify.{cell}.runs_to_first_violation.{label}"] = s.get(
                        "runs_to_first_violation"
                    )
            else:
                best = report.get("best_scenario") or {}
                figures[f"optimise.{cell}.cycle_s.best"] = (best.get("best_fresh") or {}).get("objective")
                figures[f"optimise.{cell}.cycle_s.shipped"] = (best.get("shipped_fresh") or {}).get(
                    "objective"
                )
    figures["overhead_per_candidate_ms"] = round(overhead_ms(), 2)
    for key, value in figures.items():
        print(f"{key:55s} {value}")
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
