"""Safety figures of every shipped cell: as shipped, and with speed-and-separation monitoring.

Issue 14, item 5. For every scenario in `diagrams/` (or those named), runs the cell
- `shipped`: its own configuration;
- `worst_case`: speed scaling (ISO/TS 15066 rule, clearance = the scenario's safety distance)
  on the worst-case swept volumes of [107] (0.3 s, the default human limits);
- `gp_c_filtered`: the same rule on model C's swept volumes (P = 2, 0.3 s, 90th percentile of
  the rollouts, trained on the filtered states: the variant that contains most of the motion,
  see the README's 8.1 section);
and reports per (scenario, arm): products finished, the true minimum human-robot distance, the
time and fraction of samples below the scenario's safety distance (and the time of those with
the robot not stopped by the safety system, override > 1 %), and the mean speed override.
A cell whose header says why it runs without speed scaling cites these figures.

    python tools/bench_safety.py                    # every cell, 120 s, the scenario's seed
    python tools/bench_safety.py --duration 300 --seeds 3 diagrams/torch_clock.yaml

It first prints, per cell, how far the worst-case volume reaches ahead of the resting operator
and how near the robots' targets are (`separation_at_rest`): where the targets are nearer, speed
and separation monitoring stops the robot whenever the operator rests.

Last line: one JSON object, `<scenario>.<arm>.{products, min_distance_m, time_below_s,
fraction_below, time_below_not_stopped_s, mean_override}` (each a list over the seeds) and
`<scenario>.layout.{rest_reach_m, nearest_robot_target_m}`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

ARMS = ("shipped", "worst_case", "gp_c_filtered")


def safety_system(arm: str, safety_distance: float):
    """(motion_model, speed_scaling) of an arm; None for the scenario's own."""
    from hrc_drake.motion.config import GPMotionModel, SeparationSpeedScaling, WorstCaseMotionModel

    scaling = SeparationSpeedScaling(clearance=safety_distance, reaction_time=0.1, stopping_time=0.15)
    if arm == "worst_case":
        return WorstCaseMotionModel(horizon=0.3), scaling
    if arm == "gp_c_filtered":
        return GPMotionModel(variant="C", order=2, horizon=0.3, percentile=90.0,
                             training_states="filtered"), scaling
    return None


def run(path: str, arm: str, seed: int | None, duration: float) -> dict:
    """One seeded run of a cell under one arm: its safety figures."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario

    warnings.filterwarnings("ignore")
    scenario = load_scenario(path)
    system = safety_system(arm, scenario.safety_distance)
    if system is not None:
        scenario.motion_model, scenario.speed_scaling = system
    if seed is not None:
        scenario.seed = int(seed)
    cell = build_cell(scenario, path)
    start = time.perf_counter()
    result = simulate(cell, duration, progress=None)
    metrics = result.metrics
    safety = metrics.get("safety") or {}
    return {"scenario": Path(path).stem, "arm": arm, "seed": scenario.seed,
            "wall_s": round(time.perf_counter() - start, 1),
            "products": int(metrics.get("products_finished") or 0),
            "min_distance_m": metrics.get("min_human_robot_distance"),
            "time_below_s": safety.get("time_below_s"), "fraction_below": safety.get("fraction_below"),
            "time_below_not_stopped_s": safety.get("time_below_not_stopped_s"),
            "mean_override": metrics.get("mean_speed_override")}


def _run(job):
    return run(*job)


def separation_at_rest(path: str, horizon: float = 0.3) -> dict:
    """How far the worst-case volume of [107] reaches from the resting operator, and how near
    the robot's targets are: speed and separation monitoring can only let the robot work where
    `nearest_robot_target_m` > `rest_reach_m` + clearance (+ the robot's capsule radius).

    rest_reach_m: the farthest the 0.3 s worst-case volume (default limits, from rest) reaches
    ahead of the resting wrists; nearest_robot_target_m: horizontal distance from a resting
    wrist to the nearest Cartesian target of the robots' poses.
    """
    import numpy as np

    from hrc_drake.cell.scenario import load_scenario, operator_places
    from hrc_drake.human.body import BodyModel
    from hrc_drake.human.operator import SyntheticOperator, tasks_from_schema
    from hrc_drake.motion.reactive import ReactiveMotionPredictor, worst_case_excursions

    scenario = load_scenario(path)
    op = scenario.operator
    if op.recorded:
        return {"rest_reach_m": None, "nearest_robot_target_m": None}
    body = BodyModel()
    yaw = op.base.rpy[2]
    operator = SyntheticOperator(body, tasks_from_schema(op, operator_places(scenario)), list(op.pattern),
                                 body.rest_q(base_xy=op.base.xyz[:2], yaw=yaw), 0, agent=op.name)
    predictor = ReactiveMotionPredictor(body, kind="worst_case", horizon=horizon)
    for _ in range(predictor.order + 2):
        predictor.update_q(operator.rest_config, 1e-3)
    plus, minus = worst_case_excursions(np.zeros(12), predictor.horizon, predictor.v_max, predictor.a_max)
    volumes = predictor.swept_volumes(0.0, plus, minus)
    forward = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    wrists = np.array(list(operator.rest_wrists.values()))
    ends = np.vstack([volumes.start, volumes.end])
    radius = np.concatenate([volumes.radius, volumes.radius])
    reach = float((ends @ forward + radius).max() - (wrists @ forward).max())
    targets = np.array([pose.target.xyz for robot in scenario.robots for pose in robot.poses
                        if pose.target is not None])
    nearest = None
    if len(targets):
        gaps = np.linalg.norm(targets[None, :, :2] - wrists[:, None, :2], axis=2)
        nearest = float(gaps.min())
    return {"rest_reach_m": round(reach, 3), "nearest_robot_target_m": None if nearest is None
            else round(nearest, 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", help="scenario files (default: every diagrams/*.yaml)")
    parser.add_argument("--duration", type=float, default=120.0,
                        help="simulated seconds per run (default 120)")
    parser.add_argument("--seeds", type=int, default=1,
                        help="runs per (cell, arm): the scenario's seed, then seed + 1, ... (default 1)")
    parser.add_argument("--arms", default=",".join(ARMS), help=f"comma-separated subset of {ARMS}")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    args = parser.parse_args()
    arms = [a for a in args.arms.split(",") if a]
    unknown = sorted(set(arms) - set(ARMS))
    if unknown:
        parser.error(f"unknown arms {unknown}; choose among {ARMS}")
    paths = [Path(p) for p in args.scenarios] or sorted((REPO / "diagrams").glob("*.yaml"))
    from hrc_drake.cell.scenario import load_scenario

    jobs = []
    for path in paths:
        base_seed = load_scenario(path).seed
        jobs += [(str(path), arm, base_seed + k, args.duration) for arm in arms for k in range(args.seeds)]
    print(f"{'scenario':<22} {'worst-case reach from rest':>27} {'nearest robot target':>21}")
    layouts = {}
    for path in paths:
        layouts[path.stem] = separation_at_rest(str(path))
        shown = {k: float("nan") if v is None else v for k, v in layouts[path.stem].items()}
        print(f"{path.stem:<22} {shown['rest_reach_m']:>25.3f} m {shown['nearest_robot_target_m']:>19.3f} m",
              flush=True)
    print(f"{len(jobs)} runs of {args.duration:.0f} s on {args.workers} workers ...", flush=True)
    print(f"{'scenario':<22} {'arm':<14} {'seed':>4} {'products':>8} {'min dist':>9} {'below s':>8} "
          f"{'below %':>8} {'moving s':>8} {'override':>8} {'wall s':>7}", flush=True)
    figures: dict = {}
    with ProcessPoolExecutor(max(1, args.workers)) as pool:
        for row in pool.map(_run, jobs):
            shown = {k: float("nan") if row[k] is None else row[k]
                     for k in ("min_distance_m", "time_below_s", "fraction_below", "time_below_not_stopped_s",
                               "mean_override")}
            print(f"{row['scenario']:<22} {row['arm']:<14} {row['seed']:>4} {row['products']:>8} "
                  f"{shown['min_distance_m']:>9.3f} {shown['time_below_s']:>8.1f} "
                  f"{100 * shown['fraction_below']:>8.1f} {shown['time_below_not_stopped_s']:>8.1f} "
                  f"{shown['mean_override']:>8.3f} {row['wall_s']:>7.1f}",
                  flush=True)
            cell = figures.setdefault(row["scenario"], {}).setdefault(row["arm"], {})
            for key in ("products", "min_distance_m", "time_below_s", "fraction_below",
                        "time_below_not_stopped_s", "mean_override"):
                cell.setdefault(key, []).append(row[key])
    for name, layout in layouts.items():
        figures.setdefault(name, {})["layout"] = layout
    figures["duration_s"] = args.duration
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
