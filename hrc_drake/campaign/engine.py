"""Run a campaign: every run one task on Dask distributed (a `LocalCluster` of worker processes,
or an existing scheduler at an address), the rows stored as they finish, then the analysis.

Checks come first (the campaign file with every scenario x variant, the output folder, the
scheduler's address), so bad input costs no run. A worker that dies running a run makes the
scheduler run it once more elsewhere; a second death records the run as failed.
"""

from __future__ import annotations

import json
import logging
import math
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from hrc_drake.campaign.spec import Campaign, RunTask
from hrc_drake.campaign.store import RunStore, check_output_dir
from hrc_drake.campaign.worker import failed_row, run_task, warm_up
from hrc_drake.errors import ScenarioError

#: seconds to reach a scheduler at --address before giving up
CONNECT_TIMEOUT = 3.0
#: seconds a scheduler at --address may take to show its first worker
WORKERS_TIMEOUT = 20.0
#: deaths of a worker running a run before the run is failed (the first is retried)
ALLOWED_WORKER_DEATHS = 1


@dataclass
class CampaignOutcome:
    """What a campaign did: runs asked, skipped (done before), run now, failed now; the rows."""

    total: int
    skipped: int
    ran: int
    failed: int
    wall_time: float
    rows: object  # the DataFrame of DIR/runs.parquet
    dashboard: str = ""


class Progress:
    """Runs done / failed / remaining, runs per minute and ETA, on one line rewritten in place on
    a terminal, or a line every ~10 % elsewhere (as `cell.run.simulate`)."""

    def __init__(self, total: int, stream=sys.stderr, label: str = "campaign"):
        self.total, self.stream, self.label = total, stream, label
        self.done = self.failed = 0
        self.start = time.perf_counter()
        self.interactive = stream is not None and getattr(stream, "isatty", lambda: False)()
        self._next_tenth = 1

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        if self.stream is None:
            return
        if self.interactive or self.done * 10 >= self._next_tenth * self.total or self.done == self.total:
            while self.done * 10 >= self._next_tenth * self.total:
                self._next_tenth += 1
            self._print()

    def line(self) -> str:
        elapsed = time.perf_counter() - self.start
        rate = 60.0 * self.done / elapsed if elapsed > 0 else 0.0
        left = self.total - self.done
        eta = left / rate * 60.0 if rate > 0 else math.inf
        width = 24
        filled = int(width * self.done / self.total) if self.total else width
        bar = "#" * filled + "." * (width - filled)
        return (
            f"{self.label} [{bar}] {self.done}/{self.total} done, {self.failed} failed, {left} left, "
            f"{rate:.1f} runs/min, ETA {_clock(eta)}"
        )

    def _print(self) -> None:
        end = "" if self.interactive and self.done < self.total else "\n"
        print(("\r" if self.interactive else "") + self.line(), end=end, file=self.stream, flush=True)


def _clock(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "--"
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m{secs:02d}s" if hours else f"{minutes}m{secs:02d}s"


def run_campaign(
    campaign: Campaign,
    out_dir: Path,
    workers: int = 2,
    address: str | None = None,
    progress=sys.stderr,
    analyze: bool = True,
    client=None,
) -> CampaignOutcome:
    """Run the campaign's runs not yet in DIR/runs.parquet; write the rows, replays, analysis.

    workers: worker processes of the embedded `LocalCluster`; 0 runs every run in this process,
    one after the other (no Dask). address: an existing scheduler (tcp://HOST:PORT) instead.
    client: an existing `distributed.Client` to use (and leave open) instead of either.
    """
    out_dir = Path(out_dir)
    check_output_dir(out_dir)
    if workers < 0:
        raise ScenarioError("", "--workers", f"must be >= 0, got {workers}")
    store = RunStore(out_dir)
    (out_dir / "campaign.json").write_text(json.dumps(campaign.describe(), indent=2))
    tasks = campaign.tasks()
    todo = [
        t
        for t in tasks
        if not store.is_done(t.key, t.config_hash) or (t.replay and not replay_path(out_dir, t).is_file())
    ]
    skipped = len(tasks) - len(todo)
    if progress is not None and skipped:
        print(f"resuming: {skipped} of {len(tasks)} runs are done", file=progress, flush=True)
    bar = Progress(len(todo), progress, label=campaign.name)
    start = time.perf_counter()
    dashboard = ""
    try:
        if not todo:
            pass
        elif client is not None:
            dashboard = _announce_dashboard(client, progress, local=False)
            _run_on(client, todo, store, bar, out_dir)
        elif address is None and workers == 0:
            for task in todo:
                _record(run_task(task), task, store, bar, out_dir)
        else:
            with ClusterClient(address, workers) as own_client:
                dashboard = _announce_dashboard(own_client, progress, local=address is None)
                _run_on(own_client, todo, store, bar, out_dir)
    finally:
        store.flush()
    rows = store.frame()
    if analyze:
        from hrc_drake.campaign.analysis import analyze_campaign

        analyze_campaign(rows, campaign.describe(), out_dir)
    return CampaignOutcome(
        total=len(tasks),
        skipped=skipped,
        ran=bar.done,
        failed=bar.failed,
        wall_time=time.perf_counter() - start,
        rows=rows,
        dashboard=dashboard,
    )


def replay_path(out_dir: Path, task: RunTask) -> Path:
    return Path(out_dir) / "replays" / f"{task.scenario}__{task.variant}__{task.seed}.html"


def _record(outcome: dict, task: RunTask, store: RunStore, bar: Progress, out_dir: Path) -> None:
    row = outcome["row"]
    if outcome.get("replay_html") is not None:
        path = replay_path(out_dir, task)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(outcome["replay_html"])
    store.add(row)
    bar.update(row["status"] == "ok")


def _run_on(client, todo: list[RunTask], store: RunStore, bar: Progress, out_dir: Path) -> None:
    """Submit every run, record each as it finishes (cancel the rest on Ctrl-C)."""
    from distributed import as_completed

    client.run_on_scheduler(_allow_worker_deaths, ALLOWED_WORKER_DEATHS)
    futures = {}
    for task in todo:
        key = f"hrc-run-{task.scenario}-{task.variant}-{task.seed}-{task.config_hash}"
        futures[client.submit(run_task, task, key=key, pure=False)] = task
    finished = as_completed(futures)
    try:
        for future in finished:
            task = futures[future]
            outcome = None
            if future.status == "finished":
                try:
                    outcome = future.result()
                except Exception:  # noqa: BLE001 - lost with its worker between the two calls
                    outcome = None
            elif future.status == "error":
                outcome = {"row": failed_row(task, _death_message(future.exception())), "replay_html": None}
            if outcome is None:
                # the result died with the worker that held it: the scheduler computes it again
                finished.add(future)
                continue
            del futures[future]
            future.release()
            _record(outcome, task, store, bar, out_dir)
    finally:
        if futures:
            client.cancel(list(futures))


def _death_message(err) -> str:
    name = type(err).__name__
    if name == "KilledWorker":
        return (
            f"KilledWorker: the worker running it died {ALLOWED_WORKER_DEATHS + 1} times (retried once): "
            f"{err}"
        )
    return f"{name}: {err}"


def _allow_worker_deaths(deaths: int, dask_scheduler=None) -> None:
    """On the scheduler: a run whose worker dies more than `deaths` times is failed (KilledWorker)."""
    dask_scheduler.allowed_failures = deaths


class ClusterClient:
    """A client of the scheduler at `address`, or of a new `LocalCluster` of `workers` processes
    (one thread each: a cell is single-threaded Python), its workers warm (pydrake and the cell
    imported); closed on exit. Several `run_campaign(..., client=...)` calls may share one."""

    def __init__(self, address: str | None, workers: int):
        self.address, self.workers = address, workers
        self.client = self.cluster = None

    def __enter__(self):
        from distributed import Client, LocalCluster

        if self.address:
            try:
                self.client = Client(self.address, timeout=f"{CONNECT_TIMEOUT:g}s")
            except (OSError, TimeoutError, ValueError) as err:
                raise ScenarioError(
                    "",
                    "--address",
                    f"no Dask scheduler answers at {self.address} within "
                    f"{CONNECT_TIMEOUT:g} s ({type(err).__name__}: {err})",
                ) from None
            try:
                self.client.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
            except (OSError, TimeoutError) as err:
                self.client.close()
                raise ScenarioError(
                    "",
                    "--address",
                    f"the scheduler at {self.address} has no worker after {WORKERS_TIMEOUT:g} s ({err})",
                ) from None
        else:
            import dask

            # The workers' statistical profiler samples every thread's stack every 10 ms: with a
            # cell's deep Python stacks it took ~20 % of a run (measured on torch_clock). A
            # saturation of 1 gives a worker one run at a time, so a worker's death counts
            # against the run that killed it only.
            settings = {
                "distributed.worker.profile.enabled": False,
                "distributed.scheduler.worker-saturation": 1.0,
            }
            with dask.config.set(settings):
                self.cluster = LocalCluster(
                    n_workers=self.workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0" if _has_dashboard() else None,
                    silence_logs=logging.ERROR,
                )
            self.client = Client(self.cluster)
        self.client.run(warm_up)  # import pydrake and the cell in every worker at once
        if self.cluster is not None:  # our own workers only, never a user's cluster
            # a plugin: a worker the nanny restarts (after a death) gets it too
            self.client.register_plugin(_quiet_local_worker_plugin())
        return self.client

    def __exit__(self, exc_type, exc, traceback):
        if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
            quiet_interrupted_shutdown()
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        return False


def _quiet_local_worker() -> None:
    """In a local worker process: ignore SIGINT, which a terminal's Ctrl-C sends to the whole
    process group (asyncio's handler in the worker would print a KeyboardInterrupt traceback
    while this process closes the cluster), and keep Dask's and tornado's logs to CRITICAL (their
    ERRORs then are the lost heartbeats of that shutdown; a run that fails is reported in its
    row, with its error)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    for name in ("distributed", "tornado"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _quiet_local_worker_plugin():
    """A Dask worker plugin running `_quiet_local_worker` on every worker, now and at each start."""
    from distributed import WorkerPlugin

    class QuietLocalWorker(WorkerPlugin):
        name = "hrc-drake-quiet-local-worker"

        def setup(self, worker):
            _quiet_local_worker()

    return QuietLocalWorker()


def quiet_interrupted_shutdown() -> None:
    """After Ctrl-C, Dask's nanny and tornado's loop log the cancelled tasks of the cluster's
    shutdown as errors with tracebacks (distributed.nanny CancelledError, a tornado callback's
    NameError); the user asked for the stop and the finished runs are saved: silence them."""
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _has_dashboard() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


def _announce_dashboard(client, progress, local: bool) -> str:
    """Print the scheduler's dashboard link to `progress` (when it serves one); return it.
    local: the scheduler runs in this process, which serves a dashboard only with bokeh."""
    link = _dashboard(client) if _has_dashboard() or not local else ""
    if progress is not None and link:
        print(f"Dask dashboard: {link}", file=progress, flush=True)
    return link


def _dashboard(client) -> str:
    """The link of the scheduler's dashboard, "" when it has none (a remote scheduler may have
    bokeh where this process has not, and the other way round: ask the scheduler)."""
    try:
        services = client.scheduler_info().get("services", {})
        return client.dashboard_link if "dashboard" in services else ""
    except Exception:  # noqa: BLE001 - the link is a convenience
        return ""
