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
import re
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
from hrc_drake.human.calibration import CALIBRATION_SECONDS, calibrate_body, fit_errors  # noqa: E402
from hrc_drake.human.config import Segments  # noqa: E402
from hrc_drake.human.importers import (  # noqa: E402
    UE_TAPE_COLUMNS,
    Placement,
    place_in_cell,
    read_kth,
    read_lego,
    read_ue_adl,
    read_ue_anthropometrics,
    resample,
    synthesize_missing,
    ue_static_segment_lengths,
)
from hrc_drake.messages import (  # noqa: E402
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    SKELETON_POINTS,
)
from hrc_drake.motion.geometry import point_capsule_distance  # noqa: E402
from hrc_drake.real_claims import SELECTIONS, load_claims, people_interval, select_people  # noqa: E402
from hrc_drake.real_claims import evaluate as evaluate_claims  # noqa: E402

MODELS = ("gp_a", "gp_b", "gp_c", "worst_case")
PARTS = ("prediction", "tracking", "intention", "gpdm", "importer")
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


#: the sets the pooled (headline) figures take: one reading of each recording (the LEGO trials at
#: their first rate; `lego<rate>` sets stand apart)
HEADLINE_SETS = ("lego", "ue", "kth")
#: what `recordings` learnt of each sequence it returns: its set, its person, the points its source
#: holds fixed (indices; never scored)
SEQUENCE_META: dict[str, dict] = {}


def person_of(name: str) -> str:
    """The person a sequence shows: lego:Task1/Human2/trial1 -> lego:Human2, ue:ADL004FR1 ->
    ue:ADL004, kth:giver -> kth:giver."""
    kind, rest = name.split(":", 1)
    if kind.startswith("lego"):  # the same person at another assumed rate is still that person
        return f"lego:{rest.split('/')[1]}"
    if kind == "ue":
        match = re.fullmatch(r"(.+?)(FR|AR)\d+", rest)
        return f"ue:{match.group(1) if match else rest}"
    return name


def recordings(root: Path, trials: int | None, seconds: float | None,
               read_all: bool = True, people=None, lego_rates=(LEGO_RATE,)) -> tuple[dict, list]:
    """(frames imported per set, [(name, points (T, 8, 3) at RATE, z up)]) of the first `trials`
    trials of each set under `root` (None: all), each cut to `seconds` (None: whole). read_all:
    every trial is read to count the frames of the sets (else only the trials taken). people: the
    UE participants (None: the claims file's tuning people). lego_rates: the rates (Hz) the LEGO
    trials are read at (the source states none): the set `lego` at the first, `lego<rate>` at each
    other."""
    frames, out = {}, []
    sources = []
    try:
        lego = sorted(dataset_dir("lego_assembly_arm", root).glob("Task*/Human*/trial*.txt"))
        for k, rate in enumerate(lego_rates):
            kind = "lego" if k == 0 else f"lego{rate:g}"
            sources += [(f"{kind}:{p.parent.parent.name}/{p.parent.name}/{p.stem}",
                         lambda p=p, rate=rate: read_lego(p, rate)) for p in lego]
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
        SEQUENCE_META[name] = {"set": kind, "person": person_of(name),
                               "fixed": [SKELETON_POINTS.index(p) for p in recording.fixed]}
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


#: a window "moves" when either wrist's mean speed over it, on the recorded points, reaches this (m/s)
MOVING_SPEED = 0.3
#: the measurement noise (m, per axis) of the points the pipeline sees, real and synthetic alike:
#: the synthetic operator's (`bench_motion.simulated_sequence`)
POINT_NOISE = 0.01
#: a reach's onset, detected causally on the measured points: either wrist's speed over the last
#: ONSET_WINDOW s against the ONSET_WINDOW s before reaches ONSET_SPEED (m/s)
ONSET_SPEED, ONSET_WINDOW = 0.15, 0.2
#: the GP models' warm-up on a long recording (s), as before; a UE reach is tested from its onset
WARMUP_S = 3.0


def causal_onset(measured: np.ndarray, rate: float = RATE) -> int | None:
    """The first frame at which either wrist's mean position over the last ONSET_WINDOW s has moved
    ONSET_SPEED m/s from its mean over the window before: only past frames are read."""
    w = max(1, int(round(ONSET_WINDOW * rate)))
    wrists = measured[:, [L_WRIST, R_WRIST]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN window
        for k in range(2 * w - 1, len(measured)):
            now = np.nanmean(wrists[k - w + 1 : k + 1], axis=0)
            before = np.nanmean(wrists[k - 2 * w + 1 : k - w + 1], axis=0)
            speed = np.linalg.norm(now - before, axis=1) / (w / rate)
            if np.any(speed >= ONSET_SPEED):
                return k
    return None


def window_speeds(truth: np.ndarray, steps: int) -> np.ndarray:
    """Per window [k, k + steps] the larger of the two wrists' mean speeds over it (m/s, NaN where
    neither wrist is recorded at both ends), on the recorded points."""
    wrists = truth[:, [L_WRIST, R_WRIST]]
    speed = np.linalg.norm(wrists[steps:] - wrists[:-steps], axis=-1) / (steps / RATE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmax(speed, axis=1)


def deployed_misses(predictor, deltas, filtered, measured, truth, warmup: int, scored) -> dict:
    """The measured points of the next `predictor.steps` samples (`scored` ones: never a point the
    source holds fixed) against the swept volumes of each step from `warmup` on, counted apart
    for the windows where the person moves (`MOVING_SPEED` on the recorded points) and all."""
    steps = predictor.steps
    speeds = window_speeds(truth, steps)
    out = {"tested_moving": 0, "misses_moving": [], "tested_all": 0, "misses_all": [], "windows": 0,
           "windows_moving": 0}
    for k in range(warmup, len(filtered) - steps):
        future = measured[k : k + steps + 1][:, scored].reshape(-1, 3)
        future = future[np.all(np.isfinite(future), axis=1)]
        if not len(future) or not np.isfinite(speeds[k]):
            continue
        start, end, radius = predictor.builder.build(filtered[k], deltas[k, 0], deltas[k, 1])
        gap = point_capsule_distance(future, start, end, radius).min(axis=1)
        moving = bool(speeds[k] >= MOVING_SPEED)
        out["windows"] += 1
        out["tested_all"] += len(gap)
        out["misses_all"] += gap[gap > 0].tolist()
        if moving:
            out["windows_moving"] += 1
            out["tested_moving"] += len(gap)
            out["misses_moving"] += gap[gap > 0].tolist()
    return out


def evaluate_deployed(name: str, truth: np.ndarray, n_trials: int, seed: int, fixed=(),
                      from_onset: bool = False) -> dict:
    """8.1 on one sequence as a cell runs it: the points measured with `POINT_NOISE`, the body
    calibrated from their first seconds (`human.calibration`, seated people included, no raise),
    the tracking IK on them, each model's swept volumes against the measured future points. The
    test starts after `WARMUP_S`, or with `from_onset` at the reach's causally detected onset."""
    rng = np.random.default_rng(seed)
    measured = truth + rng.normal(0.0, POINT_NOISE, truth.shape)
    if from_onset:
        onset = causal_onset(measured)
        warmup = max(ORDER + 2, onset) if onset is not None else len(measured)
        # the body from the frames before the reach only: nothing the scored windows see
        calibration = calibrate_body(measured[: max(1, warmup)], RATE)
    else:
        warmup = int(round(WARMUP_S * RATE))
        calibration = calibrate_body(measured, RATE)  # its first 2 s, inside the warm-up
    body = BodyModel(calibration.segments)
    qs, stds = joint_sequence(body, measured, 0.02)
    scored = [k for k in ARM_POINTS if k not in set(fixed)]
    out = {"fit_error_m": float(np.nanmedian(fit_errors(body, truth, scored))),
           "seated": calibration.seated,
           "hip_height_m": calibration.segments.hip_height, "warmup_frames": int(warmup)}
    for kind in MODELS:
        predictor, deltas, filtered, _ = run_model(body, qs, stds, kind, ORDER, 1.0 / RATE, n_trials, HORIZON,
                                                   min(warmup, len(qs)))
        out[kind] = deployed_misses(predictor, deltas, filtered, measured, truth, warmup, scored)
    return out


def _pooled_fraction(rows: list[dict], kind: str, part: str) -> float:
    tested = sum(r[kind][f"tested_{part}"] for r in rows)
    return sum(len(r[kind][f"misses_{part}"]) for r in rows) / tested if tested else math.nan


def _p90(misses: list, tested: int) -> float:
    return float(np.percentile(misses, 90)) if misses else (0.0 if tested else math.nan)


def summarise_deployed(rows: list[tuple[str, dict]]) -> dict:
    """Per model over (person, row) pairs, the person the unit: the mean over people of their miss
    fraction in moving windows with its 95 % interval (`real_claims.people_interval`: Student's t,
    widened to the pooled counts' exact interval), the same for their p90 miss distance there,
    the pooled figures beside, the idle share (windows where nobody moves), the miss fraction over
    every window, and each person's figure. People with no moving window have no figure."""
    by_person: dict[str, list[dict]] = {}
    for person, row in rows:
        by_person.setdefault(person, []).append(row)
    all_rows = [row for _, row in rows]
    out = {}
    for kind in MODELS:
        windows = sum(r[kind]["windows"] for r in all_rows)
        tested = sum(r[kind]["tested_moving"] for r in all_rows)
        misses = [m for r in all_rows for m in r[kind]["misses_moving"]]
        per_person, p90s = {}, {}
        for person, person_rows in sorted(by_person.items()):
            person_tested = sum(r[kind]["tested_moving"] for r in person_rows)
            if person_tested:
                person_misses = [m for r in person_rows for m in r[kind]["misses_moving"]]
                per_person[person] = len(person_misses) / person_tested
                p90s[person] = _p90(person_misses, person_tested)
        fraction, fraction_ci, n = people_interval(list(per_person.values()), (len(misses), tested))
        p90, p90_ci, _ = people_interval(list(p90s.values()))
        out[kind] = {
            "miss_fraction_moving": fraction,
            "miss_fraction_moving.ci95": fraction_ci,
            "miss_fraction_moving.people": n,
            "miss_fraction_moving_pooled": len(misses) / tested if tested else None,
            "miss_p90_m_moving": p90,
            "miss_p90_m_moving.ci95": p90_ci,
            "miss_p90_m_moving.people": n,
            "miss_p90_m_moving_pooled": _p90(misses, tested) if tested else None,
            "idle_share": (1.0 - sum(r[kind]["windows_moving"] for r in all_rows) / windows) if windows
            else None,
            "miss_fraction_all": _pooled_fraction(all_rows, kind, "all"),
            "windows": windows,
            "people": len(by_person),
            "per_person": per_person,
        }
    return out


def prediction_deployed(sequences, seconds_synthetic: float, n_trials: int, seed: int = 0) -> dict:
    """8.1 as deployed (`evaluate_deployed`) on every real sequence, summarised over people, per set
    and for the synthetic operator by the same procedure; each person's body fit error."""
    log(f"\n8.1 as deployed: windows scored where a wrist moves >= {MOVING_SPEED} m/s; points measured "
        f"with {POINT_NOISE} m noise; body from the first {CALIBRATION_SECONDS:g} s")
    rows, fits = [], {}
    for index, (name, points) in enumerate(sequences):
        meta = SEQUENCE_META[name]  # every sequence comes from `recordings`
        row = evaluate_deployed(name, points, n_trials, seed=1000 * seed + index, fixed=meta["fixed"],
                                from_onset=meta["set"] == "ue")
        rows.append((meta["person"], meta["set"], row))
        fits.setdefault(meta["set"], {}).setdefault(meta["person"], []).append(row["fit_error_m"])
        c = row["gp_c"]
        log(f"  {name[:28]:<28} fit {row['fit_error_m']:.3f} m{' seated' if row['seated'] else ''}; model C "
            f"moving {len(c['misses_moving'])}/{c['tested_moving']} missed, windows {c['windows_moving']}/"
            f"{c['windows']} moving")
    truth = synthetic_points(seconds_synthetic, seed=7)
    synthetic = evaluate_deployed("synthetic operator", truth, n_trials, seed=7)
    figures = {
        # the headline pools one reading of each recording: the LEGO trials at their first rate only
        "prediction": summarise_deployed([(p, r) for p, s, r in rows if s in HEADLINE_SETS]),
        "prediction_by_set": {kind: summarise_deployed([(p, r) for p, s, r in rows if s == kind])
                              for kind in sorted({s for _, s, _ in rows})},
        "prediction_synthetic": summarise_deployed([("synthetic", synthetic)]),
        "prediction_settings": {"moving_speed_mps": MOVING_SPEED, "point_noise_m": POINT_NOISE,
                                "calibration_s": CALIBRATION_SECONDS, "warmup_s": WARMUP_S,
                                "ue_from_causal_onset": {"speed_mps": ONSET_SPEED, "window_s": ONSET_WINDOW},
                                "fixed_points_scored": False},
    }
    figures["body_fit_error_m"] = body_fit_figures(fits)
    for kind in MODELS:
        r, s = figures["prediction"][kind], figures["prediction_synthetic"][kind]
        log(f"  {kind:<11} real moving {_percent(r['miss_fraction_moving'])} "
            f"{r['miss_fraction_moving.ci95']} "
            f"(p90 {r['miss_p90_m_moving']:.3f} m, idle share {_percent(r['idle_share'])}); synthetic "
            f"{_percent(s['miss_fraction_moving'])}")
    return figures


def _percent(value) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{100 * value:.2f} %"


def body_fit_figures(fits: dict) -> dict:
    """The body fit error (m; the calibrated body's tracking IK against the recorded arm points,
    median over frames): per person (median over their sequences), over the UE people (seated)
    their mean with its 95 % interval (`real_claims.people_interval`) and their median, and per set."""
    per_person = {person: float(np.median(values))
                  for by_set in fits.values() for person, values in by_set.items()}
    out = {"per_person": per_person}
    ue = [value for person, value in per_person.items() if person.startswith("ue:")]
    if ue:
        out["mean"], out["mean.ci95"], out["mean.people"] = people_interval(ue)
        out["median"] = float(np.median(ue))
    out["by_set"] = {kind: float(np.median([np.median(v) for v in by_set.values()]))
                     for kind, by_set in fits.items()}
    return out


def with_particles(specs: dict, particles: int) -> dict:
    """The tracker specs with every particle filter's particle count set to `particles`."""
    return {name: (kind, {**options, "particles": particles} if "particles" in options else options)
            for name, (kind, options) in specs.items()}


def gpdm_part(root: Path, quick: bool, people=None, oracle: bool = False) -> dict:
    """8.2's GPDM on the seated reaches (`real_gpdm`): the same person's other trials train it,
    each reach begins where a cell detects it from the past; with `oracle` also the former begin,
    segmented from the whole trial, as a labelled comparison."""
    result = gpdm_figures(root, seed=0, quick=quick, people=people, causal=True)
    out = {"gpdm": result["real"], "gpdm_synthetic": result["synthetic"],
           "gpdm_settings": result["settings"], "gpdm_sweep": result["sweep"]}
    if oracle:
        segmented = gpdm_figures(root, seed=0, quick=True, people=people, causal=False)
        out["gpdm_oracle_segmented_begin"] = segmented["real"]
    return out


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
    parser.add_argument("--lego-rates", default=None,
                        help="the rates (Hz) to read the LEGO trials at, comma-separated: the source states "
                             "none (default: 15,30; 15 with --quick or --smoke)")
    parser.add_argument("--oracle", action="store_true",
                        help="also the former pipeline (whole-file body, shoulders raised), labelled a "
                             "comparison")
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
    lego_rates = tuple(float(r) for r in (args.lego_rates or ("15" if quick else "15,30")).split(","))
    frames, sequences = recordings(root, trials, seconds, read_all=not args.smoke, people=people,
                                   lego_rates=lego_rates)
    log(f"imported frames per set: {frames}")
    figures = {
        "quick": bool(args.quick),
        "horizon_s": HORIZON,
        "order": ORDER,
        "rate_hz": RATE,
        "sequences": [name for name, _ in sequences],
        "frames_imported": frames,
        "people": {"selection": selection, "ue_adl": list(people),
                   "tuning": list(load_claims().people_of("ue_adl", "tuning")),
                   "test": list(load_claims().people_of("ue_adl", "test"))},
        "seconds_tested": {"real": sum(len(p) for _, p in sequences) / RATE, "synthetic": synthetic_s},
    }
    parts = args.parts.split(",")
    if "prediction" in parts:
        figures.update(prediction_deployed(sequences, synthetic_s, n_trials))
        if args.oracle:  # a labelled comparison, never the headline
            log("\n== 8.1 with the oracle body fit (whole-file lengths, shoulders raised to standing), "
                "every window, no noise: a comparison")
            oracle = prediction_part(sequences, synthetic_s, n_trials)
            figures["prediction_oracle_body_fit"] = {key: value for key, value in oracle.items()
                                                     if key != "wrist_speed_mps"}
            figures["wrist_speed_mps"] = oracle["wrist_speed_mps"]
    if "importer" in parts:
        figures["importer"] = importer_figures(root, people)
    if "tracking" in parts:
        log("\n== tracking (Ch. 9): real and synthetic arms through the cell's camera, occluders added")
        headline = [(name, points) for name, points in sequences if name.split(":")[0] in HEADLINE_SETS]
        figures.update(tracking_figures(headline, synthetic_points(synthetic_s, seed=7), seed=0,
                                        quick=quick, trackers=trackers, person_of=person_of))
    if "intention" in parts:
        log("\n== intention (3.1): the seated reaches, forward / across / rest")
        intention = intention_figures(root, seed=0, quick=quick, people=people)
        figures["intention_detail"] = intention
        for key, value in intention_keys(intention).items():
            prefix, model, name = key.split(".", 2)
            figures.setdefault(prefix, {}).setdefault(model, {})[name] = value
    if "gpdm" in parts:
        log("\n== GPDM (8.2) trained on the seated reaches, 0.3 s ahead")
        figures.update(gpdm_part(root, quick, people, args.oracle))
    figures["claims"] = evaluate_claims(load_claims(), flatten(figures), selection)
    log("\nclaims (docs/real_claims.yaml):")
    for ident, entry in figures["claims"].items():
        why = f"; {entry['why']}" if entry["why"] else ""
        log(f"  {ident:<38} {entry['verdict']:<14} {entry['key']} = {entry['estimate']} {entry['ci95']} "
            f"(rule {entry['rule']}; {entry['people_in_interval']} people){why}")
    print(json.dumps(figures))


def flatten(figures: dict, prefix: str = "") -> dict:
    """The figures' nested mappings as one level of dotted keys (lists and values kept whole)."""
    out = {}
    for key, value in figures.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, f"{name}."))
        else:
            out[name] = value
    return out


def importer_figures(root: Path, people) -> dict:
    """The UE importer's segments against the tape measures (`anthropometrics.csv`): per person the
    mean absolute error (mm) of the four arm segments of their static trial (acromion to elbow,
    elbow to wrist), and the median over people with its 95 % interval."""
    folder = dataset_dir("ue_adl", root)
    tape_path = folder / "anthropometrics.csv"
    if not tape_path.exists():
        return {"segment_error_mm": {"skipped": f"no {tape_path}"}}
    tape = read_ue_anthropometrics(tape_path)
    per_person = {}
    for person in people:
        if person not in tape:
            continue
        lengths = ue_static_segment_lengths(folder / person / f"{person}_static.csv")
        per_person[person] = float(np.mean([abs(lengths[c] - tape[person][c]) for c in UE_TAPE_COLUMNS]))
    if not per_person:
        return {"segment_error_mm": {"skipped": "no person with a tape measure"}}
    mean, ci, n = people_interval(list(per_person.values()))
    median = float(np.median(list(per_person.values())))
    log("\nimporter: arm segments against the tape, mean |error| per person (mm): "
        + ", ".join(f"{p} {v:.0f}" for p, v in per_person.items()) + f"; mean {mean:.1f} mm {ci}")
    return {"segment_error_mm": {"mean": mean, "mean.ci95": ci, "mean.people": n, "median": median,
                                 "per_person": per_person}}


if __name__ == "__main__":
    main()
