"""What a finished search writes besides results.parquet: plots, DIR/report.json with the best
(or, falsifying, the worst) candidates, and the presets' outputs: the replay of the worst candidate
(falsify), the best scenario as a YAML file and its figures against the shipped scenario's over
fresh seeds (optimise)."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from hrc_drake.campaign.spec import RunTask, _config_hash
from hrc_drake.cell.scenario import dump_raw
from hrc_drake.search import plots
from hrc_drake.search.engine import Job, _number, apply_values, best_candidates, score

REPORT_FILE = "report.json"
BEST_SCENARIO_FILE = "best_scenario.yaml"
WORST_REPLAY_FILE = "worst_replay.html"
#: fresh seeds of the optimise preset's comparison start here (far from any search's seeds)
FRESH_SEED_BASE = 1_000_000


def is_violation(row, search) -> bool:
    """A candidate that broke the cell: a violation the standard's judge holds against the robot
    (`safety.violations_total` > 0: an SSM breach, a contact its mode forbids or over its limit, a
    stop longer than S_p assumed), or, when the objective is a margin, a margin below 0 on some seed."""
    margin = search.objective.metric in ("safety.margin_m", "safety.contact_margin")
    worst_margin = row["objective"] if search.objective.over_seeds == "worst" else math.nan
    return bool(row.get("metric.safety.violations_total", 0) > 0 or (margin and worst_margin < 0))


def is_mode_violation(row) -> bool:
    """A candidate with a violation the standard's judge holds against the robot on some seed
    (`safety.violations_total` > 0). Narrower than `is_violation`: a contact margin also counts
    contacts the person made (walking into a still robot), which the judge logs but does not hold."""
    return bool(row.get("metric.safety.violations_total", 0) > 0)


def runs_to_first_violation(results, search, label: str, test=None):
    """Runs spent by search `label` up to its first candidate that `test` (`is_violation`) flags."""
    test = test or (lambda row: is_violation(row, search))
    part = results[(results["search"] == label)].sort_values("number")
    for _, row in part.iterrows():
        if row["status"] == "ok" and test(row):
            return int(row["runs"])
    return None


def _candidates(frame, search) -> list[dict]:
    out = []
    for _, row in frame.iterrows():
        out.append(
            {
                "variant": row["variant"],
                "objective": _plain(row["objective"]),
                "feasible": bool(row["feasible"]),
                "seeds": list(search.seeds),
                "parameters": {p.name: _plain(row[f"param.{p.name}"]) for p in search.parameters},
            }
        )
    return out


def _plain(value):
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def finish_search(search, out_dir: Path, outcome, evaluator, progress) -> dict:
    results = outcome.results
    out_dir = Path(out_dir)
    report: dict = {
        "name": search.name,
        "objective": search.objective.metric,
        "direction": search.objective.direction,
        "over_seeds": search.objective.over_seeds,
        "constraints": [str(c) for c in search.constraints],
        "searches": {},
    }
    if results.empty:
        _write_json(out_dir / REPORT_FILE, report)
        return report
    for label in results["search"].unique():
        top = best_candidates(search, results, label)
        report["searches"][label] = {
            "candidates": int((results["search"] == label).sum()),
            "best": _plain(top["objective"].iloc[0]) if not top.empty else None,
            "runs_to_first_violation": runs_to_first_violation(results, search, label),
            "runs_to_first_mode_violation": runs_to_first_violation(
                results, search, label, is_mode_violation
            ),
            "candidates_with_violations": int(sum(
                is_mode_violation(row) for _, row in results[results["search"] == label].iterrows()
                if row["status"] == "ok")),
            "top": _candidates(top, search),
        }
    plots.plot_history(results, search, out_dir / "history.png")
    importances = {}
    study = outcome.studies.get("optimizer")
    if study is not None:
        import optuna

        complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
        if len(complete) >= 2 and len(search.parameters) >= 1:
            try:
                importances = optuna.importance.get_param_importances(
                    study, evaluator=optuna.importance.FanovaImportanceEvaluator(seed=search.optimizer.seed)
                )
            except (RuntimeError, ValueError) as err:
                report["importances_error"] = str(err)
    report["importances"] = {k: float(v) for k, v in importances.items()}
    plots.plot_importances(importances, search, out_dir / "importances.png")
    ranked = best_candidates(search, results, "optimizer", count=len(results))
    plots.plot_parameters(
        ranked.head(search.report), ranked.tail(search.report), search, out_dir / "parameters.png"
    )
    simulated = not hasattr(evaluator, "function")
    top = best_candidates(search, results, "optimizer")
    if search.preset == "falsify" and not top.empty and simulated:
        report["worst_replay"] = _replay_worst(search, out_dir, top.iloc[0], evaluator, progress)
    if search.preset == "optimise" and not top.empty and bool(top["feasible"].iloc[0]):
        report["best_scenario"] = _optimise_outputs(search, out_dir, top.iloc[0], evaluator, progress)
    _write_json(out_dir / REPORT_FILE, report)
    return report


def _write_json(path: Path, document) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(document, indent=2, default=_plain))
    os.replace(tmp, path)


def _values(search, row) -> dict:
    """The parameter values of a results row, as written into the scenario (from the record)."""
    from hrc_drake.search.engine import Record, suggest

    line = Record(Path(row["_out_dir"])).lines[(row["search"], int(row["number"]))]
    import optuna

    trial = optuna.trial.FixedTrial(line["params"])
    return {p.name: suggest(trial, p) for p in search.parameters}


def candidate_document(search, out_dir: Path, row) -> dict:
    return apply_values(search, _values(search, {**row, "_out_dir": str(out_dir)}))


def _replay_worst(search, out_dir: Path, row, evaluator, progress) -> dict:
    """Simulate the worst candidate again on its worst seed with the replay recorded."""
    from hrc_drake.campaign.store import RunStore
    from hrc_drake.campaign.worker import run_task
    from hrc_drake.search import params as P

    document = candidate_document(search, out_dir, row)
    overrides = P.overrides_of(search.document, document)
    store = RunStore(out_dir, writable=False)
    metric = search.objective.metric
    runs = [r for r in store.rows() if r["variant"] == row["variant"] and r["status"] == "ok"]
    pick = min if search.objective.direction == "minimize" else max
    worst = pick(runs, key=lambda r: float(r.get(metric) if r.get(metric) is not None else math.inf))
    task = RunTask(
        scenario=search.scenario.stem,
        scenario_path=str(search.scenario),
        variant=row["variant"],
        overrides=overrides,
        seed=int(worst["seed"]),
        duration=search.duration,
        config_hash=_config_hash(search.scenario, overrides, search.duration),
        replay=True,
        replay_fps=search.replay_fps,
    )
    if progress is not None:
        print(f"replaying the worst candidate {row['variant']} (seed {task.seed})", file=progress, flush=True)
    outcome = run_task(task)
    path = out_dir / WORST_REPLAY_FILE
    if outcome.get("replay_html"):
        path.write_text(outcome["replay_html"])
    (out_dir / "worst_scenario.yaml").write_text(_scenario_text(search, document, task.seed, "worst"))
    return {
        "variant": row["variant"],
        "seed": task.seed,
        "objective": _plain(outcome["row"].get(metric)),
        # the standard judge's count and verdict of the worst candidate, run again
        "violations": _plain(outcome["row"].get("safety.violations_total")),
        "verdict": outcome["row"].get("safety.verdict_code"),
        "replay": str(path) if outcome.get("replay_html") else None,
        "error": outcome["row"].get("error", ""),
    }


def _scenario_text(search, document: dict, seed: int, what: str) -> str:
    header = (
        f"# The {what} candidate of search '{search.name}' ({search.file}): {search.scenario.name} with\n"
        + "".join(f"#   {p.path}\n" for p in search.parameters)
        + "# as the search set them. Relative file names resolve from this file's folder.\n"
    )
    return header + dump_raw({**document, "seed": int(seed), "duration": float(search.duration)})


def _optimise_outputs(search, out_dir: Path, row, evaluator, progress) -> dict:
    """DIR/best_scenario.yaml, then the best and the shipped scenario over fresh seeds."""
    from hrc_drake.campaign.store import RunStore
    from hrc_drake.search import params as P

    document = candidate_document(search, out_dir, row)
    path = out_dir / BEST_SCENARIO_FILE
    path.write_text(_scenario_text(search, document, search.seeds[0], "best"))
    seeds = [FRESH_SEED_BASE + k for k in range(search.fresh_seeds)]
    overrides = {"best_fresh": P.overrides_of(search.document, document), "shipped_fresh": {}}
    store = RunStore(out_dir)
    try:
        jobs = []
        for variant, ov in overrides.items():
            config_hash = _config_hash(search.scenario, ov, search.duration)
            for seed in seeds:
                task = RunTask(
                    scenario=search.scenario.stem,
                    scenario_path=str(search.scenario),
                    variant=variant,
                    overrides=ov,
                    seed=seed,
                    duration=search.duration,
                    config_hash=config_hash,
                )
                if not store.is_done(task.key, config_hash):
                    jobs.append(
                        Job(
                            task,
                            _values(search, {**row, "_out_dir": str(out_dir)})
                            if variant == "best_fresh"
                            else _shipped_values(search),
                        )
                    )
        if progress is not None and jobs:
            print(
                f"the best candidate {row['variant']} and the shipped scenario over {len(seeds)} fresh seeds",
                file=progress,
                flush=True,
            )
        evaluator.run(jobs, store, out_dir, lambda ok: None)
        store.flush()
        rows = store.rows()
    finally:
        store.close()
    out = {"file": str(path), "variant": row["variant"], "fresh_seeds": seeds}
    for variant in overrides:
        runs = [r for r in rows if r["variant"] == variant and int(r["seed"]) in seeds]
        figures = score(_with_seeds(search, seeds), runs)
        out[variant] = {
            "objective": _plain(figures["objective"]),
            "feasible": figures["feasible"],
            "metrics": {
                k: _plain(v)
                for k, v in figures["metrics"].items()
                if k in (search.objective.metric, "safety.violations_total", "products_finished")
            },
        }
    out["paired"] = paired_fresh(search, rows, seeds)
    return out


def paired_fresh(search, rows, seeds) -> dict:
    """The best and the shipped scenario seed by seed over the fresh seeds: the objective of each,
    their differences (best - shipped) and the one-sided Wilcoxon signed-rank p that the best is
    better (lower when minimising); None with fewer than 2 pairs or no difference."""
    from scipy.stats import wilcoxon

    metric = search.objective.metric  # as `score` reads it: ok runs, a number or nan
    value = {(r["variant"], int(r["seed"])): _number(r.get(metric)) for r in rows if r.get("status") == "ok"}
    pairs = [(value.get(("best_fresh", seed), math.nan), value.get(("shipped_fresh", seed), math.nan))
             for seed in seeds]
    pairs = [(b, s) for b, s in pairs if math.isfinite(b) and math.isfinite(s)]
    differences = [b - s for b, s in pairs]
    p = None
    if len(differences) >= 2 and any(d != 0.0 for d in differences):
        alternative = "less" if search.objective.direction == "minimize" else "greater"
        p = float(wilcoxon(differences, alternative=alternative).pvalue)
    return {"best": [_plain(b) for b, _ in pairs], "shipped": [_plain(s) for _, s in pairs],
            "differences": [_plain(d) for d in differences], "wilcoxon_p": p}


def _shipped_values(search) -> dict:
    from hrc_drake.search import params as P

    return {p.name: P.get_value(search.document, p.steps, allow_missing_last=True) for p in search.parameters}


def _with_seeds(search, seeds):
    import copy

    other = copy.copy(search)
    other.seeds = seeds
    return other


def search_and_report(search, out_dir: Path, **options):
    """`engine.run_search` with this module's outputs at the end (the command's entry)."""
    from hrc_drake.search.engine import run_search

    return run_search(search, out_dir, finish=finish_search, **options)
