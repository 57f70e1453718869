"""Action segmentation of thesis 4.2 on the torch cell: E_s with and without buffer distances,
against the goal-region detector, and the segmenter's step times.

On `diagrams/torch_segmentation.yaml` (a1..a5 of 4.2, shared buffers A and B): the segmenter
learns from a library recorded by a synthetic operator of other seeds and other anthropometrics
(the scenario's `library_arm_scale` and `library_shoulder_scale`: arms 8 % longer, shoulders 5 %
wider) than the test runs; each test run is a seeded operator
doing the pattern (three orders of a1..a5) on their own, at the segmenter's rate (25 Hz: the
40 ms of 4.2, 10 samples a 400 ms window) with the camera's noise. E_s (4.2.1) is the share of the
frames of the true actions labelled with another action. Variants (Fig. 4.10): F_O with the wrists'
distances to the buffer and station centres ("buffers"), or to the camera origin only
("no_buffers"); each with both readings of Phi_OjY (eq. (4.1)): the counts of 4.1.1 ("literal",
the default) and our per-action frequencies ("frequency"). Baseline: the goal-region detector
(each action marked by its first goal, `end_rule: next`) on the same frames.

    python tools/bench_segmentation.py [--quick | --smoke] [--runs N]

Last line: one JSON object with `segmentation_error_buffers`, `segmentation_error_no_buffers`
(the scenario's Phi_OjY reading), `segmentation_error_literal_phi` (buffers, counts),
`segmentation_error_literal_phi_no_buffers`, `segmentation_error_frequency_phi` (buffers,
per-action frequencies), `segmentation_error_frequency_phi_no_buffers`, `goal_region_error`
(medians over the test runs, with the per-run values), `window_ms_median` (one sliding-window
step: the GA and the marginals of a batch of L windows), `batch_period_s` (the time a batch of L
windows covers), `bp_ms_median_chain_30` (marginals of a 30-variable chain with 5 values).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

SCENARIO = REPO / "diagrams" / "torch_segmentation.yaml"


def goal_region_labels(scenario, frames, rate: float) -> list:
    """Per-frame actions of the goal-region detector (each action marked by its first goal; an
    action lasts until the next begins)."""
    from hrc_drake.intention.detector import GoalRegionDetector

    goals = {g.name: g for g in scenario.layout.goals}
    marks = [(a.name, a.region or a.goals[0]) for a in scenario.operator.actions]
    detector = GoalRegionDetector(tuple(goal for _, goal in marks),
                                  np.array([goals[goal].center for _, goal in marks], float),
                                  np.array([goals[goal].radius for _, goal in marks], float),
                                  actions=tuple(name for name, _ in marks), end_rule="next")
    labels, current = [], None
    for k, frame in enumerate(frames):
        wrists, known = detector.known_wrists(frame, np.zeros(8))
        detector, events = detector.update(k / rate, wrists, known)
        for event in events:
            if event.kind == "begin":
                current = event.action
            elif event.action == current:
                current = None
        labels.append(current)
    return labels


def batch_step_ms(segmenter, frames) -> list[float]:
    """Wall time (ms) of each sliding-window step that ran the GA on a full batch."""
    from hrc_drake.intention.segmentation import discretise, window_features

    segmenter.reset()
    sliding = segmenter._sliding
    values, bounds = window_features(frames, segmenter.window_length, segmenter.centres)
    steps = []
    for k, (row, window) in enumerate(zip(discretise(values, segmenter.model_.edges), bounds, strict=True)):
        start = time.perf_counter()
        sliding.push(row, tuple(window))
        if (k + 1) % segmenter.batch_windows == 0:
            steps.append(1000 * (time.perf_counter() - start))
    segmenter.reset()
    return steps


def chain_bp_ms(repeats: int = 20) -> float:
    """Median time (ms) of the marginals of a 30-variable chain with 5 values (App. C.0.1)."""
    from hrc_drake.intention.factor_graph import FactorGraph

    rng = np.random.default_rng(0)
    graph = FactorGraph()
    for k in range(30):
        graph.add_variable(k, 5)
        graph.add_factor([k], rng.uniform(0.1, 1.0, 5))
        if k:
            graph.add_factor([k - 1, k], rng.uniform(0.1, 1.0, (5, 5)))
    graph.marginals()  # the first call compiles the structure
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        graph.marginals({0: 1})
        times.append(1000 * (time.perf_counter() - start))
    return float(np.median(times))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 test runs of one cycle (under a minute)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--runs", type=int, default=6, help="test runs (default 6)")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")
    from hrc_drake.cell.plugins import (
        label_segments,
        new_segmenter,
        operator_stream,
        pattern_precedence,
        segmenter_library,
    )
    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.intention.segmentation import segmentation_error

    scenario = load_scenario(SCENARIO)
    config = scenario.action_detector
    # smoke: one training cycle, a tiny genetic algorithm and a few training steps: the path, not the figures
    fit_options = {"n_sequences": 10, "max_iter": 3} if args.smoke else {}
    if args.smoke:
        config = dataclasses.replace(config, training_cycles=1, population=4, generations=1)
    elif args.quick:
        config = dataclasses.replace(config, training_cycles=2)
    runs, cycles = (1, 1) if args.smoke else (2, 1) if args.quick else (args.runs, 2)
    pattern = list(scenario.operator.pattern)
    actions = list(dict.fromkeys(pattern))
    library = segmenter_library(scenario, config, seed=1000)  # another seed and person than the tests
    centres = {
        "buffers": np.array([g.center for g in scenario.layout.goals], float),
        "no_buffers": np.array([scenario.layout.camera.position], float),
    }
    readings = {"literal": "counts", "frequency": "per_action_frequencies"}  # Phi_OjY, eq. (4.1)
    segmenters = {}
    for where, points in centres.items():
        for reading, kind in readings.items():
            start = time.perf_counter()
            variant = dataclasses.replace(config, observation_potential=kind)
            segmenters[f"{where}/{reading}"] = new_segmenter(variant, points, seed=7).fit(
                library, pattern_precedence(pattern), actions=actions, seed=7, **fit_options)
            print(f"{where}, {reading} Phi_OjY: learnt from {len(library)} recorded actions in "
                  f"{time.perf_counter() - start:.1f} s", flush=True)
    default = next(r for r, kind in readings.items() if kind == config.observation_potential)
    errors = {name: [] for name in segmenters} | {"goal_region": []}
    steps = []
    print(f"{'':>12} {'E_s buffers':>25} {'E_s no buffers':>25}")
    print(f"{'run':>4} {'frames':>7} {'literal':>12} {'frequency':>12} {'literal':>12} {'frequency':>12} "
          f"{'goal regions':>13}")
    for run in range(runs):
        frames, labels = operator_stream(scenario, cycles, config.rate, seed=run)
        truth = label_segments(labels)
        for name, segmenter in segmenters.items():
            errors[name].append(segmentation_error(segmenter.segment(frames), truth))
        regions = goal_region_labels(scenario, frames, config.rate)
        errors["goal_region"].append(segmentation_error(regions, truth))
        steps += batch_step_ms(segmenters[f"buffers/{default}"], frames)
        print(f"{run:>4} {len(frames):>7} " + " ".join(f"{errors[name][-1]:>12.3f}" for name in segmenters)
              + f" {errors['goal_region'][-1]:>13.3f}", flush=True)
    batch_period = config.window * config.batch_windows

    def median(name: str) -> float:
        return float(np.median(errors[name]))

    figures = {
        "quick": bool(args.quick), "smoke": bool(args.smoke), "runs": runs, "cycles_per_run": cycles,
        "library_actions": len(library),
        "rate_hz": config.rate, "window_samples": segmenters[f"buffers/{default}"].window_length,
        "observation_potential": config.observation_potential,
        "segmentation_error_buffers": median(f"buffers/{default}"),
        "segmentation_error_no_buffers": median(f"no_buffers/{default}"),
        "segmentation_error_literal_phi": median("buffers/literal"),
        "segmentation_error_literal_phi_no_buffers": median("no_buffers/literal"),
        "segmentation_error_frequency_phi": median("buffers/frequency"),
        "segmentation_error_frequency_phi_no_buffers": median("no_buffers/frequency"),
        "goal_region_error": median("goal_region"),
        "per_run": errors,
        "window_ms_median": float(np.median(steps)) if steps else None,
        "window_s": config.window, "batch_period_s": batch_period,
        "bp_ms_median_chain_30": chain_bp_ms(2 if args.smoke else 20),
    }
    for reading in readings:
        print(f"E_s median, {reading} Phi_OjY: buffers {median(f'buffers/{reading}'):.3f}, no buffers "
              f"{median(f'no_buffers/{reading}'):.3f} (thesis Fig. 4.10: buffers lower)")
    print(f"E_s median, goal regions: {figures['goal_region_error']:.3f}")
    if steps:
        print(f"one sliding-window step (GA + marginals of L = {config.batch_windows} windows): "
              f"{figures['window_ms_median']:.0f} ms median, for {batch_period:.0f} s of camera data")
    print(f"marginals of a 30-variable chain, 5 values: {figures['bp_ms_median_chain_30']:.2f} ms")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
