"""Benchmark of reactive safety (thesis 8.1.3): epsilon+/- of models A, B, C and [107], speed.

For every sample k, eps+ = Delta+_pred - Delta+_real and eps- likewise (Fig. 8.6, 8.8), with
Delta_real the excursion of the Kalman-filtered joints over the next M steps; eps < 0 is a
violation. Joint groups: base translation (q0, q1), base yaw (q2), torso flexion (q3),
shoulders (q4-6, q8-10), elbows (q7, q11). For model C at the largest order, the distance
of the real wrists, elbows and shoulders to the swept volumes at violating samples (Fig. 8.10).

Sequences: simulated operators (`SyntheticOperator`, skeleton points -> body-model IK) and
the LEGO arm trajectories of ../shared/data/lego_assembly_arm (camera frame -> world frame,
IK with head missing; the frame rate is not stated: 15 Hz assumed).

The cycle-time comparison runs the Drake cell of diagrams/box_pcb_coexistence.yaml with model C
and with [107], several seeds (`run_cell`, `cycle_time_comparison`); robot cycle = time
between consecutive ends of L_store, reported with the true minimum human-robot distance.

Usage: python tools/bench_motion.py [--quick] [--no-cell | --cell-only]. Last line: one JSON object.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hrc_drake.human.body import BodyModel  # noqa: E402
from hrc_drake.human.config import Segments  # noqa: E402
from hrc_drake.human.operator import OperatorTask, SyntheticOperator  # noqa: E402
from hrc_drake.messages import (  # noqa: E402
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    THORAX,
)
from hrc_drake.motion.geometry import point_capsule_distance  # noqa: E402
from hrc_drake.motion.reactive import (  # noqa: E402
    ReactiveMotionPredictor,
    ik_joint_std,
    tracking_inverse,
)
from hrc_drake.motion.speed import SpeedScalerCore  # noqa: E402

GROUPS = {
    "base_xy": [0, 1], "base_yaw": [2], "torso": [3],
    "shoulders": [4, 5, 6, 8, 9, 10], "elbows": [7, 11],
}
KINDS = ("gp_a", "gp_b", "gp_c", "worst_case")
ARM_POINTS = [L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST]


def data_dir() -> Path:
    return Path(os.environ.get("HRC_DRAKE_DATA", REPO / ".." / "shared" / "data")).resolve()


# ------------------------------------------------------------------ sequences
def simulated_sequence(seconds: float, dt: float, seed: int):
    """Skeleton points (T, 8, 3) of a synthetic operator assembling at a table (3 reaching actions)."""
    body = BodyModel()
    rng = np.random.default_rng(seed)
    tasks = {
        "pick_left": OperatorTask("pick_left", [np.array([0.55, 0.35, 0.85])], "left",
                                  lambda r: r.uniform(1.2, 2.0)),
        "pick_right": OperatorTask("pick_right", [np.array([0.55, -0.35, 0.85])], "right",
                                   lambda r: r.uniform(1.2, 2.0)),
        "assemble": OperatorTask("assemble", [np.array([0.6, 0.0, 0.9]), np.array([0.45, 0.05, 0.95])],
                                 "both", lambda r: r.uniform(2.0, 3.0)),
    }
    rest = body.rest_q((1.05, 0.0), np.pi)
    operator = SyntheticOperator(body, tasks, ["pick_left", "pick_right", "assemble"], rest, rng)
    times = np.arange(0.0, seconds, dt)
    points = []
    for t in times:
        operator.update(t)
        points.append(operator.points(t))
    noise = np.random.default_rng(seed + 1).normal(0.0, 0.01, (len(times), 8, 3))
    return body, np.array(points) + noise


def lego_sequences(limit: int, max_frames: int):
    """(name, body, points (T, 8, 3)) of LEGO trials mapped to the world frame (z up, human facing -x)."""
    root = data_dir() / "lego_assembly_arm"
    if not root.is_dir():
        return []
    out = []
    for path in sorted(root.glob("Task*/Human*/trial*.txt"))[:limit]:
        raw = np.loadtxt(path)[:max_frames]
        raw = raw[np.all(np.isfinite(raw), axis=1)]
        cam = raw.reshape(-1, 6, 3)  # lw, rw, le, re, ls, rs
        # camera (x right, y down, z depth) -> world (x = depth, y = -x, z = -y), shoulders at 1.35 m
        world = np.stack([cam[..., 2], -cam[..., 0], -cam[..., 1]], -1)
        world[..., 2] += 1.35 - world[:, 4:6, 2].mean()
        points = np.full((len(world), 8, 3), np.nan)
        points[:, L_WRIST], points[:, R_WRIST] = world[:, 0], world[:, 1]
        points[:, L_ELBOW], points[:, R_ELBOW] = world[:, 2], world[:, 3]
        points[:, L_SHOULDER], points[:, R_SHOULDER] = world[:, 4], world[:, 5]
        points[:, THORAX] = 0.5 * (world[:, 4] + world[:, 5])
        fore = np.median(np.linalg.norm(world[:, 0:2] - world[:, 2:4], axis=-1))
        upper = np.median(np.linalg.norm(world[:, 2:4] - world[:, 4:6], axis=-1))
        width = np.median(np.linalg.norm(world[:, 4] - world[:, 5], axis=-1))
        body = BodyModel(Segments(shoulder_width=float(width), upper_arm=float(upper), forearm=float(fore)))
        out.append((str(path.relative_to(root)), body, points))
    return out


def joint_sequence(body, points, point_std: float):
    """q (T, 12) by IK warm-started at the previous frame, and its noise std (T, 12) (`ik_joint_std`)."""
    q, out, stds = None, [], []
    for frame in points:
        q = tracking_inverse(body, frame, q)
        out.append(q)
        stds.append(ik_joint_std(body, q, point_std, np.all(np.isfinite(frame), axis=1)))
    return np.array(out), np.array(stds)


# ------------------------------------------------------------------ evaluation
def run_model(body, qs, stds, kind, order, dt, n_trials, horizon, warmup):
    """Predicted excursions per step, filtered q, timings."""
    predictor = ReactiveMotionPredictor(body, kind, order=order, dt=dt, horizon=horizon, n_trials=n_trials,
                                        rng=0)
    deltas, filtered, step_seconds = [], [], []
    for k, q in enumerate(qs):
        start = time.perf_counter()
        fits_before = len(predictor.fit_seconds_)
        plus, minus = predictor.update_q(q, stds[k])
        elapsed = time.perf_counter() - start
        if len(predictor.fit_seconds_) > fits_before:
            elapsed -= predictor.fit_seconds_[-1]  # the model update is timed on its own
        if k >= warmup:
            step_seconds.append(elapsed)
        deltas.append((plus, minus))
        filtered.append(predictor.q_.copy())
    return predictor, np.array(deltas), np.array(filtered), step_seconds


def epsilons(deltas, filtered, steps, warmup):
    """eps+ and eps- (K, 12) for samples warmup .. T - M - 1 (8.1.3, off-line simulations)."""
    out = []
    for k in range(warmup, len(filtered) - steps):
        future = filtered[k:k + steps + 1]
        real_plus = np.maximum(future.max(0) - filtered[k], 0.0)
        real_minus = np.maximum(filtered[k] - future.min(0), 0.0)
        out.append((deltas[k, 0] - real_plus, deltas[k, 1] - real_minus))
    out = np.array(out)
    return out[:, 0], out[:, 1]


def violation_distances(predictor, body, deltas, filtered, eps_plus, eps_minus, warmup, limit=60):
    """Fig. 8.10: how far the real arm points go outside the swept volumes at violating samples (m)."""
    steps = predictor.steps
    violating = np.where(np.any((eps_plus < 0) | (eps_minus < 0), axis=1))[0]
    distances = []
    for index in violating[:: max(1, len(violating) // limit)][:limit]:
        k = index + warmup
        start, end, radius = predictor.builder.build(filtered[k], deltas[k, 0], deltas[k, 1])
        future = body.points(filtered[k:k + steps + 1])[:, ARM_POINTS].reshape(-1, 3)
        inside = point_capsule_distance(future, start, end, radius).min(axis=1)
        distances.append(max(float(inside.max()), 0.0))
    return distances


def summarise(eps_plus, eps_minus):
    row = {}
    for name, joints in GROUPS.items():
        p, m = eps_plus[:, joints].ravel(), eps_minus[:, joints].ravel()
        row[name] = {"eps_plus_median": float(np.median(p)), "eps_minus_median": float(np.median(m)),
                     "violation_rate": float(np.mean((p < 0) | (m < 0))),
                     "violation_rate_over_0.01": float(np.mean((p < -0.01) | (m < -0.01)))}
    return row


def speed_scaler_seconds(predictor, deltas, filtered, repeats=50):
    """Median time of swept volumes + speed override for one step (14 robot capsules)."""
    rng = np.random.default_rng(0)
    robot = (rng.uniform(-0.2, 0.6, (14, 3)), rng.uniform(-0.2, 0.6, (14, 3)), np.full(14, 0.06))
    scaler = SpeedScalerCore({})
    times = []
    for i in range(repeats):
        k = len(filtered) - 1 - i % 20
        start = time.perf_counter()
        swept = predictor.swept_volumes(0.0, deltas[k, 0], deltas[k, 1])
        scaler.step(robot, swept)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


# ------------------------------------------------------------------ cell
def run_cell(scenario_path, kind: str, seed: int, duration: float) -> dict:
    """One run of the cell with motion model `kind`: robot cycles, true distance, override.

    Robot cycle = time between consecutive "end" events of L_store (one PCB board stored).
    """
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario

    warnings.filterwarnings("ignore")
    import dataclasses

    from hrc_drake.motion.config import WorstCaseMotionModel

    scenario = load_scenario(scenario_path)
    gp = scenario.motion_model  # the scenario's GP model; [107] shares its bounds
    if kind == "worst_case":
        common = {f.name: getattr(gp, f.name) for f in dataclasses.fields(WorstCaseMotionModel)}
        scenario.motion_model = WorstCaseMotionModel(**common)
    else:
        scenario.motion_model = dataclasses.replace(gp, variant=kind[-1].upper())
    scenario.seed = int(seed)
    cell = build_cell(scenario, scenario_path)
    start = time.perf_counter()
    result = simulate(cell, duration, progress=None)
    log = result.log
    stores = sorted(e.time for e in log.events
                    if getattr(e, "action", "") == "L_store" and getattr(e, "kind", "") == "end")
    distances = np.asarray(log.distances, dtype=float)
    return {
        "kind": kind, "seed": int(seed), "duration": duration, "wall_s": time.perf_counter() - start,
        "store_ends": [round(t, 2) for t in stores], "cycles": np.diff(stores).round(2).tolist(),
        "robot_actions_finished": sum(1 for e in log.events if getattr(e, "agent", "").startswith("yumi")
                                      and getattr(e, "kind", "") == "end"),
        "min_human_robot_distance": float(result.metrics["min_human_robot_distance"]),
        "time_below_0.05m_s": float(np.sum(distances < 0.05) * np.mean(np.diff(log.times))),
        "mean_speed_override": float(result.metrics["mean_speed_override"]),
    }


def _run_cell_args(args):
    return run_cell(*args)


def cycle_time_comparison(scenario_path, seeds, duration, kinds=("gp_c", "worst_case"),
                          workers: int = 1) -> dict:
    """Robot cycle time on box_pcb_coexistence, model C vs [107] (thesis: 8.59 % shorter with C).

    Every (kind, seed) runs for `duration` s; per kind: all cycles pooled, their mean, the
    number of boards stored, the smallest true human-robot distance. The reduction is
    1 - mean cycle C / mean cycle [107] (None when [107] completes fewer than two stores).
    """
    jobs = [(str(scenario_path), kind, seed, duration) for kind in kinds for seed in seeds]
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as pool:
            runs = list(pool.map(_run_cell_args, jobs))
    else:
        runs = []
        for job in jobs:
            runs.append(run_cell(*job))
            print(f"  {job[1]:<11} seed {job[2]}: stores at {runs[-1]['store_ends']}", flush=True)
    results = {"scenario": Path(scenario_path).name, "duration_s": duration, "runs": runs}
    for kind in kinds:
        mine = [r for r in runs if r["kind"] == kind]
        cycles = [c for r in mine for c in r["cycles"]]
        results[kind] = {
            "mean_cycle_s": float(np.mean(cycles)) if cycles else None,
            "cycles": len(cycles), "boards_stored": int(sum(len(r["store_ends"]) for r in mine)),
            "min_distance_m": float(min(r["min_human_robot_distance"] for r in mine)),
            "robot_actions_finished": int(sum(r["robot_actions_finished"] for r in mine)),
            "mean_override": float(np.mean([r["mean_speed_override"] for r in mine])),
        }
    a, b = results[kinds[0]]["mean_cycle_s"], results[kinds[1]]["mean_cycle_s"]
    results["reduction_percent"] = None if a is None or b is None else 100.0 * (1.0 - a / b)
    return results


# ------------------------------------------------------------------ main
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small run, under a minute")
    parser.add_argument("--no-cell", action="store_true", help="skip the cycle-time comparison in the cell")
    parser.add_argument("--cell-only", action="store_true", help="only the cycle-time comparison")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    if args.quick:
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (4,), 20.0, 1, 300, 30
        kinds_orders = [(k, 4) for k in KINDS] + [("gp_c", 1)]
    else:
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (1, 2, 3, 4), 60.0, 3, 600, 50
        kinds_orders = [(k, p) for k in KINDS[:3] for p in orders] + [("worst_case", 4)]
    horizon = 0.3  # the cell's horizon: robot reaction + stopping time
    figures = {"quick": bool(args.quick), "horizon_s": horizon, "n_trials": n_trials, "sequences": {}}

    if not args.cell_only:
        sequences = []
        dt_sim = 0.05
        print(f"simulating an operator for {sim_seconds:.0f} s ...", flush=True)
        body, points = simulated_sequence(sim_seconds, dt_sim, seed=7)
        sequences.append(("simulated", body, *joint_sequence(body, points, 0.01), dt_sim))
        lego = lego_sequences(lego_limit, lego_frames)
        if not lego:
            print(f"(lego_assembly_arm not found under {data_dir()}: skipping the real sequences)")
        for name, lego_body, lego_points in lego:
            print(f"IK of {name} ({len(lego_points)} frames) ...", flush=True)
            sequences.append((f"lego:{name}", lego_body, *joint_sequence(lego_body, lego_points, 0.02),
                              1.0 / 15.0))

        step_times, fit_times, scaler_times, violations = [], [], [], []
        print(f"\n{'sequence':<34} {'model':<11} {'P':>2} {'group':<10} {'eps+ med':>9} {'eps- med':>9} "
              f"{'viol %':>7} {'>0.01 %':>8}   (eps in m or rad; violation: eps < 0, or < -0.01)")
        for seq_name, seq_body, qs, stds, dt in sequences:
            warmup = int(round(3.0 / dt))
            figures["sequences"][seq_name] = {}
            for kind, order in kinds_orders:
                predictor, deltas, filtered, steps_s = run_model(
                    seq_body, qs, stds, kind, order, dt, n_trials, horizon, warmup)
                eps_plus, eps_minus = epsilons(deltas, filtered, predictor.steps, warmup)
                row = summarise(eps_plus, eps_minus)
                figures["sequences"][seq_name][f"{kind}_P{order}"] = row
                for group, values in row.items():
                    print(f"{seq_name[:34]:<34} {kind:<11} {order:>2} {group:<10} "
                          f"{values['eps_plus_median']:>9.4f} {values['eps_minus_median']:>9.4f} "
                          f"{100 * values['violation_rate']:>7.1f} "
                          f"{100 * values['violation_rate_over_0.01']:>8.1f}")
                if kind == "gp_c" and order == 4:
                    step_times += steps_s
                    fit_times += predictor.fit_seconds_
                    scaler_times.append(speed_scaler_seconds(predictor, deltas, filtered))
                    violations += violation_distances(predictor, seq_body, deltas, filtered, eps_plus,
                                                      eps_minus, warmup)
                print(flush=True)

        figures["gp_c_P4_rollout_step_ms_median"] = 1000 * float(np.median(step_times))
        figures["gp_c_P4_model_update_ms_median"] = 1000 * float(np.median(fit_times))
        figures["swept_volumes_plus_override_ms_median"] = 1000 * float(np.median(scaler_times))
        figures["violation_distance_m"] = {
            "count": len(violations),
            "median": float(np.median(violations)) if violations else None,
            "p90": float(np.percentile(violations, 90)) if violations else None,
        }
        print(f"model C (P=4) update: {figures['gp_c_P4_model_update_ms_median']:.1f} ms median "
              f"(thesis 309.86 ms; target <= 50 ms)")
        print(f"model C (P=4) Monte Carlo excursions per step: "
              f"{figures['gp_c_P4_rollout_step_ms_median']:.1f} ms")
        print(f"swept volumes + speed override per step: "
              f"{figures['swept_volumes_plus_override_ms_median']:.1f} ms (target <= 10 ms)")
        print(f"violations (model C, P=4): distance of real arm points outside the swept volumes: "
              f"{figures['violation_distance_m']}")

    scenario = REPO / "diagrams" / "box_pcb_coexistence.yaml"
    if args.no_cell or not scenario.exists():
        print(f"cycle-time comparison on {scenario.name}: switched off")
        figures["cycle_time"] = None
    else:
        seeds, duration = ((5,), 12.0) if args.quick else ((5, 6, 7), 75.0)
        print(f"\ncycle-time comparison on {scenario.name}: seeds {list(seeds)}, {duration:.0f} s each ...",
              flush=True)
        comparison = cycle_time_comparison(scenario, seeds, duration, workers=1 if args.quick else 2)
        for run in comparison["runs"]:
            print(f"  {run['kind']:<11} seed {run['seed']}: {run['robot_actions_finished']} robot actions, "
                  f"L_store ends {run['store_ends']}  cycles "
                  f"{run['cycles']}  min true distance {run['min_human_robot_distance']:.3f} m  "
                  f"mean override {run['mean_speed_override']:.2f}  ({run['wall_s']:.0f} s wall)")
        for kind in ("gp_c", "worst_case"):
            row = comparison[kind]
            cycle = "n/a" if row["mean_cycle_s"] is None else f"{row['mean_cycle_s']:.2f} s"
            print(f"  {kind:<11} mean robot cycle {cycle} over {row['cycles']} cycles, "
                  f"{row['boards_stored']} boards stored, {row['robot_actions_finished']} robot actions, "
                  f"min true distance {row['min_distance_m']:.3f} m")
        reduction = comparison["reduction_percent"]
        print("  cycle time with C vs [107]: " + ("n/a (too few [107] cycles)" if reduction is None
                                                  else f"{reduction:.1f} % shorter") + " (thesis: 8.59 %)")
        figures["cycle_time"] = comparison
    print(json.dumps(figures, separators=(",", ":")))


if __name__ == "__main__":
    main()
