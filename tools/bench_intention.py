"""Benchmark of the intended-goal estimator (thesis 3.1.3, Table 3.1 and Fig. 3.9).

Methods: M1 (the method of [135], eq. 3.1), M2 (GMM2d on Psi only) and M3 (GMM4d/GMM2d with
the gaze switch), with the likelihoods tempered as L^w in eq. (3.2) and the estimator's goal
switch (prior mixed with the uniform one, `switch_probability` 0.02 per update) and restart
(`restart_switch` 0.5 at the first motion after a 0.25 s pause); and the plain eq. (3.2) rows
for M2 and M3: w = 1, switch_probability = 0, restart_switch = 0.

Splits (operators are seeded [seed, offset + i]; every operator has its own anthropometrics,
camera noise, gaze noise and personal offsets from the goal centres):
  training    offsets 0..    each operator in its own random layout (`random_layout` of its
                              generator), single-goal reaches, 25 % of the goals with both hands;
                              the bench learns GMM4d and GMM2d from them (no shipped model);
  validation  offsets 5000.. likewise, other random layouts; w is chosen here, separately for M2
                              and M3, as the least false positives (rising edges) + missed goals
                              per reach, on a grid extended until the error rises on both sides;
  test        offsets 10000.. in the two test layouts, which neither training nor validation
                              sees: box_usb (diagrams/box_usb.yaml, cycles of its fill, foam,
                              bring, tape actions, goals 1-5 of Fig. 3.4) and shelf_arc
                              (`second_layout`, single-goal reaches in random order).
Every operator of every split has the `RealisticBehaviour` (random eye-hand lead, glances at other
goals and at the robot, smooth gaze and hand noise, hesitations, aborted reaches, personal speeds);
--ideal gives all of them the ideal one (gaze exactly on the goal 0.3 s before the hand).

Figures per layout, method and goal (and pooled over goals, `all_goals`), as % of the reaches to
the goal (`intention.evaluation`):
  fp_pct            false positives as rising edges: a wrong goal's probability reaches 0.8 during a
                    reach, having fallen below 0.5 since it last did (at most once per goal and reach);
  fp_crossings_pct  false positives as crossings: every upward crossing of 0.8 by a wrong goal
                    during a reach (an oscillating belief counts each time);
  tn_pct            true negatives (missed goals): the true goal never reached 0.8 before arrival;
and the distance before recognition (Fig. 3.9). Thesis claim (Table 3.1): with the gaze, M3 has
fewer false positives than M2 and than [135]; `claims` says whether it holds here, from a 95 %
bootstrap interval over test operators of the paired difference. Speed: one update, 2 hands x 5 goals.

    python tools/bench_intention.py [--quick | --smoke] [--operators N] [--reaches N] [--seed S] [--ideal]
The last line printed is one JSON object with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
BOX_USB_SCENARIO = REPO / "diagrams" / "box_usb.yaml"
sys.path.insert(0, str(REPO))

from hrc_drake.cell.intention_data import (  # noqa: E402
    box_usb_layout,
    random_layout,
    random_segments,
    record_reaches,
    record_task_cycles,
    second_layout,
)
from hrc_drake.cell.plugins import ROBOT_LOOK_HEIGHT  # noqa: E402
from hrc_drake.cell.scenario import load_scenario  # noqa: E402
from hrc_drake.human.config import RealisticBehaviour  # noqa: E402
from hrc_drake.intention.bayes import GoalIntentionEstimator  # noqa: E402
from hrc_drake.intention.dataset import training_samples  # noqa: E402
from hrc_drake.intention.evaluation import (  # noqa: E402
    all_goals,
    bracketed_minimum,
    errors_per_reach,
    likelihood_trace,
    reach_outcomes,
    replay_posteriors,
    run_estimator,
    table_3_1,
)
from hrc_drake.intention.likelihood import IntentionLikelihoodLearner  # noqa: E402

METHODS = ("M1", "M2", "M3")
LEARNED = ("M2", "M3")  # the methods with a likelihood to temper
TRAIN_OFFSET, VALIDATION_OFFSET, TEST_OFFSET = 0, 5_000, 10_000
NOISE_LEVELS = (0.005, 0.01, 0.02)
GAZE_NOISE_LEVELS = (0.05, 0.1, 0.2)
SCATTER_RANGE = (0.0, 0.04)  # std (m) of a training/validation operator's offset from the centres
TEST_SCATTER = 0.03  # std (m) of each test operator's personal offset from the goal centres
BOTH_HANDS_SHARE = 0.25
#: The start of the w grid; `bracketed_minimum` extends it downwards by x0.7 as needed.
WEIGHT_GRID = (1.0, 0.7, 0.5, 0.35, 0.25, 0.18)
#: The plain eq. (3.2): untempered likelihoods, no goal switch, no restart after a pause.
PLAIN_EQ32 = {"evidence_weight": 1.0, "switch_probability": 0.0, "restart_switch": 0.0}
THESIS_TABLE_3_1 = {  # goal -> method -> (% false positives, % true negatives)
    "goal 4": {"M1": (4.54, 16.67), "M2": (11.53, 0.0), "M3": (0.0, 0.0)},
    "goal 1": {"M1": (9.09, 21.21), "M2": (11.15, 12.3), "M3": (6.06, 8.3)},
}
BOOTSTRAP_DRAWS = 2000


def robot_points() -> list:
    """Where a glance at the robot looks: the box cell's robots (the other layouts have none of their
    own and are taken to face the same robot across the table)."""
    scenario = load_scenario(BOX_USB_SCENARIO)
    return [np.asarray(r.base.xyz, dtype=float) + np.array([0.0, 0.0, ROBOT_LOOK_HEIGHT])
            for r in scenario.robots]


def random_layout_recording(i, offset, seed, n_reaches, behaviour, robots):
    """A training or validation operator: its own random layout, some goals with both hands."""
    rng = np.random.default_rng([seed, offset + i])
    noise, gaze_noise = float(rng.choice(NOISE_LEVELS)), float(rng.choice(GAZE_NOISE_LEVELS))
    scatter = rng.uniform(*SCATTER_RANGE)
    segments = random_segments(rng)
    layout = random_layout(rng)
    hands = tuple("both" if rng.random() < BOTH_HANDS_SHARE else h for h in layout.hands)
    options = {} if behaviour is None else {"behaviour": behaviour, "robot_points": robots}
    return record_reaches(layout, segments, n_reaches, rng, noise, gaze_noise, hands=hands,
                          target_scatter=scatter, **options)


def recording_of_test_operator(layout, i, seed, n_reaches, behaviour, robots):
    """Test operator i in `layout`; returns (recording, noise, gaze noise)."""
    rng = np.random.default_rng([seed, TEST_OFFSET + i])
    noise = float(rng.choice(NOISE_LEVELS))
    gaze_noise = float(rng.choice(GAZE_NOISE_LEVELS))
    segments = random_segments(rng)
    options = {"target_scatter": TEST_SCATTER}
    if behaviour is not None:
        options.update(behaviour=behaviour, robot_points=robots)
    if layout.tasks:
        cycles = max(1, round(n_reaches / 10))  # a cycle of the box cell reaches 10 goals
        recording = record_task_cycles(layout, segments, cycles, rng, noise, gaze_noise, **options)
    else:
        recording = record_reaches(layout, segments, n_reaches, rng, noise, gaze_noise, **options)
    return recording, noise, gaze_noise


def train_model(n_operators, n_reaches, seed, behaviour, robots, max_components):
    """GMM4d and GMM2d (3.1.2) learned from the training operators, w = 1 (the bench tempers)."""
    rows, flags = [], []
    for i in range(n_operators):
        recording = random_layout_recording(i, TRAIN_OFFSET, seed, n_reaches, behaviour, robots)
        phi, flag = training_samples(recording, with_gaze_flag=True)
        rows.append(phi)
        flags.append(flag)
    phi, flag = np.concatenate(rows), np.concatenate(flags)
    learner = IntentionLikelihoodLearner(candidates=range(1, max_components + 1), random_state=seed)
    learner.fit(phi, flag)
    print(f"trained on {n_operators} operators: {len(phi)} samples ({100 * flag.mean():.0f} % with F "
          f"valid), GMM4d {learner.n_components_4d_} clusters, GMM2d {learner.n_components_2d_}", flush=True)
    return learner.model_, len(phi)


def estimator(layout, model, method, **options):
    return GoalIntentionEstimator(layout.centers, model, method, goal_names=layout.goal_names, rng=0,
                                  **options)


def choose_weights(model, recordings):
    """w of each learned method on the validation recordings: `bracketed_minimum` of the errors."""
    chosen, sweeps = {}, {}
    for method in LEARNED:
        traces = [(r, likelihood_trace(estimator(r.layout, model, method, evidence_weight=1.0), r))
                  for r in recordings]

        def error(w, traces=traces, method=method):
            outcomes = []
            for r, (log_lik, active) in traces:
                probs = replay_posteriors(estimator(r.layout, model, method), r.times, log_lik, active, w)
                outcomes.extend(reach_outcomes(r, probs))
            return errors_per_reach(outcomes)

        w, scores, interior = bracketed_minimum(error, WEIGHT_GRID)
        chosen[method] = w
        sweeps[method] = {
            "grid": list(scores),
            "validation_errors_per_reach": [round(e, 4) for e in scores.values()],
            "interior": bool(interior),
        }
        curve = ", ".join(f"{k:g}: {e:.3f}" for k, e in scores.items())
        where = "interior" if interior else "NOT interior"
        print(f"  {method}: w = {w:g} ({where}); errors per reach {curve}", flush=True)
    return chosen, sweeps


def evaluate_layout(layout, n_operators, n_reaches, seed, model, weights, behaviour, robots):
    """Outcomes per variant ("tuned", "plain_eq32"), method and test operator; share of F valid."""
    outcomes = {"tuned": {m: [] for m in METHODS}, "plain_eq32": {m: [] for m in LEARNED}}
    valid = []
    plain_options = {k: v for k, v in PLAIN_EQ32.items() if k != "evidence_weight"}
    for i in range(n_operators):
        recording, noise, gaze_noise = recording_of_test_operator(layout, i, seed, n_reaches, behaviour,
                                                                  robots)
        valid.append(recording.gaze_valid.mean())
        m1 = run_estimator(estimator(layout, model, "M1"), recording)
        outcomes["tuned"]["M1"].append(reach_outcomes(recording, m1))
        for method in LEARNED:
            untempered = estimator(layout, model, method, evidence_weight=1.0)
            log_lik, active = likelihood_trace(untempered, recording)
            tuned = replay_posteriors(estimator(layout, model, method), recording.times, log_lik, active,
                                      weights[method])
            plain = replay_posteriors(estimator(layout, model, method, **plain_options), recording.times,
                                      log_lik, active, PLAIN_EQ32["evidence_weight"])
            outcomes["tuned"][method].append(reach_outcomes(recording, tuned))
            outcomes["plain_eq32"][method].append(reach_outcomes(recording, plain))
        print(f"  {layout.name}: operator {i + 1}/{n_operators} (noise {noise:.3f} m, gaze noise "
              f"{gaze_noise:.2f}, gaze valid {100 * valid[-1]:.0f} %)", flush=True)
    return outcomes, float(np.mean(valid))


def _flat(per_operator):
    return [o for outcomes in per_operator for o in outcomes]


def _rounded(row):
    return {k: (round(v, 2) if isinstance(v, float) else v) for k, v in row.items()}


def _counts(per_operator, key):
    """Per operator: the count behind the pooled figure `key` and the number of reaches, (n,) each."""
    field = {"fp_pct": "false_goals", "fp_crossings_pct": "false_crossings"}[key]
    counts = np.array([sum(len(o[field]) for o in outcomes) for outcomes in per_operator], dtype=float)
    reaches = np.array([len(outcomes) for outcomes in per_operator], dtype=float)
    return counts, reaches


def paired_difference(per_operator_a, per_operator_b, key, rng):
    """Pooled figure `key` (% of reaches) of A minus B, with its 95 % bootstrap interval: the same
    resampled operators for both (paired)."""
    count_a, reaches = _counts(per_operator_a, key)
    count_b, _ = _counts(per_operator_b, key)
    point = 100.0 * (count_a.sum() - count_b.sum()) / reaches.sum()
    pick = rng.integers(len(reaches), size=(BOOTSTRAP_DRAWS, len(reaches)))
    draws = 100.0 * (count_a[pick].sum(axis=1) - count_b[pick].sum(axis=1)) / reaches[pick].sum(axis=1)
    low, high = np.percentile(draws, [2.5, 97.5])
    verdict = "holds" if high < 0 else ("fails (M3 worse)" if low > 0 else "not resolved")
    return {"diff_pct": round(float(point), 2), "ci95": [round(float(low), 2), round(float(high), 2)],
            "verdict": verdict}


def claims(per_layout, seed):
    """Thesis (Table 3.1): M3 has fewer false positives than M2 and than [135] (M1)."""
    rng = np.random.default_rng([seed, 77])
    out = {}
    for name, outcomes in per_layout.items():
        tuned, plain = outcomes["tuned"], outcomes["plain_eq32"]
        entry = {}
        for key in ("fp_pct", "fp_crossings_pct"):
            entry[f"M3_vs_M2.{key}"] = paired_difference(tuned["M3"], tuned["M2"], key, rng)
            entry[f"M3_vs_M1.{key}"] = paired_difference(tuned["M3"], tuned["M1"], key, rng)
            entry[f"plain_eq32.M3_vs_M2.{key}"] = paired_difference(plain["M3"], plain["M2"], key, rng)
        out[name] = entry
    return out


def print_layout(layout, outcomes, gaze_valid):
    """The readable table of one layout; returns its JSON figures."""
    print(f"\nlayout {layout.name}: goals {', '.join(layout.goal_names)}; gaze flag F valid in "
          f"{100 * gaze_valid:.0f} % of the frames")
    print(f"{'goal':>6} {'method':>10} {'reaches':>7} {'% FP edge':>9} {'% FP cross':>10} {'% TN':>6} "
          f"{'dist median (m)':>15} {'thesis FP/TN':>13}")
    figures = {}
    tuned = {m: _flat(v) for m, v in outcomes["tuned"].items()}
    plain = {m: _flat(v) for m, v in outcomes["plain_eq32"].items()}
    for goal in (0, 3):
        label = f"goal {goal + 1}"
        for method in METHODS:
            row = table_3_1(tuned[method], goal)
            thesis = THESIS_TABLE_3_1[label][method] if layout.tasks else None
            thesis_s = f"{thesis[0]:.1f}/{thesis[1]:.1f}" if thesis else "-"
            print(f"{label:>6} {method:>10} {row['reaches']:>7} {row['false_positives_pct']:>9.1f} "
                  f"{row['false_positive_crossings_pct']:>10.1f} {row['true_negatives_pct']:>6.1f} "
                  f"{row['distance_median']:>15.3f} {thesis_s:>13}")
            figures[f"{label.replace(' ', '')}_{method}"] = {
                "fp_pct": round(row["false_positives_pct"], 2),
                "fp_crossings_pct": round(row["false_positive_crossings_pct"], 2),
                "tn_pct": round(row["true_negatives_pct"], 2),
                "dist_median_m": round(row["distance_median"], 3),
                "reaches": row["reaches"],
            }
    figures["all_goals"] = {m: _rounded(all_goals(tuned[m])) for m in METHODS}
    figures["plain_eq32"] = {m: _rounded(all_goals(plain[m])) for m in LEARNED}
    rows = [(m, figures["all_goals"][m]) for m in METHODS] + [
        (f"{m} plain", figures["plain_eq32"][m]) for m in LEARNED
    ]
    for name, row in rows:
        print(f"{'all':>6} {name:>10} {row['reaches']:>7} {row['fp_pct']:>9.1f} "
              f"{row['fp_crossings_pct']:>10.1f} {row['tn_pct']:>6.1f}")
    figures["gaze_valid_pct"] = round(100 * gaze_valid, 1)
    return figures


def update_speed(model, layout, n_calls, **options):
    rng = np.random.default_rng(0)
    recording = record_reaches(layout, random_segments(rng), 4, rng)
    est = GoalIntentionEstimator(layout.centers, model, "M3", rng=0, **options)
    samples = []
    for k in range(n_calls):
        j = k % len(recording.times)
        if j == 0:
            est.reset()
        start = time.perf_counter()
        est.update(recording.times[j], recording.points[j], recording.gaze[j], bool(recording.gaze_valid[j]))
        samples.append(time.perf_counter() - start)
    return float(np.median(samples))


def _finite(value):
    """NaN (no recognition at all) as JSON null."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="few operators, under a minute")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--operators", type=int, default=None, help="test operators per layout")
    parser.add_argument("--reaches", type=int, default=None, help="reaches per test operator")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ideal", action="store_true", help="ideal operators in every split (old figures)")
    args = parser.parse_args(argv)
    if args.smoke:  # one operator per split and layout, one cycle of the box cell
        n_test, n_reaches, n_train, train_reaches, max_components = 1, 10, 1, 10, 1
        n_validation, validation_reaches, n_calls = 1, 10, 50
    elif args.quick:
        n_test, n_reaches, n_train, train_reaches, max_components = 2, 18, 4, 20, 4
        n_validation, validation_reaches, n_calls = 2, 20, 300
    else:
        n_test, n_reaches, n_train, train_reaches, max_components = 10, 36, 24, 40, 12
        n_validation, validation_reaches, n_calls = 6, 40, 3000
    n_test = args.operators or n_test
    n_reaches = args.reaches or n_reaches
    load_start = os.getloadavg()
    start = time.time()
    behaviour = None if args.ideal else RealisticBehaviour()
    robots = robot_points()
    print(f"training: {n_train} operators x {train_reaches} reaches in random layouts", flush=True)
    model, n_samples = train_model(n_train, train_reaches, args.seed, behaviour, robots, max_components)
    print(f"validation: {n_validation} operators x {validation_reaches} reaches in other random layouts",
          flush=True)
    validation = [
        random_layout_recording(i, VALIDATION_OFFSET, args.seed, validation_reaches, behaviour, robots)
        for i in range(n_validation)
    ]
    weights, sweeps = choose_weights(model, validation)
    figures = {
        "operator_behaviour": "ideal" if args.ideal else "realistic",
        "seed": args.seed,
        "splits": {
            "train": {"operators": n_train, "reaches": train_reaches, "layouts": "random (own per operator)",
                      "samples": n_samples, "seed_offset": TRAIN_OFFSET},
            "validation": {"operators": n_validation, "reaches": validation_reaches,
                           "layouts": "random (own per operator)", "seed_offset": VALIDATION_OFFSET},
            "test": {"operators_per_layout": n_test, "reaches_per_operator": n_reaches,
                     "layouts": ["box_usb", "shelf_arc"], "seed_offset": TEST_OFFSET},
        },
        "weight": weights,
        "weight_sweep": sweeps,
        "weight_criterion": "validation false positives (rising edges) + missed goals per reach",
    }
    layouts = [box_usb_layout(BOX_USB_SCENARIO), second_layout()]
    per_layout = {}
    for layout in layouts:
        outcomes, gaze_valid = evaluate_layout(layout, n_test, n_reaches, args.seed, model, weights,
                                               behaviour, robots)
        per_layout[layout.name] = outcomes
        figures[layout.name] = print_layout(layout, outcomes, gaze_valid)
    pooled = {variant: {m: [ops for name in per_layout for ops in per_layout[name][variant][m]]
                        for m in per_layout[layouts[0].name][variant]}
              for variant in ("tuned", "plain_eq32")}
    figures["all_layouts"] = {
        "all_goals": {m: _rounded(all_goals(_flat(pooled["tuned"][m]))) for m in METHODS}
    }
    figures["plain_eq32"] = {"settings": PLAIN_EQ32,
                             **{m: _rounded(all_goals(_flat(pooled["plain_eq32"][m]))) for m in LEARNED}}
    per_layout["all_layouts"] = pooled
    figures["claims"] = claims(per_layout, args.seed)
    print("\nthesis (Table 3.1): M3 has fewer false positives than M2 and [135] (M1); "
          "difference in % of reaches, 95 % bootstrap over operators:")
    for name, entry in figures["claims"].items():
        for key, c in entry.items():
            print(f"  {name:>11} {key:<32} {c['diff_pct']:>7.2f} [{c['ci95'][0]:.2f}, {c['ci95'][1]:.2f}] "
                  f"{c['verdict']}")
    speed = update_speed(model, layouts[-1], n_calls)
    speed_np = update_speed(model, layouts[-1], n_calls, goal_std=0.03, n_goal_samples=20)
    print(f"\nM3 update, 2 hands x 5 goals: median {1e6 * speed:.0f} us "
          f"(with Np = 20 sampled centres, eq. 3.12: {1e6 * speed_np:.0f} us); target <= 1000 us")
    figures.update(
        {
            "update_us_median": round(1e6 * speed, 1),
            "update_np20_us_median": round(1e6 * speed_np, 1),
            "seconds": round(time.time() - start, 1),
            "load_average": {"start": [round(v, 2) for v in load_start],
                             "end": [round(v, 2) for v in os.getloadavg()]},
            "quick": bool(args.quick),
        }
    )
    print(json.dumps(_finite(figures)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
