"""Run a campaign: every run one task on Dask distributed (a `LocalCluster` of worker processes,
or an existing scheduler at an address), the rows stored as they finish, then the analysis.

Checks come first (the campaign file with every scenario x variant, the output folder, the
scheduler's address), so bad input costs no run. A worker that dies running a run makes the
scheduler run it once more elsewhere; a second death records the run as failed.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from hrc_drake.campaign.spec import Campaign, RunTask
from hrc_drake.campaign.store import (
    CampaignLock,
    RunStore,
    archive_previous,
    check_compatible,
    check_output_dir,
)
from hrc_drake.campaign.worker import failed_row, run_task, warm_up
from hrc_drake.console import ProgressLine, WarningTally
from hrc_drake.errors import EnvironmentFailure, ScenarioError

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
        self._line = ProgressLine(stream) if self.interactive else None
        self._next_tenth = 1
        self._warnings = WarningTally()

    def note(self, run: str, text: str) -> None:
        """A run's warning, on a line of its own above the bar: the first of each kind (its
        words without their figures), the others counted (`repeats`)."""
        if not self._warnings.first(text) or self.stream is None:
            return
        message = f"warning from {run}: {text}"
        if self._line is not None:
            self._line.note(message)
        else:
            print(message, file=self.stream, flush=True)

    def repeats(self) -> None:
        """How many more runs gave each warning (after the bar's last line)."""
        for line in self._warnings.repeats():
            if self.stream is not None:
                print(line, file=self.stream, flush=True)

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
        if self._line is None:
            print(self.line(), file=self.stream, flush=True)
            return
        self._line.show(self.line())
        if self.done >= self.total:
            self._line.end()


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
    new_spec: bool = False,
    wait: float = 0.0,
    limit: int | None = None,
) -> CampaignOutcome:
    """Run the campaign's runs not yet in DIR; write the rows, replays, analysis.

    workers: worker processes of the embedded `LocalCluster`; 0 runs every run in this process,
    one after the other (no Dask). address: an existing scheduler (tcp://HOST:PORT) instead.
    client: an existing `distributed.Client` to use (and leave open) instead of either.
    new_spec: move an earlier campaign's results in DIR aside (`store.archive_previous`) instead of
    refusing a spec whose runs differ from them. wait: seconds to wait for a folder another
    campaign holds (`store.CampaignLock`). limit: run at most this many of the runs not yet done,
    two seeds of each scenario x variant at a time (`Campaign.iter_tasks_in_pairs`: the runs
    made give each configuration they reach the two seeds a test needs); a later call without
    it runs the rest. An interruption (Ctrl-C,
    SIGTERM) propagates after the finished rows are saved; a run it cut short is not a row.
    """
    out_dir = Path(out_dir)
    if workers < 0:
        raise ScenarioError("", "--workers", f"must be >= 0, got {workers}")
    check_output_dir(out_dir)
    with CampaignLock(out_dir, wait, progress):
        if new_spec:
            moved = archive_previous(out_dir)
            if moved is not None and progress is not None:
                print(f"the earlier results are in {moved}", file=progress, flush=True)
        store = _environment(lambda: RunStore(out_dir), f"cannot read or update the table in {out_dir}")
        try:
            return _run_locked(campaign, out_dir, store, workers, address, progress, analyze, client, limit)
        finally:
            store.close()


def _run_locked(campaign, out_dir, store, workers, address, progress, analyze, client, limit=None
                ) -> CampaignOutcome:
    hashes = campaign.config_hashes()
    check_compatible(store.rows(), campaign.duration, hashes, out_dir)
    _environment(lambda: _write_description(out_dir, campaign), f"cannot write {out_dir / 'campaign.json'}")

    def todo(task: RunTask) -> bool:
        return not store.is_done(task.key, task.config_hash) or (
            task.replay and not replay_path(out_dir, task).is_file())

    total = campaign.run_count
    remaining = sum(1 for t in campaign.iter_tasks() if todo(t))  # counted, not held: specs may be large
    skipped = total - remaining
    if progress is not None and skipped:
        print(f"resuming: {skipped} of {total} runs are done", file=progress, flush=True)
    pending = (t for t in campaign.iter_tasks() if todo(t))
    if limit is not None:
        import itertools

        if remaining > limit and progress is not None:
            print(f"limit: {limit} of the {remaining} runs not yet done run now", file=progress, flush=True)
        remaining = min(remaining, limit)
        # two seeds of a scenario x variant before the next: a test needs two of each side
        pending = itertools.islice((t for t in campaign.iter_tasks_in_pairs() if todo(t)), limit)
    bar = Progress(remaining, progress, label=campaign.name)
    start = time.perf_counter()
    dashboard = ""
    interrupted = True
    try:
        if client is not None:
            if remaining:
                dashboard = _announce_dashboard(client, progress, local=False)
                _run_on(client, pending, store, bar, out_dir)
        elif address is None and workers == 0:
            if remaining:
                with compile_kernels_ahead(campaign.kernel_groups, address) as ahead:
                    ahead.wait()
            for task in pending:
                _record(run_task(task), task, store, bar, out_dir)
        elif remaining:
            # the kernels compile once, while the workers start, instead of in every worker
            with compile_kernels_ahead(campaign.kernel_groups, address) as ahead, \
                    ClusterClient(address, workers) as own_client:
                ahead.wait()
                dashboard = _announce_dashboard(own_client, progress, local=address is None)
                _run_on(own_client, pending, store, bar, out_dir, address)
        else:
            check_scheduler(address)  # nothing to run, but a wrong address is still an error
        interrupted = False
    finally:
        _flush(store, out_dir, quiet=interrupted)
    bar.repeats()
    rows = campaign_rows(store.frame(), campaign, hashes)
    if analyze:
        from hrc_drake.campaign.analysis import analyze_campaign

        analyze_campaign(rows, campaign.describe(), out_dir)
    return CampaignOutcome(
        total=total,
        skipped=skipped,
        ran=bar.done,
        failed=bar.failed,
        wall_time=time.perf_counter() - start,
        rows=rows,
        dashboard=dashboard,
    )


def compile_kernels_ahead(groups, address: str | None):
    """`kernels.compile_ahead` of `groups` for runs on this machine; nothing for the workers of a
    scheduler at `address` (they may be on other machines, with caches of their own)."""
    from hrc_drake.kernels import KernelsAhead, compile_ahead

    return compile_ahead(groups) if address is None and groups else KernelsAhead()


def _environment(action, what: str):
    """`action()`, an OSError of it an `EnvironmentFailure` saying `what` failed."""
    try:
        return action()
    except OSError as err:
        raise EnvironmentFailure(f"{what}: {err.strerror or err}") from None


def _flush(store: RunStore, out_dir: Path, quiet: bool) -> None:
    """Write the table at the end; when another exception is on its way (quiet), only say so."""
    try:
        store.flush()
    except OSError as err:
        message = (f"cannot rewrite {store.path} ({err.strerror or err}); the finished runs are kept in "
                   f"{store.journal_path} and join the table on the next run of the campaign")
        if not quiet:
            raise EnvironmentFailure(message) from None
        print(f"warning: {message}", file=sys.stderr, flush=True)


def _write_description(out_dir: Path, campaign: Campaign) -> None:
    """DIR/campaign.json: the campaign, the configuration of each (scenario, variant), the code."""
    from hrc_drake.provenance import code_version

    description = campaign.describe()
    description["configurations"] = {f"{s}/{v}": h for (s, v), h in campaign.config_hashes().items()}
    description["code_version"] = code_version()
    path = Path(out_dir) / "campaign.json"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(description, indent=2))
    os.replace(tmp, path)


def campaign_rows(frame, campaign: Campaign, hashes: dict):
    """The rows of `frame` that are runs of `campaign` as it is now (its seeds, scenarios and
    variants with their current configuration): rows an earlier, wider spec left are kept in
    the table but not analysed."""
    if frame.empty:
        return frame
    wanted = frame["config_hash"] == [hashes.get((s, v)) for s, v in zip(frame["scenario"], frame["variant"],
                                                                         strict=True)]
    wanted &= frame["seed"].isin(campaign.seeds)
    return frame[wanted].reset_index(drop=True)


def replay_path(out_dir: Path, task: RunTask) -> Path:
    return Path(out_dir) / "replays" / f"{task.scenario}__{task.variant}__{task.seed}.html"


def _record(outcome: dict, task: RunTask, store: RunStore, bar: Progress, out_dir: Path) -> None:
    row = outcome["row"]
    what = f"run {task.scenario}/{task.variant} seed {task.seed} finished, but"
    if outcome.get("replay_html") is not None:
        path = replay_path(out_dir, task)

        def write():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(outcome["replay_html"])

        _environment(write, f"{what} its replay cannot be written to {path}; the campaign stopped with the "
                            "earlier runs saved")
    _environment(lambda: store.add(row), f"{what} its row cannot be written to {store.journal_path} (it is "
                                         "lost); the campaign stopped with the earlier runs saved")
    for text in outcome.get("notes", ()):
        bar.note(f"{task.scenario}/{task.variant} seed {task.seed}", text)
    bar.update(row["status"] == "ok")


#: runs submitted per worker at a time: a huge spec starts at once and stops promptly
IN_FLIGHT_PER_WORKER = 2
#: seconds the client may be without its scheduler before the campaign gives up (it reconnects
#: meanwhile: a scheduler restarted at the same address takes the runs again)
SCHEDULER_LOST_TIMEOUT = 30.0
#: how often the loop looks for finished runs and the scheduler's health (s)
POLL_INTERVAL = 0.1


class SchedulerLost(EnvironmentFailure):
    """The Dask scheduler stopped answering during a campaign."""


def _run_on(client, pending, store: RunStore, bar: Progress, out_dir: Path, address: str | None = None
            ) -> None:
    """Submit the `pending` runs a few per worker at a time, record each as it finishes; stop on
    a lost scheduler (`SchedulerLost`) or an interruption, cancelling what is left."""
    from distributed import as_completed

    try:
        client.run_on_scheduler(_allow_worker_deaths, ALLOWED_WORKER_DEATHS)
    except OSError:  # the scheduler went away before the first run was sent
        raise SchedulerLost(_lost_message(address, bar, store)) from None
    n_workers = max(len(client.scheduler_info().get("workers", {})), 1)
    in_flight = IN_FLIGHT_PER_WORKER * n_workers
    futures: dict = {}
    finished = as_completed()
    attempts: dict[tuple, int] = {}
    orphans: list[RunTask] = []
    lost_since = None

    def submit(task: RunTask) -> None:
        attempt = attempts.get(task.key, 0)
        attempts[task.key] = attempt + 1
        key = f"hrc-run-{task.scenario}-{task.variant}-{task.seed}-{task.config_hash}" + (
            f"-{attempt}" if attempt else "")
        future = client.submit(run_task, task, key=key, pure=False)
        futures[future] = task
        finished.add(future)

    def top_up() -> None:
        while len(futures) < in_flight and client.status == "running":
            task = next(pending, None)
            if task is None:
                return
            submit(task)

    try:
        top_up()
        while futures or orphans:
            batch = finished.next_batch(block=False) if finished.has_ready() else []
            if not batch:
                if client.status == "running":
                    lost_since = None
                    while orphans:  # the scheduler is back: its forgotten runs again
                        submit(orphans.pop())
                else:
                    lost_since = lost_since or time.monotonic()
                    if client.status == "closed" or time.monotonic() - lost_since > SCHEDULER_LOST_TIMEOUT:
                        raise SchedulerLost(_lost_message(address, bar, store))
                time.sleep(POLL_INTERVAL)
                continue
            for future in batch:
                task = futures.pop(future)
                outcome = _outcome(future, task)
                if outcome is None and future.status == "finished":
                    # the result died with the worker that held it: the scheduler computes it again
                    futures[future] = task
                    finished.add(future)
                    continue
                future.release()
                if outcome is None:  # cancelled: the scheduler forgot it (lost, or restarted)
                    orphans.append(task)
                    continue
                _record(outcome, task, store, bar, out_dir)
            top_up()
    finally:
        if futures and client.status == "running":
            client.cancel(list(futures))


def _outcome(future, task: RunTask) -> dict | None:
    """The run's outcome, a failed row for an error, None when it has none (yet)."""
    if future.status == "finished":
        try:
            return future.result()
        except Exception:  # noqa: BLE001 - lost with its worker between the two calls
            return None
    if future.status == "error":
        return {"row": failed_row(task, _death_message(future.exception())), "replay_html": None}
    return None


def _lost_message(address: str | None, bar: Progress, store: RunStore) -> str:
    quiet_interrupted_shutdown()  # the client's own reconnect errors: this message says it
    where = f"at {address}" if address else "of the local cluster"
    return (f"lost the Dask scheduler {where} (no answer for {SCHEDULER_LOST_TIMEOUT:g} s, or the client "
            f"gave up reconnecting); {bar.done} run(s) finished and are saved in {store.out_dir}: restart "
            "the scheduler and its workers, then run the same command to resume")


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


#: the address the embedded cluster serves on (its scheduler, workers and dashboard)
LOOPBACK = "127.0.0.1"


def connect(address: str):
    """A client of the scheduler at `address`; `ScenarioError` on --address when none answers."""
    from distributed import Client

    try:
        return Client(address, timeout=f"{CONNECT_TIMEOUT:g}s")
    except (OSError, TimeoutError, ValueError) as err:
        raise ScenarioError(
            "",
            "--address",
            f"no Dask scheduler answers at {address} within {CONNECT_TIMEOUT:g} s "
            f"({type(err).__name__}: {err})",
        ) from None


def check_scheduler(address: str | None) -> None:
    """A scheduler answers at `address` (nothing to check without one)."""
    if address:
        connect(address).close()


class ClusterClient:
    """A client of the scheduler at `address`, or of a new `LocalCluster` of `workers` processes
    (one thread each: a cell is single-threaded Python), its workers warm (pydrake and the cell
    imported); closed on exit. Several `run_campaign(..., client=...)` calls may share one."""

    def __init__(self, address: str | None, workers: int):
        self.address, self.workers = address, workers
        self.client = self.cluster = None

    def __enter__(self):
        try:
            return self._enter()
        except BaseException as err:
            # interrupted (Ctrl-C) or failed while the cluster started: close what was started,
            # else distributed's exit handler finds a half-started cluster (AssertionError: Status.init)
            if isinstance(err, KeyboardInterrupt):
                quiet_interrupted_shutdown()
            for part in (self.client, self.cluster):
                if part is not None:
                    with contextlib.suppress(Exception):
                        part.close()
            raise

    def _enter(self):
        from distributed import Client, LocalCluster

        if self.address:
            self.client = connect(self.address)
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
                # loopback only: the scheduler, its unauthenticated dashboard and the workers
                self.cluster = LocalCluster(
                    n_workers=self.workers,
                    threads_per_worker=1,
                    processes=True,
                    host=LOOPBACK,
                    dashboard_address=f"{LOOPBACK}:0" if _has_dashboard() else None,
                    silence_logs=logging.ERROR,
                )
            self.client = Client(self.cluster)
        try:
            self.client.run(warm_up)  # import pydrake and the cell in every worker at once
        except OSError as err:  # the scheduler went away while its workers were warming up
            self.client.close()
            if self.cluster is not None:
                self.cluster.close()
            where = f"at {self.address}" if self.address else "of the local cluster"
            quiet_interrupted_shutdown()
            raise SchedulerLost(
                f"lost the Dask scheduler {where} while its workers were starting ({type(err).__name__}); "
                "no run had started: restart the scheduler and its workers, then run the same command "
                "to resume"
            ) from None
        if self.cluster is not None:  # our own workers only, never a user's cluster
            # a plugin: a worker the nanny restarts (after a death) gets it too
            self.client.register_plugin(_quiet_local_worker_plugin())
        return self.client

    def __exit__(self, exc_type, exc, traceback):
        if exc_type is not None and issubclass(exc_type, (KeyboardInterrupt, SchedulerLost)):
            # the user has the stop (or the lost scheduler) in words and the finished runs are
            # saved: the client's cancelled reconnection tasks are not news (under load they log
            # a CancelledError traceback while the client closes)
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
