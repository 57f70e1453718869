"""The search loop: Optuna's ask/tell in fixed batches, each candidate a set of campaign runs.

A batch of `search.batch` candidates is asked, its runs (candidate x seed, `campaign.spec.RunTask`,
the candidate's overrides as the variant) are evaluated in parallel (on Dask through the
campaign engine, in this process, or by an injected function), stored as they finish in
DIR/runs.parquet (`campaign.store.RunStore`: journal first), then every candidate of the batch is
told. The batch size is part of the spec, not the number of workers: the same spec and seeds give
the same candidates on any cluster.

Resume: DIR/candidates.jsonl records every candidate as it is asked (JSON, flushed). A new study
replays the search: it asks again batch by batch (the seeded sampler proposes the same candidates,
checked against the record) and tells each candidate from the stored runs, running only the runs
not stored; so an interrupted search goes on to the table an uninterrupted one writes. Nothing is
pickled; Optuna's in-memory storage only.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from hrc_drake.campaign.spec import RunTask, _config_hash
from hrc_drake.campaign.store import CampaignLock, RunStore, check_output_dir
from hrc_drake.campaign.worker import KEY_COLUMNS, flatten_metrics
from hrc_drake.cell.scenario import dump_raw
from hrc_drake.console import WarningTally
from hrc_drake.errors import ScenarioError
from hrc_drake.search import params as P
from hrc_drake.search.spec import CmaEs, Random, Search, SearchParameter, random_search_seed

CANDIDATES_FILE = "candidates.jsonl"
RESULTS_FILE = "results.parquet"
SEARCH_FILE = "search.json"
#: the prefix of a candidate's variant name per search
PREFIX = {"optimizer": "o", "random": "r"}
#: a constraint value standing for "violated, no figure" (a failed run, a null metric)
UNKNOWN_VIOLATION = 1e12


@dataclass
class Candidate:
    search: str  # optimizer or random
    number: int
    batch: int
    params: dict  # Optuna's parameter values
    values: dict  # parameter name -> the value written into the scenario
    overrides: dict

    @property
    def variant(self) -> str:
        return f"{PREFIX[self.search]}{self.number:05d}"


@dataclass
class Job:
    """One run of a candidate: the campaign task and the candidate's parameter values."""

    task: RunTask
    values: dict


@dataclass
class SearchOutcome:
    results: object  # DataFrame of results.parquet
    runs: int = 0
    wall_time: float = 0.0
    studies: dict = field(default_factory=dict)


# ----- parameters <-> Optuna


def suggest(trial, p: SearchParameter):
    """Ask `trial` for `p` (Optuna's distributions); returns the value written into the scenario."""
    if p.kind == "float":
        return float(trial.suggest_float(p.name, p.low, p.high, log=p.log, step=p.step or None))
    if p.kind == "int":
        return int(trial.suggest_int(p.name, int(p.low), int(p.high), log=p.log, step=int(p.step or 1)))
    if p.kind == "choice":
        return p.choices[trial.suggest_categorical(p.name, list(range(len(p.choices))))]
    keys = [trial.suggest_float(name, 0.0, 1.0) for name in p.optuna_names()]
    return P.decode_permutation(p.elements, p.precedence, keys)


def apply_values(search: Search, values: dict) -> dict:
    """The scenario document with every parameter's value written at its path."""
    document = search.document
    for p in search.parameters:
        document = P.set_value(document, p.steps, values[p.name])
    return document


def shown(value) -> object:
    """A parameter value for a table cell: numbers and text as they are, an order as 'a b c', else
    its YAML."""
    if isinstance(value, str):
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        if isinstance(value, list) and all(isinstance(v, str) for v in value):
            return " ".join(value)
        return dump_raw(value).strip().replace("\n", " ")
    return value


def make_sampler(optimizer, search: Search, random: bool = False):
    import optuna

    if random:
        return optuna.samplers.RandomSampler(seed=random_search_seed(optimizer.seed))
    if isinstance(optimizer, Random):
        return optuna.samplers.RandomSampler(seed=optimizer.seed)
    if isinstance(optimizer, CmaEs):
        return optuna.samplers.CmaEsSampler(
            seed=optimizer.seed, sigma0=optimizer.sigma0 or None, popsize=optimizer.popsize or None
        )
    options = {}
    if search.constraints and not hasattr(optuna.trial.Trial, "set_constraint"):
        # Optuna 4: constrained TPE through constraints_func (Optuna 5 reads `Trial.set_constraint`)
        options["constraints_func"] = lambda frozen: frozen.user_attrs["constraints"]
    return optuna.samplers.TPESampler(
        seed=optimizer.seed,
        n_startup_trials=optimizer.n_startup_trials,
        multivariate=optimizer.multivariate,
        **options,
    )


# ----- evaluation


class FunctionEvaluator:
    """Runs a candidate by calling `function(values, seed) -> metrics` (a dict as metrics.json,
    nested or flat) in this process: searches whose evaluation is not a simulation (tests, toys)."""

    def __init__(self, function):
        self.function = function

    def run(self, jobs, store, out_dir, done) -> None:
        for job in jobs:
            start, cpu = time.perf_counter(), time.thread_time()
            row = dict(zip(KEY_COLUMNS, job.task.key, strict=True))
            row.update(status="ok", error="", config_hash=job.task.config_hash, worker="function")
            try:
                row.update(flatten_metrics(self.function(job.values, job.task.seed)))
            except Exception as err:  # noqa: BLE001 - a failed run is a row, as in a campaign
                row.update(status="failed", error=f"{type(err).__name__}: {err}")
            row["run_wall_time"] = round(time.perf_counter() - start, 4)
            row["run_cpu_time"] = round(time.thread_time() - cpu, 4)
            store.add(row)
            done(row["status"] == "ok")


class CampaignEvaluator:
    """Runs candidates as campaign runs (`campaign.worker.run_task`): on a Dask client through the
    campaign engine (worker deaths retried once, a lost scheduler stops the search), or one after
    the other in this process (client None)."""

    def __init__(self, client=None, address: str | None = None):
        self.client, self.address = client, address

    def run(self, jobs, store, out_dir, done) -> None:
        from hrc_drake.campaign import engine as campaign_engine

        tally = WarningTally()

        class Bar:  # the campaign's progress interface: one call per finished run, its warnings
            def update(self, ok: bool) -> None:
                done(ok)

            def note(self, run: str, text: str) -> None:
                # the search prints whole lines: the first warning of each kind on its own line
                if tally.first(text):
                    print(f"warning from {run}: {text}", file=sys.stderr, flush=True)

        if self.client is None:
            from hrc_drake.campaign.worker import run_task

            for job in jobs:
                campaign_engine._record(run_task(job.task), job.task, store, Bar(), out_dir)
            return
        campaign_engine._run_on(
            self.client, iter(job.task for job in jobs), store, Bar(), out_dir, self.address
        )


# ----- the loop


class Record:
    """DIR/candidates.jsonl: every asked candidate, one JSON line, flushed to disk before its runs."""

    def __init__(self, out_dir: Path):
        self.path = Path(out_dir) / CANDIDATES_FILE
        self.lines: dict[tuple[str, int], dict] = {}
        if self.path.is_file():
            for text in self.path.read_text(encoding="utf-8").splitlines():
                try:
                    line = json.loads(text)
                except json.JSONDecodeError:
                    continue  # the line being written when the search stopped
                self.lines[(line["search"], int(line["number"]))] = line

    def check_or_add(self, c: Candidate) -> None:
        line = {"search": c.search, "number": c.number, "batch": c.batch, "params": c.params}
        known = self.lines.get((c.search, c.number))
        if known is not None:
            if known["params"] != json.loads(json.dumps(c.params)):
                raise ScenarioError(
                    self.path,
                    f"{c.search}[{c.number}]",
                    "the search asked a different candidate than the one recorded (another spec, "
                    "seed or Optuna version wrote this folder): use a new --out",
                )
            return
        with open(self.path, "a", encoding="utf-8") as out:
            out.write(json.dumps(line) + "\n")
            out.flush()
            os.fsync(out.fileno())
        self.lines[(c.search, c.number)] = line


def aggregate(values: list[float], how: str, direction: str) -> float:
    import numpy as np

    if how == "mean":
        return float(np.mean(values))
    if how == "median":
        return float(np.median(values))
    return float(min(values) if direction == "minimize" else max(values))


def score(search: Search, rows: list[dict]) -> dict:
    """A candidate's figures from its runs: objective over seeds, each constraint's worst value
    over seeds (<= 0: kept), feasibility, and the mean of every numeric metric."""
    ok = [r for r in rows if r.get("status") == "ok"]
    metric = search.objective.metric
    values = [_number(r.get(metric)) for r in ok]
    complete = len(ok) == len(search.seeds) and all(math.isfinite(v) for v in values)
    objective = (
        aggregate(values, search.objective.over_seeds, search.objective.direction) if complete else math.nan
    )
    constraints = [
        max((c.violation(_number(r.get(c.metric))) for r in ok), default=math.inf)
        if len(ok) == len(search.seeds)
        else math.inf
        for c in search.constraints
    ]
    means = {}
    for name in search.metric_names:
        xs = [_number(r.get(name)) for r in ok]
        xs = [x for x in xs if math.isfinite(x)]
        means[name] = sum(xs) / len(xs) if xs else math.nan
    return {
        "objective": objective,
        "constraints": constraints,
        "complete": complete,
        "feasible": complete and all(c <= 0 for c in constraints),
        "seeds_ok": len(ok),
        "metrics": means,
        "errors": [r.get("error", "") for r in rows if r.get("status") != "ok"],
    }


def _number(x) -> float:
    if x is None or isinstance(x, (str, bytes)):
        return math.nan
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


class SearchProgress:
    """One line per batch on stderr: candidates and runs done, the best so far, failures, ETA."""

    def __init__(self, search: Search, label: str, total_runs: int, stream=sys.stderr):
        self.search, self.label, self.total, self.stream = search, label, total_runs, stream
        self.runs = self.failed = self.ran = 0
        self.start = time.perf_counter()

    def run_done(self, ok: bool, ran: bool = True) -> None:
        self.runs += 1
        self.ran += ran
        self.failed += not ok

    def line(self, candidates: int, best) -> str:
        elapsed = time.perf_counter() - self.start
        rate = self.ran / elapsed if elapsed > 0 and self.ran else 0.0
        eta = (self.total - self.runs) / rate if rate else math.inf
        best_text = "none yet" if best is None else f"{best[0]:.4g} ({best[1]})"
        eta_text = "--" if not math.isfinite(eta) else f"{int(eta // 60)}m{int(eta % 60):02d}s"
        return (
            f"search {self.search.name} {self.label}: {candidates}/{self.search.candidates} candidates, "
            f"{self.runs}/{self.total} runs, {self.failed} failed, best {self.search.objective.metric} "
            f"{best_text}, ETA {eta_text}"
        )

    def show(self, candidates: int, best) -> None:
        if self.stream is not None:
            print(self.line(candidates, best), file=self.stream, flush=True)


def run_search(
    search: Search,
    out_dir: Path,
    evaluator=None,
    progress=sys.stderr,
    workers: int = 2,
    address: str | None = None,
    wait: float = 0.0,
    finish=None,
) -> SearchOutcome:
    """Run (or resume) `search` into `out_dir`: the optimiser, then random search when the spec
    compares them; results.parquet. finish(search, out_dir, outcome, evaluator, progress): called at
    the end with the evaluator still open (`report.finish_search`: plots, the preset's outputs).

    evaluator: how runs run (`FunctionEvaluator`, `CampaignEvaluator`); None: campaign runs on a
    local cluster of `workers` processes (0: in this process) or the scheduler at `address`."""
    out_dir = Path(out_dir)
    check_output_dir(out_dir)
    with CampaignLock(out_dir, wait, progress):
        _check_same_search(search, out_dir)
        if evaluator is not None:
            return _run_with(search, out_dir, evaluator, progress, finish)
        from hrc_drake.campaign.engine import ClusterClient, compile_kernels_ahead

        with compile_kernels_ahead(search.kernel_groups, address) as ahead:
            if address is None and workers == 0:
                ahead.wait()
                return _run_with(search, out_dir, CampaignEvaluator(), progress, finish)
            # the kernels compile once, while the workers start, instead of in every worker
            with ClusterClient(address, workers) as client:
                ahead.wait()
                return _run_with(search, out_dir, CampaignEvaluator(client, address), progress, finish)


def _check_same_search(search: Search, out_dir: Path) -> None:
    path = out_dir / SEARCH_FILE
    description = search.describe()
    if path.is_file():
        before = json.loads(path.read_text())
        mine = {k: v for k, v in json.loads(json.dumps(description)).items() if k not in ("budget", "file")}
        theirs = {k: v for k, v in before.items() if k not in ("budget", "file", "code_version")}
        if mine != theirs:
            changed = sorted(k for k in set(mine) | set(theirs) if mine.get(k) != theirs.get(k))
            raise ScenarioError(
                out_dir,
                "--out",
                f"holds another search (it differs in {', '.join(changed)}): "
                "use a new folder (only the budget may grow)",
            )
    from hrc_drake.provenance import code_version

    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps({**description, "code_version": code_version()}, indent=2))
    os.replace(tmp, path)


def _run_with(search: Search, out_dir: Path, evaluator, progress, finish) -> SearchOutcome:
    start = time.perf_counter()
    store = RunStore(out_dir)
    record = Record(out_dir)
    rows: list[dict] = []
    studies = {}
    try:
        for label in ("optimizer", "random") if search.compare_random else ("optimizer",):
            studies[label] = _one_search(search, label, out_dir, evaluator, store, record, rows, progress)
    finally:
        store.flush()
        store.close()
        results = _write_results(out_dir, rows)
    outcome = SearchOutcome(
        results=results,
        runs=len(results) * len(search.seeds),
        wall_time=time.perf_counter() - start,
        studies=studies,
    )
    if finish is not None:
        finish(search, out_dir, outcome, evaluator, progress)
    return outcome


def _one_search(search: Search, label: str, out_dir, evaluator, store, record, rows, progress):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(
        direction=search.objective.direction,
        sampler=make_sampler(search.optimizer, search, random=label == "random"),
        study_name=f"{search.name}-{label}",
    )
    bar = SearchProgress(search, label, search.candidates * len(search.seeds), progress)
    scenario = search.scenario.stem
    best = None
    number = batch = 0
    while number < search.candidates:
        size = min(search.batch, search.candidates - number)
        batch_candidates = []
        for _ in range(size):
            trial = study.ask()
            values = {p.name: suggest(trial, p) for p in search.parameters}
            document = apply_values(search, values)
            c = Candidate(
                label, number, batch, dict(trial.params), values, P.overrides_of(search.document, document)
            )
            record.check_or_add(c)
            batch_candidates.append((trial, c))
            number += 1
        jobs = []
        for _, c in batch_candidates:
            config_hash = _config_hash(search.scenario, c.overrides, search.duration)
            for seed in search.seeds:
                task = RunTask(
                    scenario=scenario,
                    scenario_path=str(search.scenario),
                    variant=c.variant,
                    overrides=c.overrides,
                    seed=seed,
                    duration=search.duration,
                    config_hash=config_hash,
                )
                if store.is_done(task.key, config_hash):
                    bar.run_done(True, ran=False)
                else:
                    jobs.append(Job(task, c.values))
        if jobs:
            evaluator.run(jobs, store, out_dir, bar.run_done)
        by_key = {(r["variant"], int(r["seed"])): r for r in store.rows() if r["scenario"] == scenario}
        for trial, c in batch_candidates:
            runs = [by_key[(c.variant, s)] for s in search.seeds if (c.variant, s) in by_key]
            figures = score(search, runs)
            _tell(study, trial, search, figures)
            rows.append(_result_row(search, c, figures))
            if figures["feasible"] and math.isfinite(figures["objective"]):
                better = best is None or (
                    figures["objective"] < best[0]
                    if search.objective.direction == "minimize"
                    else figures["objective"] > best[0]
                )
                if better:
                    best = (figures["objective"], c.variant)
        bar.show(number, best)
        batch += 1
    return study


def _tell(study, trial, search: Search, figures: dict) -> None:
    import optuna

    constraints = [c if math.isfinite(c) else UNKNOWN_VIOLATION for c in figures["constraints"]]
    trial.set_user_attr("constraints", constraints)
    if hasattr(trial, "set_constraint"):  # Optuna 5: constrained TPE reads these
        for k, value in enumerate(constraints):
            trial.set_constraint(f"c{k}", value)
    value = figures["objective"]
    if not math.isfinite(value):
        study.tell(trial, state=optuna.trial.TrialState.FAIL)
        return
    if isinstance(study.sampler, optuna.samplers.CmaEsSampler) and constraints:
        # CMA-ES has no constrained sampling: the told value carries a penalty (docs/search.md)
        violation = sum(max(c, 0.0) for c in constraints)
        sign = 1.0 if search.objective.direction == "minimize" else -1.0
        value = value + sign * search.penalty * min(violation, UNKNOWN_VIOLATION)
    study.tell(trial, value)


def _result_row(search: Search, c: Candidate, figures: dict) -> dict:
    row = {
        "search": c.search,
        "number": c.number,
        "batch": c.batch,
        "variant": c.variant,
        "runs": (c.number + 1) * len(search.seeds),
        "objective": figures["objective"],
        "feasible": figures["feasible"],
        "status": "ok" if figures["complete"] else "failed",
        "error": "; ".join(e for e in figures["errors"] if e)[:500],
        "seeds_ok": figures["seeds_ok"],
    }
    for p in search.parameters:
        row[f"param.{p.name}"] = shown(c.values[p.name])
    for k, constraint in enumerate(search.constraints):
        row[f"constraint.{constraint}"] = figures["constraints"][k]
    for name, value in figures["metrics"].items():
        row[f"metric.{name}"] = value
    return row


def _write_results(out_dir: Path, rows: list[dict]):
    import pandas as pd

    frame = pd.DataFrame(rows)
    if not frame.empty:
        frame = frame.sort_values(["search", "number"], ascending=[False, True]).reset_index(drop=True)
        for column in frame.columns:
            if column.startswith("param.") and frame[column].map(type).nunique() > 1:
                frame[column] = frame[column].map(str)
    path = out_dir / RESULTS_FILE
    tmp = path.with_name(f".{path.name}.tmp")
    frame.to_parquet(tmp, index=False)
    os.replace(tmp, path)
    return frame


def best_candidates(search: Search, results, label: str = "optimizer", count: int | None = None):
    """The `count` best candidates of a search (feasible first; for falsify the worst for the cell:
    the smallest margin), as rows of results."""
    frame = results[(results["search"] == label) & (results["status"] == "ok")]
    ascending = search.objective.direction == "minimize"
    frame = frame.assign(_infeasible=~frame["feasible"].astype(bool))
    frame = frame.sort_values(["_infeasible", "objective", "number"], ascending=[True, ascending, True])
    return frame.drop(columns="_infeasible").head(count or search.report)
