"""The GPDM of thesis 8.2.2 trained on real reaches (issue 37): its prediction error at the cells'
0.3 s horizon against constant-velocity extrapolation, on the UE seated reaches and on the
project's synthetic operator doing the same two reaches.

Observation vector: the moving arm's shoulder, elbow and wrist (9 numbers), as
`motion.proactive` records a realisation (8.2.2: "the position in the space of some points of
interest"); the right arm in every trial here. GPDM settings are the `ProactivePlanner` defaults
(latent_dim 3, 100 L-BFGS iterations).

Reach segmentation (`segment_reach`): the right wrist's speed (central differences at 30 Hz);
the reach runs from the last frame before the speed peak whose speed is below 10 % of the peak
to the first frame after it below 10 % of the peak. One reach per trial.

Prediction task, the same for every predictor: one GPDM per action kind (FR forward reach, AR
reach across) fitted on the segmented realisations of the other trials, leave one trial out:
"same person" trains on that person's other trials of the kind (4), "other person" on the other
person's trials of the kind (5). At every frame t of the held-out reach (start <= t <= end) the
arm's three points at t + 0.3 s are predicted by
  - gpdm (8.2's alignment): Phi (eq. 8.26, median training length) starts at the action's begin
    event, here the segmented start: Phi_k is the pose at start + k frames, its last pose held
    after its end. 8.2 never aligns Phi otherwise: its cloud (8.27-8.28) is time-independent;
  - gpdm_phase (not in the thesis): Phi indexed by the phase that best matches the last 0.1 s
    observed (`phase_index`), then advanced by the horizon;
  - gpdm_anchored (not in the thesis): as gpdm, Phi translated (each point) so that its first pose
    is the observed pose at the begin event (a spatial, not a temporal, alignment);
  - constant_velocity: the current points plus the horizon times their velocity over the last
    frame (`constant_velocity`; the best window of the sweep in `sweep`);
  - hold: the current points.
rms_m = sqrt(mean |error|^2) over every predicted point (3 points x frames x trials);
remaining_rms_m the same over every later frame of the reach (the whole remaining trajectory).

Synthetic: `SyntheticOperator` (ideal behaviour) alternating the two reaches with a return to
rest, goals at the real targets' cell positions (ADL001), two persons (default and 0.92-scaled
anthropometrics), 2 mm point noise (the real sets are motion capture), same procedure.

Usage: python3 tools/real_gpdm.py [--quick] [--data DIR]; `gpdm_figures(root, seed, quick)`.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

TOOLS = Path(__file__).resolve().parent
sys.path.insert(0, str(TOOLS.parent))

from hrc_drake.datasets import data_root, dataset_dir  # noqa: E402
from hrc_drake.human.body import BodyModel  # noqa: E402
from hrc_drake.human.config import Segments  # noqa: E402
from hrc_drake.human.importers import (  # noqa: E402
    Placement,
    place_in_cell,
    read_ue_adl,
    resample,
    synthesize_missing,
)
from hrc_drake.human.operator import OperatorTask, SyntheticOperator  # noqa: E402
from hrc_drake.motion.config import ProactivePlanner  # noqa: E402
from hrc_drake.motion.gpdm import GPDM  # noqa: E402
from hrc_drake.motion.proactive import ARM_POINTS  # noqa: E402
from hrc_drake.real_claims import people_interval, select_people  # noqa: E402

RATE = 30.0
#: the cells' prediction horizon (diagrams/*.yaml `GPMotionModel {horizon: 0.3}`)
HORIZON = 0.3
#: reach start/end: wrist speed below this fraction of the reach's peak speed
SPEED_FRACTION = 0.1
#: frames of recent motion whose mean velocity the constant-velocity predictor extrapolates: the
#: last frame difference, the strongest baseline of the sweep 1, 2, 3, 5 on the real reaches
#: (RMS 0.045, 0.049, 0.052, 0.058 m; motion capture, ~mm noise)
CV_WINDOW = 1
#: frames matched by the phase alignment (0.1 s)
PHASE_WINDOW = 3
ARM = list(ARM_POINTS["right"])
KINDS = ("FR", "AR")
METHODS = ("gpdm", "gpdm_phase", "gpdm_anchored", "constant_velocity", "hold", "mean_of_other_reaches")
#: the reach's begin event as a cell detects it, from the past only (issue 56): the wrist's speed
#: over the last CAUSAL_WINDOW frames (backward differences) reaches CAUSAL_SPEED (m/s)
CAUSAL_SPEED, CAUSAL_WINDOW = 0.15, 3
#: synthetic operator: hips, facing, and the goals of the two reaches at the real targets (cell frame)
SYNTH_BASE, SYNTH_YAW = (1.05, 0.0), math.pi
SYNTH_GOALS = {"FR": (0.55, 0.20, 0.87), "AR": (0.59, 0.02, 0.86), "home": (0.80, 0.17, 0.81)}
SYNTH_NOISE = 0.002


def log(text: str) -> None:
    print(text, flush=True)


# ------------------------------------------------------------------------------ building blocks
def wrist_speed(wrist: np.ndarray, rate: float) -> np.ndarray:
    """Speed (T,) m/s of a point track (T, 3): central differences (one-sided at the ends)."""
    return np.linalg.norm(np.gradient(np.asarray(wrist, dtype=float), axis=0), axis=1) * rate


def segment_reach(speed: np.ndarray, fraction: float = SPEED_FRACTION) -> tuple[int, int]:
    """(start, end) frames, inclusive, of the reach around the speed peak: the last frame before
    the peak below `fraction` x peak and the first after it (the track's ends if none)."""
    speed = np.asarray(speed, dtype=float)
    if speed.ndim != 1 or len(speed) < 3 or not np.all(np.isfinite(speed)):
        raise ValueError(f"segment_reach: need a finite (T >= 3,) speed profile, got shape {speed.shape}")
    peak = int(np.argmax(speed))
    low = speed < fraction * speed[peak]
    before = np.flatnonzero(low[:peak])
    after = np.flatnonzero(low[peak:])
    start = int(before[-1]) if len(before) else 0
    end = peak + int(after[0]) if len(after) else len(speed) - 1
    return start, end


def causal_start(wrist: np.ndarray, rate: float, floor: int = 0) -> int | None:
    """The first frame (>= `floor`) at which the wrist's mean speed over the last `CAUSAL_WINDOW`
    frames reaches `CAUSAL_SPEED`: the begin event as a cell sees it, from past frames only
    (`segment_reach` reads the whole trial, its future speed peak included)."""
    wrist = np.asarray(wrist, dtype=float)
    for k in range(max(CAUSAL_WINDOW, floor), len(wrist)):
        speed = np.linalg.norm(wrist[k] - wrist[k - CAUSAL_WINDOW]) * rate / CAUSAL_WINDOW
        if speed >= CAUSAL_SPEED:
            return k
    return None


def mean_of_reaches(reaches: list[np.ndarray]) -> np.ndarray:
    """The time-aligned mean (L, P, 3) of reaches (each (T_i, P, 3) from its begin event): frame k
    the mean over the reaches at k, each holding its last pose after its end; L the median length
    (as Phi of eq. 8.26)."""
    length = int(np.median([len(r) for r in reaches]))
    held = [r[np.minimum(np.arange(length), len(r) - 1)] for r in reaches]
    return np.mean(held, axis=0)


def constant_velocity(observed: np.ndarray, steps: int, window: int = CV_WINDOW) -> np.ndarray:
    """Poses at the next 1..steps frames (steps, ...) of `observed` (k, ...), the past up to now:
    now + s x (mean per-frame velocity over the last `window` frames, fewer if fewer observed)."""
    observed = np.asarray(observed, dtype=float)
    m = min(int(window), len(observed) - 1)
    velocity = (observed[-1] - observed[-1 - m]) / m if m > 0 else np.zeros_like(observed[-1])
    s = np.arange(1, int(steps) + 1).reshape((-1,) + (1,) * (observed.ndim - 1))
    return observed[-1] + s * velocity


def phase_index(phi: np.ndarray, recent: np.ndarray) -> int:
    """Index k of Phi (L, D) whose last w poses Phi_{k-w+1..k} (Phi_0 repeated before the start)
    are nearest (summed squared distance) to the last w observed poses `recent` (w, D)."""
    phi, recent = np.asarray(phi, dtype=float), np.asarray(recent, dtype=float)
    w = len(recent)
    padded = np.concatenate([np.repeat(phi[:1], w - 1, axis=0), phi])
    windows = np.stack([padded[j:j + len(phi)] for j in range(w)], axis=1)  # (L, w, D): k-w+1..k
    cost = ((windows - recent[None]) ** 2).sum(axis=(1, 2))
    return int(np.argmin(cost))


def _held(phi: np.ndarray, k) -> np.ndarray:
    """Phi_k with its last pose held after its end."""
    return phi[np.minimum(k, len(phi) - 1)]


def trial_errors(phi: np.ndarray, poses: np.ndarray, start: int, end: int, steps: int,
                 cv_window: int = CV_WINDOW, mean_phi: np.ndarray | None = None) -> dict:
    """Squared point errors of every method on one held-out reach (module docstring):
    method -> {"horizon": (n, P), "remaining": (m, P)} for poses (T, P, 3), Phi (L, P * 3);
    mean_phi (L', P, 3): the time-aligned mean of the training reaches (default: Phi itself)."""
    n_points = poses.shape[1]
    phi = np.asarray(phi, dtype=float).reshape(len(phi), n_points, 3)
    mean_phi = phi if mean_phi is None else np.asarray(mean_phi, dtype=float)
    flat_phi = phi.reshape(len(phi), -1)
    anchored = phi + (poses[start] - phi[0])
    out = {m: {"horizon": [], "remaining": []} for m in METHODS}
    for t in range(start, end + 1):
        if t + steps >= len(poses):
            break
        truth = poses[t + steps]
        past = poses[: t + 1]
        recent = past[-PHASE_WINDOW:].reshape(min(PHASE_WINDOW, len(past)), -1)
        k_phase = phase_index(flat_phi, recent)
        later = np.arange(t + 1, end + 1)
        ahead = later - t
        preds = {
            "gpdm": (_held(phi, t - start + steps), _held(phi, later - start)),
            "gpdm_phase": (_held(phi, k_phase + steps), _held(phi, k_phase + ahead)),
            "gpdm_anchored": (_held(anchored, t - start + steps), _held(anchored, later - start)),
            "mean_of_other_reaches": (_held(mean_phi, t - start + steps), _held(mean_phi, later - start)),
        }
        cv = constant_velocity(past, max(steps, int(ahead[-1]) if len(ahead) else 1), cv_window)
        preds["constant_velocity"] = (cv[steps - 1], cv[ahead - 1])
        preds["hold"] = (poses[t], np.repeat(poses[t][None], len(later), axis=0))
        for m, (at_horizon, rest) in preds.items():
            out[m]["horizon"].append(((at_horizon - truth) ** 2).sum(-1))
            if len(later):
                out[m]["remaining"].append(((rest - poses[later]) ** 2).sum(-1))
    return {m: {k: np.concatenate([np.atleast_2d(e) for e in v]) if v else np.zeros((0, n_points))
                for k, v in d.items()} for m, d in out.items()}


# ------------------------------------------------------------------------------ data
def _trial(person: str, kind: str, index: int, points: np.ndarray, causal: bool = False) -> dict | None:
    """A trial record: the arm's poses (T, 3, 3) and its reach: segmented from the whole trial, or
    with `causal` from its begin event detected from the past only (`causal_start`) to the
    segmented end (None when no begin is detected before it)."""
    poses = points[:, ARM]
    start, end = segment_reach(wrist_speed(poses[:, -1], RATE))
    if causal:
        begin = causal_start(poses[:, -1], RATE)
        if begin is None or begin >= end:
            return None
        start = begin
    return {"person": person, "kind": kind, "index": index, "poses": poses, "start": start, "end": end}


def real_trials(root, people=None, causal: bool = False) -> list[dict]:
    """The UE seated reaches (`data/real/ue_adl`) of `people` (None: the claims file's tuning
    people, `hrc_drake.real_claims`): read, thorax and head synthesised, placed in the cell
    (`Placement()`), resampled to 30 Hz, segmented."""
    out = []
    folder = dataset_dir("ue_adl", root)
    people = select_people(folder, "tuning") if people is None else tuple(people)
    paths = [p for person in people for p in (folder / person).glob("*.csv") if "static" not in p.name]
    for path in sorted(paths):
        person, rest = path.parent.name, path.stem[len(path.parent.name):]
        kind, index = rest[:2], int(rest[2:])
        if kind not in KINDS:
            continue
        placed, _, _ = place_in_cell(synthesize_missing(read_ue_adl(path)), Placement())
        points = resample(placed, RATE).points
        if not np.all(np.isfinite(points[:, ARM])):
            log(f"skipped {path.stem}: untracked arm points")
            continue
        trial = _trial(person, kind, index, points, causal)
        if trial is None:
            log(f"skipped {path.stem}: no begin detected from the past before the reach's end")
            continue
        out.append(trial)
    return out


def synthetic_trials(seed: int, per_kind: int = 5, causal: bool = False) -> list[dict]:
    """Reaches of the synthetic operator to the real targets (module docstring): two persons,
    pattern FR, home, AR, home; each FR/AR action cut from 0.2 s before its begin to 0.3 s after
    its end (the hand still: the next action's head lead)."""
    out = []
    for p, scale in enumerate((1.0, 0.92)):
        s = Segments()
        body = BodyModel(Segments(torso=s.torso * scale, neck=s.neck * scale,
                                  shoulder_width=s.shoulder_width * scale, upper_arm=s.upper_arm * scale,
                                  forearm=s.forearm * scale))
        rng = np.random.default_rng([seed, p])
        tasks = {name: OperatorTask(name, [np.array(goal)], "right", lambda r: float(r.uniform(1.2, 2.2)))
                 for name, goal in SYNTH_GOALS.items()}
        rest = body.rest_q(SYNTH_BASE, SYNTH_YAW)
        operator = SyntheticOperator(body, tasks, ["FR", "home", "AR", "home"], rest, rng,
                                     rest_height=SYNTH_GOALS["home"][2])
        times = np.arange(0.0, 4 * 2.2 * per_kind + 1.0, 1.0 / RATE)
        points = []
        for t in times:
            operator.update(t)
            points.append(operator.points(t))
        points = np.array(points) + rng.normal(0.0, SYNTH_NOISE, (len(times), 8, 3))
        begins = {}
        counts = dict.fromkeys(KINDS, 0)
        for event in operator.events:
            if event.action not in KINDS:
                continue
            if event.kind == "begin":
                begins[event.action] = event.time
            elif event.kind == "end" and event.action in begins and counts[event.action] < per_kind:
                lo = int(np.searchsorted(times, begins.pop(event.action) - 0.2))
                hi = int(np.searchsorted(times, event.time + 0.3))  # the next reach waits 0.3 s
                counts[event.action] += 1
                trial = _trial(f"synthetic{p + 1}", event.action, counts[event.action], points[lo:hi], causal)
                if trial is not None:
                    out.append(trial)
    return out


# ------------------------------------------------------------------------------ evaluation
def _fit(sequences: list[np.ndarray], seed) -> np.ndarray:
    """Phi (eq. 8.26) of a GPDM with the `ProactivePlanner` defaults fitted on the realisations."""
    settings = ProactivePlanner()
    model = GPDM(settings.latent_dim, max_iter=settings.gpdm_iterations, random_state=seed)
    return model.fit([s.reshape(len(s), -1) for s in sequences]).regressed_trajectory()


def _reach(trial: dict) -> np.ndarray:
    return trial["poses"][trial["start"]: trial["end"] + 1]


def _summary(errors: list[dict]) -> dict:
    """RMS (m) per method over all points, the wrist alone and the remaining trajectory."""
    out = {}
    for m in METHODS:
        horizon = np.concatenate([e[m]["horizon"] for e in errors])
        remaining = np.concatenate([e[m]["remaining"] for e in errors])
        prefix = "" if m == "gpdm" else f"{m}_"
        out[f"{prefix}rms_m"] = float(np.sqrt(horizon.mean()))
        out[f"{prefix}wrist_rms_m"] = float(np.sqrt(horizon[:, -1].mean()))
        out[f"{prefix}remaining_rms_m"] = float(np.sqrt(remaining.mean()))
    out["predictions"] = int(sum(len(e["gpdm"]["horizon"]) for e in errors))
    return out


def _training(trials: list[dict], trial: dict, mode: str, capacity: int | None) -> tuple[list, tuple]:
    """The realisations a held-out trial's GPDM is fitted on, and the key of that fit: the same
    person's other trials of its kind (with `capacity`, only the `capacity` trials before it,
    cyclically: 8.2.4's FIFO of 3), or the other person's trials of its kind."""
    kind = [t for t in trials if t["kind"] == trial["kind"]]
    if mode == "other_person":
        return [t for t in kind if t["person"] != trial["person"]], (trial["person"],)
    own = sorted((t for t in kind if t["person"] == trial["person"]), key=lambda t: t["index"])
    at = next(i for i, t in enumerate(own) if t is trial)
    others = own[at + 1:] + own[:at]
    return (others[-capacity:] if capacity else others), (trial["person"], trial["index"])


def evaluate(trials: list[dict], seed: int, label: str = "", cv_window: int = CV_WINDOW,
             capacity: int | None = None) -> dict:
    """Leave-one-out figures (module docstring) of one set of trials: "same_person",
    "other_person", each pooled over both kinds with "per_kind"; the pooled same-person figures
    also at top level. label: a table row per mode and kind is printed ("" prints none)."""
    steps = int(round(HORIZON * RATE))
    fits = 0
    result = {}
    by_person: dict[str, list[dict]] = {}
    for mode in ("same_person", "other_person"):
        per_kind = {}
        for kind in KINDS:
            errors, cache = [], {}
            for trial in (t for t in trials if t["kind"] == kind):
                train, key = _training(trials, trial, mode, capacity)
                if not train:
                    continue
                if key not in cache:
                    cache[key] = (_fit([_reach(t) for t in train], [seed, fits]),
                                  mean_of_reaches([_reach(t) for t in train]))
                    fits += 1
                phi, mean_phi = cache[key]
                errors.append(trial_errors(phi, trial["poses"], trial["start"], trial["end"], steps,
                                           cv_window, mean_phi))
                if mode == "same_person":
                    by_person.setdefault(trial["person"], []).append(errors[-1])
            if errors:
                per_kind[kind] = (errors, _summary(errors))
        if not per_kind:
            continue
        pooled = _summary([e for errors, _ in per_kind.values() for e in errors])
        pooled["per_kind"] = {k: s for k, (_, s) in per_kind.items()}
        result[mode] = pooled
        for kind, (_, s) in per_kind.items() if label else ():
            log(f"{label:<10} {mode:<13} {kind:<4} {s['rms_m']:8.3f} {s['gpdm_phase_rms_m']:8.3f} "
                f"{s['gpdm_anchored_rms_m']:8.3f} {s['constant_velocity_rms_m']:8.3f} {s['hold_rms_m']:8.3f}"
                f" {s['remaining_rms_m']:9.3f} {s['constant_velocity_remaining_rms_m']:9.3f} "
                f"{s['predictions']:6d}")
    top = dict(result.get("same_person", {}))
    top.pop("per_kind", None)
    durations = [(t["end"] - t["start"]) / RATE for t in trials]
    return {**top, **result, "trials": len(trials), "persons": sorted({t["person"] for t in trials}),
            "gpdm_fits": fits, "reach_s_median": float(np.median(durations)),
            **person_differences(by_person, seed)}


def _rms(errors: list[dict], method: str) -> float:
    horizon = [e[method]["horizon"] for e in errors if len(e[method]["horizon"])]
    return float(np.sqrt(np.concatenate(horizon).mean())) if horizon else math.nan


def person_differences(by_person: dict, seed: int = 0) -> dict:
    """The same-person GPDM's RMS minus constant velocity's and minus the mean of the other
    reaches' (m; negative: the GPDM is better): the mean over people of each person's difference
    (paired by person) with its 95 % Student's t interval (`real_claims.people_interval`; None with
    fewer than two people), how many people, and every person's RMS per method. seed: unused (the
    interval is not drawn), kept for the callers."""
    per_person = {p: {m: _rms(e, m) for m in ("gpdm", "constant_velocity", "mean_of_other_reaches")}
                  for p, e in sorted(by_person.items())}
    out = {"per_person": per_person}
    for other, key in (("constant_velocity", "rms_m_minus_constant_velocity"),
                       ("mean_of_other_reaches", "rms_m_minus_mean_of_other_reaches")):
        differences = [row["gpdm"] - row[other] for row in per_person.values()]
        out[key], out[f"{key}.ci95"], out[f"{key}.people"] = people_interval(differences)
    return out


def resegmented(trials: list[dict], fraction: float) -> list[dict]:
    """The trials with their reaches segmented at another speed fraction (`segment_reach`)."""
    out = []
    for t in trials:
        start, end = segment_reach(wrist_speed(t["poses"][:, -1], RATE), fraction)
        out.append({**t, "start": start, "end": end})
    return out


def sweep(trials: list[dict], seed: int) -> list[dict]:
    """Same-person figures on `trials` around the chosen settings, one changed at a time: the
    constant-velocity window, the segmentation's speed fraction, the training set size."""
    rows = []
    settings = [{"cv_window": w} for w in (1, 2, 3, 5)] + [{"fraction": f} for f in (0.05, 0.2)] \
        + [{"capacity": 3}]
    log(f"\nsweep (real, same person): {'setting':<16} {'gpdm':>8} {'phase':>8} {'anch.':>8} {'c.vel.':>8}")
    for change in settings:
        chosen = resegmented(trials, change["fraction"]) if "fraction" in change else trials
        row = evaluate(chosen, seed, "", change.get("cv_window", CV_WINDOW), change.get("capacity"))
        name = ", ".join(f"{k} {v}" for k, v in change.items())
        log(f"{'':<27}{name:<16} {row['rms_m']:8.3f} {row['gpdm_phase_rms_m']:8.3f} "
            f"{row['gpdm_anchored_rms_m']:8.3f} {row['constant_velocity_rms_m']:8.3f}")
        keys = ("rms_m", "gpdm_phase_rms_m", "gpdm_anchored_rms_m", "constant_velocity_rms_m")
        rows.append({"setting": change, **{k: row[k] for k in keys}})
    return rows


def gpdm_figures(root=None, seed: int = 0, quick: bool = False, people=None, causal: bool = False) -> dict:
    """{"real": ..., "synthetic": ..., "settings": ..., "sweep": ...}: the GPDM of 8.2 against
    constant velocity at the 0.3 s horizon (module docstring). "real" and "synthetic" hold, pooled
    over both kinds for same-person leave-one-out: rms_m (GPDM, 8.2's begin alignment),
    constant_velocity_rms_m, gpdm_phase_rms_m, gpdm_anchored_rms_m, hold_rms_m, each also as
    *wrist_rms_m and *remaining_rms_m (whole remaining reach), predictions; "same_person" and
    "other_person" the same figures with "per_kind"; trials, persons, gpdm_fits,
    reach_s_median. quick: three synthetic reaches per kind instead of five, no sweep ([]).
    people: the UE participants (None: the claims file's tuning people). causal: each reach begins
    where a cell would detect it from the past (`causal_start`), not where the whole trial's
    segmentation puts it; "rms_m_minus_*" with 95 % intervals over people compare the GPDM with
    constant velocity and with the time-aligned mean of the person's other reaches."""
    start = time.process_time()
    log(f"\n{'set':<10} {'training':<13} {'kind':<4} {'gpdm':>8} {'phase':>8} {'anch.':>8} {'c.vel.':>8} "
        f"{'hold':>8} {'gpdm rem':>9} {'cv rem':>9} {'n':>6}  (RMS m at {HORIZON:g} s; rem: remaining reach)")
    trials = real_trials(data_root(root), people, causal)
    real = evaluate(trials, seed, "real")
    synthetic = evaluate(synthetic_trials(seed, 3 if quick else 5, causal), seed, "synthetic")
    for name, row in (("real", real), ("synthetic", synthetic)):
        log(f"{name}: GPDM {row['rms_m']:.3f} m vs constant velocity {row['constant_velocity_rms_m']:.3f} m"
            f" (same person; other person {row['other_person']['rms_m']:.3f} vs "
            f"{row['other_person']['constant_velocity_rms_m']:.3f})")
    rows = [] if quick else sweep(trials, seed)
    settings = {"horizon_s": HORIZON, "rate_hz": RATE, "speed_fraction": SPEED_FRACTION,
                "cv_window_frames": CV_WINDOW, "phase_window_frames": PHASE_WINDOW,
                "observation": "right shoulder, elbow, wrist (9-D)", "alignment": "begin event (8.2)",
                "seed": seed, "quick": bool(quick), "cpu_s": time.process_time() - start,
                "begin": ("detected from the past only: the wrist's speed over the last "
                          f"{CAUSAL_WINDOW} frames >= {CAUSAL_SPEED} m/s") if causal
                else "segmented from the whole trial (its future speed peak included)"}
    return {"real": real, "synthetic": synthetic, "settings": settings, "sweep": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer synthetic reaches, no sweep (~10 s)")
    parser.add_argument("--data", default=None, help="a data folder laid out like data/ (default: it)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(json.dumps(gpdm_figures(args.data, args.seed, args.quick)))


if __name__ == "__main__":
    main()
