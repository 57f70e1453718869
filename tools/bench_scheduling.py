"""Benchmark of hrc_drake.scheduling: Monte Carlo decision latency (thesis 7.3.1, 7.5.2), the
best-scenario decision latency on the use case a net (7.2), the Fig. 7.12 campaign on the
Fig. 7.11 net, use case a patterns 1 and 2 (7.5.1) and use case b patterns 1 and 2 (7.5.2,
Scheduler A against Scheduler B) at event level, with the sweeps of their settings, and (not in
--quick) use case c in the Drake cell (7.5.3, `bench_use_case_c.py`).

The Monte Carlo arms: `monte_carlo` generates the trials as 7.3.1 has them (independent, the root
drawn uniformly over every enabled controllable transition, waits of t_w); `monte_carlo+<variant>`
adds a departure (`MC_VARIANTS`: wait_grid, stratified_crn, agent_roots; earlier = all three, the
trials before issue 38), so each one's effect is measured side by side. Actions of two robot arms
start as 6.3.3 has it (the first arm free holds until its partner frees); `+simultaneous` runs an
arm on the former net, where both arms must be free at the same instant (the best-scenario arm
always: its planner targets the one commitment of Fig. 7.3).

Prints a table and, as the last line, one JSON object with the figures (latencies as medians).
`--only SECTION ...` runs some of the sections (latency, fig7_12, use_case_a, use_case_b,
use_case_c).

    python tools/bench_scheduling.py [--quick | --smoke] [--only SECTION ...]

--quick: small campaigns (about a minute); --smoke: the --quick path with one run of the fewest
cycles, products and trials per arm (seconds; figures meaningless; the tests run it).
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from scipy.stats import mannwhitneyu

from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.baselines import BestOfRolloutsPlanPolicy, RandomEnabledPolicy, RoundRobinPolicy
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy

#: the bench's sizes: "smoke" (the whole --quick path once, seconds), "quick" (about a minute), "full"
SIZES = ("smoke", "quick", "full")


def pick(size: str, smoke, quick, full):
    """The setting of the bench's `size` (one of `SIZES`)."""
    return {"smoke": smoke, "quick": quick, "full": full}[size]


def latency_ms(net, agent, n_trials, horizon, repeats, seed=0):
    sched = MonteCarloPolicy(net, n_trials=n_trials, horizon=horizon, random_state=seed)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sched.decide(net.m0, agent)
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))


class _RecordingPolicy:
    """A policy that keeps every (marking, agent, now, elapsed) it is asked to decide on."""

    def __init__(self, policy):
        self.policy, self.asked = policy, []

    def decide(self, marking, agent, now=0.0, elapsed=None):
        self.asked.append((marking.copy(), agent, now, None if elapsed is None else elapsed.copy()))
        return self.policy.decide(marking, agent, now, elapsed)

    def observe(self, transition, delay):
        self.policy.observe(transition, delay)


def bnb_latency_ms(net, programs, n_decisions, horizon=60.0, seed=0):
    """Median and max time (ms) of one best-scenario decision (7.2, Algorithms 2-3) over the
    markings a round-robin run of the net meets, each with the collaboration predicted to start
    0-5, 10-15 and 20-25 s ahead."""
    from hrc_drake.scheduling.best_scenario import BestScenarioPolicy

    recorder = _RecordingPolicy(RoundRobinPolicy(net, programs=programs, random_state=seed))
    simulate_cell(net, recorder, np.random.default_rng(seed), n_cycles=max(2, n_decisions // 4))
    policy = BestScenarioPolicy(net, "collab", "ic", "fuse", horizon=horizon)
    times, nodes = [], []
    for marking, agent, now, elapsed in recorder.asked[:n_decisions]:
        for ahead in (0.0, 10.0, 20.0):
            policy.set_forecast(now + ahead, now + ahead + 5.0)
            t0 = time.perf_counter()
            policy.decide(marking, agent, now, elapsed)
            times.append(time.perf_counter() - t0)
            nodes.append(policy.last_plan_.nodes if policy.last_plan_ is not None else 0)
    return 1000 * float(np.median(times)), 1000 * float(np.max(times)), int(np.median(nodes)), len(times)


def best_scenario_policy(net, horizon=60.0, levels=(0.2, 0.8), order=2):
    """The use case a scheduler of 7.2 with the Ch. 5 predictor (HOMM, waiting times) it reads,
    learning online from the run's human events."""
    from hrc_drake.prediction.config import HigherOrderMarkovPredictor
    from hrc_drake.prediction.online import OnlineForecaster
    from hrc_drake.scheduling.best_scenario import BestScenarioPolicy

    config = HigherOrderMarkovPredictor(order=order, percentile_levels=sorted({0.2, 0.5, 0.8, *levels}))
    forecaster = OnlineForecaster(config, ["ic", "collab"])
    return BestScenarioPolicy(net, "collab", "ic", "fuse", horizon=horizon, levels=levels,
                              forecaster=forecaster)


def fuzzy_latency_ms(n_decisions: int, horizon: float = 50.0, seed: int = 0, max_nodes: int = 300,
                     merge: bool = True, horizon_events: float | None = None) -> dict:
    """Time of one fuzzy (7.4, Algorithm 5) and one uniform (eq. 7.21-7.23) decision at T_sch =
    `horizon` (or the time of `horizon_events` events at the net's rate) on the torch_clock net
    (t_w = 5 s, 7.5.3), over the markings a round-robin run of that net meets (decisions with a
    choice); also the trees' sizes (nodes), how many of them the node cap (max_nodes) cut short
    of T_sch, how far ahead they reached (s, median), the share of decisions taken by the tie
    rule (root children of equal J) and of markings where fuzzy and uniform chose alike."""
    from pathlib import Path

    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.scheduling.config import FuzzyScheduler
    from hrc_drake.scheduling.fuzzy_scheduler import FuzzyPolicy, UniformPolicy
    from hrc_drake.scheduling.systems import net_from_scenario

    root = Path(__file__).resolve().parents[1]
    # the fuzzy cell's flow: torch_clock.yaml's with the scheduler's priors, this simulation's delays
    scenario = load_scenario(root / "diagrams" / "torch_clock_fuzzy.yaml")
    net = net_from_scenario(scenario, FuzzyScheduler(wait_quantum=5.0))
    recorder = _RecordingPolicy(RoundRobinPolicy(net, random_state=seed))
    simulate_cell(net, recorder, np.random.default_rng(seed), max_time=40.0 * n_decisions)
    asked = [a for a in recorder.asked  # decisions with a choice
             if net.enabled(a[0])[net.agent_transitions(a[1])].sum() > 1][:n_decisions]
    out, choices = {}, {}
    for name, kind in (("fuzzy", FuzzyPolicy), ("uniform", UniformPolicy)):
        policy = kind(net, horizon=horizon, max_nodes=max_nodes, merge=merge, horizon_events=horizon_events)
        times, nodes, depths, chosen = [], [], [], []
        for marking, agent, now, elapsed in asked:
            t0 = time.perf_counter()
            chosen.append(policy.decide(marking, agent, now, elapsed))
            times.append(time.perf_counter() - t0)
            nodes.append(policy.last_tree_size_)
            depths.append(policy.last_depth_reached_)
        choices[name] = chosen
        s = policy.stats_  # counts every decision with a choice (FuzzyStats)
        out[name] = {"ms_median": 1000 * float(np.median(times)), "ms_max": 1000 * float(np.max(times)),
                     "nodes_median": int(np.median(nodes)), "truncated": s.truncated,
                     "depth_reached_s_median": float(np.median(depths)),
                     "ties_pct": round(100.0 * s.ties / max(s.decisions, 1), 1), "decisions": len(times),
                     "t_sch_s": round(policy.current_horizon(), 2)}
    same = [a == b for a, b in zip(choices["fuzzy"], choices["uniform"], strict=True)]
    out["fuzzy"]["same_choice_as_uniform_pct"] = round(100.0 * float(np.mean(same)), 1) if same else None
    return out


#: the Monte Carlo scheduler's departures from the trials of 7.3.1 (options of MonteCarloPolicy), as
#: "+" suffixes of a Monte Carlo kind, e.g. "monte_carlo+wait_grid", "monte_carlo_T30+earlier"
MC_VARIANTS = {
    "wait_grid": {"wait_grid": True},  # waits end on the global t_w grid (the cell waits so too)
    "stratified_crn": {"stratified_roots": True, "common_random_numbers": True},
    "agent_roots": {"root_choices": "agent"},  # the root branches over the deciding robot's choices
}
#: all three: the trials as they were before issue 38 (bar the refilled delay pools)
MC_VARIANTS["earlier"] = {k: v for variant in list(MC_VARIANTS.values()) for k, v in variant.items()}
#: the net's variant, not the policy's: "+simultaneous" runs the arm on the net whose actions of two
#: robots need both arms free at once (`compiler.JOINT_ACTIONS`); the best-scenario arm always does
#: (its planner targets the one commitment of Fig. 7.3)
MC_VARIANTS["simultaneous"] = {}


def on_simultaneous_net(kind: str) -> bool:
    """Whether arm `kind` runs on the net compiled with joint_actions="simultaneous"."""
    return kind == "best_scenario" or "+simultaneous" in kind


def make_policy(kind, net, seed, horizon=30.0, n_trials=100, programs=None):
    if kind.startswith("monte_carlo") and "+" in kind:
        base, *variants = kind.split("+")
        options = {k: v for variant in variants for k, v in MC_VARIANTS[variant].items()}
        policy = make_policy(base, net, seed, horizon, n_trials, programs)
        return MonteCarloPolicy(net, n_trials=policy.n_trials, horizon=policy.horizon, random_state=seed,
                                min_branch_samples=policy.min_branch_samples, rollout=policy.rollout,
                                durations=policy.durations, **options)
    if kind == "best_scenario":
        return best_scenario_policy(net)
    if kind == "monte_carlo":
        return MonteCarloPolicy(net, n_trials=n_trials, horizon=horizon, random_state=seed)
    if kind.startswith("monte_carlo_T"):  # a second horizon, side by side
        return MonteCarloPolicy(net, n_trials=n_trials, horizon=float(kind[13:]), random_state=seed)
    if kind.startswith("monte_carlo_work_first"):  # rollouts start every enabled action (option)
        return MonteCarloPolicy(net, n_trials=n_trials, horizon=horizon, random_state=seed,
                                rollout="work_first")
    if kind.startswith("fuzzy_nodes"):  # Algorithm 5 with another node cap
        from hrc_drake.scheduling.fuzzy_scheduler import FuzzyPolicy

        return FuzzyPolicy(net, horizon=horizon, max_nodes=int(kind[11:]), random_state=seed)
    if kind.startswith("fuzzy_w"):  # fuzzy_w<w1>_<w2>[_frac][_random]: w_1, w_2 (7.16), W_R's unit, ties
        from hrc_drake.scheduling.fuzzy_scheduler import FuzzyPolicy

        w1, w2, *flags = kind[7:].split("_")
        return FuzzyPolicy(net, horizon=horizon, w_human=float(w1), w_robot=float(w2), random_state=seed,
                           robot_wait_measure="horizon_fraction" if "frac" in flags else "seconds",
                           ties="random" if "random" in flags else "first")
    if kind == "monte_carlo_uniform_support":  # Scheduler B of 7.5.2: uniform delays on the measured supports
        return MonteCarloPolicy(
            net, n_trials=n_trials, horizon=horizon, random_state=seed, durations="uniform_support"
        )
    if kind == "monte_carlo_pooled":  # the branch pooling variant: rule (b) needs 20 trials per child
        return MonteCarloPolicy(
            net, n_trials=n_trials, horizon=horizon, random_state=seed, min_branch_samples=20
        )
    if kind == "round_robin":
        return RoundRobinPolicy(net, programs=programs, random_state=seed)
    if kind == "random_enabled":
        return RandomEnabledPolicy(net, random_state=seed)
    if kind == "best_of_rollouts_plan":
        return BestOfRolloutsPlanPolicy(net, random_state=seed)
    raise ValueError(f"make_policy: unknown kind {kind!r}")


def campaign(net, kinds, n_runs, n_cycles, label, horizon=30.0, programs=None, n_products=None, n_trials=100,
             simultaneous_net=None):
    """Each arm over `n_runs` seeded runs of `n_cycles` human pattern cycles (a cycle is then one
    pattern), or of `n_products` products (a cycle is then the time between two successive
    products, as Fig. 7.19 measures it). kinds: a list of `make_policy` kinds, or a dict
    arm name -> kind; n_trials: the Monte Carlo arms' trials per decision. simultaneous_net: the
    same flow compiled with joint_actions="simultaneous", for the arms `on_simultaneous_net`
    (default: `net`)."""
    arms = kinds if isinstance(kinds, dict) else {kind: kind for kind in kinds}
    out = {}
    default_net = net
    for arm, kind in arms.items():
        net = simultaneous_net if simultaneous_net is not None and on_simultaneous_net(kind) else default_net
        cycles, per_product, human_idle, t0 = [], [], [], time.perf_counter()
        for seed in range(n_runs):
            run = simulate_cell(
                net,
                make_policy(kind.replace("+simultaneous", ""), net, seed, horizon, n_trials,
                            programs=programs),
                np.random.default_rng(1000 + seed),
                n_cycles=n_cycles,
                n_products=n_products,
                # ~5x the slowest cycle seen; only a run that deadlocks reaches it
                max_time=300.0 * n_cycles if n_products is None else 600.0 * n_products,
            )
            if n_products is None:
                cycles.extend(run.cycle_times.tolist())
            else:
                cycles.extend(np.diff(run.product_times).tolist())
            per_product.append(run.time_per_product)
            human_idle.append(run.idle[net.human_agent] / max(len(run.product_times), 1))
        finite = np.isfinite(per_product)
        out[arm] = {
            "cycle_median": float(np.median(cycles)) if cycles else float("nan"),
            "cycle_mean": float(np.mean(cycles)) if cycles else float("nan"),
            "cycle_p90": float(np.percentile(cycles, 90)) if cycles else float("nan"),
            # a run without a product (deadlocked) has no time per product: nan, and counted
            "time_per_product": float(np.mean(per_product)) if finite.all() else float("nan"),
            "time_per_product_runs": [round(float(x), 3) if np.isfinite(x) else None for x in per_product],
            "runs_without_product": int((~finite).sum()),
            "human_idle_per_product": float(np.mean(human_idle)),
        }
        if n_products is not None:
            out[arm]["cycle_times"] = [round(float(x), 3) for x in cycles]
        print(
            f"  {label:10s} {arm:28s} cycle median {out[arm]['cycle_median']:7.2f} s  mean "
            f"{out[arm]['cycle_mean']:7.2f} s  p90 {out[arm]['cycle_p90']:7.2f} s  per product "
            f"{out[arm]['time_per_product']:6.2f} s  human idle/product "
            f"{out[arm]['human_idle_per_product']:5.2f} s  runs without a product "
            f"{out[arm]['runs_without_product']}  ({time.perf_counter() - t0:.1f} s)",
            flush=True,
        )
    return out


def sweep_best_scenario(size: str) -> dict:
    """The settings the use case a best-scenario arm uses, each varied around its value: T_wait
    (the nets' collab patience, default 5 t_w = 15 s), the percentile levels of [P_c1, P_c2]
    and the HOMM order of the predictor; time per product, mean over the runs."""
    print("  sweep of the best-scenario arm (time per product, s):")
    out = {}
    runs, cycles = pick(size, (1, 1), (2, 4), (10, 10))
    patiences = pick(size, (15.0,), (6.0, 15.0), (3.0, 6.0, 15.0, 30.0))
    all_levels = pick(size, ((0.2, 0.8),), ((0.2, 0.8), (0.2, 0.5)), ((0.2, 0.8), (0.2, 0.5), (0.5, 0.8)))
    for pat in (1, 2):
        flow, buffers, pattern, robots = tc.use_case_a(pat)
        rows = {}
        for patience in patiences:
            for levels in all_levels:
                for order in ((1, 2) if size == "full" else (2,)):
                    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0,
                                       collab_patience=patience, joint_actions="simultaneous")
                    per_product = []
                    for seed in range(runs):
                        policy = best_scenario_policy(net, levels=levels, order=order)
                        run = simulate_cell(net, policy, np.random.default_rng(1000 + seed), n_cycles=cycles,
                                            max_time=50.0 * cycles * 60)
                        per_product.append(run.time_per_product)
                    key = f"T_wait{patience:g}_p{levels[0]:g}-{levels[1]:g}_order{order}"
                    rows[key] = round(float(np.mean(per_product)), 3)
        best = min(rows, key=rows.get)
        print(f"    pattern {pat}: " + ", ".join(f"{k} {v:.2f}" for k, v in rows.items()), flush=True)
        print(f"    pattern {pat}: best {best} ({rows[best]:.2f} s)", flush=True)
        out[f"pattern{pat}"] = rows
    return out


def sweep_fuzzy_max_nodes(quick: bool) -> dict:
    """The fuzzy scheduler's node cap (default 300, chosen for the decision time): the decision
    time on the torch_clock net and, at event level (the net's durations, round robin as the
    reference), the human's idle time per product over 6 runs of 6 products, per cap."""
    from pathlib import Path

    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.scheduling.config import FuzzyScheduler
    from hrc_drake.scheduling.systems import net_from_scenario

    caps = (300, 600) if quick else (150, 300, 600, 1200, 2400)
    root = Path(__file__).resolve().parents[1]
    # the fuzzy cell's flow: torch_clock.yaml's with the scheduler's priors, this simulation's delays
    scenario = load_scenario(root / "diagrams" / "torch_clock_fuzzy.yaml")
    net = net_from_scenario(scenario, FuzzyScheduler(wait_quantum=5.0))
    out = {}
    for cap in caps:
        latency = fuzzy_latency_ms(5 if quick else 30, max_nodes=cap)["fuzzy"]
        runs = campaign(net, {f"fuzzy_nodes{cap}": f"fuzzy_nodes{cap}"}, 2 if quick else 6, None,
                        f"fuzzy cap {cap}", horizon=50.0, n_products=4 if quick else 6)[f"fuzzy_nodes{cap}"]
        out[f"max_nodes_{cap}"] = {"ms_median": round(latency["ms_median"], 2),
                                   "truncated": latency["truncated"], "decisions": latency["decisions"],
                                   "human_idle_per_product": round(runs["human_idle_per_product"], 3),
                                   "time_per_product": round(runs["time_per_product"], 3)}
    reference = campaign(net, ["round_robin"], 2 if quick else 6, None, "fuzzy ref", horizon=50.0,
                         n_products=4 if quick else 6)["round_robin"]
    out["round_robin"] = {"human_idle_per_product": round(reference["human_idle_per_product"], 3),
                          "time_per_product": round(reference["time_per_product"], 3)}
    return out


def sweep_fuzzy_weights(size: str) -> dict:
    """w_1, w_2 of eq. (7.16) (the thesis: tunable, cost per hour of worker against robots), W_R
    in seconds (the thesis) and as t_w / T_sch per wait (the variant on W_H's scale), and the
    random tie rule: at event level on the torch_clock net (T_sch 50 s, t_w 5 s, round robin as
    the reference), the human's idle time and the time per product, and the ties' share."""
    from pathlib import Path

    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.scheduling.config import FuzzyScheduler
    from hrc_drake.scheduling.systems import net_from_scenario

    root = Path(__file__).resolve().parents[1]
    # the fuzzy cell's flow: torch_clock.yaml's with the scheduler's priors, this simulation's delays
    scenario = load_scenario(root / "diagrams" / "torch_clock_fuzzy.yaml")
    net = net_from_scenario(scenario, FuzzyScheduler(wait_quantum=5.0))
    grid = pick(size, ["1_1_frac"], ["1_1", "1_1_frac"],
                ["1_1", "1_0.1", "10_1", "1_1_random", "1_1_frac", "1_0.1_frac", "10_1_frac"])
    arms = {f"w{g}": f"fuzzy_w{g}" for g in grid} | {"round_robin": "round_robin"}
    runs = campaign(net, arms, pick(size, 1, 2, 4), None, "fuzzy w", horizon=50.0,
                    n_products=pick(size, 1, 4, 6))
    return {arm: {"human_idle_per_product": round(r["human_idle_per_product"], 3),
                  "time_per_product": round(r["time_per_product"], 3)} for arm, r in runs.items()}


def fuzzy_reach(size: str) -> dict:
    """How far the fuzzy tree reaches on the torch_clock net at T_sch = 50 s per node cap, merged
    (exact DAG, the default) and literal (Algorithm 5's tree): nodes, depth reached, latency."""
    caps = pick(size, (300,), (300, 3000), (300, 1000, 3000, 10000))
    out = {}
    # the full horizon (merged): 300,000 nodes reach T_sch in every tree measured, at ~35 s a
    # decision, so 3 decisions and only in the full run
    per_cap = pick(size, 1, 3, 10)
    runs = [(merge, cap, per_cap) for merge in (True, False) for cap in caps]
    if size == "full":
        runs.append((True, 300_000, 3))
    for merge, cap, decisions in runs:
        f = fuzzy_latency_ms(decisions, max_nodes=cap, merge=merge)["fuzzy"]
        key = f"{'merged' if merge else 'literal'}_{cap}"
        out[key] = {k: f[k] for k in ("nodes_median", "depth_reached_s_median", "ms_median", "truncated",
                                      "decisions")}
        print(f"  fuzzy tree {key:14s}: {f['nodes_median']:6d} nodes, reaches "
              f"{f['depth_reached_s_median']:5.1f} s of 50 s, {f['ms_median']:8.1f} ms, "
              f"{f['truncated']} of {f['decisions']} cut", flush=True)
    return out


def sweep_use_case_b(quick: bool) -> dict:
    """Scheduler A of use case b around the thesis's settings: T_sch (15, 30, 60 s), the
    work-first rollouts and branch pooling (options), per pattern; time per product and human
    idle per product over 10 runs of 9 products."""
    kinds = (["monte_carlo_T15", "monte_carlo_T30"] if quick else
             ["monte_carlo_T15", "monte_carlo_T30", "monte_carlo_T60", "monte_carlo_work_first",
              "monte_carlo_pooled"])
    out = {}
    for pat in (1, 2):
        flow, buffers, pattern, robots = tc.use_case_b(pat)
        net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0, cost_robot=0.5,
                           cost_human=1.0, agent_costs=tc.USE_CASE_B_AGENT_COSTS)
        arms = campaign(net, kinds, 2 if quick else 10, None, f"b sweep {pat}", horizon=30.0, n_products=9)
        out[f"pattern{pat}"] = {k: {"time_per_product": round(v["time_per_product"], 3),
                                    "human_idle_per_product": round(v["human_idle_per_product"], 3),
                                    "cycle_median": round(v["cycle_median"], 3)} for k, v in arms.items()}
    return out


def sweep_checked_stock(quick: bool) -> dict:
    """Use case a's assumed stock of checked boards at the start (1 in the benchmark): 0, 1, 2,
    best scenario and round robin, time per product over 10 runs of 10 cycles."""
    programs = {1: {"yumi_left": ["fuse", "check"]}, 2: {"yumi_left": ["fuse", "fuse", "check", "check"]}}
    out = {}
    for pat in (1, 2):
        row = {}
        for stock in ((0, 1) if quick else (0, 1, 2)):
            flow, buffers, pattern, robots = tc.use_case_a(pat, checked_stock=stock)
            net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
            net_s = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0,
                                 joint_actions="simultaneous")
            arms = campaign(net, ["best_scenario", "round_robin+simultaneous"], 2 if quick else 10,
                            4 if quick else 10, f"a stock {stock}", programs=programs[pat],
                            simultaneous_net=net_s)
            row[f"stock_{stock}"] = {k: round(v["time_per_product"], 3) for k, v in arms.items()}
        out[f"pattern{pat}"] = row
    return out


def sweep_min_branch_samples(size: str) -> dict:
    """Algorithm 4's rule (b) with branch pooling: trials every child of a controllable
    branching needs (1 = as written) against the time per product on use case a (waits of t_w,
    joint actions held, 6.3.3)."""
    values = pick(size, (20,), (1, 20), (1, 5, 10, 20, 40))
    runs, cycles = pick(size, (1, 1), (2, 4), (10, 10))
    out = {}
    for pat in (1, 2):
        flow, buffers, pattern, robots = tc.use_case_a(pat)
        net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
        row = {}
        for value in values:
            per_product = []
            for seed in range(runs):
                policy = MonteCarloPolicy(net, n_trials=100, horizon=15.0, random_state=seed,
                                          min_branch_samples=value)
                run = simulate_cell(net, policy, np.random.default_rng(1000 + seed), n_cycles=cycles,
                                    max_time=50.0 * cycles * 60)
                per_product.append(run.time_per_product)
            row[f"min_branch_samples_{value}"] = round(float(np.mean(per_product)), 3)
        print(f"  Monte Carlo, pattern {pat}, time per product by min_branch_samples: "
              + ", ".join(f"{k[19:]}: {v:.2f} s" for k, v in row.items()), flush=True)
        out[f"pattern{pat}"] = row
    return out


def latencies(size: str, result: dict) -> None:
    """The decision latencies, written into `result`."""
    print("Decision latency of the Monte Carlo scheduler (median over repeats, ms)")
    flow, buffers, pattern, robots = tc.fig_7_6()
    net76 = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=1.0)
    thesis = {10: 23.9, 20: 35.4, 30: 85.0}
    for horizon in (10, 20, 30):
        ms = latency_ms(net76, "robot", 100, float(horizon), pick(size, 1, 5, 20))
        result[f"latency_fig7_6_T{horizon}_ms"] = ms
        print(
            f"  Fig. 7.6, N=100, T_sch={horizon:2d} s: {ms:7.1f} ms   (thesis {thesis[horizon]} ms)",
            flush=True,
        )
    flow, buffers, pattern, robots = tc.use_case_b(1)
    net_b = compile_flow(
        flow,
        buffers,
        "human",
        pattern,
        robots,
        wait_quantum=3.0,
        cost_robot=0.5,
        cost_human=1.0,
        agent_costs=tc.USE_CASE_B_AGENT_COSTS,
    )
    # the first decision has only the wait for the right arm; take a marking with a real conflict
    m = net_b.m0.copy()
    m[net_b.place_index["buf:tested"]] = 1
    m[net_b.place_index["space:tested"]] -= 1
    sched = MonteCarloPolicy(net_b, n_trials=150, horizon=30.0, random_state=0)
    times = []
    for _ in range(pick(size, 1, 5, 20)):
        t0 = time.perf_counter()
        sched.decide(m, "yumi_right")
        times.append(time.perf_counter() - t0)
    ms = 1000 * float(np.median(times))
    result["latency_use_case_b_N150_T30_ms"] = ms
    print(f"  use case b (reconstruction), N=150, T_sch=30 s: {ms:7.1f} ms   (thesis 286 ms)", flush=True)

    flow, buffers, pattern, robots = tc.use_case_a(1)
    net_a1 = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0,
                          joint_actions="simultaneous")
    programs_a1 = {"yumi_left": ["fuse", "check"]}
    median, worst, nodes, count = bnb_latency_ms(net_a1, programs_a1, pick(size, 2, 10, 60))
    result["latency_bnb_use_case_a_ms"] = median
    result["latency_bnb_use_case_a_max_ms"] = worst
    result["bnb_use_case_a_nodes_median"] = nodes
    print(f"  best scenario (7.2), use case a, T_sch = 60 s: {median:7.2f} ms median, {worst:.2f} ms max, "
          f"{nodes} nodes ({count} decisions; the thesis gives no figure)", flush=True)

    if size == "full":
        result["sweep_fuzzy_max_nodes"] = sweep_fuzzy_max_nodes(quick=False)
        print("  fuzzy node cap (decision ms, trees cut, event-level idle per product): "
              + json.dumps(result["sweep_fuzzy_max_nodes"]), flush=True)
    fuzzy = fuzzy_latency_ms(pick(size, 2, 10, 50))
    result["latency_fuzzy_T50_ms"] = fuzzy["fuzzy"]["ms_median"]
    result["latency_uniform_T50_ms"] = fuzzy["uniform"]["ms_median"]
    result["fuzzy_T50"] = fuzzy
    for name, f in fuzzy.items():
        print(f"  {name} (7.4), torch_clock net, T_sch = 50 s: {f['ms_median']:7.1f} ms median, "
              f"{f['ms_max']:.1f} ms max, {f['nodes_median']} nodes, reaches "
              f"{f['depth_reached_s_median']:.1f} s, "
              f"{f['truncated']} of {f['decisions']} trees cut at max_nodes, {f['ties_pct']} % ties "
              "(thesis: a few ms)", flush=True)
    f = fuzzy["fuzzy"]
    result["fuzzy"] = {key: f[key] for key in ("depth_reached_s_median", "nodes_median", "ties_pct",
                                               "ms_median", "truncated", "decisions")}
    # at the thesis's event count (7.5.3: T_sch for "an average 4 events"), the literal tree
    # (Algorithm 5: no merging) with no practical cap
    at4 = fuzzy_latency_ms(pick(size, 2, 10, 50), max_nodes=1_000_000, merge=False, horizon_events=4.0)
    f4 = at4["fuzzy"]
    result["fuzzy"].update({"events_in_horizon": 4.0, "t_sch_s": f4["t_sch_s"],
                            "nodes_median": f4["nodes_median"], "latency_ms_median": f4["ms_median"],
                            "depth_reached_s_median": f4["depth_reached_s_median"],
                            "ties_pct": f4["ties_pct"],
                            "same_choice_as_uniform_pct": f4["same_choice_as_uniform_pct"],
                            "truncated": f4["truncated"], "decisions": f4["decisions"]})
    result["fuzzy_T50"]["fuzzy"]["t_sch_s"] = 50.0
    print(f"  fuzzy (7.4) at 4 events in the horizon (T_sch = {f4['t_sch_s']} s at the net's rate), literal "
          f"tree: {f4['nodes_median']} nodes, {f4['ms_median']:.1f} ms median ({f4['ms_max']:.1f} max), "
          f"{f4['ties_pct']} % ties, the uniform scheduler's choice in {f4['same_choice_as_uniform_pct']} % "
          f"of {f4['decisions']} decisions", flush=True)
    result["fuzzy"]["reach"] = fuzzy_reach(size)
    result["fuzzy"]["sweep_weights"] = sweep_fuzzy_weights(size)
    print("  fuzzy w_1, w_2 (event level, idle per product, time per product): "
          + json.dumps(result["fuzzy"]["sweep_weights"]), flush=True)


def use_case_a_campaign(size: str) -> dict:
    """Use case a (7.5.1), patterns 1 and 2, and the sweeps of its best-scenario and Monte Carlo arms."""
    print(
        "Use case a (7.5.1), time per finished product (thesis, best-scenario scheduler of 7.2 vs "
        "RR: 35.80 -> 27.63 s, 33.35 -> 30.10 s); Monte Carlo at T_sch = 15 s, also 30 s; the "
        "baselines wait on the t_w grid"
    )
    # the round robin of 7.5.1: fuse, check (pattern 1); fuse, fuse, check, check (pattern 2)
    programs = {1: {"yumi_left": ["fuse", "check"]}, 2: {"yumi_left": ["fuse", "fuse", "check", "check"]}}
    thesis_a = {1: (35.80, 27.63), 2: (33.35, 30.10)}
    out = {}
    for pat in (1, 2):
        flow, buffers, pattern, robots = tc.use_case_a(pat)
        net_a = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
        net_s = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0,
                             joint_actions="simultaneous")
        runs, cycles = pick(size, (1, 1), (2, 4), (20, 10))
        # the literal trials (monte_carlo) wait t_w; the arms meet for the two-arm check and the
        # collaboration by holding (6.3.3). On the simultaneous net (the former model) arms that
        # wait t_w apart never meet: monte_carlo+simultaneous shows it
        kinds = ["best_scenario", "monte_carlo", "monte_carlo+simultaneous", *MC_VARIANT_ARMS,
                 "monte_carlo_T30", "monte_carlo_pooled", "round_robin", "round_robin+simultaneous"]
        arms = campaign(net_a, kinds, runs, cycles, f"a, pat {pat}", horizon=15.0, programs=programs[pat],
                        n_trials=pick(size, 10, 100, 100), simultaneous_net=net_s)
        # like with like: the round robin on the best-scenario arm's net (both arms start together)
        rr_arm = "round_robin+simultaneous"
        bs, rr = arms["best_scenario"]["time_per_product_runs"], arms[rr_arm]["time_per_product_runs"]
        p_value = float(mannwhitneyu(bs, rr, alternative="less").pvalue) if len(bs) > 1 else None
        gain = 100 * (1 - arms["best_scenario"]["time_per_product"] / arms[rr_arm]["time_per_product"])
        thesis_gain = 100 * (1 - thesis_a[pat][1] / thesis_a[pat][0])
        arms["best_scenario_vs_round_robin"] = {"gain_percent": round(gain, 2), "thesis_gain_percent":
                                                round(thesis_gain, 2), "mannwhitney_p_less": p_value}
        print(f"  a, pat {pat}: best scenario {gain:+.1f} % faster than round robin per product (thesis "
              f"{thesis_gain:+.1f} %), one-sided rank-sum p = {p_value}", flush=True)
        out[f"pattern{pat}"] = arms
    out["sweep_best_scenario"] = sweep_best_scenario(size)
    out["sweep_min_branch_samples"] = sweep_min_branch_samples(size)
    if size != "full":  # the sweeps below are the full run's
        return out
    out["sweep_checked_stock"] = sweep_checked_stock(quick=False)
    print("  checked boards in stock at the start (time per product, s): "
          + json.dumps(out["sweep_checked_stock"]), flush=True)
    return out


def use_case_b_campaign(size: str) -> dict:
    """Use case b (7.5.2) on the reconstructed net (`thesis_cells.use_case_b`; t_w = 3 s, c_R = 0.5,
    c_H = 1.0, the carts' idle cost 0): Scheduler A (Monte Carlo on the observed delays, 7.3) against
    Scheduler B (the same on uniform delays between the smallest and the largest observed ones),
    N = 100, T_sch = 30 s, and the round robin as a reference; 9 products per run, a cycle is the
    time between two successive products (Fig. 7.19). One-sided rank-sum p of A < B on the runs'
    times per product (as use case a) and on the pooled cycle times (as Fig. 7.19)."""
    runs = pick(size, 1, 2, 20)
    # a cycle is the time between two products: smoke makes the fewest that give one
    n_products, n_trials = pick(size, (2, 10), (9, 100), (9, 100))
    arms = {"A": "monte_carlo", "B": "monte_carlo_uniform_support", "RR": "round_robin",
            **{f"A+{k[12:]}": k for k in MC_VARIANT_ARMS},
            "B+earlier": "monte_carlo_uniform_support+earlier"}
    out = {"n_runs": runs, "n_products": n_products, "n_trials": n_trials, "horizon": 30.0}
    for pat in (1, 2):
        flow, buffers, pattern, robots = tc.use_case_b(pat)
        net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0, cost_robot=0.5,
                           cost_human=1.0, agent_costs=tc.USE_CASE_B_AGENT_COSTS)
        result = campaign(net, arms, runs, None, f"b, pat {pat}", horizon=30.0, n_products=n_products,
                          n_trials=n_trials)
        a, b = result["A"], result["B"]
        many = len(a["time_per_product_runs"]) > 1
        p_runs = (float(mannwhitneyu(a["time_per_product_runs"], b["time_per_product_runs"],
                                     alternative="less").pvalue) if many else None)
        p_cycles = float(mannwhitneyu(a["cycle_times"], b["cycle_times"], alternative="less").pvalue)
        result["A_vs_B"] = {"mannwhitney_p_less": p_runs, "mannwhitney_p_less_cycles": p_cycles}
        early_a, early_b = result["A+earlier"], result["B+earlier"]  # the same test on the earlier trials
        p_runs_early = (float(mannwhitneyu(early_a["time_per_product_runs"], early_b["time_per_product_runs"],
                                           alternative="less").pvalue) if many else None)
        p_cycles_early = float(mannwhitneyu(early_a["cycle_times"], early_b["cycle_times"],
                                            alternative="less").pvalue)
        result["A_vs_B_earlier"] = {"mannwhitney_p_less": p_runs_early,
                                    "mannwhitney_p_less_cycles": p_cycles_early}
        print(f"  b, pat {pat}: A {a['cycle_median']:.2f} s vs B {b['cycle_median']:.2f} s median cycle, "
              f"{a['time_per_product']:.2f} vs {b['time_per_product']:.2f} s per product; one-sided "
              f"rank-sum p (A < B) = {p_runs} (runs' time per product), {p_cycles:.3g} (cycles)", flush=True)
        print(f"  b, pat {pat}, earlier trials: A {early_a['cycle_median']:.2f} s vs B "
              f"{early_b['cycle_median']:.2f} s median cycle; p (A < B) = {p_runs_early} (runs), "
              f"{p_cycles_early:.3g} (cycles)", flush=True)
        out[f"pattern{pat}"] = result
    if size != "full":
        return out
    out["sweep"] = sweep_use_case_b(quick=False)
    print("  Scheduler A around T_sch = 30 s (time per product, s): " + json.dumps(out["sweep"]), flush=True)
    return out


#: the Monte Carlo arms beside the literal trials (monte_carlo): each departure alone, and all
#: of them (the trials before issue 38)
MC_VARIANT_ARMS = ["monte_carlo+wait_grid", "monte_carlo+stratified_crn", "monte_carlo+agent_roots",
                   "monte_carlo+earlier"]


SECTIONS = ("latency", "fig7_12", "use_case_a", "use_case_b", "use_case_c")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small campaigns, finishes in under a minute")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--only", nargs="+", choices=SECTIONS, default=list(SECTIONS), metavar="SECTION",
                        help=f"run only these sections ({', '.join(SECTIONS)}; default: all)")
    args = parser.parse_args(argv)
    size = "smoke" if args.smoke else "quick" if args.quick else "full"
    quick = size != "full"  # the --quick path (smoke runs it too, smaller)
    result = {"quick": args.quick, "size": size, "sections": list(args.only),
              "load_average_1min_start": round(os.getloadavg()[0], 2)}
    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 cores shared)")
    if "latency" in args.only:
        latencies(size, result)
    if "fig7_12" in args.only:
        print("Fig. 7.12 campaign on the Fig. 7.11 net (cycle = one human pattern A,A,B,B)")
        flow, buffers, pattern, robots = tc.fig_7_11()
        net711 = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
        runs, cycles = pick(size, (1, 1), (3, 3), (20, 10))
        result["fig7_12"] = campaign(
            net711,
            ["monte_carlo", *MC_VARIANT_ARMS, "best_of_rollouts_plan", "random_enabled", "round_robin"],
            runs, cycles, "Fig 7.11", n_trials=pick(size, 10, 100, 100)
        )
    if "use_case_a" in args.only:
        result["use_case_a"] = use_case_a_campaign(size)
    if "use_case_b" in args.only:
        print("Use case b (7.5.2, reconstructed net), 9 products per run, cycle = time between two products "
              "(thesis: Scheduler A has the lower median cycle on both patterns)")
        result["use_case_b"] = use_case_b_campaign(size)
    if "use_case_c" in args.only:
        if quick:  # Drake cells: minutes per arm
            print("Use case c (7.5.3) runs in the Drake cell: not in --quick or --smoke "
                  "(bench_use_case_c.py --quick)")
        else:
            import bench_use_case_c

            print("Use case c (7.5.3) in the Drake cell (bench_use_case_c.py, 10 seeds)", flush=True)
            result["use_case_c"] = bench_use_case_c.main(["--seeds", "10", "--workers", "2"])["use_case_c"]
    result["load_average_1min_end"] = round(os.getloadavg()[0], 2)
    print(json.dumps(_strict(result)))


def _strict(value):
    """`value` with NaN and inf as null, so the last line is strict JSON."""
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_strict(v) for v in value]
    return value


if __name__ == "__main__":
    main()
