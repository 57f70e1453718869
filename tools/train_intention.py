"""Record labelled reaches from synthetic operators and learn GMM4d / GMM2d (thesis 3.1.2, Fig. 3.8).

Operators vary in anthropometrics, camera noise, gaze noise, where exactly they put the hand
at each goal, and the cell: random layouts (single-goal reaches, one hand or both) and the
box-with-USB-pen cell of 3.1.3 (cycles of its fill, foam, bring, tape actions); the second
benchmark layout is never used here. GMM4d learns from the samples whose gaze flag F is valid,
GMM2d from all. The model is saved as JSON (weights, means, covariances), by default as the
shipped hrc_drake/data/intention_default.json.

Samples come from the approach phase of each reach only (start to arrival, the wrist moving by
the significance test of `features`): a wrist lingering at its goal is no evidence of intent.
The exponent w of the likelihoods (L^w in eq. 3.2: consecutive features share most of their
velocity window, so they are not independent) is chosen on separate validation operators
(seeds from VALIDATION_SEED_OFFSET, neither training nor benchmark operators), as the value
with the fewest false positives + missed goals averaged over M2 and M3, on a grid extended
downwards until the error rises below the chosen w (`evaluation.bracketed_minimum`), and saved
with the model. tools/bench_intention.py does not use this model: it learns its own, from other
splits, and chooses w separately for M2 and M3.

    python tools/train_intention.py [--operators 24] [--reaches 40] [--validation 6] [--out PATH] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
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
)
from hrc_drake.intention.dataset import training_samples  # noqa: E402
from hrc_drake.intention.evaluation import choose_evidence_weight  # noqa: E402
from hrc_drake.intention.likelihood import DEFAULT_MODEL_PATH, IntentionLikelihoodLearner  # noqa: E402

NOISE_LEVELS = (0.005, 0.01, 0.02)
GAZE_NOISE_LEVELS = (0.05, 0.1, 0.2)
#: Seeds of the training operators start here; the validation ones at 5_000; the benchmark's at 10_000.
TRAIN_SEED_OFFSET = 0
VALIDATION_SEED_OFFSET = 5_000
EVIDENCE_WEIGHTS = (1.0, 0.7, 0.5, 0.35, 0.25, 0.18)


#: std (m) of an operator's personal offset from each goal centre
SCATTER_RANGE = (0.0, 0.04)
#: share of the random layouts' goals reached with both hands
BOTH_HANDS_SHARE = 0.25


def record_operator(i: int, n_reaches: int, seed: int, offset: int = TRAIN_SEED_OFFSET):
    """Recording of operator i (every third one in the box cell, the others in random layouts)."""
    rng = np.random.default_rng([seed, offset + i])
    noise, gaze_noise = rng.choice(NOISE_LEVELS), rng.choice(GAZE_NOISE_LEVELS)
    scatter = rng.uniform(*SCATTER_RANGE)
    segments = random_segments(rng)
    if i % 3 == 2:
        layout = box_usb_layout(BOX_USB_SCENARIO)
        n_cycles = max(1, n_reaches // 12)  # a cycle of the box cell is 10-12 reaches
        recording = record_task_cycles(
            layout, segments, n_cycles, rng, noise, gaze_noise, target_scatter=scatter
        )
    else:
        layout = random_layout(rng)
        hands = tuple("both" if rng.random() < BOTH_HANDS_SHARE else h for h in layout.hands)
        recording = record_reaches(
            layout, segments, n_reaches, rng, noise, gaze_noise, hands=hands, target_scatter=scatter
        )
    return recording, (noise, gaze_noise, scatter)


def collect(n_operators: int, n_reaches: int, seed: int, verbose: bool = True):
    """Phi samples (M, 4) of `n_operators` synthetic operators and their gaze flags F (M,)."""
    rows, flags = [], []
    for i in range(n_operators):
        recording, (noise, gaze_noise, scatter) = record_operator(i, n_reaches, seed)
        layout = recording.layout
        phi, flag = training_samples(recording, with_gaze_flag=True)
        rows.append(phi)
        flags.append(flag)
        if verbose:
            print(
                f"  operator {i + 1}/{n_operators}: {layout.name}, noise {noise:.3f} m, "
                f"gaze noise {gaze_noise:.2f}, scatter {scatter:.3f} m, {len(phi)} samples "
                f"({100 * flag.mean():.0f} % with a valid gaze flag)",
                flush=True,
            )
    return np.concatenate(rows), np.concatenate(flags)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--operators", type=int, default=24)
    parser.add_argument("--reaches", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--validation", type=int, default=6, help="validation operators for w (0: w = 1)")
    parser.add_argument("--max-components", type=int, default=12)
    parser.add_argument("--out", type=Path, default=DEFAULT_MODEL_PATH)
    args = parser.parse_args(argv)
    start = time.time()
    print(f"recording {args.operators} operators x {args.reaches} reaches", flush=True)
    phi, gaze_valid = collect(args.operators, args.reaches, args.seed)
    print(f"{len(phi)} samples in {time.time() - start:.0f} s; fitting", flush=True)
    learner = IntentionLikelihoodLearner(candidates=range(1, args.max_components + 1), random_state=args.seed)
    learner.fit(phi, gaze_valid)
    scores = {}
    if args.validation > 0:
        print(f"choosing the evidence weight w on {args.validation} validation operators", flush=True)
        recordings = [
            record_operator(i, args.reaches, args.seed, VALIDATION_SEED_OFFSET)[0]
            for i in range(args.validation)
        ]
        weight, scores = choose_evidence_weight(learner.model_, recordings, EVIDENCE_WEIGHTS)
        learner.model_.evidence_weight = weight
        for w, errors in scores.items():
            print(f"  w = {w:.2f}: {errors:.3f} errors (false positives + missed goals) per reach")
    learner.model_.info.update(
        {
            "operators": args.operators,
            "reaches_per_operator": args.reaches,
            "seed": args.seed,
            "samples_gaze_valid": int(gaze_valid.sum()),
            "tool": "tools/train_intention.py",
            "approach_only": True,
            "validation_operators": args.validation,
            "evidence_weight_scores": {str(w): e for w, e in scores.items()},
        }
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    learner.model_.save(args.out)
    print("held-out log-likelihood per sample (Fig. 3.8):")
    print(f"{'clusters':>8} {'GMM4d':>9} {'GMM2d':>9}")
    for k in learner.heldout_scores_4d_:
        print(
            f"{k:>8} {learner.heldout_scores_4d_[k]:>9.3f} "
            f"{learner.heldout_scores_2d_.get(k, float('nan')):>9.3f}"
        )
    print(
        f"chosen: GMM4d {learner.n_components_4d_} clusters, GMM2d {learner.n_components_2d_}; "
        f"saved {args.out}"
    )
    print(
        json.dumps(
            {
                "samples": len(phi),
                "samples_gaze_valid": int(gaze_valid.sum()),
                "n_components_4d": learner.n_components_4d_,
                "n_components_2d": learner.n_components_2d_,
                "evidence_weight": learner.model_.evidence_weight,
                "seconds": round(time.time() - start, 1),
            }
        )
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
