"""Benchmark of the activity prediction (thesis Ch. 5): Fig. 5.4, Fig. 5.7, IKEA ASM data, speed.

Usage: python tools/bench_prediction.py [--quick | --smoke]
Prints readable tables and, as its last line, one JSON object with the figures.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hrc_drake.datasets import data_root  # noqa: E402
from hrc_drake.prediction import (  # noqa: E402
    ChingHigherOrderModel,
    HigherOrderMarkovModel,
    MarkovChainModel,
    SuffixTreeModel,
    VariableOrderMarkovModel,
    WaitingTimePredictor,
)

PATTERN_54 = [0, 1, 2, 0, 1, 3, 2, 4]  # a1 a2 a3 a1 a2 a4 a3 a5
STAGES_58 = [[0, 1], [2], [3, 4, 5], [6, 7], [8, 9]]
AFFINE_58 = [[0, 1], [3, 4, 5], [6, 7], [8, 9]]


def log(msg: str) -> None:
    print(msg, flush=True)


# ------------------------------------------------------------------------------ Fig. 5.4
def mutated_pattern(rng: np.random.Generator, repeats=75, rate=0.03, m=5) -> list[int]:
    seq = np.array(PATTERN_54 * repeats)
    mutate = rng.random(seq.size) < rate
    seq[mutate] = rng.integers(0, m, size=mutate.sum())
    return seq.tolist()


def one_step_error(model, seq: list[int], skip: int) -> float:
    """Fraction of steps whose most probable next action is wrong (Fig. 5.4 error)."""
    wrong = total = 0
    for k, action in enumerate(seq):
        if k >= skip:
            wrong += int(np.argmax(model.predict_proba(seq[max(0, k - 16) : k])) != action)
            total += 1
        model.partial_fit(action)
    return wrong / total


def bench_fig54(seeds: int, lengths: list[int]) -> dict:
    makers = {
        "homm_n7": lambda b: HigherOrderMarkovModel(order=7, buffer_size=b, actions=5),
        "markov_chain": lambda b: MarkovChainModel(buffer_size=b, actions=5),
        "ching_n7": lambda b: ChingHigherOrderModel(order=7, buffer_size=b, actions=5),
        "vomm_ppm_d5": lambda b: VariableOrderMarkovModel(max_depth=5, buffer_size=b, actions=5),
    }
    errors = {name: {length: [] for length in lengths} for name in makers}
    for seed in range(seeds):
        seq = mutated_pattern(np.random.default_rng(seed))
        for length in lengths:
            for name, make in makers.items():
                errors[name][length].append(one_step_error(make(length), seq, skip=len(PATTERN_54)))
        log(f"  fig 5.4: seed {seed + 1}/{seeds} done")
    table = {name: {str(k): float(np.mean(v)) for k, v in per.items()} for name, per in errors.items()}
    log("\nFig. 5.4 - one-step prediction error (argmax wrong) vs FIFO length, mean over seeds")
    log(f"{'model':<14}" + "".join(f"{length:>8}" for length in lengths))
    for name, per in table.items():
        log(f"{name:<14}" + "".join(f"{per[str(k)]:>8.3f}" for k in lengths))
    longest = str(lengths[-1])
    best = min(table, key=lambda n: table[n][longest])
    log(f"lowest error at FIFO {longest}: {best}")
    return {"error": table, "best_at_longest_fifo": best}


# ------------------------------------------------------------------------------ Fig. 5.7
#: alpha of the suffix tree in Fig. 5.7. The series are stationary (20 cycles, no change of
#: pattern), so the forgetting time N = 5 / alpha of (5.26) is set past the 200-step series,
#: as the HOMM's FIFO of 200 covers it all. The default alpha = 0.02 (N = 250, but a token
#: 35 steps old already weighs 1/2) and 0.001, 0.005, 0.01 are run alongside: the sweep.
FORGETTING_57 = 0.002


def button_series_with_truth(rng: np.random.Generator, cycles=20, noise=0.05, m=10) -> tuple[list, list]:
    """(series with 5 % of the elements replaced at random, the clean series)."""
    clean = []
    for _ in range(cycles):
        for stage in STAGES_58:
            clean.extend(rng.permutation(stage).tolist())
    seq = np.array(clean)
    replace = rng.random(seq.size) < noise
    seq[replace] = rng.integers(0, m, size=replace.sum())
    return seq.tolist(), clean


def button_series(rng: np.random.Generator, cycles=20, noise=0.05, m=10) -> list[int]:
    return button_series_with_truth(rng, cycles, noise, m)[0]


def oracle_probabilities(clean_prefix: list[int], noise=0.05, m=10) -> np.ndarray:
    """The true P(A_{k+1}) of the generator, knowing the clean stage state (a reference floor)."""
    done = set(clean_prefix[len(clean_prefix) - len(clean_prefix) % m :])
    probs = np.zeros(m)
    for stage in STAGES_58:
        left = [a for a in stage if a not in done]
        if left:
            probs[left] = 1.0 / len(left)
            break
    return (1.0 - noise) * probs + noise / m


def squared_errors(model, seq: list[int], m: int) -> np.ndarray:
    """||X_hat_{k+1} - X_{k+1}||^2 at every step k >= 1 (X: one-hot of the observed action, as
    the X of eq. 5.9), the model learning online from an empty start."""
    eye = np.eye(m)
    errs = []
    for k, action in enumerate(seq):
        if k > 0:
            errs.append(float(np.sum((model.predict_proba(seq[max(0, k - 12) : k]) - eye[action]) ** 2)))
        model.partial_fit(action)
    return np.array(errs)


def mean_squared_error(model, seq: list[int], m: int) -> float:
    """Mean ||X_hat_{k+1} - X_{k+1}||^2 over the series (Fig. 5.7)."""
    return float(squared_errors(model, seq, m).mean())


FIG57_THESIS_MODELS = ("st_no_priors", "st_2_priors", "st_all_priors", "homm")


def bench_fig57(n_series: int, orders: list[int], n_reference_series: int = 20) -> dict:
    """Fig. 5.7 on `n_series` series; the two reference rows (not in the thesis) on the first
    `n_reference_series` of them only, to keep the run short."""

    def tree(sets, alpha=FORGETTING_57):
        return lambda s: SuffixTreeModel(order=s, affine_sets=sets, forgetting=alpha, actions=10)

    alpha = FORGETTING_57
    makers = {
        "st_no_priors": tree([]),
        "st_2_priors": tree(AFFINE_58[:2]),
        "st_all_priors": tree(AFFINE_58),
        # HOMM order n uses n+1 past actions: n = sigma - 1 compares equal memories
        "homm": lambda s: HigherOrderMarkovModel(order=s - 1, buffer_size=200, actions=10),
        # references, not in the thesis: the sweep of alpha around FORGETTING_57 (0.02 is the
        # default), a PPM of the same depth
        "st_all_alpha0.001": tree(AFFINE_58, 0.001),
        "st_all_alpha0.005": tree(AFFINE_58, 0.005),
        "st_all_alpha0.01": tree(AFFINE_58, 0.01),
        "st_all_alpha0.02": tree(AFFINE_58, 0.02),
        "ppm_reference": lambda s: VariableOrderMarkovModel(max_depth=s, buffer_size=None, actions=10),
    }
    results = {name: {o: [] for o in orders} for name in makers}
    second_half = {name: {o: [] for o in orders} for name in makers}
    oracle = []
    for index in range(n_series):
        seq, clean = button_series_with_truth(np.random.default_rng(1000 + index))
        truth = np.array([oracle_probabilities(clean[:k]) for k in range(1, len(seq))])
        oracle.append(float(np.mean(np.sum((truth - np.eye(10)[seq[1:]]) ** 2, axis=1))))
        for order in orders:
            for name, make in makers.items():
                if name not in FIG57_THESIS_MODELS and index >= n_reference_series:
                    continue
                errs = squared_errors(make(order), seq, 10)
                results[name][order].append(float(errs.mean()))
                second_half[name][order].append(float(errs[len(errs) // 2 :].mean()))
        if (index + 1) % max(1, n_series // 10) == 0:
            log(f"  fig 5.7: series {index + 1}/{n_series} done")
    log(
        f"\nFig. 5.7 - mean squared error ||X_hat - X||^2 vs model order, {n_series} series "
        f"(median [20th, 80th] over series; reference rows on {min(n_series, n_reference_series)}); "
        f"suffix tree alpha = {alpha} unless named"
    )
    log(f"{'model':<17}" + "".join(f"{o:>22}" for o in orders))
    table = {}
    for name, per in results.items():
        row = {}
        cells = []
        for order in orders:
            q20, q50, q80 = np.percentile(per[order], [20, 50, 80])
            row[str(order)] = {
                "mean": float(np.mean(per[order])),
                "p20": q20,
                "p50": q50,
                "p80": q80,
                "mean_second_half": float(np.mean(second_half[name][order])),
            }
            cells.append(f"{q50:.3f} [{q20:.3f},{q80:.3f}]")
        table[name] = row
        log(f"{name:<17}" + "".join(f"{c:>22}" for c in cells))
    q20, q50, q80 = np.percentile(oracle, [20, 50, 80])
    log(f"{'oracle (truth)':<17}{f'{q50:.3f} [{q20:.3f},{q80:.3f}]':>22}  (knows the clean stage state)")
    log("second half of each series (after learning), mean:")
    for name in table:
        log(f"{name:<17}" + "".join(f"{table[name][str(o)]['mean_second_half']:>22.3f}" for o in orders))
    mean_over_orders = {n: float(np.mean([table[n][str(o)]["mean"] for o in orders])) for n in table}
    ranking = sorted(FIG57_THESIS_MODELS, key=mean_over_orders.get)
    best_per_order = {
        str(o): min(FIG57_THESIS_MODELS, key=lambda n, o=o: table[n][str(o)]["mean"]) for o in orders
    }
    log(f"ranking by mean error over orders (best first): {ranking}")
    log(f"best thesis model per order: {best_per_order}")
    return {
        "mse": table,
        "mean_over_orders": mean_over_orders,
        "ranking": ranking,
        "best_per_order": best_per_order,
        "oracle_mean": float(np.mean(oracle)),
        "n_series": n_series,
    }


# ------------------------------------------------------------------------------ IKEA ASM
def data_dir() -> Path:
    """The real recordings: the repository's data/, or $HRC_DRAKE_DATA (`hrc_drake.datasets`)."""
    return data_root()


def load_ikea() -> dict[str, list[tuple[list[str], list[float]]]] | None:
    """Furniture -> sequences of (actions, start times) from the no-NA ground truth."""
    path = data_dir() / "ikea_asm_eventlog" / "ikea_asm_test_gt_segments_no_na.csv"
    if not path.exists():
        return None
    traces: dict[str, list] = defaultdict(list)
    furniture_of = {}
    with open(path, newline="") as handle:
        for row in csv.DictReader(handle):
            traces[row["trace_id"]].append(
                (int(row["event_index"]), row["activity"], float(row["start_s"]), float(row["end_s"]))
            )
            furniture_of[row["trace_id"]] = row["furniture"]
    out: dict[str, list] = defaultdict(list)
    for trace_id, events in traces.items():
        events.sort()
        out[furniture_of[trace_id]].append(([e[1] for e in events], [e[2] for e in events], events[-1][3]))
    return dict(out)


def bench_ikea(max_held_out: int | None) -> dict:
    data = load_ikea()
    if data is None:
        log("\nIKEA ASM annotations not found: skipped (not shipped: the IKEA ASM data terms are not "
            "restated by their source; put ikea_asm_eventlog/ in a folder named by $HRC_DRAKE_DATA)")
        return {"skipped": True}
    makers = {
        "markov_chain": lambda acts: MarkovChainModel(buffer_size=None, actions=acts),
        "homm_n2": lambda acts: HigherOrderMarkovModel(order=2, buffer_size=None, actions=acts),
        "vomm_ppm_d3": lambda acts: VariableOrderMarkovModel(max_depth=3, buffer_size=None, actions=acts),
        "suffix_tree_s2": lambda acts: SuffixTreeModel(order=2, forgetting=0.005, actions=acts),
    }
    accuracy: dict[str, dict[str, float]] = {}
    below_p80 = []
    for furniture, sequences in sorted(data.items()):
        actions = sorted({a for seq, _, _ in sequences for a in seq})
        held = range(len(sequences)) if max_held_out is None else range(min(max_held_out, len(sequences)))
        hits = defaultdict(int)
        total = 0
        for index in held:
            train = [a for j, (seq, _, _) in enumerate(sequences) if j != index for a in seq]
            test, starts, end = sequences[index]
            total += len(test) - 1
            for name, make in makers.items():
                model = make(actions).fit(train)
                waiting = None
                if name == "homm_n2":
                    waiting = WaitingTimePredictor(model, resolution=0.2, max_samples=200)
                    for j, (seq, st, last_end) in enumerate(sequences):
                        if j != index:
                            stops = list(st[1:]) + [last_end]
                            for a, t0, t1 in zip(seq, st, stops, strict=True):
                                if t1 > t0:
                                    waiting.observe_duration(a, t1 - t0)
                for k in range(1, len(test)):
                    history = test[:k]
                    hits[name] += int(actions[int(np.argmax(model.predict_proba(history)))] == test[k])
                    if waiting is not None:
                        # at the begin of A_{k-1}: when will the true next action begin?
                        pct = waiting.percentiles(history, 0.0, (0.8,), horizon=60.0)
                        true_wait = starts[k] - starts[k - 1]
                        below_p80.append(true_wait <= pct[actions.index(test[k]), 0])
        accuracy[furniture] = {name: hits[name] / total for name in makers}
        log(f"  ikea: {furniture} done ({len(held)} held-out sequences)")
    log("\nIKEA ASM - one-step accuracy (argmax right), leave-one-sequence-out per furniture")
    names = list(makers)
    log(f"{'furniture':<22}" + "".join(f"{n:>16}" for n in names))
    for furniture, row in accuracy.items():
        log(f"{furniture:<22}" + "".join(f"{row[n]:>16.3f}" for n in names))
    mean = {n: float(np.mean([row[n] for row in accuracy.values()])) for n in names}
    log(f"{'mean':<22}" + "".join(f"{mean[n]:>16.3f}" for n in names))
    fraction = float(np.mean(below_p80)) if below_p80 else float("nan")
    log(f"waiting-time calibration (HOMM n=2): true wait <= predicted p80 in {fraction:.3f} of steps")
    return {
        "accuracy": accuracy,
        "mean_accuracy": mean,
        "fraction_below_p80": fraction,
        "n_calib": len(below_p80),
    }


# ------------------------------------------------------------------------------ speed
def bench_speed(repeats: int) -> dict:
    rng = np.random.default_rng(7)
    seq = button_series(rng, cycles=120)
    model = SuffixTreeModel(order=3, affine_sets=AFFINE_58, actions=10)
    for a in seq[:1000]:
        model.partial_fit(a)
    st_times = []
    for k in range(1000, 1000 + repeats):
        t0 = time.perf_counter()
        model.partial_fit(seq[k])
        model.predict_proba(seq[k - 3 : k + 1])
        st_times.append(time.perf_counter() - t0)
    homm = HigherOrderMarkovModel(order=7, buffer_size=200, actions=5)
    seq54 = mutated_pattern(rng)
    for a in seq54:
        homm.partial_fit(a)
    homm_times = []
    for k in range(repeats):
        t0 = time.perf_counter()
        homm.partial_fit(seq54[k])
        homm.predict_proba(seq54[k - 8 : k + 1] if k >= 8 else seq54[:8])
        homm_times.append(time.perf_counter() - t0)
    waiting_times, waiting_cpu, waiting_warm, single_target, tree_sizes = {}, {}, {}, {}, {}
    for name, seq_model, history, m in (
        ("homm_n7", homm, seq54[-20:], 5),
        ("suffix_tree", model, seq[1000 + repeats - 10 : 1000 + repeats], 10),
    ):
        waiting = WaitingTimePredictor(seq_model)
        for a in range(m):
            for d in rng.uniform(2.0, 6.0, size=30):
                waiting.observe_duration(a, d)
        cold, cpu, warm, single = [], [], [], []
        for rep in range(max(7, repeats // 5)):
            # cold: as right after a new action (model and duration caches invalid)
            waiting.clear_cache()
            t0, c0 = time.perf_counter(), time.process_time()
            waiting.distributions(history, 1.0, horizon=60.0)
            cold.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            tree_sizes[name] = len(waiting._prob_cache)
            # warm: a periodic update before the next action (model unchanged)
            t0 = time.perf_counter()
            waiting.distributions(history, 1.0, horizon=60.0)
            warm.append(time.perf_counter() - t0)
            # one target's distribution (Algorithm 1 for one a), cold
            waiting.clear_cache()
            t0 = time.perf_counter()
            waiting.distribution(history, 1.0, target=rep % m, horizon=60.0)
            single.append(time.perf_counter() - t0)
        waiting_times[name] = float(np.median(cold) * 1e3)
        waiting_cpu[name] = float(np.median(cpu) * 1e3)
        waiting_warm[name] = float(np.median(warm) * 1e3)
        single_target[name] = float(np.median(single) * 1e3)
    result = {
        "suffix_tree_update_predict_ms": float(np.median(st_times) * 1e3),
        "homm_update_predict_ms": float(np.median(homm_times) * 1e3),
        "waiting_60s_ms": waiting_times,
        "waiting_60s_cpu_ms": waiting_cpu,
        "waiting_60s_warm_ms": waiting_warm,
        "waiting_60s_one_target_ms": single_target,
    }
    log("\nSpeed (medians; targets: suffix tree <= 5 ms, waiting time <= 20 ms)")
    st_ms, homm_ms = result["suffix_tree_update_predict_ms"], result["homm_update_predict_ms"]
    log(f"  suffix tree partial_fit + predict_proba after 1000 actions: {st_ms:.2f} ms")
    log(f"  HOMM (n=7, FIFO 200) partial_fit + predict_proba:          {homm_ms:.2f} ms")
    log("  waiting times over 60 s, all actions in one tree (cold: wall / CPU; warm) and one target (cold):")
    for name, value in waiting_times.items():
        log(
            f"    {name:<12} all: {value:6.2f} / {waiting_cpu[name]:6.2f} ms, "
            f"warm {waiting_warm[name]:6.2f} ms ({tree_sizes[name]} contexts predicted); "
            f"one target: {single_target[name]:6.2f} ms"
        )
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer seeds and series (< 1 min)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--series", type=int, default=100, help="Fig. 5.7 series in the full run")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    if args.smoke:
        fig54 = bench_fig54(seeds=1, lengths=[16])
        fig57 = bench_fig57(n_series=1, orders=[2])
        ikea = bench_ikea(max_held_out=1)
        speed = bench_speed(repeats=7)
    elif args.quick:
        fig54 = bench_fig54(seeds=1, lengths=[16, 256])
        fig57 = bench_fig57(n_series=2, orders=[2, 3])
        ikea = bench_ikea(max_held_out=1)
        speed = bench_speed(repeats=30)
    else:
        fig54 = bench_fig54(seeds=5, lengths=[16, 32, 64, 128, 256, 512])
        fig57 = bench_fig57(n_series=args.series, orders=[1, 2, 3, 4, 5])
        ikea = bench_ikea(max_held_out=None)
        speed = bench_speed(repeats=200)
    elapsed = time.perf_counter() - start
    log(f"\ntotal {elapsed:.1f} s")
    summary = {
        "quick": bool(args.quick),
        "fig54_error_at_longest_fifo": {n: list(v.values())[-1] for n, v in fig54["error"].items()},
        "fig54_best_at_longest_fifo": fig54["best_at_longest_fifo"],
        "fig57_mean_mse_over_orders": fig57["mean_over_orders"],
        "fig57_ranking": fig57["ranking"],
        "fig57_best_per_order": fig57["best_per_order"],
        "fig57_oracle_mse": fig57["oracle_mean"],
        "fig57_n_series": fig57["n_series"],
        "ikea_mean_accuracy": ikea.get("mean_accuracy"),
        "ikea_fraction_below_p80": ikea.get("fraction_below_p80"),
        **speed,
        "seconds": round(elapsed, 1),
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
