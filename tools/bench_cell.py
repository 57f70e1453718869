"""Benchmark: realtime factor of the torch-and-clock cell (kinematic / dynamic, replay on / off).

Prints a table, then as its last line one JSON object with the figures.
Usage: python tools/bench_cell.py [--quick] [--duration S] [--scenario FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def run_once(scenario_path: Path, duration: float, mode: str, record: bool) -> dict:
    from pydrake.geometry import Meshcat

    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario

    scenario = load_scenario(scenario_path)
    for robot in scenario.robots:
        robot.mode = mode
        robot.time_step = 0.01
    meshcat = Meshcat() if record else None
    start = time.perf_counter()
    cell = build_cell(scenario, scenario_path, meshcat=meshcat)
    build_time = time.perf_counter() - start
    result = simulate(cell, duration, progress=None, record=record)
    replay_bytes = len(meshcat.StaticHtml()) if record else 0
    return {
        "mode": mode,
        "record": record,
        "build_s": round(build_time, 2),
        "wall_s": round(result.wall_time, 2),
        "realtime_factor": round(duration / result.wall_time, 1),
        "products": result.metrics["products_finished"],
        "replay_mb": round(replay_bytes / 1e6, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="60 s of simulated time instead of 600 s")
    parser.add_argument("--duration", type=float, default=None)
    parser.add_argument("--scenario", default=str(REPO / "diagrams" / "torch_clock.yaml"))
    parser.add_argument(
        "--repeats", type=int, default=3, help="kinematic runs per configuration (median kept)"
    )
    args = parser.parse_args()
    duration = args.duration or (60.0 if args.quick else 600.0)
    warnings.simplefilter("ignore")
    rows = []
    for mode in ("kinematic", "dynamic"):
        for record in (False, True):
            # Kinematic runs are short: repeat them and keep the median, as the machine is shared.
            repeats = args.repeats if mode == "kinematic" else 1
            runs = []
            for k in range(repeats):
                print(
                    f"running {mode:9s} replay={'on' if record else 'off':3s} ({k + 1}/{repeats}) "
                    f"for {duration:.0f} s of simulated time ...",
                    flush=True,
                )
                runs.append(run_once(Path(args.scenario), duration, mode, record))
            runs.sort(key=lambda r: r["realtime_factor"])
            rows.append(runs[len(runs) // 2])
    print()
    print(
        f"{'mode':10s} {'replay':>6s} {'build s':>8s} {'wall s':>8s} {'RTF':>7s} "
        f"{'products':>8s} {'replay MB':>9s}"
    )
    for r in rows:
        print(
            f"{r['mode']:10s} {('on' if r['record'] else 'off'):>6s} {r['build_s']:8.2f} {r['wall_s']:8.2f} "
            f"{r['realtime_factor']:7.1f} {r['products']:8d} {r['replay_mb']:9.1f}"
        )
    figures = {"scenario": Path(args.scenario).name, "simulated_s": duration}
    for r in rows:
        key = f"rtf_{r['mode']}_{'replay' if r['record'] else 'noreplay'}"
        figures[key] = r["realtime_factor"]
    figures["replay_mb"] = max(r["replay_mb"] for r in rows)
    figures["load_average_1min"] = round(os.getloadavg()[0], 2)
    figures["products_kinematic"] = rows[0]["products"]
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
