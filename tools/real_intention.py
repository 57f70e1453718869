"""Intention (thesis 3.1) on real seated reaches (issue 37): when does each goal estimator commit
to the right target, and how often to a wrong one?

Real reaches: data/real/ue_adl (two participants, right arm, 100 Hz Vicon), trials *FR1-5
(forward reach to a target) and *AR1-5 (reach across to a target), each imported as
tools/bench_real.py does (`read_ue_adl`, `synthesize_missing`, `place_in_cell(Placement())`,
`resample` to the 30 Hz of the cells' camera). A trial holds one reach from rest and no return.

Reach segmentation (`reach_span`): the right wrist's speed (central differences); the reach is
the run of samples around the speed peak whose speed is at least max(0.05 m/s, 10 % of the
peak): start = its first sample, end = its last.

Goals (`real_goal_centres`), per participant and leave-one-trial-out (a reach's own end never
places its goal): `forward` / `across` = median of the right wrist at the reach end over the
participant's other trials of that kind; `rest` = median of the right wrist at the reach start
over the participant's other trials. The rest goal is in the layout by default (`with_rest`):
a cell's estimator knows the home position as a goal (goal 1 of Fig. 3.4), the prior is then
1/3 per goal, not 1/2, and the belief must leave home before it can pick a target.

Models: M1 ([135], eq. 3.1), M2 (GMM2d on Psi), M3 (GMM4d on Phi with the gaze switch, 3.1.2),
all with the shipped model hrc_drake/data/intention_default.json (learned from synthetic
operators only, its evidence weight w chosen on synthetic validation operators): no real reach
trains anything. No gaze is recorded (the head is synthesised from the shoulders), so the
frames carry the gaze flag F = invalid and M3 falls back to GMM2d on Psi every frame: on the
real reaches M3 is M2 (the figures say whether the traces are identical).

Figures per model (`summarise`), over the reaches to forward and across, threshold 0.8 (the
feedback threshold of Fig. 3.6, `evaluation.reach_outcomes`):
  commit_fraction_median  (t_commit - t_start) / (t_end - t_start), t_commit the first sample
                          of the reach at which the right target's probability is >= 0.8;
                          median over the committed reaches;
  missed_pct              % of reaches whose right target never reached 0.8 by the reach end;
  wrong_commit_pct        % of reaches in which a wrong goal's probability rose to 0.8 at some
                          sample of the reach (before the right one or after it; a rise is an
                          upward crossing, so a belief held since before the reach is none),
                          with its 95 % Wilson interval (`wrong_commit_ci95`);
  wrong_first_pct         % of reaches in which a wrong goal reached 0.8 before the right one
                          (or the right one never did).
Synthetic beside it (`synthetic_reaches`): the synthetic operator with the `RealisticBehaviour`
(`record_reaches`), standing at the placement's operator position, in each participant's layout
(centres: medians over all that participant's trials), alternating rest -> target -> rest ...;
its reaches rest -> forward and rest -> across are cut by the same speed rule on its true wrist
and each is estimated from a fresh uniform belief started up to 1 s before it (after the previous
reach ended), as a real trial starts after ~1 s at rest.

Thesis claim (3.1.3, Table 3.1): the learned likelihood (M2, M3) recognises goals with fewer
false positives and fewer missed goals than [135] (M1), and M3's gaze reduces them further.

    python3 tools/real_intention.py [--quick] [--data DIR] [--seed S]
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import warnings
from pathlib import Path

import numpy as np

TOOLS = Path(__file__).resolve().parent
if str(TOOLS.parent) not in sys.path:
    sys.path.insert(0, str(TOOLS.parent))

from hrc_drake.datasets import data_root, dataset_dir  # noqa: E402
from hrc_drake.human.importers import (  # noqa: E402
    Placement,
    place_in_cell,
    read_ue_adl,
    resample,
    synthesize_missing,
)
from hrc_drake.messages import R_WRIST  # noqa: E402
from hrc_drake.real_claims import people_interval, select_people  # noqa: E402

METHODS = ("M1", "M2", "M3")
RATE = 30.0
THRESHOLD = 0.8
#: a reach: the run around the speed peak at >= max(SPEED_FLOOR, SPEED_FRACTION * peak)
SPEED_FRACTION = 0.1
SPEED_FLOOR = 0.05
TARGETS = ("forward", "across")
KINDS = {"FR": "forward", "AR": "across"}
RIGHT = 1  # row of the right hand in the estimator's probabilities (2, G)
#: camera noise (m) of the synthetic operator: the lowest level of the benches (the real markers
#: are Vicon, nearly noise-free)
SYNTHETIC_NOISE = 0.005
SYNTHETIC_GAZE_NOISE = 0.1
#: a synthetic reach is estimated from a fresh (uniform) belief started this long (s) before its
#: start, but not before the end of the previous reach, as each real trial starts (~1 s of rest)
LEAD_IN = 1.0


def log(text: str) -> None:
    print(text, flush=True)


# ---------------------------------------------------------------- pure helpers (tested)


def wrist_speed(times: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Speed (T,) m/s of a point track (T, 3) by central differences (one-sided at the ends);
    NaN where a neighbour is missing."""
    times = np.asarray(times, dtype=float)
    positions = np.asarray(positions, dtype=float)
    if len(times) < 2:
        return np.full(len(times), np.nan)
    velocity = np.gradient(positions, times, axis=0)
    return np.linalg.norm(velocity, axis=1)


def reach_span(speed: np.ndarray, fraction: float = SPEED_FRACTION, floor: float = SPEED_FLOOR):
    """(start, end) sample indices of the reach in a speed profile (T,): the run of samples around
    the speed peak whose speed is >= max(floor, fraction * peak). None if the peak is below floor."""
    speed = np.asarray(speed, dtype=float)
    if not len(speed) or not np.any(np.isfinite(speed)):
        return None
    peak = int(np.nanargmax(speed))
    if speed[peak] < floor:
        return None
    level = max(floor, fraction * speed[peak])
    fast = np.nan_to_num(speed, nan=0.0) >= level
    start = peak
    while start > 0 and fast[start - 1]:
        start -= 1
    end = peak
    while end < len(speed) - 1 and fast[end + 1]:
        end += 1
    return start, end


def reach_outcome(times, probabilities, goal: int, start: int, end: int, threshold: float = THRESHOLD):
    """One reach's figures from a probability trace (T, G) of one hand: commit fraction (NaN if
    the right `goal` never reached `threshold` in samples start..end); wrong commitment: a wrong
    goal crossed `threshold` upwards at a sample of the reach (below it at the sample before,
    which may precede the reach: a belief held since before the reach started is no new
    commitment), at all and before the right goal's first sample at the threshold."""
    times = np.asarray(times, dtype=float)
    trace = np.asarray(probabilities, dtype=float)
    p = trace[start : end + 1]
    before = trace[start - 1] if start > 0 else np.zeros(trace.shape[1])
    previous = np.vstack([before[None], p[:-1]])
    right = np.nonzero(p[:, goal] >= threshold)[0]
    crossed = (p >= threshold) & (previous < threshold)
    wrong = np.nonzero(np.any(np.delete(crossed, goal, axis=1), axis=1))[0]
    duration = times[end] - times[start]
    fraction = math.nan
    if len(right):
        fraction = float((times[start + right[0]] - times[start]) / duration) if duration > 0 else 0.0
    first_right = right[0] if len(right) else np.inf
    return {
        "committed": bool(len(right)),
        "commit_fraction": fraction,
        "wrong": bool(len(wrong)),
        "wrong_first": bool(len(wrong) and wrong[0] < first_right),
    }


def wilson_pct(count: int, n: int, z: float = 1.96) -> list[float]:
    """95 % Wilson score interval (in %) of a share count / n."""
    if n <= 0:
        return [math.nan, math.nan]
    q = count / n
    centre = (q + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(q * (1 - q) / n + z * z / (4 * n * n))
    return [round(100 * max(0.0, centre - half), 1), round(100 * min(1.0, centre + half), 1)]


def summarise(outcomes: list[dict]) -> dict:
    """Median commit fraction over the committed reaches; % missed, % wrong commitments (at all,
    and before the right one) over all reaches, with the 95 % Wilson interval of the wrong %."""
    n = len(outcomes)
    if not n:
        return {"reaches": 0, "commit_fraction_median": None, "missed_pct": None, "wrong_commit_pct": None,
                "wrong_first_pct": None, "wrong_commit_ci95": [None, None]}
    fractions = [o["commit_fraction"] for o in outcomes if o["committed"]]
    return {
        "reaches": n,
        "commit_fraction_median": round(float(np.median(fractions)), 3) if fractions else None,
        "missed_pct": round(100.0 * sum(not o["committed"] for o in outcomes) / n, 1),
        "wrong_commit_pct": round(100.0 * sum(o["wrong"] for o in outcomes) / n, 1),
        "wrong_first_pct": round(100.0 * sum(o["wrong_first"] for o in outcomes) / n, 1),
        "wrong_commit_ci95": wilson_pct(sum(o["wrong"] for o in outcomes), n),
    }


def right_hand_trace(estimator, times, points, gaze=None, gaze_valid=None) -> np.ndarray:
    """The right hand's goal probabilities (T, G) after each frame (points (T, 8, 3)); without
    `gaze` every frame has flag F invalid (no gaze recorded)."""
    estimator.reset()
    no_gaze = np.full(3, np.nan)
    out = np.empty((len(times), estimator.n_goals))
    for k, t in enumerate(times):
        g = no_gaze if gaze is None else gaze[k]
        valid = False if gaze_valid is None else bool(gaze_valid[k])
        out[k] = estimator.update(float(t), points[k], g, valid)[RIGHT]
    return out


# ---------------------------------------------------------------- real reaches


def real_reaches(root, people=None) -> list[dict]:
    """Every FR/AR trial of ue_adl under `root` of the participants `people` (None: the claims
    file's tuning people, `hrc_drake.real_claims`): participant, trial, kind, times, points
    (T, 8, 3) at RATE in the cell (z up), reach start and end (`reach_span` of the right wrist)."""
    folder = dataset_dir("ue_adl", root)
    people = select_people(folder, "tuning") if people is None else tuple(people)
    out = []
    for path in sorted(p for person in people for p in (folder / person).glob("*.csv")):
        match = re.fullmatch(r"(.+?)(FR|AR)(\d+)", path.stem)
        if not match:
            continue
        recording = read_ue_adl(path)
        placed, _, _ = place_in_cell(synthesize_missing(recording), Placement())
        sampled = resample(placed, RATE)
        span = reach_span(wrist_speed(sampled.times, sampled.points[:, R_WRIST]))
        if span is None:
            log(f"  {path.stem}: no reach found (right wrist never faster than {SPEED_FLOOR} m/s)")
            continue
        out.append({"participant": match.group(1), "trial": path.stem, "kind": KINDS[match.group(2)],
                    "times": sampled.times, "points": sampled.points, "start": span[0], "end": span[1]})
    return out


def real_goal_centres(reaches: list[dict], index: int | None = None, with_rest: bool = True):
    """Goal names and centres (G, 3) for reach `index`: per participant, medians of the right
    wrist at the reach ends (targets) and starts (rest) over the participant's other trials
    (leave-one-trial-out); with index None over all of the participant's trials."""
    me = reaches[index] if index is not None else None

    def pool(participant, kind=None, at="end"):
        rows = [r["points"][r[at], R_WRIST] for k, r in enumerate(reaches)
                if r["participant"] == participant and (kind is None or r["kind"] == kind)
                and (me is None or k != index)]
        return np.median(rows, axis=0)

    participant = me["participant"] if me is not None else reaches[0]["participant"]
    names = list(TARGETS) + (["rest"] if with_rest else [])
    centres = [pool(participant, kind) for kind in TARGETS]
    if with_rest:
        centres.append(pool(participant, at="start"))
    return tuple(names), np.array(centres)


def participant_centres(reaches: list[dict], participant: str, with_rest: bool = True):
    """Names and centres (G, 3) of a participant's layout from all of their trials."""
    mine = [r for r in reaches if r["participant"] == participant]
    return real_goal_centres(mine, None, with_rest)


def make_estimator(method: str, centres, names, model, seed: int):
    from hrc_drake.intention.bayes import GoalIntentionEstimator

    return GoalIntentionEstimator(centres, None if method == "M1" else model, method, goal_names=names,
                                  rng=seed)


def evaluate_real(reaches, model, with_rest: bool, seed: int) -> tuple[dict, dict, bool]:
    """Outcomes per method over the real reaches; per-reach rows; whether M3's traces equal M2's."""
    outcomes = {m: [] for m in METHODS}
    rows = {}
    m3_is_m2 = True
    for k, reach in enumerate(reaches):
        names, centres = real_goal_centres(reaches, k, with_rest)
        goal = names.index(reach["kind"])
        traces = {}
        for method in METHODS:
            est = make_estimator(method, centres, names, model, seed)
            traces[method] = right_hand_trace(est, reach["times"], reach["points"])
            o = reach_outcome(reach["times"], traces[method], goal, reach["start"], reach["end"])
            outcomes[method].append(o)
            rows.setdefault(reach["trial"], {})[method] = o
        m3_is_m2 &= bool(np.array_equal(traces["M2"], traces["M3"]))
    return outcomes, rows, m3_is_m2


# ---------------------------------------------------------------- synthetic reaches


def synthetic_reaches(names, centres, n_targets: int, seed, operator: int = 0) -> dict:
    """One synthetic operator (`RealisticBehaviour`, seeded [seed, operator]) reaching rest ->
    target -> rest ... in the layout (names include "rest"; the targets in random order,
    `n_targets` of them): {"recording", "reaches": [{goal, start, end}]}, its reaches to the
    targets cut by `reach_span` on the true right wrist within each labelled run."""
    from hrc_drake.cell.intention_data import random_segments, record_reaches
    from hrc_drake.cell.plugins import ROBOT_LOOK_HEIGHT
    from hrc_drake.human.config import RealisticBehaviour
    from hrc_drake.intention.dataset import GoalLayout

    rng = np.random.default_rng([seed, operator])
    rest = names.index("rest")
    targets = [names.index(t) for t in TARGETS]
    layout = GoalLayout("ue_adl", tuple(names), centres, ("right",) * len(names),
                        operator_base=(*Placement().operator_xy, Placement().facing))
    pattern = [g for target in rng.choice(targets, size=n_targets) for g in (rest, int(target))]
    robot = np.array([0.0, 0.0, ROBOT_LOOK_HEIGHT])  # the placement faces a robot at the origin
    recording = record_reaches(layout, random_segments(rng), len(pattern), rng, SYNTHETIC_NOISE,
                               SYNTHETIC_GAZE_NOISE, pattern=pattern, hands=("right",) * len(names),
                               behaviour=RealisticBehaviour(), robot_points=[robot])
    target = recording.target[:, RIGHT]
    change = np.nonzero(np.diff(target) != 0)[0] + 1
    starts, ends = np.concatenate([[0], change]), np.concatenate([change, [len(target)]])
    speed = wrist_speed(recording.times, recording.true_wrists[:, RIGHT])
    lead = int(round(LEAD_IN * RATE))
    out, previous_end = [], -1
    for s, e in zip(starts, ends, strict=True):
        span = reach_span(speed[s:e])
        if span is None:
            continue
        start, end = int(s + span[0]), int(s + span[1])
        if int(target[s]) in targets:
            out.append({"goal": int(target[s]), "start": start, "end": end,
                        "from": max(previous_end + 1, start - lead)})
        previous_end = end
    return {"recording": recording, "reaches": out}


def evaluate_synthetic(items, model, with_rest: bool, seed: int) -> dict:
    """Outcomes per method over the synthetic operators' reaches (`items`: (names, centres,
    `synthetic_reaches`) per operator); without rest the estimator knows only the targets."""
    outcomes = {m: [] for m in METHODS}
    for names, centres, item in items:
        known = len(names) if with_rest else len(TARGETS)
        rec = item["recording"]
        for method in METHODS:
            est = make_estimator(method, centres[:known], names[:known], model, seed)
            for reach in item["reaches"]:
                a, b = reach["from"], reach["end"] + 1
                gaze = rec.gaze[a:b], rec.gaze_valid[a:b]
                trace = right_hand_trace(est, rec.times[a:b], rec.points[a:b], *gaze)
                outcomes[method].append(
                    reach_outcome(rec.times[a:b], trace, reach["goal"], reach["start"] - a, reach["end"] - a))
    return outcomes


# ---------------------------------------------------------------- the section of bench_real


def intention_figures(root=None, seed: int = 0, quick: bool = False, with_rest: bool = True,
                      two_goal_variant: bool = True, people=None) -> dict:
    """The intention section of issue 37 (thesis 3.1): commit fraction, missed and wrong
    commitments of M1, M2, M3 on the real seated reaches of `people` (None: the tuning people),
    the synthetic operator beside them."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a goal slightly out of a synthetic arm's reach is fine here
        return _figures(root, seed, quick, with_rest, two_goal_variant, people)


def _figures(root, seed: int, quick: bool, with_rest: bool, two_goal_variant: bool, people=None) -> dict:
    from hrc_drake.intention.likelihood import default_model

    model = default_model()
    root = data_root(root)
    reaches = real_reaches(root, people)
    if not reaches:
        raise FileNotFoundError(f"no FR/AR reaches under {root}")
    durations = [r["times"][r["end"]] - r["times"][r["start"]] for r in reaches]
    lengths = [float(np.linalg.norm(r["points"][r["end"], R_WRIST] - r["points"][r["start"], R_WRIST]))
               for r in reaches]
    log(f"intention on real reaches: {len(reaches)} reaches (ue_adl), duration median "
        f"{np.median(durations):.2f} s, wrist travel median {np.median(lengths):.3f} m")
    participants = sorted({r["participant"] for r in reaches})
    per_participant = {p: participant_centres(reaches, p, True) for p in participants}
    for p, (names, centres) in per_participant.items():
        log(f"  {p} goals: " + ", ".join(f"{n} {np.round(c, 3).tolist()}" for n, c in zip(names, centres,
                                                                                          strict=True)))
    operators, n_targets = (1, 10) if quick else (8, 12)
    items = []
    for p_index, participant in enumerate(participants):
        names, centres = per_participant[participant]
        for i in range(operators):
            item = synthetic_reaches(list(names), centres, n_targets, seed, 100 * p_index + i)
            items.append((names, centres, item))
    n_synthetic = sum(len(item["reaches"]) for _, _, item in items)
    log(f"  synthetic: {len(items)} operators, {n_synthetic} reaches rest -> target")
    variants = [("three_goals" if with_rest else "two_goals", with_rest)]
    if two_goal_variant and with_rest:
        variants.append(("two_goals", False))
    figures = {"threshold": THRESHOLD, "reaches": len(reaches), "seed": seed, "quick": bool(quick),
               "segmentation": f"run around the right wrist's speed peak at >= max({SPEED_FLOOR} m/s, "
                               f"{SPEED_FRACTION:g} x peak)",
               "reach_duration_median_s": round(float(np.median(durations)), 3),
               "reach_travel_median_m": round(float(np.median(lengths)), 3),
               "goals": {p: {n: np.round(c, 4).tolist() for n, c in zip(*v, strict=True)}
                         for p, v in per_participant.items()},
               "model": "hrc_drake/data/intention_default.json (synthetic training), evidence weight "
                        f"{model.evidence_weight:g}",
               "synthetic_operators": operators * len(participants)}
    for name, rest in variants:
        real, rows, m3_is_m2 = evaluate_real(reaches, model, rest, seed)
        synthetic = evaluate_synthetic(items, model, rest, seed)
        block = {"real": {m: summarise(real[m]) for m in METHODS},
                 "synthetic": {m: summarise(synthetic[m]) for m in METHODS},
                 "m3_equals_m2_on_real": m3_is_m2}
        log(f"\nlayout {name} (threshold {THRESHOLD}); M3 on real = M2 (no gaze, F invalid): {m3_is_m2}")
        log(f"{'model':<6} {'data':<10} {'reaches':>7} {'commit frac':>11} {'missed %':>8} {'wrong %':>8} "
            f"{'(95 % CI)':>12} {'wrong 1st %':>11}")
        for m in METHODS:
            for data in ("real", "synthetic"):
                s = block[data][m]
                frac = "-" if s["commit_fraction_median"] is None else f"{s['commit_fraction_median']:.3f}"
                ci = f"[{s['wrong_commit_ci95'][0]:.0f}, {s['wrong_commit_ci95'][1]:.0f}]"
                log(f"{m:<6} {data:<10} {s['reaches']:>7} {frac:>11} {s['missed_pct']:>8.1f} "
                    f"{s['wrong_commit_pct']:>8.1f} {ci:>12} {s['wrong_first_pct']:>11.1f}")
        if name == variants[0][0]:
            add_people_intervals(block, reaches, real, synthetic)
            figures["real"], figures["synthetic"] = block["real"], block["synthetic"]
            figures["m3_equals_m2_on_real"] = m3_is_m2
            figures["per_reach"] = {trial: {m: (None if math.isnan(o["commit_fraction"])
                                                else round(o["commit_fraction"], 3)) for m, o in r.items()}
                                    for trial, r in rows.items()}
            figures["layout"] = name
        else:
            figures[name] = block
    return figures


def add_people_intervals(block: dict, reaches: list[dict], real: dict, synthetic: dict) -> None:
    """Into block["real"][m]: the mean over people of their wrong-commitment % with its 95 %
    interval (`real_claims.people_interval`: Student's t widened to the pooled counts' exact one;
    None with fewer than two people), each person's %, and the real minus the synthetic % with that
    interval widened by the synthetic operators' own exact binomial interval."""
    from scipy.stats import binomtest

    for m, outcomes in real.items():
        by_person: dict[str, list[dict]] = {}
        for reach, outcome in zip(reaches, outcomes, strict=True):
            by_person.setdefault(reach["participant"], []).append(outcome)
        per_person = {p: 100.0 * sum(o["wrong"] for o in v) / len(v) for p, v in sorted(by_person.items())}
        wrong = sum(o["wrong"] for o in outcomes)
        mean, ci, n = people_interval([v / 100.0 for v in per_person.values()], (wrong, len(outcomes)))
        row = block["real"][m]
        row["wrong_commit_pct_mean_over_people"] = None if mean is None else 100.0 * mean
        row["wrong_commit_pct.ci95"] = None if ci is None else [100.0 * ci[0], 100.0 * ci[1]]
        row["wrong_commit_pct.people"] = n
        row["wrong_commit_pct_per_person"] = {p: round(v, 1) for p, v in per_person.items()}
        synthetic_wrong = sum(o["wrong"] for o in synthetic[m])
        if mean is not None and synthetic[m]:
            exact = binomtest(synthetic_wrong, len(synthetic[m])).proportion_ci(0.95, method="exact")
            synthetic_pct = 100.0 * synthetic_wrong / len(synthetic[m])
            row["wrong_commit_pct_minus_synthetic"] = round(100.0 * mean - synthetic_pct, 2)
            row["wrong_commit_pct_minus_synthetic.ci95"] = (
                None if ci is None else [100.0 * (ci[0] - exact.high), 100.0 * (ci[1] - exact.low)])
            row["wrong_commit_pct_minus_synthetic.people"] = n


def bench_keys(figures: dict) -> dict:
    """The flat keys of the issue: intention.<model>.* (real) and intention_synthetic.<model>.*."""
    out = {}
    for data, prefix in (("real", "intention"), ("synthetic", "intention_synthetic")):
        for m, row in figures[data].items():
            for key in ("commit_fraction_median", "wrong_commit_pct", "missed_pct", "wrong_first_pct",
                        "wrong_commit_pct.ci95", "wrong_commit_pct.people",
                        "wrong_commit_pct_minus_synthetic", "wrong_commit_pct_minus_synthetic.ci95",
                        "wrong_commit_pct_minus_synthetic.people"):
                if key in row:
                    out[f"{prefix}.{m}.{key}"] = row[key]
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--data", default=None)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    figures = intention_figures(args.data, args.seed, args.quick)
    print(json.dumps({**bench_keys(figures), "intention": figures}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
