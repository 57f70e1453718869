"""One run of a campaign, as a Dask worker (or this process) runs it: load the scenario with the
variant's overrides, set the seed, build the cell, simulate, and return the metrics row.

A run that raises is a row with `status: failed` and the error; only a worker's death reaches
the scheduler (which retries the run once, `engine`).

Test-only hook: the environment variable `HRC_DRAKE_CAMPAIGN_TEST_KILL`, a comma-separated list
of `VARIANT/SEED` (the Dask worker process running that run exits at once, on every attempt)
and `VARIANT/SEED@FILE` (it exits only when FILE does not exist yet, and creates it: the retry
succeeds). Nothing else reads it; never set it outside tests.
"""

from __future__ import annotations

import copy
import os
import sys
import time
from pathlib import Path

from hrc_drake.campaign.spec import RunTask

KEY_COLUMNS = ("scenario", "variant", "seed", "duration")
#: columns every row has besides the key and the metrics
RUN_COLUMNS = ("status", "error", "config_hash", "worker", "run_wall_time", "run_cpu_time")
#: columns that differ between identical runs (machine and load), left out of comparisons of rows
TIMING_COLUMNS = ("worker", "run_wall_time", "run_cpu_time", "wall_time", "realtime_factor")
TEST_KILL_VARIABLE = "HRC_DRAKE_CAMPAIGN_TEST_KILL"


def flatten_metrics(metrics: dict, prefix: str = "") -> dict:
    """The scalars of a metrics dict (`cell.metrics.summarize`), nested names joined by dots
    (`agents.human.idle_time`); lists and the `definitions` texts are left out."""
    out = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if key == "definitions" and not prefix:
            continue
        if isinstance(value, dict):
            out.update(flatten_metrics(value, f"{name}."))
        elif isinstance(value, (list, tuple)):
            continue
        else:
            out[name] = value
    return out


def run_task(task: RunTask) -> dict:
    """Run `task`; returns {"row": the metrics row, "replay_html": the replay or None, "notes":
    the warnings and log records it gave (`console.notes_to`), which the campaign prints above
    its progress bar instead of a worker printing them into it}."""
    from hrc_drake.console import notes_to

    notes: list[str] = []
    with notes_to(notes.append):
        outcome = _run_task(task)
    return {**outcome, "notes": notes}


def _run_task(task: RunTask) -> dict:
    start, start_cpu = time.perf_counter(), time.thread_time()
    row = dict(zip(KEY_COLUMNS, task.key, strict=True))
    row.update(status="ok", error="", config_hash=task.config_hash, worker=_worker_name())
    html = None
    _test_kill(task)
    try:
        from hrc_drake.cell.build import build_cell
        from hrc_drake.cell.run import local_meshcat, replay_html, simulate

        scenario = copy.deepcopy(_scenario(task.scenario_path, task.config_hash, task.overrides))
        scenario.seed = task.seed
        meshcat, fps = None, task.replay_fps
        if task.replay:
            from hrc_drake.config_common import replay_fps_within

            meshcat = local_meshcat()
            fps = replay_fps_within(task.replay_fps, task.duration)
        cell = build_cell(scenario, task.scenario_path, meshcat=meshcat, replay_fps=fps)
        result = simulate(cell, task.duration, progress=None, record=task.replay)
        if result.interrupted:
            # a run cut short is never a row: the campaign stops, and a resume runs it again
            from hrc_drake.interrupts import interruption

            raise interruption(result.stopped_by)
        row.update(flatten_metrics(result.metrics))
        if task.extra_metrics:
            from hrc_drake.campaign.extras import extra_columns

            row.update(extra_columns(task.extra_metrics, result, scenario))
        if task.replay:
            html = replay_html(cell, result)  # with its title, clock and legend
    except Exception as err:  # noqa: BLE001 - a failed run is a row with its error, not a lost campaign
        row.update(status="failed", error=f"{type(err).__name__}: {err}")
    row["run_wall_time"] = round(time.perf_counter() - start, 4)
    # the CPU time of the run's thread: unlike the wall time, it hardly moves with the machine's load
    row["run_cpu_time"] = round(time.thread_time() - start_cpu, 4)
    return {"row": row, "replay_html": html}


def failed_row(task: RunTask, error: str) -> dict:
    """The row of a run that did not return (its worker died, or the client lost it)."""
    row = dict(zip(KEY_COLUMNS, task.key, strict=True))
    row.update(
        status="failed",
        error=error,
        config_hash=task.config_hash,
        worker="",
        run_wall_time=float("nan"),
        run_cpu_time=float("nan"),
    )
    return row


#: (scenario path, config hash) -> the loaded scenario with its overrides, in this process
_SCENARIOS: dict[tuple[str, str], object] = {}
_MAX_CACHED_SCENARIOS = 64


def _scenario(path: str, config_hash: str, overrides: dict):
    """The loaded scenario with its overrides, once per worker process and configuration. The
    config hash covers the file's text and the overrides, so it keys the cache without dumping
    the overrides again on every run; the file alone was checked by `load_campaign`."""
    key = (path, config_hash)
    if key not in _SCENARIOS:
        from hrc_drake.cell.scenario import load_scenario_with

        if len(_SCENARIOS) >= _MAX_CACHED_SCENARIOS:
            _SCENARIOS.pop(next(iter(_SCENARIOS)))
        _SCENARIOS[key] = load_scenario_with(path, overrides or {}, check_file_alone=False)
    return _SCENARIOS[key]


def warm_up() -> str:
    """Import the cell's modules (pydrake, the systems) in this worker; returns its name."""
    import hrc_drake.cell.build  # noqa: F401
    import hrc_drake.cell.run  # noqa: F401

    return _worker_name()


def peak_rss_mb() -> float:
    """The peak resident memory of this process (MB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _worker_name() -> str:
    if "distributed" in sys.modules:
        from distributed import get_worker

        try:
            return get_worker().address
        except ValueError:
            pass
    return f"in-process:{os.getpid()}"


def _test_kill(task: RunTask) -> None:
    targets = os.environ.get(TEST_KILL_VARIABLE, "")
    if not targets or _worker_name().startswith("in-process"):
        return  # only a Dask worker process is ever killed
    for target in targets.split(","):
        which, _, marker = target.partition("@")
        if which != f"{task.variant}/{task.seed}":
            continue
        if marker:
            if Path(marker).exists():
                return
            Path(marker).write_text("killed once\n")
        os._exit(17)
