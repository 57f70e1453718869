"""Sweep of the weights of the proactive cost (8.32) on a real replanning of the 8.2.4 cell.

The thesis leaves lambda_1, lambda_2 and alpha "problem-specific ... tuned through a set of few
offline simulations" (8.2.3). This script runs `diagrams/box_usb_proactive.yaml` until its
planner has made its first path (the databases full), takes that moment's clouds and P_RH row,
and runs STOMP on them for a grid of lambda_1 / lambda_2 (only the ratio matters: J_Ob is 0 on
a collision-free path) and alpha, several STOMP seeds each. Per setting: J_Rep and J_Diff of the
nominal and the proactive path, the mean joint deformation (rad per waypoint), and the smallest
distance of the arm's control points (elbow, tool) to the cloud points.

    python tools/bench_proactive_sweep.py [--seeds 3] [--smoke]

--smoke: a planner that replans as soon as the operator's first cover from buffer 2 is recorded
(`SMOKE_PLANNER`, ~20 s simulated instead of ~220 s), one setting, one seed: figures meaningless.

Last line: one JSON object, `sweep` (a list of settings with their figures) and `replan_time_s`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

SCENARIO = REPO / "diagrams" / "box_usb_proactive.yaml"
RATIOS = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
ALPHAS = (5.0, 10.0, 20.0)
#: --smoke's planner: one realisation of the operator's first cover (buffer 2, done at ~20 s) fills
#: its only database, and it replans every 5 s (the scenario's: three of each cover, ~220 s)
SMOKE_PLANNER = {"capacity": 1, "human_actions": ["cover_b2"], "replan_period": 5.0}


def first_replanning(path: Path, limit: float = 900.0, planner_changes: dict | None = None):
    """The planner's core (a copy) right after its first replanning, and that time.
    planner_changes: fields of the scenario's `ProactivePlanner` replaced before the cell is built."""
    from pydrake.systems.analysis import Simulator

    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.scenario import load_scenario

    scenario = load_scenario(path)
    if planner_changes:
        scenario.proactive_planner = dataclasses.replace(scenario.proactive_planner, **planner_changes)
    cell = build_cell(scenario, path)
    simulator = Simulator(cell.diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    planner = cell.diagram.GetSubsystemByName("proactive_planner")
    t = 0.0
    while t < limit:
        t += 5.0
        simulator.AdvanceTo(t)
        core = planner.core(planner.GetMyContextFromRoot(context))
        if core.reports_:
            return core.clone(), core.reports_[0].time
    raise SystemExit(f"no replanning in {limit:.0f} s of {path.name}: the databases never filled")


def nearest_cloud_distance(chain, path, points) -> float:
    """Smallest distance (m) of the control points of a path to the cloud points."""
    control = chain.points(np.asarray(path))
    return float(min(np.linalg.norm(control[k][:, None, :] - points[None], axis=-1).min()
                     for k in range(len(control))))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="STOMP seeds per setting (default 3)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    args = parser.parse_args(argv)
    ratios, alphas, seeds = ((0.5,), (10.0,), 1) if args.smoke else (RATIOS, ALPHAS, args.seeds)
    warnings.filterwarnings("ignore")
    from hrc_drake.motion.clouds import weighted_union
    from hrc_drake.motion.stomp import ProactiveCost, plan_proactive_path

    print(f"running {SCENARIO.name} to its first replanning ...", flush=True)
    core, when = first_replanning(SCENARIO, planner_changes=SMOKE_PLANNER if args.smoke else None)
    weights = core.interaction.matrix(when)[0]
    clouds, _, _ = core.clouds()
    union = weighted_union(clouds, weights)
    points, gamma = np.asarray(union.points), np.asarray(union.gamma)
    s = core.settings
    base = nearest_cloud_distance(core.chain, core.nominal, points)
    print(f"t = {when:.1f} s, P_RH row {np.round(weights, 3)}, {len(points)} cloud points, nominal path "
          f"{base:.3f} m from the cloud", flush=True)
    print(f"{'l1/l2':>6} {'alpha':>6} {'J_Rep nom':>10} {'J_Rep pro':>10} {'dq rad':>7} {'dist m':>7} "
          f"{'ms':>6}")
    sweep = []
    for alpha in alphas:
        for ratio in ratios:
            cost = ProactiveCost(core.chain.capsules, core.chain.points, core.nominal, points, gamma,
                                 core.boxes, ratio, 1.0, alpha)
            j_rep_nominal = float(cost.terms(core.nominal[1:-1])[1].sum())
            rows = []
            for seed in range(seeds):
                start = time.perf_counter()
                result = plan_proactive_path(core.nominal, cost, core.chain.joint_limits,
                                             np.random.default_rng(seed), n_rollouts=s.n_rollouts,
                                             max_iterations=s.iterations, noise_std=s.noise_std)
                seconds = time.perf_counter() - start
                path = np.asarray(result.path)
                _, j_rep, j_diff = cost.terms(path[1:-1])
                rows.append((float(j_rep.sum()), float(j_diff.mean()),
                             nearest_cloud_distance(core.chain, path, points), seconds))
            j_rep, deform, distance, seconds = (float(np.mean(c)) for c in zip(*rows, strict=True))
            sweep.append({"lambda1_over_lambda2": ratio, "alpha": alpha, "j_rep_nominal": j_rep_nominal,
                          "j_rep_proactive": j_rep, "mean_deformation_rad": deform,
                          "min_cloud_distance_m": distance, "nominal_min_cloud_distance_m": base,
                          "stomp_ms": 1000 * seconds})
            print(f"{ratio:>6g} {alpha:>6g} {j_rep_nominal:>10.2f} {j_rep:>10.2f} {deform:>7.3f} "
                  f"{distance:>7.3f} {1000 * seconds:>6.0f}", flush=True)
    print(json.dumps({"replan_time_s": when, "sweep": sweep}))


if __name__ == "__main__":
    main()
