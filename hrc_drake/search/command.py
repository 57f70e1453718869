"""`hrc-drake search SPEC --out DIR [--workers N | --address ADDR]` (the CLI's dispatch lands here)."""

from __future__ import annotations

import sys
from pathlib import Path


def shipped_search_names() -> list[str]:
    """The bare names of the search specs shipped in diagrams/searches (`cell.shipped`)."""
    from hrc_drake.cell.shipped import example_names

    return example_names("search")


def search_path(name: str) -> Path:
    """`name` itself when a file is there, else the search spec of that bare name shipped in
    diagrams/searches (`hrc-drake search falsify_pcb_ic`), as `cell.shipped.resolve` finds every
    shipped example; else ScenarioError ("no such file") naming the shipped ones."""
    from hrc_drake.cell.shipped import resolve

    return resolve(name, "search")


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
        print(f"interrupted: {_saved_words(out)}", file=sys.stderr)
        raise
    import json

    report = json.loads((out / REPORT_FILE).read_text())
    for label, figures in report["searches"].items():
        first = figures["runs_to_first_violation"]
        mode = figures.get("runs_to_first_mode_violation")
        print(
            f"{label}: best {search.objective.metric} {figures['best']} "
            f"({figures['top'][0]['variant'] if figures['top'] else 'none'}); runs to the first violation: "
            f"{first if first is not None else 'none'} (of the mode, held against the robot: "
            f"{mode if mode is not None else 'none'})"
        )
    if "worst_replay" in report:
        print(f"worst candidate replayed: {report['worst_replay']}")
    if "best_scenario" in report:
        best = report["best_scenario"]
        print(f"best scenario: {best['file']}; over {len(best['fresh_seeds'])} fresh seeds "
              f"{search.objective.metric} {_rounded(best['best_fresh']['objective'])} against the shipped "
              f"{_rounded(best['shipped_fresh']['objective'])}; {_paired_verdict(best.get('paired') or {})}")
    print(f"{len(outcome.results)} candidate(s) in {out / 'results.parquet'}; plots and report.json in {out}")
    return 0


def _rounded(value) -> str:
    return "n/a" if value is None else f"{value:.4g}"


def _paired_verdict(paired: dict) -> str:
    """One phrase on the seed-by-seed comparison of the best and the shipped scenario."""
    differences, p = paired.get("differences") or [], paired.get("wilcoxon_p")
    if p is None and len(differences) < 2:
        return f"no paired test ({len(differences)} fresh seed(s) with a figure for both)"
    if p is None:
        return "no paired test (the same figure on every fresh seed)"
    better = "better" if p < 0.05 else "not significantly better"
    return f"{better} seed by seed (one-sided Wilcoxon p = {p:.3g} over {len(differences)} pairs)"


def _saved_words(out) -> str:
    """What an interrupted search left in `out`, in words: only files that exist are named."""
    from hrc_drake.campaign.store import read_runs

    try:
        runs = len(read_runs(out))
    except Exception:  # noqa: BLE001 - the message only
        runs = 0
    saved = []
    if runs:
        saved.append(f"{runs} finished run(s) in {out / 'runs.parquet'}")
    if (out / "candidates.jsonl").is_file():
        saved.append(f"the candidates asked in {out / 'candidates.jsonl'}")
    if not saved:
        return "before any run finished: nothing was saved"
    return " and ".join(saved) + "; run the same command again to resume"
