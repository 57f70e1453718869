"""Benchmark of reactive safety (thesis 8.1.3): epsilon+/- of models A, B, C and [107], speed.

For every sample k, eps+ = Delta+_pred - Delta+_real and eps- likewise (Fig. 8.6, 8.8), with
Delta_real the excursion of the Kalman-filtered joints over the next M steps; eps < 0 is a
violation. Joint groups: base translation (q0, q1), base yaw (q2), torso flexion (q3),
shoulders (q4-6, q8-10), elbows (q7, q11). For model C at the largest order, the distance
of the real wrists, elbows and shoulders to the swept volumes at violating samples (Fig. 8.10).

Sequences: simulated operators (`SyntheticOperator`, skeleton points -> body-model IK) and
the LEGO arm trajectories of data/lego_assembly_arm (or $HRC_DRAKE_DATA) (camera frame -> world frame,
IK with head missing; the frame rate is not stated: 15 Hz assumed).

The cycle-time comparison runs the Drake cell of
diagrams/variants/box_pcb_coexistence_swept_volumes.yaml (the thesis's SSM on the swept volumes, a
declared departure from ISO 13855: NON-CONFORMING; JSON key `cycle_time`) and the shipped cell
diagrams/box_pcb_coexistence.yaml in its declared ISO/TS 15066 mode (`cycle_time_declared`) with
model C and with [107], several seeds (`run_cell`, `cycle_time_comparison`); robot cycle = time
between consecutive ends of L_store, reported with the true human-robot distance, robot idle, and
per run the independent judge's verdict, violations, protective stops, time slowed and products
(`judge_figures`, `judge_summary`); whether C and [107] ran identically seed by seed (`same_runs`).
The proactive-path comparison (8.2.4, diagrams/box_usb_proactive.yaml) carries the same figures.

With --sweep-hyperparameters, only model C with its kernel's hyperparameters re-optimised at
every k-th model refresh (`hyperparameter_every` k = 1, 2, 4, 8; 1 is the thesis): eps+/- and
violation rates pooled over all joints and sequences, and the mean model update time.

Usage: python tools/bench_motion.py [--quick | --smoke] [--no-cell | --cell-only | --sweep-hyperparameters].
--smoke: every part once on the shortest sequences and runs, in this process (figures meaningless).
Last line: one JSON object.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hrc_drake.datasets import data_root  # noqa: E402
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
#: eps+ / eps- of every model at P = 4 (and [107]) are pooled into `eps_violation_rate.<model>`
POOLED_KINDS = ("gp_a", "gp_b", "gp_c", "gp_c_filtered", "worst_case")
ARM_POINTS = [L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST]


def data_dir() -> Path:
    """The real recordings: the repository's data/, or $HRC_DRAKE_DATA (`hrc_drake.datasets`)."""
    return data_root()


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
def run_model(body, qs, stds, kind, order, dt, n_trials, horizon, warmup, **extra):
    """Predicted excursions per step, filtered q, timings. kind "gp_c_filtered": model C trained
    on the Kalman-filtered states (the `training_states` variant), uncapped like the others;
    extra: further `ReactiveMotionPredictor` options."""
    options = {"training_states": "filtered"} if kind == "gp_c_filtered" else {}
    options.update(extra)
    predictor = ReactiveMotionPredictor(body, kind.replace("_filtered", ""), order=order, dt=dt,
                                        horizon=horizon, n_trials=n_trials, rng=0, **options)
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
def judge_figures(metrics: dict) -> dict:
    """The independent ISO/TS 15066 judge's figures of one run (`metrics["safety"]`, see
    `hrc_drake.cell.metrics.DEFINITIONS`), with the run's time slowed and products finished.

    own_model_violations: the violations counted by the changed judge or the controller's own
    model of a non-conforming run (`safety["own_model"]`), else None. A run without the judge's
    figures has verdict_code None and no counts.
    """
    safety = metrics.get("safety") or {}
    own = safety.get("own_model") or None
    return {
        "verdict_code": safety.get("verdict_code"),
        "verdict": safety.get("verdict"),
        "violations_total": safety.get("violations_total"),
        "violations": dict(safety.get("violations") or {}),
        "ssm_breach_s": safety.get("ssm_breach_s"),
        "protective_stops": safety.get("protective_stops"),
        "closest_approach_m": safety.get("closest_approach_m"),
        "own_model_violations": None if own is None else own.get("violations_total"),
        "time_slowed_s": float(metrics.get("time_slowed_s") or 0.0),
        "products": int(metrics.get("products_finished") or 0),
    }


def judge_summary(runs: list[dict]) -> dict:
    """The judge's figures of one arm's runs (`judge_figures` rows): runs, how many the judge
    found SAFE, every verdict code's count, violations summed (the standard judge's, and the
    own model's over the runs that have one), protective stops and time slowed per run (means),
    products (total and mean)."""
    codes: dict[str, int] = {}
    for r in runs:
        codes[str(r.get("verdict_code"))] = codes.get(str(r.get("verdict_code")), 0) + 1
    judged = [r for r in runs if r.get("violations_total") is not None]
    stops = [r["protective_stops"] for r in runs if r.get("protective_stops") is not None]
    own = [r["own_model_violations"] for r in runs if r.get("own_model_violations") is not None]
    return {
        "runs": len(runs),
        "safe_runs": sum(1 for r in runs if r.get("verdict_code") == "safe"),
        "verdict_codes": codes,
        "violations_total": int(sum(r["violations_total"] for r in judged)) if judged else None,
        "ssm_breach_s_total": float(sum(r.get("ssm_breach_s") or 0.0 for r in judged)) if judged else None,
        "protective_stops_per_run": float(np.mean(stops)) if stops else None,
        "own_model_violations_total": int(sum(own)) if own else None,
        "own_model_runs": len(own),
        "time_slowed_s_per_run": float(np.mean([r["time_slowed_s"] for r in runs])) if runs else None,
        "products_total": int(sum(r["products"] for r in runs)),
        "products_per_run": float(np.mean([r["products"] for r in runs])) if runs else None,
    }


def judge_line(summary: dict) -> str:
    """One printed line of `judge_summary`: SAFE x of N, codes, violations, stops, time slowed."""
    codes = ", ".join(f"{k} {v}" for k, v in sorted(summary["verdict_codes"].items()))
    own = ("" if summary["own_model_violations_total"] is None else
           f", own model {summary['own_model_violations_total']} violations "
           f"({summary['own_model_runs']} runs)")
    per_run = summary["protective_stops_per_run"]
    stops = "n/a" if per_run is None else f"{per_run:.1f}"
    breach = summary["ssm_breach_s_total"] or 0.0
    return (f"judge: SAFE {summary['safe_runs']} of {summary['runs']} ({codes}), "
            f"{summary['violations_total']} violations (SSM breach {breach:.2f} s)"
            f"{own}, {stops} protective stops/run, "
            f"time slowed {summary['time_slowed_s_per_run']:.1f} s/run, "
            f"{summary['products_per_run']:.1f} products/run")


def same_runs(runs: list[dict], kinds=("gp_c", "worst_case")) -> dict:
    """Whether the two kinds' runs of every seed are identical in what the robot did and what
    the judge saw (`SAME_KEYS`): the seeds that differ, empty when the motion model did not
    influence the robot at all."""
    by_seed: dict[int, dict[str, dict]] = {}
    for r in runs:
        by_seed.setdefault(r["seed"], {})[r["kind"]] = r
    differ = [seed for seed, pair in sorted(by_seed.items())
              if all(k in pair for k in kinds)
              and any(pair[kinds[0]].get(key) != pair[kinds[1]].get(key) for key in SAME_KEYS)]
    paired = sum(1 for pair in by_seed.values() if all(k in pair for k in kinds))
    return {"seeds_paired": paired, "seeds_differing": differ, "identical": paired > 0 and not differ}


#: what two runs must share to count as identical (`same_runs`)
SAME_KEYS = ("store_ends", "robot_actions_finished", "min_human_robot_distance", "median_distance_m",
             "mean_speed_override", "robot_idle_pct", "time_slowed_s", "violations_total",
             "protective_stops", "products")


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
    overrides = np.asarray(log.overrides, dtype=float)
    return {
        "kind": kind, "seed": int(seed), "duration": duration, "wall_s": time.perf_counter() - start,
        "store_ends": [round(t, 2) for t in stores], "cycles": np.diff(stores).round(2).tolist(),
        "robot_actions_finished": sum(1 for e in log.events if getattr(e, "agent", "").startswith("yumi")
                                      and getattr(e, "kind", "") == "end"),
        "min_human_robot_distance": float(result.metrics["min_human_robot_distance"]),
        "median_distance_m": float(np.median(distances)),
        "robot_idle_pct": float(100.0 * np.mean(overrides < 0.01)),
        "time_below_0.05m_s": float(np.sum(distances < 0.05) * np.mean(np.diff(log.times))),
        "mean_speed_override": float(result.metrics["mean_speed_override"]),
        **judge_figures(result.metrics),
    }


def _run_cell_args(args):
    return run_cell(*args)


def cycle_time_comparison(scenario_path, seeds, duration, kinds=("gp_c", "worst_case"),
                          workers: int = 1) -> dict:
    """Robot cycle time on box_pcb_coexistence, model C vs [107] (thesis: 8.59 % shorter with C).

    Every (kind, seed) runs for `duration` s; per kind: all cycles pooled, their mean, the
    number of boards stored, the smallest true human-robot distance, the medians over runs of
    the median distance and of robot idle % (override < 1 %), and the judge's figures
    (`judge_summary`). The reduction is 1 - mean cycle C / mean cycle [107] (None when [107]
    completes fewer than two stores); `same_runs` says whether the two kinds ran identically
    seed by seed (the motion model then did not influence the robot).
    """
    jobs = [(str(scenario_path), kind, seed, duration) for kind in kinds for seed in seeds]
    runs = []
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as pool:
            for job, run in zip(jobs, pool.map(_run_cell_args, jobs), strict=True):
                runs.append(run)
                print(f"  {job[1]:<11} seed {job[2]}: done ({run['wall_s']:.0f} s wall)", flush=True)
    else:
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
            "median_distance_median_m": float(np.median([r["median_distance_m"] for r in mine])),
            "robot_idle_pct": float(np.median([r["robot_idle_pct"] for r in mine])),
            "robot_actions_finished": int(sum(r["robot_actions_finished"] for r in mine)),
            "mean_override": float(np.mean([r["mean_speed_override"] for r in mine])),
            "judge": judge_summary(mine),
        }
    a, b = results[kinds[0]]["mean_cycle_s"], results[kinds[1]]["mean_cycle_s"]
    results["reduction_percent"] = None if a is None or b is None else 100.0 * (1.0 - a / b)
    results["same_runs"] = same_runs(runs, kinds)
    return results


# ------------------------------------------------------------------ proactive paths (8.2.4)
PROACTIVE_SCENARIO = REPO / "diagrams" / "box_usb_proactive.yaml"


def run_proactive_cell(proactive: bool, seed: int, duration: float) -> dict:
    """One run of the 8.2.4 cell with (or without: the nominal path) the proactive planner.

    Distance: the true human-robot distance of every recorded sample; robot idle: the percentage
    of samples whose applied speed override is below 1 % (8.2.4: robot speed below 1 % of its
    nominal value); the ISO/TS 15066 judge's figures, time slowed and products (`judge_figures`).
    """
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.motion.config import NoProactivePlanner

    warnings.filterwarnings("ignore")
    scenario = load_scenario(PROACTIVE_SCENARIO)
    if not proactive:
        scenario.proactive_planner = NoProactivePlanner()
    scenario.seed = int(seed)
    cell = build_cell(scenario, PROACTIVE_SCENARIO)
    start = time.perf_counter()
    result = simulate(cell, duration, progress=None)
    distances = np.asarray(result.log.distances, dtype=float)
    overrides = np.asarray(result.log.overrides, dtype=float)
    row = {"proactive": proactive, "seed": int(seed), "wall_s": time.perf_counter() - start,
           "min_distance_m": float(np.min(distances)), "median_distance_m": float(np.median(distances)),
           "robot_idle_pct": float(100.0 * np.mean(overrides < 0.01)),
           **judge_figures(result.metrics), "replannings": [],
           # per-sample trace for the figures after the first replanning (dropped from the JSON)
           "_trace": (np.asarray(result.log.times, dtype=float), distances, overrides)}
    if proactive:
        planner = cell.diagram.GetSubsystemByName("proactive_planner")
        core = planner.core(planner.GetMyContextFromRoot(result.context))
        row["replannings"] = [
            {"time": r.time, "weights": list(r.weights), "nominal_cost": r.nominal_cost,
             "proactive_cost": r.proactive_cost, "cloud_points": r.cloud_points,
             "cloud_ms": 1000 * r.cloud_s / len(r.weights), "stomp_ms": 1000 * r.stomp_s,
             "gpdm_ms": 1000 * r.gpdm_s} for r in core.reports_]
    return row


def _run_proactive_args(args):
    return run_proactive_cell(*args)


def after_first_plan(runs, out: dict) -> None:
    """The same figures from the first replanning on, where the arms can differ: until then
    both follow the nominal path, and a seed's two runs are the same. Per seed the cut is its
    proactive run's first replanning; a seed without one is left out."""
    from scipy.stats import mannwhitneyu

    cuts = {r["seed"]: r["replannings"][0]["time"] for r in runs if r["proactive"] and r["replannings"]}
    rows = {True: [], False: []}
    for r in runs:
        if r["seed"] not in cuts:
            continue
        times, distances, overrides = r["_trace"]
        keep = times >= cuts[r["seed"]]
        rows[r["proactive"]].append((float(np.median(distances[keep])), float(np.min(distances[keep])),
                                     float(100.0 * np.mean(overrides[keep] < 0.01))))
    for name, arm in (("proactive", True), ("nominal", False)):
        mine = rows[arm]
        out[name]["after_first_plan"] = None if not mine else {
            "seeds": len(mine),
            "median_distance_median_m": float(np.median([m[0] for m in mine])),
            "min_distance_median_m": float(np.median([m[1] for m in mine])),
            "robot_idle_pct": float(np.median([m[2] for m in mine]))}
    if rows[True] and rows[False]:
        out["proactive"]["after_first_plan"]["wilcoxon_p_distance"] = float(mannwhitneyu(
            [m[0] for m in rows[True]], [m[0] for m in rows[False]], alternative="greater").pvalue)
        out["proactive"]["after_first_plan"]["wilcoxon_p_idle"] = float(mannwhitneyu(
            [m[2] for m in rows[True]], [m[2] for m in rows[False]], alternative="less").pvalue)


def proactive_comparison(seeds, duration: float, workers: int = 2) -> dict:
    """Proactive vs nominal paths on the 8.2.4 cell (thesis: distance up, p = 1 - 1e-7 in its
    notation; idle time down, p = 0.9984), one run per (arm, seed). The test is a one-sided
    Wilcoxon rank-sum on the runs' median distances (proactive greater). workers = 1: the runs
    one after the other in this process."""
    jobs = [(arm, seed, duration) for arm in (True, False) for seed in seeds]

    def done(job, run: dict) -> dict:
        print(f"  {'proactive' if job[0] else 'nominal':<9} seed {job[1]}: done "
              f"({run['wall_s']:.0f} s wall)", flush=True)
        return run

    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as pool:
            finished = pool.map(_run_proactive_args, jobs)
            runs = [done(job, run) for job, run in zip(jobs, finished, strict=True)]
    else:
        runs = [done(job, run_proactive_cell(*job)) for job in jobs]
    return summarise_proactive(runs, seeds, duration)


def summarise_proactive(runs: list[dict], seeds, duration: float) -> dict:
    """The figures of `proactive_comparison` from its runs (`run_proactive_cell` rows): per arm
    the distances, robot idle and the judge's figures (`judge_summary`), the one-sided rank-sum
    on the median distances, the figures after the first replanning, and the replannings' times
    and cost ratios (`plan_figures`). Drops each run's per-sample trace."""
    from scipy.stats import mannwhitneyu

    out = {"scenario": PROACTIVE_SCENARIO.name, "duration_s": duration, "seeds": list(seeds),
           "runs": runs}
    for name, arm in (("proactive", True), ("nominal", False)):
        mine = [r for r in runs if r["proactive"] is arm]
        out[name] = {"runs": len(mine),
                     "min_distance_median_m": float(np.median([r["min_distance_m"] for r in mine])),
                     "min_distance_m": float(np.min([r["min_distance_m"] for r in mine])),
                     "median_distance_median_m": float(np.median([r["median_distance_m"] for r in mine])),
                     "robot_idle_pct": float(np.median([r["robot_idle_pct"] for r in mine])),
                     "judge": judge_summary(mine)}
    pro = [r["median_distance_m"] for r in runs if r["proactive"]]
    nom = [r["median_distance_m"] for r in runs if not r["proactive"]]
    out["proactive"]["wilcoxon_p_distance"] = float(mannwhitneyu(pro, nom, alternative="greater").pvalue)
    after_first_plan(runs, out)
    for r in runs:
        r.pop("_trace", None)
    out.update(plan_figures([p for r in runs for p in r["replannings"]]))
    return out


def plan_figures(plans: list[dict]) -> dict:
    """Replannings: their number, median cloud and STOMP times (ms), and the median of
    J(proactive) / J(nominal) over the replannings whose nominal path has a cost (a nominal
    cost of 0 leaves the ratio undefined: counted in `zero_nominal_cost`, left out)."""
    ratios = [p["proactive_cost"] / p["nominal_cost"] for p in plans if p["nominal_cost"] > 0]
    return {
        "replannings": len(plans),
        "cloud_ms_G25": float(np.median([p["cloud_ms"] for p in plans])) if plans else None,
        "stomp_path_ms_G25": float(np.median([p["stomp_ms"] for p in plans])) if plans else None,
        "stomp_cost_ratio_median": float(np.median(ratios)) if ratios else None,
        "zero_nominal_cost": sum(1 for p in plans if not p["nominal_cost"] > 0),
    }


def judge_words(run: dict) -> str:
    """One run's judge figures in words: verdict, violations (and the own model's), stops, slowed."""
    own = "" if run["own_model_violations"] is None else f" (own model {run['own_model_violations']})"
    return (f"judge {run['verdict_code']}: {run['violations_total']} violations{own}, "
            f"{run['protective_stops']} stops, slowed {run['time_slowed_s']:.1f} s")


def print_proactive(comparison: dict) -> None:
    """The table of `summarise_proactive`: every run, every arm, the p-values."""
    for run in comparison["runs"]:
        print(f"  {'proactive' if run['proactive'] else 'nominal':<9} seed {run['seed']}: min distance "
              f"{run['min_distance_m']:.3f} m, median {run['median_distance_m']:.3f} m, robot idle "
              f"{run['robot_idle_pct']:.1f} %, {run['products']} products, "
              f"{len(run['replannings'])} replannings, {judge_words(run)} ({run['wall_s']:.0f} s wall)")
    for name in ("proactive", "nominal"):
        row = comparison[name]
        print(f"  {name:<9} {row['runs']} runs: median of min distances "
              f"{row['min_distance_median_m']:.3f} m "
              f"(smallest {row['min_distance_m']:.3f} m), of median "
              f"distances {row['median_distance_median_m']:.3f} m, "
              f"robot idle {row['robot_idle_pct']:.1f} %")
        print(f"  {'':<9} {judge_line(row['judge'])}")
    print(f"  distance proactive > nominal: one-sided rank-sum p = "
          f"{comparison['proactive']['wilcoxon_p_distance']:.3g} (thesis: evidence that it increases)")
    for name in ("proactive", "nominal"):
        row = comparison[name]["after_first_plan"]
        if row:
            print(f"  {name:<9} after the first replanning ({row['seeds']} seeds): median distance "
                  f"{row['median_distance_median_m']:.3f} m, min {row['min_distance_median_m']:.3f} m, "
                  f"robot idle {row['robot_idle_pct']:.1f} %")
    after = comparison["proactive"]["after_first_plan"]
    if after and "wilcoxon_p_distance" in after:
        print(f"  after the first replanning: distance up p = {after['wilcoxon_p_distance']:.3g}, "
              f"idle down p = {after['wilcoxon_p_idle']:.3g}")
    ratio = comparison["stomp_cost_ratio_median"]
    print(f"  {comparison['replannings']} replannings, J proactive / nominal median "
          + ("n/a" if ratio is None else f"{ratio:.2f}")
          + f" ({comparison['zero_nominal_cost']} with a nominal cost of 0 left out)")


def proactive_timings(repeats: int = 3) -> dict:
    """Cloud (G = 25) and STOMP path (43 waypoints) times of the 8.2 pipeline on a hand-made
    YuMi problem: three reaches of a forearm across the left arm's path (tests/motion)."""
    from hrc_drake.motion.clouds import probability_cloud
    from hrc_drake.motion.proactive import ProactivePlannerCore, nominal_path, table_box
    from hrc_drake.robots.chain import SerialChain

    qa = np.array([-0.858, -0.681, 2.086, 0.062, 4.18, 0.645, -1.942])
    qb = np.array([-0.922, -0.442, 1.624, 0.778, 4.382, 0.894, -0.897])
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, 40))[:, None]
    arm = np.stack([np.broadcast_to([1.25, 0.22, 0.55], (40, 3)),
                    np.array([1.05, 0.22, 0.35]) + s * [-0.2, 0.0, 0.0],
                    np.array([0.9, 0.22, 0.3]) + s * [-0.4, 0.0, 0.0]], axis=1)
    cloud_times = []
    for _ in range(repeats):
        start = time.perf_counter()
        probability_cloud(arm, 0.06, 25)
        cloud_times.append(time.perf_counter() - start)
    chain = SerialChain.from_model("yumi", "left")
    core = ProactivePlannerCore("yumi_left", "r1", ["a1"], {"a1": "right"}, nominal_path(qa, qb), chain,
                                [table_box([0.5, 0.0], [1.2, 1.6, 0.1], 0.0)], rng=0)
    core.databases["a1"] = tuple(arm + np.random.default_rng(k).normal(0.0, 0.005, arm.shape)
                                 for k in range(3))
    stomp_times = []
    for k in range(repeats):
        core.plan(float(k), [1.0])
        stomp_times.append(core.reports_[-1].stomp_s)
    return {"cloud_ms_G25": 1000 * float(np.median(cloud_times)),
            "stomp_path_ms_G25": 1000 * float(np.median(stomp_times)),
            "cloud_points": core.reports_[-1].cloud_points,
            "cost_ratio": core.reports_[-1].proactive_cost / core.reports_[-1].nominal_cost}


# ------------------------------------------------------------------ main
#: hyperparameter_every values of the sweep (1: the thesis, a refit of the kernel at every refresh)
HYPERPARAMETER_EVERY = (1, 2, 4, 8)


def hyperparameter_sweep(sequences, orders, n_trials, horizon) -> dict:
    """Model C (as eq. 8.13 and on filtered states) with the kernel's hyperparameters
    re-optimised at every k-th model refresh only (`hyperparameter_every`): eps+/- over all
    joints and sequences, and the model update time."""
    out = {}
    print(f"\n{'model':<14} {'P':>2} {'every':>5} {'viol %':>7} {'>0.01 %':>8} {'eps+ med':>9} "
          f"{'eps- med':>9} {'update ms':>10}   (all joints and sequences pooled)")
    for kind, order, every in itertools.product(("gp_c", "gp_c_filtered"), orders, HYPERPARAMETER_EVERY):
        plus_all, minus_all, fits = [], [], []
        for _, seq_body, qs, stds, dt in sequences:
            warmup = int(round(3.0 / dt))
            predictor, deltas, filtered, _ = run_model(seq_body, qs, stds, kind, order, dt, n_trials,
                                                       horizon, warmup, hyperparameter_every=every)
            eps_plus, eps_minus = epsilons(deltas, filtered, predictor.steps, warmup)
            plus_all.append(eps_plus.ravel())
            minus_all.append(eps_minus.ravel())
            fits += predictor.fit_seconds_
        p, m = np.concatenate(plus_all), np.concatenate(minus_all)
        row = {"violation_rate": float(np.mean((p < 0) | (m < 0))),
               "violation_rate_over_0.01": float(np.mean((p < -0.01) | (m < -0.01))),
               "eps_plus_median": float(np.median(p)), "eps_minus_median": float(np.median(m)),
               "model_update_ms_mean": 1000 * float(np.mean(fits))}
        out[f"{kind}_P{order}_every{every}"] = row
        print(f"{kind:<14} {order:>2} {every:>5} {100 * row['violation_rate']:>7.2f} "
              f"{100 * row['violation_rate_over_0.01']:>8.2f} {row['eps_plus_median']:>9.4f} "
              f"{row['eps_minus_median']:>9.4f} {row['model_update_ms_mean']:>10.1f}", flush=True)
    return out


def cycle_time_section(scenario, seeds, duration, workers) -> dict:
    """Run `cycle_time_comparison` on one scenario and print its table: every run, every kind
    (cycle, boards, products, distances, idle, the judge's figures), the reduction, and whether
    the two kinds ran identically seed by seed."""
    print(f"\ncycle-time comparison on {scenario.name}: seeds {list(seeds)}, {duration:.0f} s each ...",
          flush=True)
    comparison = cycle_time_comparison(scenario, seeds, duration, workers=workers)
    for run in comparison["runs"]:
        print(f"  {run['kind']:<11} seed {run['seed']}: {run['robot_actions_finished']} robot actions, "
              f"L_store ends {run['store_ends']}  cycles "
              f"{run['cycles']}  min true distance {run['min_human_robot_distance']:.3f} m  "
              f"median {run['median_distance_m']:.3f} m  idle {run['robot_idle_pct']:.1f} %  "
              f"mean override {run['mean_speed_override']:.2f}  {run['products']} products  "
              f"{judge_words(run)}  ({run['wall_s']:.0f} s wall)")
    for kind in ("gp_c", "worst_case"):
        row = comparison[kind]
        cycle = "n/a" if row["mean_cycle_s"] is None else f"{row['mean_cycle_s']:.2f} s"
        print(f"  {kind:<11} {row['judge']['runs']} runs: mean robot cycle {cycle} over {row['cycles']} "
              f"cycles, {row['boards_stored']} boards stored, {row['robot_actions_finished']} robot "
              f"actions, min true distance {row['min_distance_m']:.3f} m, median distance "
              f"{row['median_distance_median_m']:.3f} m, robot idle {row['robot_idle_pct']:.1f} % "
              f"(medians over runs)")
        print(f"  {'':<11} {judge_line(row['judge'])}")
    reduction = comparison["reduction_percent"]
    print(f"  cycle time with C vs [107] on {scenario.name}: "
          + ("n/a (too few [107] cycles)" if reduction is None else f"{reduction:.2f} % shorter")
          + " (thesis: 8.59 %)")
    same = comparison["same_runs"]
    if same["identical"]:
        print(f"  model C and [107] gave identical runs on all {same['seeds_paired']} seeds: the motion "
              f"model did not influence the robot here")
    else:
        print(f"  model C and [107] runs differ on seeds {same['seeds_differing']} "
              f"of {same['seeds_paired']}")
    return comparison


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small run, under a minute")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--no-cell", action="store_true", help="skip the cycle-time comparison in the cell")
    parser.add_argument("--cell-only", action="store_true", help="only the cycle-time comparison")
    parser.add_argument("--no-proactive", action="store_true",
                        help="skip the proactive-path comparison (8.2.4)")
    parser.add_argument("--sweep-hyperparameters", action="store_true",
                        help="only the sweep of hyperparameter_every (model C, P = 2 and 4)")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")
    if args.smoke:  # a few samples past the 3 s warm-up and one horizon; few Monte Carlo trials
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (4,), 4.0, 1, 55, 5
        kinds_orders = [(k, 4) for k in KINDS] + [("gp_c_filtered", 4)]
    elif args.quick:
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (4,), 20.0, 1, 300, 30
        kinds_orders = [(k, 4) for k in KINDS] + [("gp_c", 1), ("gp_c_filtered", 4)]
    else:
        orders, sim_seconds, lego_limit, lego_frames, n_trials = (1, 2, 3, 4), 60.0, 3, 600, 50
        kinds_orders = ([(k, p) for k in KINDS[:3] for p in orders] + [("gp_c_filtered", 4)]
                        + [("worst_case", 4)])
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

        if args.sweep_hyperparameters:
            figures["hyperparameter_sweep"] = hyperparameter_sweep(sequences, (2, 4), n_trials, horizon)
            print(json.dumps(figures))
            return
        step_times, fit_times, scaler_times, violations = [], [], [], []
        pooled = {kind: [] for kind in POOLED_KINDS}
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
                if order == 4 and kind in pooled:
                    pooled[kind].append(((eps_plus < 0) | (eps_minus < 0)).ravel())
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

        figures["eps_violation_rate"] = {kind: float(np.mean(np.concatenate(v))) for kind, v in pooled.items()
                                         if v}
        print("eps < 0 (a joint excursion the prediction missed), all joints and sequences, P = 4: "
              + ", ".join(f"{k} {100 * v:.1f} %" for k, v in figures["eps_violation_rate"].items()))
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

    # 8.1.3 twice: the thesis's experiment, SSM on the swept volumes (a declared departure, the
    # judge's verdict NON-CONFORMING), and the shipped cell in its declared ISO mode (ISO 13855's
    # speeds), where the motion model can only act through the speed scaler under the SSM.
    cell_scenarios = {
        "cycle_time": REPO / "diagrams" / "variants" / "box_pcb_coexistence_swept_volumes.yaml",
        "cycle_time_declared": REPO / "diagrams" / "box_pcb_coexistence.yaml",
    }
    if args.smoke:
        seeds, duration = (5,), 1.0
    else:
        seeds, duration = ((5,), 12.0) if args.quick else (tuple(range(5, 15)), 75.0)  # 10 per arm
    in_process = args.quick or args.smoke
    for key, scenario in cell_scenarios.items():
        if args.no_cell or not scenario.exists():
            print(f"cycle-time comparison on {scenario.name}: switched off")
            figures[key] = None
            continue
        figures[key] = cycle_time_section(scenario, seeds, duration, workers=1 if in_process else 2)

    timings = proactive_timings(repeats=1 if args.smoke else 3)
    print(f"\nproactive pipeline (hand-made YuMi problem): cloud at G = 25 "
          f"{timings['cloud_ms_G25']:.0f} ms, "
          f"STOMP path of 43 waypoints {timings['stomp_path_ms_G25']:.0f} ms (thesis: 1.23 s per path "
          f"at G = 25; goal <= 500 ms), J proactive / nominal {timings['cost_ratio']:.2f}")
    figures["cloud_ms_G25"] = timings["cloud_ms_G25"]
    figures["stomp_path_ms_G25"] = timings["stomp_path_ms_G25"]
    if args.quick or args.no_proactive or not PROACTIVE_SCENARIO.exists():
        print(f"proactive vs nominal paths on {PROACTIVE_SCENARIO.name}: switched off")
    else:
        # the databases fill after ~250 s: a smoke run ends before any replanning
        seeds, duration = ((11,), 1.0) if args.smoke else (tuple(range(11, 18)), 600.0)
        print(f"proactive vs nominal paths on {PROACTIVE_SCENARIO.name}: seeds {list(seeds)}, "
              f"{duration:.0f} s each ...", flush=True)
        comparison = proactive_comparison(seeds, duration, workers=1 if args.smoke else 2)
        print_proactive(comparison)
        figures["proactive"] = comparison["proactive"]
        figures["nominal"] = comparison["nominal"]
        figures["proactive_runs"] = comparison
        if comparison["cloud_ms_G25"] is not None:
            figures["cell_cloud_ms_G25"] = comparison["cloud_ms_G25"]
            figures["cell_stomp_path_ms_G25"] = comparison["stomp_path_ms_G25"]
    print(json.dumps(figures, separators=(",", ":")))


if __name__ == "__main__":
    main()
