"""`hrc-drake search SPEC --out DIR [--workers N | --address ADDR]` (the CLI's dispatch lands here)."""

from __future__ import annotations

import sys
from pathlib import Path


def search_path(name: str) -> Path:
    """`name`, or the search spec of that name shipped in diagrams/searches/."""
    path = Path(name)
    if path.exists() or path.suffix in (".yaml", ".yml"):
        return path
    shipped = Path(__file__).resolve().parents[1] / "diagrams" / "searches" / f"{name}.yaml"
    return shipped if shipped.is_file() else path


def run_command(args) -> int:
    """Load the spec (exit 2 on a bad one, via the CLI), run or resume the search, print the figures.
    An interruption propagates (the CLI exits 130 / 143) after the finished runs are saved."""
    from hrc_drake.campaign.store import check_output_dir
    from hrc_drake.search.report import REPORT_FILE, search_and_report
    from hrc_drake.search.spec import load_search

    out = Path(args.out)
    check_output_dir(out, create=False)
    search = load_search(search_path(args.spec))
    where = args.address or (f"{args.workers} local worker process(es)" if args.workers else "this process")
    searches = "the optimiser and random search" if search.compare_random else "the optimiser"
    print(
        f"{search.name}: {search.objective.direction} {search.objective.metric} "
        f"({search.objective.over_seeds} over {len(search.seeds)} seed(s)) over "
        f"{len(search.parameters)} parameter(s), "
        f"{search.candidates} candidates ({search.budget} runs of {search.duration:g} s) for {searches}, "
        f"{type(search.optimizer).__name__}, on {where}",
        flush=True,
    )
    try:
        outcome = search_and_report(
            search, out, workers=args.workers, address=args.address, progress=sys.stderr
        )
    except KeyboardInterrupt:
        from hrc_drake.campaign.engine import quiet_interrupted_shutdown

        quiet_interrupted_shutdown()
        print(
            f"interrupted: the finished runs are in {out / 'runs.parquet'} and the candidates asked in "
            f"{out / 'candidates.jsonl'}; run the same command again to resume",
            file=sys.stderr,
        )
        raise
    import json

    report = json.loads((out / REPORT_FILE).read_text())
    for label, figures in report["searches"].items():
        first = figures["runs_to_first_violation"]
        print(
            f"{label}: best {search.objective.metric} {figures['best']} "
            f"({figures['top'][0]['variant'] if figures['top'] else 'none'}); runs to the first violation: "
            f"{first if first is not None else 'none'}"
        )
    if "worst_replay" in report:
        print(f"worst candidate replayed: {report['worst_replay']}")
    if "best_scenario" in report:
        best = report["best_scenario"]
        print(
            f"best scenario: {best['file']}; over fresh seeds {search.objective.metric} "
            f"{best['best_fresh']['objective']} against the shipped {best['shipped_fresh']['objective']}"
        )
    print(f"{len(outcome.results)} candidate(s) in {out / 'results.parquet'}; plots and report.json in {out}")
    return 0
