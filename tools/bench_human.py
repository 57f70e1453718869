"""Benchmark of hrc_drake.human: kinematics, operator, camera, Drake adapters, IK on real data.

Prints a table, then as its last line one JSON object with the figures (medians).

Usage: python tools/bench_human.py [--quick | --smoke]
`--quick` finishes in well under a minute; `--smoke` in a few seconds (figures meaningless).
"""

from __future__ import annotations

import argparse
import json
import time
from typing import NamedTuple

import numpy as np

from hrc_drake.datasets import data_root
from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.human.config import Segments
from hrc_drake.human.operator import OperatorTask, SyntheticOperator
from hrc_drake.messages import L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST


class Sizes(NamedTuple):
    """How much each part measures."""

    repeats: int  # timings per figure (each of `inner` calls)
    ik_samples: int  # random postures fitted by IK
    sim_time: float  # simulated s of the Drake diagram
    real_files: int | None  # real recordings fitted (None: all)
    real_frames: int | None  # first frames of each (None: every 5th frame of the whole recording)


FULL = Sizes(repeats=50, ik_samples=100, sim_time=120.0, real_files=None, real_frames=None)
QUICK = Sizes(repeats=15, ik_samples=20, sim_time=20.0, real_files=1, real_frames=200)
SMOKE = Sizes(repeats=3, ik_samples=10, sim_time=1.0, real_files=1, real_frames=20)


def median_time(fn, repeats: int, inner: int = 1) -> float:
    """Median seconds per call of fn over `repeats` timings of `inner` calls."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(inner):
            fn()
        samples.append((time.perf_counter() - start) / inner)
    return float(np.median(samples))


def make_operator(seed=0):
    body = BodyModel()
    tasks = {
        "pick_place": OperatorTask("pick_place", [np.array([0.68, 0.30, 0.80]), np.array([0.62, 0.0, 0.80])],
                                   "right", lambda rng: rng.uniform(3.0, 4.0)),
        "screw": OperatorTask("screw", [np.array([0.62, -0.15, 0.85])], "both", lambda rng: 2.0),
    }
    return SyntheticOperator(body, tasks, ["pick_place", "screw"], body.rest_q((1.05, 0.0), np.pi),
                             np.random.default_rng(seed))


def bench_core(sizes: Sizes) -> dict:
    body = BodyModel()
    rng = np.random.default_rng(0)
    reps = sizes.repeats
    q1 = body.rest_q((1.0, 0.0), np.pi)
    q500 = rng.uniform(body.q_lower, body.q_upper, (500, 12))
    q500[:, :2] = rng.uniform(-1, 1, (500, 2))
    out = {
        "fk_single_us": median_time(lambda: body.points(q1), reps, 200) * 1e6,
        "fk_500_us": median_time(lambda: body.points(q500), reps, 20) * 1e6,
        "capsules_single_us": median_time(lambda: body.capsules(q1), reps, 100) * 1e6,
    }
    low = np.array([-1, -1, -3, -0.2, -0.5, -0.3, -1.2, 0.3, -0.5, -0.3, -1.2, 0.3])
    high = np.array([1, 1, 3, 1.0, 2.5, 1.4, 1.2, 2.4, 2.5, 1.4, 1.2, 2.4])
    qs = rng.uniform(low, high, (sizes.ik_samples, 12))
    errors, times = [], []
    for q in qs:
        noisy = body.points(q) + rng.normal(0, 0.01, (8, 3))
        start = time.perf_counter()
        q_hat = body.inverse(noisy, q0=q)
        times.append(time.perf_counter() - start)
        errors.append(np.sqrt(np.mean(np.sum((body.points(q_hat) - body.points(q)) ** 2, axis=-1))))
    out["ik_ms"] = float(np.median(times)) * 1e3
    out["ik_point_rms_noise1cm_mm"] = float(np.median(errors)) * 1e3
    exact = [np.abs(body.inverse(body.points(q)) - q).max() for q in qs[:10]]
    out["ik_exact_max_joint_err"] = float(np.max(exact))

    op = make_operator()
    for k in range(100):
        op.update(k * 0.02)
    out["operator_update_us"] = median_time(lambda: op.update(2.0), reps, 200) * 1e6
    out["operator_q_us"] = median_time(lambda: op.q(2.01), reps, 200) * 1e6
    out["operator_points_us"] = median_time(lambda: op.points(2.01), reps, 200) * 1e6
    out["operator_gaze_us"] = median_time(lambda: op.gaze(2.01), reps, 200) * 1e6

    camera = DepthCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0],
                              [([0.6, 0.3, 0.95], [0.2, 0.2, 0.3]), ([0.3, -0.4, 1.0], [0.1, 0.3, 0.4])])
    particles = rng.normal([0.8, 0.0, 1.1], 0.3, (8, 500, 3))
    caps = (rng.normal([0.3, 0, 1.1], 0.2, (14, 3)), rng.normal([0.3, 0, 1.1], 0.2, (14, 3)),
            np.full(14, 0.05))
    out["hidden_8x500_boxes_ms"] = median_time(lambda: camera.is_hidden(particles), reps, 5) * 1e3
    out["hidden_8x500_boxes_14caps_ms"] = median_time(lambda: camera.is_hidden(particles, caps), reps,
                                                      5) * 1e3
    pts = op.points(2.0)
    out["camera_measure_us"] = median_time(lambda: camera.measure(0.0, pts, np.array([1.0, 0, 0]), rng),
                                           reps, 50) * 1e6
    return out


def bench_drake(sizes: Sizes) -> dict:
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from hrc_drake.human.systems import DepthCamera, OperatorSource

    sim_time = sizes.sim_time
    op = make_operator()
    builder = DiagramBuilder()
    source = builder.AddSystem(OperatorSource(op, rate=50.0))
    camera = builder.AddSystem(DepthCamera(DepthCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0],
                                                            [([0.6, 0.3, 0.95], [0.2, 0.2, 0.3])]), 0))
    builder.Connect(source.GetOutputPort("skeleton"), camera.GetInputPort("skeleton"))
    builder.Connect(source.GetOutputPort("gaze"), camera.GetInputPort("gaze"))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    start = time.perf_counter()
    step = sim_time / 4
    for k in range(1, 5):
        simulator.AdvanceTo(k * step)
        print(f"  drake: simulated {k * step:g} / {sim_time:g} s", flush=True)
    wall = time.perf_counter() - start
    # the operator lives in the context (the system holds only its initial copy)
    operator = source.operator(source.GetMyContextFromRoot(simulator.get_context()))
    actions = sum(1 for e in operator.events if e.kind == "end")
    return {"drake_operator_camera_realtime_factor": sim_time / wall, "drake_sim_s": sim_time,
            "drake_actions_done": actions}


def bench_real_ik(sizes: Sizes) -> dict:
    """IK of the 12-dof model on real upper-limb frames (LEGO assembly, RealSense + OpenPose)."""
    root = data_root() / "lego_assembly_arm"
    if not root.is_dir():
        print(f"  real data: {root} absent, skipped")
        return {}
    files = sorted(root.glob("Task*/Human*/trial*.txt"))
    files = files[: sizes.real_files]
    residuals, times, frames = [], [], 0
    for path in files:
        raw = np.loadtxt(path)
        raw = raw[np.all(np.isfinite(raw), axis=1)]
        # every 5th frame keeps the full run within minutes
        raw = raw[: sizes.real_frames] if sizes.real_frames else raw[::5]
        # camera frame (x right, y down, z depth) -> world (x, depth, up); the subject faces -y
        cam = raw.reshape(-1, 6, 3)
        world = np.stack([cam[..., 0], cam[..., 2], -cam[..., 1]], -1)
        pts = np.full((len(world), 8, 3), np.nan)
        for col, point in enumerate((L_WRIST, R_WRIST, L_ELBOW, R_ELBOW, L_SHOULDER, R_SHOULDER)):
            pts[:, point] = world[:, col]
        def bone(a, b, pts=pts):
            return float(np.median(np.linalg.norm(pts[:, a] - pts[:, b], axis=-1)))

        segments = Segments(shoulder_width=bone(L_SHOULDER, R_SHOULDER),
                            upper_arm=0.5 * (bone(L_SHOULDER, L_ELBOW) + bone(R_SHOULDER, R_ELBOW)),
                            forearm=0.5 * (bone(L_ELBOW, L_WRIST) + bone(R_ELBOW, R_WRIST)))
        body = BodyModel(segments)
        # the camera origin is arbitrary: put the shoulders at the model's upright shoulder height
        shoulder_mid = 0.5 * (pts[:, L_SHOULDER] + pts[:, R_SHOULDER])
        pts[..., 2] += body.hip_height + body.torso - np.median(shoulder_mid[:, 2])
        q = None
        for frame in pts:
            start = time.perf_counter()
            q = body.inverse(frame, q0=q)
            times.append(time.perf_counter() - start)
            visible = np.all(np.isfinite(frame), axis=1)
            residuals.append(np.linalg.norm(body.points(q)[visible] - frame[visible], axis=-1))
            frames += 1
        print(f"  real data: {path.relative_to(root)} {len(pts)} frames", flush=True)
    residuals = np.concatenate(residuals)
    return {"real_ik_frames": frames, "real_ik_median_residual_mm": float(np.median(residuals)) * 1e3,
            "real_ik_p95_residual_mm": float(np.percentile(residuals, 95)) * 1e3,
            "real_ik_ms": float(np.median(times)) * 1e3}


def main(argv: list[str] | None = None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small run (< 1 min)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    args = parser.parse_args(argv)
    sizes = SMOKE if args.smoke else QUICK if args.quick else FULL
    print("human core ...", flush=True)
    figures = bench_core(sizes)
    print("drake diagram ...", flush=True)
    figures.update(bench_drake(sizes))
    print("IK on real data ...", flush=True)
    figures.update(bench_real_ik(sizes))
    figures = {k: (round(v, 4) if isinstance(v, float) else v) for k, v in figures.items()}
    print()
    print(f"{'figure':45s} {'value':>12s}")
    for key, value in figures.items():
        print(f"{key:45s} {value:>12}")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
