"""`hrc-drake` command: simulate or validate a cell scenario."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hrc_drake.errors import ScenarioError

# Each command imports what it uses when it runs, so `hrc-drake --help` loads neither pydrake
# nor scipy / scikit-learn.


def _simulate(args) -> int:
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate, write_replay, write_report
    from hrc_drake.cell.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        scenario.seed = args.seed
    duration = args.duration if args.duration is not None else scenario.duration
    if duration <= 0:
        raise ScenarioError(args.scenario, "--duration", f"must be positive, got {duration}")
    meshcat = None
    if args.meshcat or args.replay:
        from pydrake.geometry import Meshcat

        meshcat = Meshcat()
        if args.meshcat:
            print(f"Meshcat live view: {meshcat.web_url()}", flush=True)
    print(f"Building {args.scenario} (seed {scenario.seed}) ...", flush=True)
    cell = build_cell(scenario, args.scenario, meshcat=meshcat, replay_fps=args.replay_fps)
    realtime_rate = args.realtime_rate if args.realtime_rate is not None else (1.0 if args.meshcat else 0.0)
    result = simulate(
        cell, duration, progress=sys.stderr, record=bool(args.replay), realtime_rate=realtime_rate
    )
    m = result.metrics
    print(f"simulated time    {m['simulated_time']:.1f} s")
    print(f"wall time         {m['wall_time']:.2f} s")
    print(f"realtime factor   {m['realtime_factor']:.1f}x")
    print(f"products finished {m['products_finished']}")
    mean_cycle = m["mean_cycle_time"]
    print(
        f"mean cycle time   {mean_cycle:.2f} s"
        if mean_cycle is not None
        else "mean cycle time   n/a (no product)"
    )
    for agent, a in m["agents"].items():
        print(
            f"  {agent:14s} busy {a['busy_time']:7.1f} s   waiting {a['wait_time']:7.1f} s   "
            f"actions {a['actions_finished']}"
        )
    if m["min_human_robot_distance"] is not None:
        print(f"min human-robot distance {m['min_human_robot_distance']:.3f} m")
    if args.replay:
        size = write_replay(cell, Path(args.replay))
        print(f"replay            {args.replay} ({size / 1e6:.1f} MB)")
    if args.out:
        paths = write_report(cell, result, Path(args.out))
        print("report            " + ", ".join(str(p) for p in paths))
    if args.meshcat:
        print("Meshcat is still serving the live view; press Ctrl-C to quit.", flush=True)
        try:
            import time

            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            pass
    return 0


def _validate(args) -> int:
    from hrc_drake.cell.scenario import load_scenario

    scenario = load_scenario(args.scenario, check_reachability=True)
    n_robot_actions = sum(len(r.actions) for r in scenario.robots)
    print(
        f"{args.scenario}: OK ({len(scenario.robots)} robot(s), {n_robot_actions} robot actions, "
        f"{len(scenario.operator.actions)} operator actions, {len(scenario.flow.actions)} flow actions)"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="hrc-drake", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="simulate a scenario and report its metrics")
    sim.add_argument("scenario", help="scenario YAML file")
    sim.add_argument(
        "--duration", type=float, default=None, help="simulated seconds (default: the scenario's)"
    )
    sim.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    sim.add_argument("--replay", default=None, help="write a self-contained HTML replay to this file")
    sim.add_argument(
        "--replay-fps", type=float, default=10.0, help="frames per second of the replay (default 10)"
    )
    sim.add_argument("--meshcat", action="store_true", help="serve a live Meshcat view on localhost")
    sim.add_argument(
        "--realtime-rate",
        type=float,
        default=None,
        help="pace the run: 1 = wall-clock speed (default with --meshcat), 0 = as fast as possible",
    )
    sim.add_argument("--out", default=None, help="folder for metrics.json, events.csv and gantt.png")
    sim.set_defaults(func=_simulate)
    val = sub.add_parser(
        "validate", help="load and check a scenario (names, durations, flow, IK reachability)"
    )
    val.add_argument("scenario")
    val.set_defaults(func=_validate)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
