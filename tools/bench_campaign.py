"""Benchmark: campaigns on Dask (issue #16). The same set of torch_clock runs (the scenario as
shipped, seeds 0..N-1) in this process one after the other, then as a campaign on a
`LocalCluster` of 1 worker process and of 2, side by side in one invocation.

Figures: runs per minute with 1 and 2 workers (runs / wall time of the campaign, workers already
started and warm: pydrake imported, one cell of the same configuration built and run), the
scaling efficiency rpm_2 / (2 rpm_1), the peak resident memory of a worker, whether the three
ways give the same rows, and the overhead per run with 1 worker, in two parts: the dispatch
(campaign wall time minus the runs' own wall times in the worker, per run: scheduling, transfer,
the table's rewrites) plus the run's slow-down in a worker process: the median over up to 8
seeds, each run in this process and then on the warm worker, alternately (a drift of the load
hits both alike), of the worker's run wall time minus the in-process one (build + simulate);
beside it the same difference of CPU times (`run_cpu_time`, the run thread's: steadier under
load) and of the round trip (submit to result), and the load average at start and end. Goals: efficiency
>= 0.9; overhead below 5 % of a 300 s torch_clock run; 1,000 runs of 300 s in under 10 minutes
on 2 cores.

Usage:
    PYTHONPATH=. python3 tools/bench_campaign.py [--quick | --smoke] [--runs N] [--duration S]
--quick: 6 runs of 40 s (under a minute on an idle machine). Default: 40 runs of 300 s.
--smoke: 1 run of 1 s, the clusters' workers threads of this process (no worker processes to start):
the whole path in a few seconds, figures meaningless.
Last line: one JSON object (`runs`, `runs_per_min_1_worker`, `runs_per_min_2_workers`,
`scaling_efficiency_2`, `overhead_per_run_ms` (= `dispatch_ms_per_run` +
`worker_slowdown_ms_median`), `worker_cpu_slowdown_ms_median`, `peak_worker_rss_mb`, and details).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hrc_drake.campaign.engine import run_campaign  # noqa: E402
from hrc_drake.campaign.spec import load_campaign  # noqa: E402
from hrc_drake.campaign.store import RunStore  # noqa: E402
from hrc_drake.campaign.worker import TIMING_COLUMNS, peak_rss_mb, run_task, warm_up  # noqa: E402

SCENARIO = ROOT / "diagrams" / "torch_clock.yaml"


def write_spec(folder: Path, runs: int, duration: float, first_seed: int = 0) -> Path:
    path = folder / f"bench_{first_seed}.yaml"
    import yaml

    # dumped, not formatted: a path with YAML's special characters stays one string
    path.write_text(yaml.safe_dump({
        "name": "bench_campaign", "duration": float(duration), "seeds": {"count": runs, "first": first_seed},
        "scenarios": [str(SCENARIO)], "metrics": ["mean_time_between_products"]}))
    return path


def in_process(campaign) -> tuple[list[float], list[dict]]:
    """Wall time (s) and row of every run, one after the other in this process (after a warm-up run)."""
    tasks = campaign.tasks()
    run_task(tasks[0])  # imports and the first build's one-off costs
    walls, rows = [], []
    for task in tasks:
        start = time.perf_counter()
        rows.append(run_task(task)["row"])
        walls.append(time.perf_counter() - start)
    return walls, rows


#: seeds of the paired overhead measurement (each run once in this process and once in the worker)
PAIRED_RUNS = 8


def on_cluster(campaign, warm_campaign, workers: int, out: Path, paired: int = 0,
               processes: bool = True) -> dict:
    """The campaign on a warm LocalCluster of `workers` processes: wall time, rows, peak RSS; and
    for the first `paired` tasks, each run in this process then in the worker, alternately (so a
    change of the machine's load hits both alike): the in-process wall and CPU times, the round
    trip (submit to result) and the run's own wall and CPU times in the worker. processes=False:
    the workers are threads of this process (no interpreter to start: the smoke setting)."""
    import dask
    from distributed import Client, LocalCluster

    settings = {"distributed.worker.profile.enabled": False, "distributed.scheduler.worker-saturation": 1.0}
    with dask.config.set(settings):
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=processes,
            # loopback only: the scheduler and workers are unauthenticated (threads talk in-process)
            host="127.0.0.1" if processes else None,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
    client = Client(cluster)
    try:
        client.run(warm_up)
        addresses = list(client.scheduler_info()["workers"])
        warm_tasks = warm_campaign.tasks()
        client.gather(
            [client.submit(run_task, warm_tasks[k], workers=[a], pure=False) for k, a in enumerate(addresses)]
        )
        start = time.perf_counter()
        outcome = run_campaign(campaign, out, client=client, progress=None, analyze=False)
        wall = time.perf_counter() - start
        pairs = []
        for task in campaign.tasks()[:paired]:
            alone = run_task(task)["row"]
            start_trip = time.perf_counter()
            there = client.submit(run_task, task, pure=False).result()["row"]
            trip = time.perf_counter() - start_trip
            pairs.append({
                "alone_wall": alone["run_wall_time"],
                "alone_cpu": alone["run_cpu_time"],
                "trip": trip,
                "worker_wall": there["run_wall_time"],
                "worker_cpu": there["run_cpu_time"],
            })
        rss = max(client.run(peak_rss_mb).values())
    finally:
        client.close()
        cluster.close()
    return {"wall": wall, "rows": outcome.rows, "failed": outcome.failed, "rss": rss, "pairs": pairs}


def _comparable(frame):
    frame = frame.drop(columns=[c for c in TIMING_COLUMNS if c in frame.columns])
    return frame.sort_values(["scenario", "variant", "seed"]).reset_index(drop=True)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="6 runs of 40 s")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--runs", type=int, default=None, help="runs per measurement (default 40; quick 6)")
    parser.add_argument(
        "--duration", type=float, default=None, help="simulated s per run (default 300; quick 40)"
    )
    args = parser.parse_args(argv)
    runs = args.runs or (1 if args.smoke else 6 if args.quick else 40)
    duration = args.duration or (1.0 if args.smoke else 40.0 if args.quick else 300.0)
    processes = not args.smoke

    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        campaign = load_campaign(write_spec(tmp, runs, duration))
        warm_campaign = load_campaign(write_spec(tmp, 2, duration, first_seed=100_000))
        print(
            f"{runs} torch_clock runs of {duration:g} s; load average at start {load:.2f} on "
            f"{os.cpu_count()} CPUs",
            flush=True,
        )
        walls, rows = in_process(campaign)
        print(f"in process : {np.median(walls):.3f} s per run (median; mean {np.mean(walls):.3f} s)",
              flush=True)
        one = on_cluster(campaign, warm_campaign, 1, tmp / "one", paired=min(runs, PAIRED_RUNS),
                         processes=processes)
        rpm1 = 60.0 * runs / one["wall"]
        print(f"1 worker   : {one['wall']:.1f} s, {rpm1:.1f} runs/min", flush=True)
        two = on_cluster(campaign, warm_campaign, 2, tmp / "two", processes=processes)
        rpm2 = 60.0 * runs / two["wall"]
        print(f"2 workers  : {two['wall']:.1f} s, {rpm2:.1f} runs/min", flush=True)
        reference_store = RunStore(tmp / "reference")  # the same column types as a campaign's table
        for row in rows:
            reference_store.add(row)
        reference = _comparable(reference_store.frame())
        same = all(_same(r["rows"], reference) for r in (one, two))
    in_process_median = float(np.median(walls))
    # the campaign's own share: its wall time beyond the runs' wall times in the worker
    dispatch_ms = 1000.0 * (one["wall"] - float(one["rows"]["run_wall_time"].sum())) / runs

    def paired_ms(a: str, b: str) -> float:
        return 1000.0 * float(np.median([p[a] - p[b] for p in one["pairs"]]))

    slowdown_ms = paired_ms("worker_wall", "alone_wall")
    cpu_slowdown_ms = paired_ms("worker_cpu", "alone_cpu")
    round_trip_ms = paired_ms("trip", "alone_wall")
    overhead_ms = dispatch_ms + slowdown_ms
    load_end = os.getloadavg()[0]
    result = {
        "runs": runs,
        "duration_s": duration,
        "runs_per_min_1_worker": round(rpm1, 2),
        "runs_per_min_2_workers": round(rpm2, 2),
        "scaling_efficiency_2": round(rpm2 / (2 * rpm1), 3),
        "overhead_per_run_ms": round(overhead_ms, 1),
        "overhead_fraction_of_run": round(overhead_ms / (1000.0 * in_process_median), 4),
        "dispatch_ms_per_run": round(dispatch_ms, 1),
        "worker_slowdown_ms_median": round(slowdown_ms, 1),
        "worker_cpu_slowdown_ms_median": round(cpu_slowdown_ms, 1),
        "round_trip_minus_in_process_ms_median": round(round_trip_ms, 1),
        "paired_runs": len(one["pairs"]),
        # the former figure: campaign wall per run minus the mean in-process run
        "overhead_wall_minus_mean_ms": round(1000.0 * (one["wall"] / runs - float(np.mean(walls))), 1),
        "in_process_s_per_run": round(in_process_median, 3),
        "peak_worker_rss_mb": round(max(one["rss"], two["rss"]), 1),
        "projected_min_for_1000_runs_2_workers": round(1000.0 / rpm2, 1),
        "same_rows": bool(same),
        "failed": one["failed"] + two["failed"],
        "load_average_at_start": round(load, 2),
        "load_average_at_end": round(load_end, 2),
    }
    print(
        f"scaling efficiency {result['scaling_efficiency_2']}, overhead {result['overhead_per_run_ms']} ms "
        f"per run ({100 * result['overhead_fraction_of_run']:.2f} % of a run: dispatch {dispatch_ms:.1f} ms "
        "+ "
        f"run in a worker {slowdown_ms:.1f} ms, CPU {cpu_slowdown_ms:.1f} ms), peak worker RSS "
        f"{result['peak_worker_rss_mb']} MB; 1,000 such runs on 2 workers would take "
        f"{result['projected_min_for_1000_runs_2_workers']} min (projected, not measured)",
        flush=True,
    )
    print(json.dumps(result))
    return result


def _same(frame, reference) -> bool:
    import pandas as pd

    got = _comparable(frame)
    columns = sorted(reference.columns)
    try:
        pd.testing.assert_frame_equal(got[columns], reference[columns], check_dtype=False)
    except AssertionError:
        return False
    return True


if __name__ == "__main__":
    main()
