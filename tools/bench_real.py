"""Human-side systems on real people (issue 37): every shipped recording set imported
(`hrc_drake.human.importers`) and each human-side system judged on it, the synthetic operator
beside it by the same procedure (the gap between the two is the point).

prediction (8.1) Each sequence (every trial of every set, or --trials / --seconds; --quick: one
    trial per set, 12 s) is placed upright, resampled to 30 Hz (the cells' camera rate), its
    shoulders put at the standing body model's height (`standing`), fitted by the body model's IK
    and fed step by step to the GP models A, B, C (P = 4) and the worst-case model [107]
    (`bench_motion.run_model`). The GP models of 8.1 are fit online on the operator's own last
    samples, so every step trains on the part of the trial before it and tests on what follows
    (a model trained on one person and tested on another is not how 8.1 uses them). After a 3 s
    warm-up the swept volumes of each step are tested against the recorded arm points
    (shoulders, elbows, wrists) of the next 0.3 s: `miss_fraction` is the share outside every
    volume, `miss_median_m` / `miss_p90_m` how far the missing ones lie outside, `volume_m3` the
    summed capsule volume (median over steps); `joint_eps_violation_rate` the joint-space eps of
    8.1.3. Wrist speeds (median, p95) say how the motions differ.
tracking (Ch. 9) `real_tracking`: the sequences through the analytic camera of pcb_occlusion.yaml
    with its shelves, plus occluder panels hiding a wrist, an elbow or both during seeded 1-3 s
    windows; hold, kf2, kf4, pf and two pf variants on the same frames: RMS error of the hidden
    points and the coverage of each tracker's belief region with its volume.
intention (3.1) `real_intention`: the UE seated reaches (forward, across, and the rest position
    as goals placed from the other trials); when M1, M2, M3 first commit (0.8) to the right
    target, as a fraction of the reach, and how often a wrong target reaches 0.8.
gpdm (8.2) `real_gpdm`: one GPDM per reach kind fitted on the same person's other trials (leave
    one out) predicts the arm 0.3 s ahead, against constant-velocity extrapolation.

Usage:
    python3 tools/bench_real.py [--quick | --smoke] [--data DIR] [--people tuning|test|all|folder]
        [--parts prediction,tracking,intention,gpdm] [--trials N] [--seconds S]
--people: which UE participants (docs/real_claims.yaml splits the shipped ones into tuning and
test people; `folder` takes every participant of --data's folder, e.g. held-out ones); default:
tuning for the shipped data, folder for --data.
--smoke: every part once on the smallest setting (one trial per set, 3.5 s each, only the trials
taken are read, 5 Monte Carlo trials, 50 particles, the other tools' quick settings): figures
meaningless.
Last line: one JSON object (frames_imported.<set>, prediction.<model>.*,
prediction_synthetic.<model>.*, tracking.<tracker>.*, tracking_synthetic.<tracker>.*,
intention.<model>.*, intention_synthetic.<model>.*, gpdm.*, gpdm_synthetic.*).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

TOOLS = Path(__file__).resolve().parent
sys.path.insert(0, str(TOOLS.parent))
sys.path.insert(0, str(TOOLS))

from bench_motion import GROUPS, epsilons, joint_sequence, run_model, simulated_sequence  # noqa: E402
from real_gpdm import gpdm_figures  # noqa: E402
from real_intention import bench_keys as intention_keys  # noqa: E402
from real_intention import intention_figures  # noqa: E402
from real_tracking import TRACKERS, synthetic_points, tracking_figures  # noqa: E402

from hrc_drake.datasets import data_root, dataset_dir  # noqa: E402
from hrc_drake.human.body import BodyModel  # noqa: E402
from hrc_drake.human.config import Segments  # noqa: E402
from hrc_drake.human.importers import (  # noqa: E402
    Placement,
    place_in_cell,
    read_kth,
    read_lego,
    read_ue_adl,
    resample,
    synthesize_missing,
)
from hrc_drake.messages import L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST  # noqa: E402
from hrc_drake.motion.geometry import point_capsule_distance  # noqa: E402
from hrc_drake.real_claims import SELECTIONS, select_people  # noqa: E402

MODELS = ("gp_a", "gp_b", "gp_c", "worst_case")
PARTS = ("prediction", "tracking", "intention", "gpdm")
#: the trackers of 9.1.3 (hold, kf2, kf4, pf) and two particle-filter variants beside them: the
#: literal bootstrap PF for seen points too (`bootstrap_tracked`), and hidden points starting at
#: rest (`hidden_at_rest`, ours, after the drift this bench found on real arms)
TRACKER_SPECS = {**TRACKERS,
                 "pf_bootstrap": ("particle_filter", {"particles": 500, "bootstrap_tracked": 1}),
                 "pf_at_rest": ("particle_filter", {"particles": 500, "hidden_at_rest": 1})}
#: joint-space eps of 8.1.3 (bench_motion): the share of (sample, joint) pairs whose real excursion
#: over the horizon left the predicted interval, on the IK's filtered joints
JOINT_GROUPS = ("shoulders", "elbows")
ARM_POINTS = [L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST]
RATE = 30.0
HORIZON = 0.3
ORDER = 4
#: the LEGO set does not state its rate (4.5 mm of wrist motion per frame: 15-30 Hz)
LEGO_RATE = 15.0


def log(text: str) -> None:
    print(text, flush=True)


def recordings(root: Path, trials: int | None, seconds: float | None,
               read_all: bool = True, people=None) -> tuple[dict, list]:
    """(frames imported per set, [(name, points (T, 8, 3) at RATE, z up)]) of the first `trials`
    trials of each set under `root` (None: all), each cut to `seconds` (None: whole). read_all:
    every trial is read to count the frames of the sets (else only the trials taken). people: the
    UE participants (None: the claims file's tuning people)."""
    frames, out = {}, []
    sources = []
    try:
        lego = sorted(dataset_dir("lego_assembly_arm", root).glob("Task*/Human*/trial*.txt"))
        sources += [
            (f"lego:{p.parent.parent.name}/{p.parent.name}/{p.stem}", lambda p=p: read_lego(p, LEGO_RATE))
            for p in lego
        ]
    except FileNotFoundError as err:
        log(f"skipped: {err}")
    try:
        folder = dataset_dir("ue_adl", root)
        chosen = select_people(folder, "tuning") if people is None else tuple(people)
        ue = sorted(p for person in chosen for p in (folder / person).glob("*.csv") if "static" not in p.name)
        sources += [(f"ue:{p.stem}", lambda p=p: read_ue_adl(p)) for p in ue]
    except FileNotFoundError as err:
        log(f"skipped: {err}")
    try:
        kth = dataset_dir("kth_handover", root)
        sources += [
            (f"kth:{person}", lambda person=person: read_kth(kth, person)) for person in ("giver", "taker")
        ]
    except FileNotFoundError as err:
        log(f"skipped: {err}")
    taken: dict[str, int] = {}
    for name, read in sources:
        kind = name.split(":")[0]
        enough = trials is not None and taken.get(kind, 0) >= trials
        if enough and not read_all:
            continue
        recording = read()
        frames[kind] = frames.get(kind, 0) + recording.frames
        if enough:
            continue
        try:
            placed, _, _ = place_in_cell(synthesize_missing(recording), Placement())
        except ValueError as err:  # e.g. a shoulder the source never recorded (flag_stuck_points)
            log(f"skipped {name}: {err}")
            continue
        taken[kind] = taken.get(kind, 0) + 1
        points = resample(placed, RATE).points
        out.append((name, points if seconds is None else points[: int(seconds * RATE)]))
    return frames, out


def arm_speeds(points: np.ndarray) -> np.ndarray:
    """Speeds (m/s) of the wrists between consecutive frames at RATE where both are recorded."""
    wrists = points[:, [L_WRIST, R_WRIST]]
    speed = np.linalg.norm(np.diff(wrists, axis=0), axis=-1).ravel() * RATE
    return speed[np.isfinite(speed)]


def speed_summary(speeds: list[np.ndarray]) -> dict:
    joined = np.concatenate(speeds) if speeds else np.zeros(0)
    if not joined.size:
        return {"median": None, "p95": None}
    return {"median": float(np.median(joined)), "p95": float(np.percentile(joined, 95))}


def body_of(points: np.ndarray) -> BodyModel:
    """A body model with the recording's segment lengths (medians over frames)."""

    def length(a, b):
        return float(np.nanmedian(np.linalg.norm(points[:, a] - points[:, b], axis=-1)))

    upper = 0.5 * (length(L_SHOULDER, L_ELBOW) + length(R_SHOULDER, R_ELBOW))
    fore = 0.5 * (length(L_ELBOW, L_WRIST) + length(R_ELBOW, R_WRIST))
    width = length(L_SHOULDER, R_SHOULDER)
    return BodyModel(Segments(shoulder_width=width, upper_arm=upper, forearm=fore))


def cartesian_misses(predictor, deltas, filtered, points, warmup: int) -> dict:
    """The recorded arm points of the next `predictor.steps` samples against the swept volumes of
    each step: miss fraction, miss distances (median, p90), mean summed capsule volume."""
    steps = predictor.steps
    outside, misses, volumes = 0, [], []
    total = 0
    for k in range(warmup, len(filtered) - steps):
        start, end, radius = predictor.builder.build(filtered[k], deltas[k, 0], deltas[k, 1])
        future = points[k : k + steps + 1][:, ARM_POINTS].reshape(-1, 3)
        future = future[np.all(np.isfinite(future), axis=1)]
        if not len(future):
            continue
        gap = point_capsule_distance(future, start, end, radius).min(axis=1)
        total += len(gap)
        outside += int(np.sum(gap > 0))
        misses += gap[gap > 0].tolist()
        lengths = np.linalg.norm(np.asarray(end) - np.asarray(start), axis=1)
        radius = np.asarray(radius)
        volumes.append(float(np.sum(math.pi * radius**2 * lengths + 4.0 / 3.0 * math.pi * radius**3)))
    return {
        "miss_fraction": outside / total if total else math.nan,
        "miss_median_m": float(np.median(misses)) if misses else 0.0,
        "miss_p90_m": float(np.percentile(misses, 90)) if misses else 0.0,
        "volume_m3": float(np.median(volumes)) if volumes else math.nan,
        "points_tested": total,
        "misses_m": misses,
    }


def standing(points: np.ndarray, body: BodyModel) -> np.ndarray:
    """The points raised or lowered so that their median shoulder height is the body model's
    upright one (hip + torso): the model stands (its hip height is fixed), and a seated person's
    lower shoulders made the IK lean the torso to reach them (LEGO Task1/Human1/trial1: 13 cm
    shoulder error, 25 % of the arm points outside the capsules fitted to their own frame)."""
    shoulders = np.nanmedian(points[:, [L_SHOULDER, R_SHOULDER], 2])
    return points + np.array([0.0, 0.0, body.hip_height + body.torso - shoulders])


def evaluate(name: str, body: BodyModel, points: np.ndarray, n_trials: int) -> dict:
    dt = 1.0 / RATE
    qs, stds = joint_sequence(body, points, 0.02)
    warmup = int(round(3.0 / dt))
    out = {}
    for kind in MODELS:
        start = time.perf_counter()
        predictor, deltas, filtered, _ = run_model(body, qs, stds, kind, ORDER, dt, n_trials, HORIZON, warmup)
        out[kind] = cartesian_misses(predictor, deltas, filtered, points, warmup)
        row = out[kind]
        if len(filtered) > warmup + predictor.steps:
            eps_plus, eps_minus = epsilons(deltas, filtered, predictor.steps, warmup)
        else:  # a recording shorter than the warm-up and one horizon (a UE reach): nothing to test
            eps_plus = eps_minus = np.zeros((0, 12))
        row["joint_misses"] = {group: int(np.sum((eps_plus[:, GROUPS[group]] < 0)
                                                 | (eps_minus[:, GROUPS[group]] < 0)))
                               for group in JOINT_GROUPS}
        row["joint_samples"] = {group: int(eps_plus[:, GROUPS[group]].size) for group in JOINT_GROUPS}
        log(
            f"{name[:30]:<30} {kind:<11} {100 * row['miss_fraction']:7.2f} {row['miss_median_m']:8.3f} "
            f"{row['miss_p90_m']:8.3f} {row['volume_m3']:9.4f} {time.perf_counter() - start:7.1f}"
        )
    return out


def pooled(rows: list[dict]) -> dict:
    """Per model over all sequences: the share of future points missed, the distances of every
    miss (median, p90), the median of the sequences' median summed volumes."""
    out = {}
    for kind in MODELS:
        tested = sum(r[kind]["points_tested"] for r in rows)
        misses = [m for r in rows for m in r[kind]["misses_m"]]
        out[kind] = {
            "miss_fraction": len(misses) / tested if tested else None,
            "miss_median_m": float(np.median(misses)) if misses else 0.0,
            "miss_p90_m": float(np.percentile(misses, 90)) if misses else 0.0,
            "volume_m3": float(np.median([r[kind]["volume_m3"] for r in rows])),
            "joint_eps_violation_rate": {
                group: sum(r[kind]["joint_misses"][group] for r in rows)
                / max(1, sum(r[kind]["joint_samples"][group] for r in rows))
                for group in JOINT_GROUPS
            },
        }
    return out


def prediction_part(sequences, seconds_synthetic: float, n_trials: int) -> dict:
    """8.1 on real motion: each sequence's Cartesian misses and joint eps per model, pooled over
    all, per set, and for the synthetic operator over `seconds_synthetic` s; wrist speeds beside."""
    log(f"\n{'sequence':<30} {'model':<11} {'miss %':>7} {'med m':>8} {'p90 m':>8} {'vol m3':>9} {'s':>7}")
    rows, speeds = {}, {}
    for name, points in sequences:
        body = body_of(points)
        kind = name.split(":")[0]
        rows.setdefault(kind, []).append(evaluate(name, body, standing(points, body), n_trials))
        speeds.setdefault(kind, []).append(arm_speeds(points))
    body, synthetic = simulated_sequence(seconds_synthetic, 1.0 / RATE, seed=7)
    synthetic_row = evaluate("synthetic operator", body, synthetic, n_trials)
    real = [row for kind_rows in rows.values() for row in kind_rows]
    figures = {
        "prediction": pooled(real),
        "prediction_by_set": {kind: pooled(kind_rows) for kind, kind_rows in rows.items()},
        "prediction_synthetic": pooled([synthetic_row]),
        "wrist_speed_mps": {**{kind: speed_summary(v) for kind, v in speeds.items()},
                            "real": speed_summary([x for v in speeds.values() for x in v]),
                            # the operator's own motion: the test sequence carries 1 cm of noise,
                            # whose frame differences alone read as 0.7 m/s at 30 Hz
                            "synthetic": speed_summary([arm_speeds(synthetic_points(seconds_synthetic,
                                                                                     seed=7))])},
    }
    log("\npooled over the real sequences (every future point tested, every miss):")
    for kind in MODELS:
        r, s = figures["prediction"][kind], figures["prediction_synthetic"][kind]
        if r["miss_fraction"] is None or s["miss_fraction"] is None:
            log(f"  {kind:<11} nothing tested (recordings shorter than the 3 s warm-up)")
            continue
        log(
            f"  {kind:<11} real {100 * r['miss_fraction']:6.2f} % (p90 {r['miss_p90_m']:.3f} m, "
            f"{r['volume_m3']:.4f} m3)   synthetic {100 * s['miss_fraction']:6.2f} % "
            f"(p90 {s['miss_p90_m']:.3f} m, {s['volume_m3']:.4f} m3)"
        )
    for kind, row in figures["wrist_speed_mps"].items():
        if row["median"] is not None:
            log(f"  wrist speed {kind:<10} median {row['median']:.3f} m/s, p95 {row['p95']:.3f} m/s")
    return figures


def with_particles(specs: dict, particles: int) -> dict:
    """The tracker specs with every particle filter's particle count set to `particles`."""
    return {name: (kind, {**options, "particles": particles} if "particles" in options else options)
            for name, (kind, options) in specs.items()}


def gpdm_part(root: Path, quick: bool, people=None) -> dict:
    """8.2's GPDM on the seated reaches (`real_gpdm`): the same person's other trials train it."""
    result = gpdm_figures(root, seed=0, quick=quick, people=people)
    return {"gpdm": result["real"], "gpdm_synthetic": result["synthetic"],
            "gpdm_settings": result["settings"], "gpdm_sweep": result["sweep"]}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="one trial per set, 12 s each (about a minute)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--trials", type=int, default=None, help="trials per set (default: all)")
    parser.add_argument("--seconds", type=float, default=None,
                        help="cut each recording to this length (default: whole)")
    parser.add_argument("--data", default=None, help="a data folder laid out like data/ (default: it)")
    parser.add_argument("--people", choices=SELECTIONS, default=None,
                        help="the UE participants: a split of docs/real_claims.yaml or every one in the "
                             "folder (default: tuning for data/, folder for --data)")
    parser.add_argument("--parts", default=",".join(PARTS),
                        help=f"comma-separated parts to run (default: all of {','.join(PARTS)})")
    args = parser.parse_args(argv)
    unknown = set(args.parts.split(",")) - set(PARTS)
    if unknown:
        parser.error(f"--parts: unknown {sorted(unknown)}; known: {', '.join(PARTS)}")
    warnings.filterwarnings("ignore")
    trackers = TRACKER_SPECS
    if args.smoke:  # past the 3 s warm-up by a few horizons: the prediction is tested at a few steps
        trials, seconds, n_trials, synthetic_s = 1, 3.5, 5, 3.5
        trackers = with_particles(TRACKER_SPECS, 50)
    elif args.quick:
        trials, seconds, n_trials, synthetic_s = 1, 12.0, 30, 12.0
    else:
        trials, seconds, n_trials, synthetic_s = args.trials, args.seconds, 50, 120.0
    # the other tools have a quick setting, none smaller
    quick = args.quick or args.smoke
    root = data_root(args.data)
    selection = args.people or ("folder" if args.data else "tuning")
    try:
        people = select_people(dataset_dir("ue_adl", root), selection)
    except FileNotFoundError:
        people = ()
    log(f"real recordings from {root} ({trials or 'all'} trial(s) per set, "
        f"{f'{seconds:g} s' if seconds else 'whole'} each, {RATE:g} Hz); UE people ({selection}): "
        f"{', '.join(people) or 'none'}")
    frames, sequences = recordings(root, trials, seconds, read_all=not args.smoke, people=people)
    log(f"imported frames per set: {frames}")
    figures = {
        "quick": bool(args.quick),
        "horizon_s": HORIZON,
        "order": ORDER,
        "rate_hz": RATE,
        "sequences": [name for name, _ in sequences],
        "frames_imported": frames,
        "people": {"selection": selection, "ue_adl": list(people)},
        "seconds_tested": {"real": sum(len(p) for _, p in sequences) / RATE, "synthetic": synthetic_s},
    }
    parts = args.parts.split(",")
    if "prediction" in parts:
        figures.update(prediction_part(sequences, synthetic_s, n_trials))
    if "tracking" in parts:
        log("\n== tracking (Ch. 9): real and synthetic arms through the cell's camera, occluders added")
        figures.update(tracking_figures(sequences, synthetic_points(synthetic_s, seed=7), seed=0,
                                        quick=quick, trackers=trackers))
    if "intention" in parts:
        log("\n== intention (3.1): the seated reaches, forward / across / rest")
        intention = intention_figures(root, seed=0, quick=quick, people=people)
        figures["intention_detail"] = intention
        for key, value in intention_keys(intention).items():
            prefix, model, name = key.split(".")
            figures.setdefault(prefix, {}).setdefault(model, {})[name] = value
    if "gpdm" in parts:
        log("\n== GPDM (8.2) trained on the seated reaches, 0.3 s ahead")
        figures.update(gpdm_part(root, quick, people))
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
