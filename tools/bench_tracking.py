"""Benchmark of the occlusion-aware skeleton tracker (thesis Ch. 9, issue 3).

Parts:
  speed     one particle-filter update, 8 points x 500 particles (median, ms), with the wrist
            and elbow of one arm hidden behind a box (case 3) and with everything seen;
  synthetic RMS error of occluded points, PF vs KF, on a synthetic reach behind an occluder
            box (stand-in for pcb_occlusion.yaml until the cell exists);
  lego      RMS error of occluded points, PF vs KF, on the real arm trajectories of
            ../shared/data/lego_assembly_arm with synthetic occluder boxes hiding the wrist
            and/or the elbow for 1-3 s (frame rate unknown: 30 Hz assumed);
  cycles    Fig. 9.7 stand-in: a robot tool point runs a fixed path in the workspace box at
            the 9.1.3 speed override while the operator reaches behind the occluder; 30 robot
            cycles with PF and with KF: cycle times and the true minimum human-robot distance.

Usage: python tools/bench_tracking.py [--quick]. Last line: one JSON object with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hrc_drake.messages import (  # noqa: E402
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    SkeletonFrame,
)
from hrc_drake.perception.geometry import BoxOcclusion  # noqa: E402
from hrc_drake.perception.particle_filter import SkeletonParticleFilter  # noqa: E402
from hrc_drake.perception.synthetic import reaching_sequence  # noqa: E402
from hrc_drake.perception.tracker import SkeletonTracker, speed_override  # noqa: E402

RATE = 30.0
CAMERA = np.array([-0.2, 0.0, 1.7])
OCCLUDER = ([0.5, 0.27, 1.09], [0.05, 0.14, 0.16])
REST, BEHIND = np.array([0.8, 0.25, 1.0]), np.array([0.6, 0.3, 1.0])
WS_CENTER, WS_SIZE = np.array([0.2, 0.1, 1.0]), np.array([0.5, 0.8, 0.6])


def data_dir() -> Path:
    env = os.environ.get("HRC_DRAKE_DATA")
    return Path(env) if env else Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def rms(errors) -> float:
    e = np.concatenate(errors) if errors else np.zeros(0)
    return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")


# ----------------------------------------------------------------------------- speed
def bench_speed(n_steps: int) -> dict:
    """Median update time on the frames of a reach behind the occluder where a point is hidden
    (label case1: the wrist), and on frames where all points are seen."""
    rng = np.random.default_rng(0)
    _, truth = reaching_sequence([REST, BEHIND, REST], [1.0, 1.0], torso_dir=(-1, 0, 0), dwell=1.0)
    occ = BoxOcclusion(CAMERA, [OCCLUDER])
    hidden = occ(truth)
    out = {}
    for mode in ("kalman", "bootstrap"):
        pf = SkeletonParticleFilter(500, dt=1 / RATE, rng=1, tracked_update=mode)
        occluded_ms, seen_ms = [], []
        k = 0
        while len(occluded_ms) < n_steps:
            i = k % len(truth)
            pts = truth[i] + rng.normal(0, 0.01, (8, 3))
            pts[hidden[i]] = np.nan
            t0 = time.perf_counter()
            pf.step(pts, is_hidden=occ)
            (occluded_ms if hidden[i].any() else seen_ms).append(1000 * (time.perf_counter() - t0))
            k += 1
        out[f"occluded_{mode}"] = float(np.median(occluded_ms))
        out[f"seen_{mode}"] = float(np.median(seen_ms))
    return out


# ------------------------------------------------------------------------- synthetic
def run_trackers(frames_pts, frames_seen, is_hidden_at, truth, seed, params=None):
    """Run PF and KF over a sequence; errors (m) of the occluded points of each frame."""
    errors = {"particle_filter": [], "kalman": []}
    for kind in errors:
        tracker = SkeletonTracker(kind, params, None, WS_CENTER, WS_SIZE, RATE, seed)
        for k in range(len(frames_pts)):
            tracker.is_hidden = is_hidden_at(k)
            est = tracker.update(SkeletonFrame(time=k / RATE, points=frames_pts[k], tracked=frames_seen[k]))
            hidden = ~frames_seen[k]
            if np.any(hidden):
                errors[kind].append(np.linalg.norm(est.points[hidden] - truth[k, hidden], axis=1))
    return errors


def bench_synthetic(n_runs: int) -> dict:
    occ = BoxOcclusion(CAMERA, [OCCLUDER])
    all_err = {"particle_filter": [], "kalman": []}
    hidden_frames = 0
    for run in range(n_runs):
        rng = np.random.default_rng(100 + run)
        durations = rng.uniform(0.7, 1.3, size=4)
        _, truth = reaching_sequence([REST, BEHIND, REST, BEHIND, REST], durations, torso_dir=(-1, 0, 0),
                                     dwell=rng.uniform(0.3, 1.0))
        hidden = occ(truth)
        pts = truth + rng.normal(0, 0.01, truth.shape)
        pts[hidden] = np.nan
        errs = run_trackers(pts, ~hidden, lambda k: occ, truth, run)
        for kind in all_err:
            all_err[kind] += errs[kind]
        hidden_frames += int(hidden.any(axis=1).sum())
        print(f"  synthetic run {run + 1}/{n_runs}: PF {rms(errs['particle_filter']):.3f} m, "
              f"KF {rms(errs['kalman']):.3f} m", flush=True)
    return {"rms_pf": rms(all_err["particle_filter"]), "rms_kf": rms(all_err["kalman"]),
            "occluded_frames": hidden_frames}


# ------------------------------------------------------------------------------ lego
def lego_skeleton(raw: np.ndarray) -> np.ndarray:
    """(T, 18) lego columns -> (T, 8, 3); thorax = mid-shoulders, head 0.25 m above (camera y down)."""
    pts = np.empty((len(raw), 8, 3))
    pts[:, L_WRIST], pts[:, R_WRIST] = raw[:, 0:3], raw[:, 3:6]
    pts[:, L_ELBOW], pts[:, R_ELBOW] = raw[:, 6:9], raw[:, 9:12]
    pts[:, L_SHOULDER], pts[:, R_SHOULDER] = raw[:, 12:15], raw[:, 15:18]
    pts[:, 0] = 0.5 * (pts[:, L_SHOULDER] + pts[:, R_SHOULDER])
    pts[:, 1] = pts[:, 0] + [0.0, -0.25, 0.0]
    return pts


def occluder_for(targets: np.ndarray) -> tuple:
    """A thin box between the camera (origin) and the target points (M, 3), covering them."""
    depth = 0.6 * targets[:, 2].min()
    proj = targets * (depth / targets[:, 2:3])
    lo, hi = proj.min(axis=0) - 0.02, proj.max(axis=0) + 0.02
    center = 0.5 * (lo + hi)
    size = hi - lo
    center[2], size[2] = depth, 0.02
    return center, size


def bench_lego(files_limit: int, windows_per_file: int) -> dict:
    root = data_dir() / "lego_assembly_arm"
    if not root.is_dir():
        print(f"  lego data not found at {root}: part skipped")
        return {"skipped": True}
    files = sorted(root.glob("Task*/Human*/trial*.txt"))[:files_limit]
    all_err = {"particle_filter": [], "kalman": []}
    by_case = {"wrist": [0, 0], "elbow": [0, 0], "both": [0, 0]}
    rng = np.random.default_rng(7)
    for f_i, path in enumerate(files):
        raw = np.loadtxt(path)
        raw = raw[np.all(np.isfinite(raw), axis=1)]
        skel = lego_skeleton(raw)
        for _w in range(windows_per_file):
            warm = int(2 * RATE)
            length = int(rng.uniform(1.0, 3.0) * RATE)
            if len(skel) < warm + length + 10:
                continue
            start = int(rng.integers(0, len(skel) - warm - length - 1))
            seq = skel[start:start + warm + length + 10]
            side = rng.choice(["left", "right"])
            case = rng.choice(["wrist", "elbow", "both"])
            wrist, elbow = (L_WRIST, L_ELBOW) if side == "left" else (R_WRIST, R_ELBOW)
            target = {"wrist": [wrist], "elbow": [elbow], "both": [wrist, elbow]}[case]
            stretch = slice(warm, warm + length)
            box = occluder_for(seq[stretch][:, target].reshape(-1, 3))
            occ_on, occ_off = BoxOcclusion(np.zeros(3), [box]), BoxOcclusion(np.zeros(3), [])
            hidden = np.zeros(seq.shape[:2], dtype=bool)
            hidden[stretch] = occ_on(seq[stretch])
            pts = seq.copy()
            pts[hidden] = np.nan

            def is_hidden_at(k, on=occ_on, off=occ_off, lo=warm, hi=warm + length):
                return on if lo <= k < hi else off

            errs = run_trackers(pts, ~hidden, is_hidden_at, seq, f_i)
            for kind in all_err:
                all_err[kind] += errs[kind]
            e_pf, e_kf = rms(errs["particle_filter"]), rms(errs["kalman"])
            if np.isfinite(e_pf):
                by_case[case][0] += 1
                by_case[case][1] += int(e_pf < e_kf)
        print(f"  lego file {f_i + 1}/{len(files)} {path.relative_to(root)}: running PF "
              f"{rms(all_err['particle_filter']):.3f} m, KF {rms(all_err['kalman']):.3f} m", flush=True)
    return {"rms_pf": rms(all_err["particle_filter"]), "rms_kf": rms(all_err["kalman"]),
            "windows_pf_better": {k: f"{v[1]}/{v[0]}" for k, v in by_case.items()}}


# ---------------------------------------------------------------------------- cycles
ROBOT_PATH = np.array([[0.05, -0.2, 1.0], [0.3, 0.1, 1.0], [0.05, 0.3, 1.05], [0.05, -0.2, 1.0]])
NOMINAL_CYCLE = 6.0


def robot_point(progress: float) -> np.ndarray:
    s = (progress % 1.0) * (len(ROBOT_PATH) - 1)
    i = min(int(s), len(ROBOT_PATH) - 2)
    return ROBOT_PATH[i] + (s - i) * (ROBOT_PATH[i + 1] - ROBOT_PATH[i])


def bench_cycles(n_cycles: int) -> dict:
    occ = BoxOcclusion(CAMERA, [OCCLUDER])
    out = {}
    for kind in ("particle_filter", "kalman"):
        rng = np.random.default_rng(11)
        moves, goals = [], [REST]
        for _ in range(400):
            goals.append(BEHIND if len(goals) % 2 else REST)
            moves.append(rng.uniform(0.8, 1.4))
        _, truth = reaching_sequence(goals, moves, torso_dir=(-1, 0, 0), dwell=0.8)
        hidden = occ(truth)
        meas = truth + rng.normal(0, 0.01, truth.shape)
        meas[hidden] = np.nan
        tracker = SkeletonTracker(kind, None, occ, WS_CENTER, WS_SIZE, RATE, 3)
        progress, cycle_start, cycles, min_dist, slow_frames = 0.0, 0.0, [], np.inf, 0
        k = 0
        while len(cycles) < n_cycles and k < len(truth):
            est = tracker.update(SkeletonFrame(time=k / RATE, points=meas[k], tracked=~hidden[k]))
            override = speed_override(est)
            slow_frames += override < 1.0
            progress += override / (NOMINAL_CYCLE * RATE)
            if progress >= len(cycles) + 1:
                cycles.append(k / RATE - cycle_start)
                cycle_start = k / RATE
            min_dist = min(min_dist, float(np.linalg.norm(truth[k] - robot_point(progress), axis=1).min()))
            k += 1
        out[kind] = {"cycles": len(cycles), "mean_cycle_s": float(np.mean(cycles)),
                     "median_cycle_s": float(np.median(cycles)), "std_cycle_s": float(np.std(cycles)),
                     "slow_fraction": slow_frames / max(k, 1), "min_distance_m": min_dist}
        print(f"  {kind}: {len(cycles)} cycles, mean {np.mean(cycles):.2f} s", flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, under a minute")
    args = parser.parse_args()
    quick = args.quick
    print("speed (8 points x 500 particles, one update)")
    speed = bench_speed(100 if quick else 500)
    print("synthetic reach behind an occluder (pcb_occlusion.yaml stand-in)")
    synthetic = bench_synthetic(2 if quick else 10)
    print("lego_assembly_arm with synthetic occluders")
    lego = bench_lego(3 if quick else 20, 2 if quick else 5)
    print("robot cycles with the 9.1.3 slow-down rule (Fig. 9.7 stand-in)")
    cycles = bench_cycles(8 if quick else 30)

    print()
    print(f"{'figure':48s} {'PF':>10s} {'KF':>10s}")
    for key, label in [("occluded_kalman", "update 8x500, wrist hidden (ms, median)"),
                       ("seen_kalman", "update 8x500, all seen (ms, median)"),
                       ("occluded_bootstrap", "same, bootstrap seen points, hidden (ms)"),
                       ("seen_bootstrap", "same, bootstrap seen points, all seen (ms)")]:
        print(f"{label:48s} {speed[key]:10.3f}")
    print(f"{'synthetic: RMS error occluded points (m)':48s} {synthetic['rms_pf']:10.3f} "
          f"{synthetic['rms_kf']:10.3f}")
    if not lego.get("skipped"):
        print(f"{'lego: RMS error occluded points (m)':48s} {lego['rms_pf']:10.3f} {lego['rms_kf']:10.3f}")
        print(f"{'lego: windows where PF beats KF':48s} {json.dumps(lego['windows_pf_better'])}")
    for key, label in [("mean_cycle_s", "cycles: mean robot cycle (s)"),
                       ("median_cycle_s", "cycles: median (s)"),
                       ("slow_fraction", "cycles: share of time slowed"),
                       ("min_distance_m", "cycles: true min human-robot distance (m)")]:
        print(f"{label:48s} {cycles['particle_filter'][key]:10.3f} {cycles['kalman'][key]:10.3f}")
    figures = {
        "quick": quick,
        "update_ms_median_8x500_occluded": round(speed["occluded_kalman"], 3),
        "update_ms_median_8x500_all_seen": round(speed["seen_kalman"], 3),
        "update_ms_median_8x500_occluded_bootstrap": round(speed["occluded_bootstrap"], 3),
        "update_ms_median_8x500_all_seen_bootstrap": round(speed["seen_bootstrap"], 3),
        "synthetic_rms_pf_m": round(synthetic["rms_pf"], 4),
        "synthetic_rms_kf_m": round(synthetic["rms_kf"], 4),
        "lego_rms_pf_m": None if lego.get("skipped") else round(lego["rms_pf"], 4),
        "lego_rms_kf_m": None if lego.get("skipped") else round(lego["rms_kf"], 4),
        "cycle_mean_pf_s": round(cycles["particle_filter"]["mean_cycle_s"], 3),
        "cycle_mean_kf_s": round(cycles["kalman"]["mean_cycle_s"], 3),
        "min_distance_pf_m": round(cycles["particle_filter"]["min_distance_m"], 3),
        "min_distance_kf_m": round(cycles["kalman"]["min_distance_m"], 3),
        "cycles": cycles["particle_filter"]["cycles"],
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
