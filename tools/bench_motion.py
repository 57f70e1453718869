"""Benchmark of reactive safety (thesis 8.1.3): epsilon+/- of models A, B, C and [107], speed.

For every sample k, eps+ = Delta+_pred - Delta+_real and eps- likewise (Fig. 8.6, 8.8), with
Delta_real the excursion of the Kalman-filtered joints over the next M steps; eps < 0 is a
violation. Joint groups: base translation (q0, q1), base yaw (q2), torso flexion (q3),
shoulders (q4-6, q8-10), elbows (q7, q11). For model C at the largest order, the distance
of the real wrists, elbows and shoulders to the swept volumes at violating samples (Fig. 8.10).

Sequences: simulated operators (`SyntheticOperator`, skeleton points -> body-model IK) and
the LEGO arm trajectories of ../shared/data/lego_assembly_arm (camera frame -> world frame,
IK with head missing; the frame rate is not stated: 15 Hz assumed).

The cycle-time comparison on box_pcb_coexistence.yaml needs the cell: `cycle_time_comparison`
takes a `run_cell(scenario_path, motion_kind) -> dict` callable; it runs only when the
scenario file exists and a runner is wired (see `_cell_runner`).

Usage: python tools/bench_motion.py [--quick]. Last line: one JSON object.
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

from hrc_drake.cell.schema import Segments  # noqa: E402
from hrc_drake.human.body import BodyModel  # noqa: E402
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
from hrc_drake.motion.reactive import ReactiveMotionPredictor  # noqa: E402
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


def joint_sequence(body, points) -> np.ndarray:
    """q (T, 12) by the body model's IK, warm-started from the previous frame."""
    q, out = None, []
    for frame in points:
        q = body.inverse(frame, q0=q)
        out.append(q)
    return np.array(out)


# ------------------------------------------------------------------ evaluation
def run_model(body, qs, kind, order, dt, n_trials, horizon, warmup):
    """Predicted excursions per step, filtered q, timings."""
    predictor = ReactiveMotionPredictor(body, kind, order=order, dt=dt, horizon=horizon, n_trials=n_trials,
                                        rng=0)
    deltas, filtered, step_seconds = [], [], []
    for k, q in enumerate(qs):
        start = time.perf_counter()
        fits_before = len(predictor.fit_seconds_)
        plus, minus = predictor.update_q(q)
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
                     "violation_rate": float(np.mean((p < 0) | (m < 0)))}
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
def cycle_time_comparison(run_cell, scenario_path, kinds=("gp_c", "worst_case"), runs: int = 3) -> dict:
    """Robot cycle time on box_pcb_coexistence, model C vs [107] (thesis: 8.59 % shorter with C).

    run_cell(scenario_path, motion_kind) -> dict with "robot_cycle_time" (s) and
    "min_human_robot_distance" (m). Returns per kind the mean cycle time and the smallest
    true distance over the runs, plus the relative reduction of the first kind w.r.t. the second.
    """
    results = {}
    for kind in kinds:
        cycles, distances = [], []
        for _ in range(runs):
            out = run_cell(scenario_path, kind)
            cycles.append(float(out["robot_cycle_time"]))
            distances.append(float(out["min_human_robot_distance"]))
        results[kind] = {"cycle_time": float(np.mean(cycles)), "min_distance": float(np.min(distances))}
    a, b = kinds[0], kinds[1]
    results["reduction_percent"] = 100.0 * (1.0 - results[a]["cycle_time"] / results[b]["cycle_time"])
    return results


def _cell_runner():
    """A run_cell callable when the cell and the scenario exist, else (None, reason)."""
    scenario = REPO / "diagrams" / "box_pcb_coexistence.yaml"
    try:
        import hrc_drake.cell.build  # noqa: F401
    except ImportError:
        return None, scenario, "hrc_drake.cell.build does not exist yet"
    if not scenario.exists():
        return None, scenario, f"{scenario.name} does not exist yet (the lead writes it)"
    return None, scenario, "no run_cell adapter wired yet (the lead wires it to the cell's motion_model)"


# ------------------------------------------------------------------ main
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small run, under a minute")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    if args.quick:
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (4,), 25.0, 1, 350, 30
        kinds_orders = [(k, 4) for k in KINDS] + [("gp_c", 1)]
    else:
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (1, 2, 3, 4), 120.0, 4, 900, 50
        kinds_orders = [(k, p) for k in KINDS[:3] for p in orders] + [("worst_case", 4)]
    horizon = 0.5
    figures = {"quick": bool(args.quick), "horizon_s": horizon, "n_trials": n_trials, "sequences": {}}

    sequences = []
    dt_sim = 0.05
    print(f"simulating an operator for {sim_seconds:.0f} s ...", flush=True)
    body, points = simulated_sequence(sim_seconds, dt_sim, seed=7)
    sequences.append(("simulated", body, joint_sequence(body, points), dt_sim))
    lego = lego_sequences(lego_limit, lego_frames)
    if not lego:
        print(f"(lego_assembly_arm not found under {data_dir()}: skipping the real sequences)")
    for name, lego_body, lego_points in lego:
        print(f"IK of {name} ({len(lego_points)} frames) ...", flush=True)
        sequences.append((f"lego:{name}", lego_body, joint_sequence(lego_body, lego_points), 1.0 / 15.0))

    step_times, fit_times, scaler_times, violations = [], [], [], []
    print(f"\n{'sequence':<34} {'model':<11} {'P':>2} {'group':<10} {'eps+ med':>9} {'eps- med':>9} "
          f"{'viol %':>7}")
    for seq_name, seq_body, qs, dt in sequences:
        warmup = int(round(3.0 / dt))
        figures["sequences"][seq_name] = {}
        for kind, order in kinds_orders:
            predictor, deltas, filtered, steps_s = run_model(seq_body, qs, kind, order, dt, n_trials, horizon,
                                                             warmup)
            eps_plus, eps_minus = epsilons(deltas, filtered, predictor.steps, warmup)
            row = summarise(eps_plus, eps_minus)
            figures["sequences"][seq_name][f"{kind}_P{order}"] = row
            for group, values in row.items():
                print(f"{seq_name[:34]:<34} {kind:<11} {order:>2} {group:<10} "
                      f"{values['eps_plus_median']:>9.3f} {values['eps_minus_median']:>9.3f} "
                      f"{100 * values['violation_rate']:>7.1f}")
            if kind == "gp_c" and order == 4:
                step_times += steps_s
                fit_times += predictor.fit_seconds_
                scaler_times.append(speed_scaler_seconds(predictor, deltas, filtered))
                violations += violation_distances(predictor, seq_body, deltas, filtered, eps_plus, eps_minus,
                                                  warmup)
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

    runner, scenario, reason = _cell_runner()
    if runner is None:
        print(f"cycle-time comparison on {scenario.name}: switched off ({reason})")
        figures["cycle_time"] = None
    else:
        figures["cycle_time"] = cycle_time_comparison(runner, scenario, runs=1 if args.quick else 3)
    print(json.dumps(figures, separators=(",", ":")))


if __name__ == "__main__":
    main()
