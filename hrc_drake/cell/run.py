"""Run a cell: simulate (with progress output when asked), gather metrics, write the replay and report."""

from __future__ import annotations

import json
import signal
import sys
import time
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import EventStatus
from threadpoolctl import threadpool_limits

from hrc_drake.allocator import keep_freed_memory
from hrc_drake.cell.build import Cell
from hrc_drake.cell.metrics import (
    DEFINITIONS,
    MetricsLog,
    plot_collaboration,
    plot_gantt,
    summarize,
    write_events_csv,
)
from hrc_drake.console import ProgressLine, notes_to
from hrc_drake.interrupts import signal_of, stop_requested_by_signals
from hrc_drake.safety.report import plot_safety


@dataclass
class RunResult:
    """A finished run: its metrics, log and the diagram context it ran in."""

    metrics: dict
    wall_time: float
    simulated_time: float
    log: MetricsLog
    context: object
    #: the run was stopped (Ctrl-C, SIGTERM) before `duration`: the figures cover `simulated_time` only
    interrupted: bool = False
    #: the simulated time asked for (s)
    duration: float = 0.0
    #: the signal that stopped it (signal.SIGINT or SIGTERM), None when it ran to `duration`
    stopped_by: int | None = None


def simulate(
    cell: Cell,
    duration: float,
    progress=None,
    record: bool = False,
    chunks: int = 50,
    realtime_rate: float = 0.0,
) -> RunResult:
    """Simulate `cell` for `duration` s, silently unless asked: `progress` a text stream (e.g.
    `sys.stderr`, as `hrc-drake simulate` passes) or True (stderr) prints its progress there, a
    line every 10 % (one line rewritten in place on a terminal); None or False: nothing printed.

    realtime_rate: 0 runs as fast as possible; 1 paces the run with the wall clock (live view).
    Every call runs in a new Context: one built cell can be simulated again. Ctrl-C stops the
    run (SIGTERM too, `interrupts`): the result then covers the time simulated so far, with
    `interrupted` and `stopped_by` set.
    """
    if duration <= 0:
        raise ValueError(f"duration must be positive, got {duration}")
    if progress is True:
        progress = sys.stderr
    elif progress is False:
        progress = None
    keep_freed_memory()
    simulator = Simulator(cell.diagram)
    context = simulator.get_context()
    world_system = cell.world_system
    world_context = world_system.GetMyContextFromRoot(context)
    simulator.set_target_realtime_rate(realtime_rate)
    if record and cell.visualizer is not None:
        cell.visualizer.StartRecording(False)
    # On a terminal one line is rewritten in place; in a log, a line every 10 %.
    interactive = progress is not None and getattr(progress, "isatty", lambda: False)()
    line = ProgressLine(progress) if interactive else None
    start = time.perf_counter()
    # One BLAS thread: a cell's matrices are small (at most 100 x 100), where OpenBLAS's extra
    # threads only spin (torch_segmentation: 33 % more CPU for the same wall time), and seeded
    # runs side by side (campaigns) use the other cores.
    # on a terminal, warnings and log records print above the progress line, not inside it
    with threadpool_limits(limits=1, user_api="blas"), stop_requested_by_signals() as stop, \
            (notes_to(line.note) if line is not None else nullcontext()):
        # a signal only sets `stop`; the monitor ends the step it lands in (`interrupts`)
        diagram = cell.diagram
        simulator.set_monitor(
            lambda _: EventStatus.ReachedTermination(diagram, "stop requested by a signal") if stop else None)
        try:
            simulator.Initialize()
            for k in range(1, chunks + 1):
                simulator.AdvanceTo(duration * k / chunks)
                if stop:
                    break
                if progress is not None and (interactive or (10 * k) % chunks == 0 or k == chunks):
                    _print_progress(line or progress, simulator, world_system, world_context, k, chunks,
                                    duration, time.perf_counter() - start)
        except KeyboardInterrupt as err:
            stop.signum = stop.signum or signal_of(err)
        except SystemError as err:
            # an interruption raised inside a compiled kernel (numba reports it so)
            if not isinstance(err.__context__ or err.__cause__, KeyboardInterrupt):
                raise
            stop.signum = stop.signum or signal_of(err.__context__ or err.__cause__)
        interrupted = bool(stop) and context.get_time() < duration
        stopped_by = stop.signum
    wall = time.perf_counter() - start
    if line is not None:
        line.end()
    if record and cell.visualizer is not None:
        cell.visualizer.StopRecording()
        cell.visualizer.PublishRecording()
    end_time = context.get_time() if interrupted else duration
    log = cell.log(context)
    warmup = cell.scenario.metrics
    metrics = summarize(log, end_time, cell.agents, cell.product_actions, wall_time=wall,
                        warmup_products=warmup.warmup_products, warmup_time=warmup.warmup_time,
                        shared_actions=cell.shared_actions, flow_actions=cell.scenario.flow.actions,
                        buffers=cell.scenario.layout.buffers)
    metrics["safety"] = {**(metrics.get("safety") or {}), **cell.safety(context)}
    if interrupted:
        metrics["interrupted"] = True
        metrics["stopped_by"] = signal.Signals(stopped_by).name
    return RunResult(metrics=metrics, wall_time=wall, simulated_time=end_time, log=log, context=context,
                     interrupted=interrupted, duration=duration,
                     stopped_by=stopped_by if interrupted else None)


def _print_progress(progress, simulator, world_system, world_context, k: int, chunks: int,
                    duration: float, wall: float) -> None:
    """One progress line: rewritten on a terminal (`progress` a `ProgressLine`), a new one in a log."""
    t = simulator.get_context().get_time()
    text = (f"  simulating {100 * k // chunks:3d}%  t = {t:7.1f} / {duration:.0f} s"
            f"   products = {world_system.world(world_context).finished_products:3d}"
            f"   realtime factor = {t / max(wall, 1e-9):6.1f}x")
    if isinstance(progress, ProgressLine):
        progress.show(text)
    else:
        print(text, file=progress, flush=True)


def local_meshcat(quiet: bool = True):
    """A Meshcat that serves localhost only: a replay's recorder, not a view for the network.

    quiet: it does not log "Meshcat listening for connections at http://localhost:PORT" (a
    recorder's server shows nothing a person should open, and is gone when the run ends); the
    live view (quiet False) logs it, and the caller prints its link."""
    import logging

    from pydrake.geometry import Meshcat, MeshcatParams

    logger = logging.getLogger("drake")
    level = logger.level
    if quiet:
        logger.setLevel(max(logging.WARNING, level))
    try:
        return Meshcat(MeshcatParams(host="localhost"))
    finally:
        logger.setLevel(level)


def replay_html(cell: Cell, result: RunResult | None = None) -> str:
    """The recorded run as one self-contained HTML page, with the overlay of `replay.add_overlay`:
    a title (scenario, seed, duration), the safety verdict and the products of `result`, the
    simulated clock as it plays, the legend of the markers' colours."""
    from hrc_drake.cell.replay import add_overlay

    scenario = cell.scenario
    duration = result.simulated_time if result is not None else None
    markers = cell.system("replay_markers") if cell.has_system("replay_markers") else None
    legend = markers.legend() if markers is not None else []
    name = Path(cell.scenario_path).stem if cell.scenario_path != "<scenario>" else "cell"
    metrics = result.metrics if result is not None else {}
    return add_overlay(cell.meshcat.StaticHtml(), name=name, description=scenario.description or "",
                       seed=scenario.seed, duration=duration,
                       interrupted=bool(result is not None and result.interrupted), legend=legend,
                       verdict=(metrics.get("safety") or {}).get("verdict"),
                       products=metrics if "products_finished" in metrics else None)


def write_replay(cell: Cell, path: Path, result: RunResult | None = None) -> int:
    """Write the recorded run as one self-contained HTML file (`replay_html`); returns its size in bytes."""
    html = replay_html(cell, result)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(html)
    return path.stat().st_size


#: the files `write_report` may write: an earlier run's are removed first, so a folder never
#: holds one run's results beside another's plots
REPORT_FILES = ("metrics.json", "events.csv", "gantt.png", "safety.png", "collaboration.png")


def run_header(cell: Cell, result: RunResult) -> dict:
    """What metrics.json says it is: the scenario file, seed, duration asked and simulated, the code."""
    from hrc_drake.provenance import code_version

    return {"scenario": cell.scenario_path, "seed": cell.scenario.seed, "duration": result.duration,
            "simulated_time": result.simulated_time, "interrupted": result.interrupted,
            "code_version": code_version()}


def metrics_document(header: dict, metrics: dict) -> dict:
    """metrics.json: the run's header, then the safety verdict line (a copy of `safety.verdict`,
    so the file answers "is it safe?" first), then the figures, throughput first."""
    verdict = (metrics.get("safety") or {}).get("verdict")
    if not verdict:
        return {"run": header, **metrics}
    definitions = {"verdict": DEFINITIONS["verdict"], **metrics.get("definitions", {})}
    return {"run": header, "verdict": verdict, **metrics, "definitions": definitions}


def scenario_action_names(scenario) -> list[str]:
    """Every action name a scenario's agents may perform (flow, robots', operator's): the key of
    the Gantt chart's colours, the same in every run of the scenario."""
    names = {a.name for a in scenario.flow.actions}
    names.update(a.name for r in scenario.robots for a in r.actions)
    names.update(a.name for a in scenario.operator.actions)
    return sorted(names)


def write_report(cell: Cell, result: RunResult, out_dir: Path) -> list[Path]:
    """metrics.json (headed by `run_header`), events.csv, gantt.png and safety.png (separation
    against S_p, contacts, worst ratio per body region) in `out_dir`; with a use case a robot and
    a predictor also collaboration.png (thesis Fig. 5.15). An earlier run's `REPORT_FILES` there
    are removed first."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name in REPORT_FILES:
        (out_dir / name).unlink(missing_ok=True)
    metrics_path = out_dir / "metrics.json"
    metrics_path.write_text(json.dumps(metrics_document(run_header(cell, result), result.metrics), indent=2))
    events_path = out_dir / "events.csv"
    write_events_csv(events_path, result.log.events, result.log.perceived_events,
                     (result.metrics.get("safety") or {}).get("events", ()))
    gantt_path = out_dir / "gantt.png"
    title = cell.scenario.description or "cell"
    plot_gantt(gantt_path, result.log, result.simulated_time, cell.agents, title=title,
               action_names=scenario_action_names(cell.scenario), safety=result.metrics.get("safety"))
    paths = [metrics_path, events_path, gantt_path]
    trace, contacts = cell.safety_trace(result.context)
    paths.append(plot_safety(out_dir / "safety.png", trace, contacts, result.metrics.get("safety") or {},
                             title=title))
    scheduler = cell.scenario.scheduler
    if hasattr(scheduler, "request_action") and result.log.forecasts:
        collaboration_path = out_dir / "collaboration.png"
        plot_collaboration(collaboration_path, result.log, result.simulated_time, cell.scenario.operator.name,
                           scheduler.agent, scheduler.request_action, scheduler.assist_actions, title=title)
        paths.append(collaboration_path)
    return paths
