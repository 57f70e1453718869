"""Cell metrics from the event log: cycle times, idle times, utilisation, human-robot distance.

Pure Python core: `MetricsLog` is filled by the `MetricsRecorder` system (or by any event-level
simulator) and `summarize` turns it into the figures of a report.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hrc_drake.traces import AppendOnly, DecimatedTrace  # noqa: F401 (re-exported: the recorder's logs)
from hrc_drake.untrusted import csv_cell


@dataclass
class Interval:
    agent: str
    action: str
    kind: str  # "work" or "wait"
    start: float
    end: float


@dataclass(frozen=True)
class LoggedEvent:
    """An event of another source (e.g. "robot understood" of the intention estimator) in the log."""

    time: float
    agent: str
    action: str
    kind: str
    seq: int


#: Speed override at or below which the robot counts as stopped (8.2.4's idle: under 1 % of nominal).
STOPPED_OVERRIDE = 0.01
#: Speed override under which the robot counts as slowed (a path moves at most 99 % of its speed).
SLOWED_OVERRIDE = 0.99


@dataclass(frozen=True)
class SampleStats:
    """Exact running figures over every periodic sample, however many the trace dropped;
    `below`: samples whose true human-robot distance was under the safety distance;
    `below_not_stopped`: those of them with a speed override above `STOPPED_OVERRIDE` (the
    safety system let the robot move; below it the robot is held and the human came to it);
    `slowed`: samples with a speed override under `SLOWED_OVERRIDE` (a moving path slowed or
    stopped: with no path moving the speed rules leave the override at 1)."""

    count: int = 0
    min_distance: float = np.inf
    override_sum: float = 0.0
    below: int = 0
    below_not_stopped: int = 0
    slowed: int = 0

    def add(self, distance: float, override: float, safety_distance: float = -np.inf) -> SampleStats:
        below = bool(distance < safety_distance)
        return SampleStats(self.count + 1, min(self.min_distance, distance) if np.isfinite(distance)
                           else self.min_distance, self.override_sum + override, self.below + below,
                           self.below_not_stopped + (below and override > STOPPED_OVERRIDE),
                           self.slowed + (override < SLOWED_OVERRIDE))


@dataclass
class MetricsLog:
    """What a run recorded: events of every agent (the truth), the action detector's perceived
    human events (empty without one), and periodic samples."""

    events: list = field(default_factory=list)
    perceived_events: list = field(default_factory=list)
    #: (time, Forecast) of the activity predictor, where it changed (empty without one)
    forecasts: list = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    distances: list[float] = field(default_factory=list)
    overrides: list[float] = field(default_factory=list)
    buffers: list[dict] = field(default_factory=list)
    products: list[int] = field(default_factory=list)
    human_points: list = field(default_factory=list)
    #: exact figures over every sample; None: computed from the lists (all samples kept)
    stats: SampleStats | None = None
    #: samples taken / samples kept in the lists (1 unless the recorder's trace decimated them)
    sample_stride: int = 1
    #: the scheduler's decisions, `RobotCommand`s (time, agent, action or None for a wait)
    decisions: list = field(default_factory=list)
    #: the scenario's safety distance (m) the samples were compared with, and their period (s)
    safety_distance: float = -np.inf
    sample_period: float = 0.1

    def record(
        self, time: float, distance: float, override: float, buffers: dict, products: int, human_points=None
    ) -> None:
        self.times.append(time)
        self.human_points.append(human_points)
        self.distances.append(distance)
        self.overrides.append(override)
        self.buffers.append(buffers)
        self.products.append(products)


def _agent_of(event) -> str:
    return getattr(event, "agent", "human")


def intervals(events, end_time: float) -> list[Interval]:
    """Work and wait intervals of every agent; an interval still open at `end_time` is cut there."""
    open_work: dict[str, tuple[str, float]] = {}
    open_wait: dict[str, tuple[str, float]] = {}
    out: list[Interval] = []
    for e in sorted(events, key=lambda e: (e.time, _agent_of(e), e.seq)):
        agent = _agent_of(e)
        if e.kind == "begin":
            open_work[agent] = (e.action, e.time)
        elif e.kind == "end" and agent in open_work:
            action, start = open_work.pop(agent)
            out.append(Interval(agent, action, "work", start, e.time))
        elif e.kind == "wait_begin":
            open_wait[agent] = (e.action, e.time)
        elif e.kind == "wait_end" and agent in open_wait:
            action, start = open_wait.pop(agent)
            out.append(Interval(agent, action, "wait", start, e.time))
    for agent, (action, start) in open_work.items():
        out.append(Interval(agent, action, "work", start, end_time))
    for agent, (action, start) in open_wait.items():
        out.append(Interval(agent, action, "wait", start, end_time))
    return sorted(out, key=lambda i: (i.agent, i.start))


#: What each figure of metrics.json means (written into the file as "definitions").
DEFINITIONS = {
    "verdict": "the safety verdict line, a copy of safety.verdict put first in metrics.json",
    "products_per_hour": "throughput: products_finished / simulated_time x 3600, every type together, no "
                         "warm-up left out",
    "products": "per product type (product buffer): finished; per_hour (finished / simulated_time x 3600); "
                "cycle_times, each product's own cycle time (s): from the begin of the first action on any "
                "of its parts to its completion, parts followed through the buffers first in, first out "
                "(raw parts have no history; a part in a buffer at t = 0 starts when an action takes it), "
                "products finished before the warm-up time left out; cycle_time_median and cycle_time_p90 "
                "(the median and the 90th percentile, linear between order statistics; null with no "
                "product); "
                "times_between (intervals between its consecutive products after the warm-up) and their "
                "mean_time_between",
    "products_finished": "finished products of every type: each part put in a product buffer by the end of a "
                         "flow action",
    "mean_time_between_products": "mean interval between consecutive products of any type after the warm-up "
                                  "(s): 1 / throughput, not any product's cycle time (in a cell making two "
                                  "types it is about half of either type's interval); null with fewer than "
                                  "two products after it",
    "product_times": "when each product was finished (s), every type together",
    "times_between_products": "intervals between consecutive products of any type (s), the first from t = 0 "
                              "(the lead time), no warm-up left out",
    "warmup": "the warm-up rule (scenario `metrics`): products finished before `time` s are left out, and "
              "the first `products` of the rest only start the clock of the times between products (0: "
              "the first interval starts at `time`); a product's own cycle time needs no clock, so only "
              "`time` applies to it",
    "busy_time": "time an agent spent executing actions (begin to end) (s)",
    "wait_time": "time an agent spent blocked (wait_begin to wait_end): it chose, or its program reached, an "
                 "action the cell refused for want of parts, room or a partner (s)",
    "idle_time": "time an agent was not executing an action: simulated_time - busy_time; it includes "
                 "wait_time and the time with no action to do (s)",
    "utilisation": "busy_time / simulated_time",
    "actions_finished": "actions the agent ended before the end of the run",
    "min_human_robot_distance": "smallest true distance between the human's and the robots' capsules over "
                                "every 0.1 s sample (m; negative: the capsules overlap)",
    "mean_speed_override": "mean robot speed override over every sample (1: full speed)",
    "time_slowed_s": "time the speed override was under 0.99 (samples x period, s): a moving path slowed or "
                     "stopped by the safety controller or the thesis's speed rules",
    "safety": "samples whose true human-robot distance is under the scenario's safety_distance: their "
              "time (samples x period, s), their fraction of all samples, and whether there is any; "
              "time_below_not_stopped_s: the time of those samples where the speed override was above 1 % "
              "(the robot was not held; with a speed scaler the rest is the human coming to a stopped "
              "robot). ISO/TS 15066, decided by the independent judge (hrc_drake.safety.judge, on the "
              "truth every 1/30 s, with the standard's values: ISO 13855's speeds, Annex A as shipped, T_r "
              "of the cell's chain, the robot's own stop; never the controller's tuning): mode (the "
              "declared mode: none, ssm, pfl, hybrid; none is judged as pfl); standard (the limits table); "
              "verdict_code (safe, unsafe: some violation, no_safety_system, non_conforming: the scenario's "
              "judge: block or the controller's S_h departs from the standard) and verdict (one line, "
              "starting SAFE:, UNSAFE:, NO SAFETY SYSTEM: or NON-CONFORMING:, every violation counted; "
              "the CLI prints it first); violations by kind and violations_total, each an episode the "
              "standard judge holds against the robot (ssm_breach: a robot point approaching a pair SSM "
              "governs inside its S_p, unless a protective stop begun within T_r and not longer than S_p "
              "assumed is under way; ssm_contact: the robot, approaching, touched a region SSM governs; "
              "pfl_contact: a contact PFL governs over its limit at some sample while it lasted, transient "
              "for the first 0.5 s of a free contact, quasi-static once clamped against any rigid body "
              "or later, incl. the spring force of the depth the robot pressed; stop: a protective stop "
              "that took longer or travelled further than S_p assumed); events (each violation: kind, "
              "onset, duration, link, body part, region, worst figure, detail); ssm_breach_s (time in an "
              "SSM breach); margin_m: the smallest true clearance - S_p over every sample and every "
              "(robot capsule, body region) pair SSM governs whose robot point approaches the body faster "
              "than 1 mm/s (S_p of eq. 1-2 on the truth, C = Z_d = Z_r = 0; m; negative: such a point was "
              "inside its S_p, in a breach or in an excused one; null with no such pair); worst_ratio per "
              "body region (the largest ratio of a contact's peak force or pressure to its limit; 0: no "
              "contact; null: a force where no contact is permitted); contact_margin: 1 - the largest "
              "finite worst_ratio (1 with no contact; negative: a contact over its limit); contact_count "
              "and contacts (every contact, violation or logged: a person walking into a robot that does "
              "not approach is logged, not held against it); stops_measured (the protective stops the "
              "judge measured on the truth) and stop_ratio_worst (the largest measured / assumed stopping "
              "distance or time, each with its rounding tolerance: above 1 exactly for a stop violation); "
              "unobserved_s (time some skeleton point went unmeasured), unobserved_longest_s "
              "(the longest a point did) and reach_growth_m (2 m/s x that: how far its reachable set "
              "grew); closest_approach_m (the smallest true robot-body clearance the judge saw); "
              "protective_stops (the controller's commands of 0); judge (conforming, deviations, T_r "
              "reaction_time_s, the stop's deceleration_m_s2); own_model: the same figures (no contacts) "
              "by the changed judge or the controller's own model of a non-conforming run, else null",
    "detection": "the action detector's perceived events against the truth (precision, recall, latency)",
    "realtime_factor": "simulated_time / wall_time",
}


def product_times(events, product_actions: dict[str, tuple[str, ...]],
                  shared_actions: dict[str, tuple[str, ...]] | None = None) -> dict[str, list[float]]:
    """Per product type (product buffer), the sorted times at which its products were finished:
    ends of the flow actions that put a part in it. An action of several agents
    (`shared_actions`: action -> its agents) finishes its k-th product when the last of its
    agents ends its k-th part."""
    shared = shared_actions or {}
    times: dict[str, list[float]] = {kind: [] for kinds in product_actions.values() for kind in kinds}
    parts: dict[str, dict[str, list[float]]] = {a: {agent: [] for agent in shared[a]} for a in shared}
    for e in events:
        if e.kind == "end" and e.action in product_actions:
            if e.action in parts:
                if e.agent in parts[e.action]:
                    parts[e.action][e.agent].append(e.time)
                continue
            for kind in product_actions[e.action]:
                times[kind].append(e.time)
    for action, ends in parts.items():
        if action in product_actions:
            for k in range(min(len(ts) for ts in ends.values())):
                for kind in product_actions[action]:
                    times[kind].append(max(ts[k] for ts in ends.values()))
    return {kind: sorted(ts) for kind, ts in times.items()}


def product_spans(events, actions, buffers, shared_actions: dict[str, tuple[str, ...]] | None = None
                  ) -> dict[str, list[tuple[float, float]]]:
    """Per product type (product buffer), (start, finish) of each product in the order finished:
    its parts are followed through the flow (`actions`: name, inputs, outputs; `buffers`: name,
    kind, initial), first in, first out, as the cell world takes and puts them (finishes before
    starts at one instant). A part's start is the earliest begin of an action on it or on the
    parts it was made of; raw parts have no history, and a part already in a buffer at t = 0
    starts when an action takes it. An action of several agents (`shared_actions`) takes its
    parts at the first of its agents' k-th begins and puts them at the last of their k-th ends."""
    from collections import deque

    shared = shared_actions or {}
    flow = {a.name: a for a in actions}
    kinds = {b.name: b.kind for b in buffers}
    queues = {b.name: deque([None] * int(b.initial)) for b in buffers if b.kind == "intermediate"}
    spans: dict[str, list[tuple[float, float]]] = {b.name: [] for b in buffers if b.kind == "product"}
    running: dict[tuple[str, str], deque] = {}  # (agent, action) -> starts of its parts under way
    joint: dict[str, list[list]] = {}  # shared action -> per instance [start, agents yet to end]
    counts: dict[tuple[str, str, str], int] = {}  # (agent, action, kind) -> begins / ends so far

    def take(spec, time: float) -> float:
        starts = [queues[b].popleft() if queues[b] else None for b in spec.inputs if b in queues]
        return min([time, *(t for t in starts if t is not None)])

    def put(spec, start: float, time: float) -> None:
        for b in spec.outputs:
            if kinds.get(b) == "product":
                spans[b].append((start, time))
            elif b in queues:
                queues[b].append(start)

    # finishes before starts at one instant: the world puts a part before another action takes it
    for e in sorted((e for e in events if e.kind in ("begin", "end") and e.action in flow),
                    key=lambda e: (e.time, e.kind == "begin", e.seq)):
        spec, agent = flow[e.action], _agent_of(e)
        if e.action in shared:
            key = (agent, e.action, e.kind)
            k = counts[key] = counts.get(key, 0) + 1
            instances = joint.setdefault(e.action, [])
            if e.kind == "begin" and k > len(instances):
                instances.append([take(spec, e.time), set(shared[e.action])])
            elif e.kind == "end" and k <= len(instances) and agent in instances[k - 1][1]:
                instances[k - 1][1].discard(agent)
                if not instances[k - 1][1]:
                    put(spec, instances[k - 1][0], e.time)
        elif e.kind == "begin":
            running.setdefault((agent, e.action), deque()).append(take(spec, e.time))
        elif running.get((agent, e.action)):
            put(spec, running[(agent, e.action)].popleft(), e.time)
    return spans


def _percentiles(values) -> tuple[float | None, float | None]:
    """Median and 90th percentile (numpy's linear rule), rounded; None for no values."""
    if not len(values):
        return None, None
    median, p90 = np.percentile(values, [50, 90])
    return round(float(median), 3), round(float(p90), 3)


def _safety(stats: SampleStats, log: MetricsLog) -> dict | None:
    """Time and fraction of the samples below the safety distance, and whether any was."""
    if not np.isfinite(log.safety_distance) or not stats.count:
        return None
    return {"safety_distance": log.safety_distance,
            "time_below_s": round(stats.below * log.sample_period, 3),
            "fraction_below": round(stats.below / stats.count, 4),
            "time_below_not_stopped_s": round(stats.below_not_stopped * log.sample_period, 3),
            "below": bool(stats.below)}


def cycle_times_after_warmup(times, warmup_products: int = 1, warmup_time: float = 0.0) -> np.ndarray:
    """Intervals between consecutive products after the warm-up (schema `Metrics`): products
    before `warmup_time` are left out and the first `warmup_products` of the rest only start
    the clock; with 0 the first interval runs from `warmup_time`."""
    kept = [t for t in sorted(times) if t >= warmup_time]
    if warmup_products == 0:
        return np.diff([warmup_time, *kept])
    return np.diff(kept[warmup_products - 1:]) if len(kept) >= warmup_products else np.zeros(0)


def _rounded_mean(values) -> float | None:
    return round(float(np.mean(values)), 3) if len(values) else None


def summarize(
    log: MetricsLog,
    end_time: float,
    agents: list[str],
    product_actions: dict[str, tuple[str, ...]],
    wall_time: float | None = None,
    warmup_products: int = 1,
    warmup_time: float = 0.0,
    shared_actions: dict[str, tuple[str, ...]] | None = None,
    flow_actions=None,
    buffers=None,
) -> dict:
    """Figures of a run (`DEFINITIONS`): throughput, each product type's own cycle times
    (`product_spans` over the flow's `flow_actions` and `buffers`; without them a product
    starts at the begin of the action that finishes it) and the times between products (after
    the warm-up), busy, wait and idle time per agent, minimum distance."""
    spans = intervals(log.events, end_time)
    by_type = product_times(log.events, product_actions, shared_actions)
    if flow_actions is None:
        from types import SimpleNamespace

        flow_actions = [SimpleNamespace(name=a, inputs=(), outputs=kinds)
                        for a, kinds in product_actions.items()]
        buffers = [SimpleNamespace(name=k, kind="product", initial=0) for k in by_type]
    lives = product_spans(log.events, flow_actions, buffers or (), shared_actions)
    done = sorted(t for ts in by_type.values() for t in ts)
    between = np.diff([0.0, *done]) if done else np.zeros(0)
    warm = cycle_times_after_warmup(done, warmup_products, warmup_time)

    def per_hour(count: int) -> float | None:
        return round(count / end_time * 3600.0, 3) if end_time > 0 else None

    products = {}
    for kind, ts in by_type.items():
        cycles = [finish - start for start, finish in lives.get(kind, ()) if finish >= warmup_time]
        median, p90 = _percentiles(cycles)
        gaps = cycle_times_after_warmup(ts, warmup_products, warmup_time)
        products[kind] = {"finished": len(ts), "per_hour": per_hour(len(ts)), "cycle_time_median": median,
                          "cycle_time_p90": p90, "cycle_times": [round(float(c), 3) for c in cycles],
                          "mean_time_between": _rounded_mean(gaps),
                          "times_between": [round(float(c), 3) for c in gaps]}
    per_agent = {}
    for agent in agents:
        work = sum(i.end - i.start for i in spans if i.agent == agent and i.kind == "work")
        wait = sum(i.end - i.start for i in spans if i.agent == agent and i.kind == "wait")
        count = sum(1 for i in spans if i.agent == agent and i.kind == "work" and i.end < end_time)
        per_agent[agent] = {
            "busy_time": round(work, 3),
            "wait_time": round(wait, 3),
            "idle_time": round(max(end_time - work, 0.0), 3),
            "utilisation": round(work / end_time, 4) if end_time > 0 else 0.0,
            "actions_finished": count,
        }
    if log.stats is not None:
        stats = log.stats
    else:
        stats = SampleStats()
        for distance, override in zip(log.distances, log.overrides, strict=True):
            stats = stats.add(distance, override, log.safety_distance)
    # throughput and each type's own cycle time lead: what a reader of the report asks first
    out = {
        "products_per_hour": per_hour(len(done)),
        "products": products,
        "products_finished": len(done),
        "mean_time_between_products": _rounded_mean(warm),
        "simulated_time": round(end_time, 3),
        "product_times": [round(t, 3) for t in done],
        "times_between_products": [round(float(c), 3) for c in between],
        "warmup": {"products": warmup_products, "time": warmup_time},
        "agents": per_agent,
        "min_human_robot_distance": round(stats.min_distance, 4) if np.isfinite(stats.min_distance) else None,
        "safety": _safety(stats, log),
        "mean_speed_override": round(stats.override_sum / stats.count, 4) if stats.count else None,
        "time_slowed_s": round(stats.slowed * log.sample_period, 3),
    }
    if log.perceived_events:
        out["detection"] = detection_summary(log.events, log.perceived_events)
    if wall_time is not None:
        out["wall_time"] = round(wall_time, 3)
        out["realtime_factor"] = round(end_time / wall_time, 2) if wall_time > 0 else None
    out["definitions"] = {key: text for key, text in DEFINITIONS.items() if key in out or key in
                          ("busy_time", "wait_time", "idle_time", "utilisation", "actions_finished")}
    return out


def detection_summary(events, perceived_events) -> dict:
    """`intention.detector.detection_quality` of the perceived human events against the true
    events of the same agents (rounded, for metrics.json)."""
    from hrc_drake.intention.detector import detection_quality

    agents = {_agent_of(e) for e in perceived_events}
    truth = [e for e in events if _agent_of(e) in agents and e.kind in ("begin", "end")]
    quality = detection_quality(truth, perceived_events)
    return {k: (round(v, 4) if isinstance(v, float) and np.isfinite(v) else v) for k, v in quality.items()}


def write_events_csv(path: Path, events, perceived_events=(), violations=()) -> None:
    """Every event in time order, one global `seq` (the row number); `source` says "truth" (what
    the agents did), "perceived" (the action detector) or "judge" (a violation of the ISO/TS 15066
    judge, metrics.json's `safety.events`: agent the robot link, action the body part, kind the
    violation's kind, with its duration and words), `source_seq` the source's own seq."""
    order = {"truth": 0, "perceived": 1, "judge": 2}
    rows = [(e.time, "truth", _agent_of(e), e.action, e.kind, e.seq, "", "") for e in events]
    rows += [(e.time, "perceived", _agent_of(e), e.action, e.kind, e.seq, "", "") for e in perceived_events]
    rows += [(float(v["onset"]), "judge", v["link"], v["body_part"], v["kind"], n, v["duration"],
              f"{v['region']}: {v['detail']}" if v["region"] else v["detail"])
             for n, v in enumerate(violations, start=1)]
    rows.sort(key=lambda row: (row[0], order[row[1]], row[2], row[5]))
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["time", "agent", "action", "kind", "seq", "source", "source_seq", "duration",
                         "detail"])
        for k, (time, source, agent, action, kind, source_seq, duration, detail) in enumerate(rows, 1):
            # names come from the scenario: none is run as a spreadsheet formula
            writer.writerow([f"{time:.3f}", csv_cell(agent), csv_cell(action), csv_cell(kind), k, source,
                             source_seq, duration, csv_cell(detail)])


#: the Gantt chart's palette: one colour per action of the scenario's action list, in that
#: list's sorted order (tab20, then tab20b's)
def _palette() -> list:
    import matplotlib

    return list(matplotlib.colormaps["tab20"].colors) + list(matplotlib.colormaps["tab20b"].colors)


def action_colors(names) -> dict:
    """A colour per action name, fixed by the set of `names` (e.g. a scenario's actions): the
    sorted names take the palette in turn, so every run of a scenario (any seed, duration, or
    actions that happened) draws an action in the same colour. A name outside `names` gets one
    from a hash of its name (stable too)."""
    return _ColorMap(sorted(set(names)))


class _ColorMap(dict):
    def __init__(self, names: list[str]):
        palette = _palette()
        super().__init__({name: palette[k % len(palette)] for k, name in enumerate(names)})
        #: the key a bar too short for its name shows (the legend pairs it with the name)
        self.keys_ = {name: str(k + 1) for k, name in enumerate(names)}

    def __missing__(self, name: str):
        import zlib

        palette = _palette()
        self[name] = palette[zlib.crc32(name.encode()) % len(palette)]
        self.keys_[name] = str(len(self.keys_) + 1)
        return self[name]


def safety_line(safety: dict | None) -> str:
    """The run's safety in one line (for the Gantt chart's title): the time below the safety
    distance and the ISO/TS 15066 verdict, where the run has them."""
    if not safety:
        return "no safety distance or safety system"
    parts = []
    if "safety_distance" in safety:
        distance = safety["safety_distance"]
        parts.append(f"below the safety distance {distance:g} m for {safety['time_below_s']:.1f} s"
                     if safety.get("below") else f"never below the safety distance {distance:g} m")
    if safety.get("verdict"):
        parts.append(str(safety["verdict"]))
    return "; ".join(parts) or "no safety distance or safety system"


def plot_gantt(path: Path, log: MetricsLog, end_time: float, agents: list[str], title: str = "",
               action_names=(), safety: dict | None = None) -> None:
    """`gantt_figure` saved as a PNG at `path`."""
    import matplotlib.pyplot as plt

    fig = gantt_figure(log, end_time, agents, title, action_names, safety)
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: label size (pt) of the action names in the bars
GANTT_LABEL_SIZE = 7


def gantt_figure(log: MetricsLog, end_time: float, agents: list[str], title: str = "", action_names=(),
                 safety: dict | None = None):
    """Gantt chart (cf. thesis Fig. 7.15): one row per agent, a bar per action in its colour
    (`action_colors` of `action_names`, the scenario's actions, so runs compare; the actions
    that happened when none are given), waits hatched, the scheduler's decisions as triangles;
    below, the human-robot distance against the safety distance and the speed override. The
    title carries the safety verdict (`safety_line` of metrics.json's `safety`). A bar shows its
    action's name where the name fits, else its key (the legend pairs keys and names), else
    nothing: labels never run into each other."""
    from hrc_drake.untrusted import headless_pyplot

    plt = headless_pyplot()
    from matplotlib.patches import Patch

    spans = intervals(log.events, end_time)
    happened = sorted({i.action for i in spans if i.kind == "work"})
    colors = action_colors(action_names or happened)
    actions = [a for a in sorted(colors) if a in happened] + [a for a in happened if a not in colors]
    for a in actions:
        colors[a]  # noqa: B018 - a name outside the list takes its colour (and key) now
    fig, (ax, ax2) = plt.subplots(
        2,
        1,
        figsize=(12, 1.2 + 0.7 * len(agents) + 1.6),
        sharex=True,
        gridspec_kw={"height_ratios": [max(len(agents), 1), 1.4]},
    )
    # One collection per agent and action (not a patch per bar): a 2 h run draws as fast and
    # as small as a short one.
    bars: dict[tuple[int, str, str], list[tuple[float, float]]] = {}
    rows = {agent: row for row, agent in enumerate(agents)}
    for i in spans:
        if i.agent in rows:
            bars.setdefault((rows[i.agent], i.kind, i.action), []).append((i.start, i.end - i.start))
    for (row, kind, action), ranges in bars.items():
        if kind == "work":
            ax.broken_barh(ranges, (row - 0.3, 0.6), facecolors=colors[action], edgecolors="black",
                           linewidths=0.3, label=f"_bars {action}")
        else:
            ax.broken_barh(ranges, (row - 0.175, 0.35), facecolors="lightgrey", hatch="////",
                           edgecolors="grey", linewidths=0.3, label="_waits")
    marks = _plot_decisions(ax, log.decisions, rows, colors)
    ax.set_yticks(range(len(agents)))
    ax.set_yticklabels(agents)
    ax.set_ylim(len(agents) - 0.5, -0.6)  # rows top down, room for the decision marks
    handles = [Patch(facecolor=colors[a], edgecolor="black", linewidth=0.3, label=f"{colors.keys_[a]}: {a}")
               for a in actions]
    handles.append(Patch(facecolor="lightgrey", hatch="////", edgecolor="grey", linewidth=0.3,
                         label="waiting (parts, partner)"))
    handles.extend(marks)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7,
              handler_map=_tuple_handler())
    ax.set_title(f"{title or 'Agents activities'}\n{safety_line(safety)}", fontsize=10)
    safety_distance = (safety or {}).get("safety_distance", log.safety_distance)
    if log.times:
        d = np.array(log.distances, dtype=float)
        ax2.plot(log.times, np.where(np.isfinite(d), d, np.nan), color="tab:red", lw=0.8,
                 label="min human-robot distance")
        if safety_distance is not None and np.isfinite(safety_distance):
            ax2.axhline(safety_distance, color="black", ls="--", lw=0.9,
                        label=f"safety distance {safety_distance:g} m")
        ax2.set_ylabel("distance [m]")
        ax3 = ax2.twinx()
        ax3.plot(log.times, log.overrides, color="tab:blue", lw=0.8, label="speed override")
        ax3.set_ylim(-0.05, 1.05)
        ax3.set_ylabel("override")
        # one legend beside the panel (inside, it hid the distances it names)
        ax3.legend(handles=ax2.get_lines() + ax3.get_lines(), loc="upper left", bbox_to_anchor=(1.06, 1.0),
                   fontsize=7)
    ax2.set_xlabel("time [s]")
    ax2.set_xlim(0, end_time)
    fig.tight_layout()
    _label_bars(fig, ax, [i for i in spans if i.agent in rows and i.kind == "work"], rows, colors)
    return fig


def _label_bars(fig, ax, spans: list[Interval], rows: dict[str, int], colors) -> None:
    """Each bar's label: the action's name where it fits in the bar (with a margin), else its
    key, else none. Widths are measured once per text in display pixels after the layout."""
    renderer = fig.canvas.get_renderer()
    widths: dict[str, float] = {}

    def width(text: str) -> float:
        if text not in widths:
            probe = ax.text(0, 0, text, fontsize=GANTT_LABEL_SIZE)
            widths[text] = probe.get_window_extent(renderer).width
            probe.remove()
        return widths[text]

    x0, x1 = ax.get_xlim()
    pixels_per_s = ax.get_window_extent(renderer).width / (x1 - x0)
    margin = 4.0  # px
    for i in spans:
        room = (i.end - i.start) * pixels_per_s - margin
        for text in (i.action, colors.keys_[i.action]):
            if width(text) <= room:
                ax.text((i.start + i.end) / 2, rows[i.agent], text, ha="center", va="center",
                        fontsize=GANTT_LABEL_SIZE, gid="bar_label")
                break


def _tuple_handler() -> dict:
    from matplotlib.legend_handler import HandlerTuple

    return {tuple: HandlerTuple(ndivide=None, pad=0.0)}


#: the scheduler's decision marks: size (scatter points^2) and edges, in the plot and its legend
DECISION_SIZE, DECISION_WAIT_SIZE = 14, 9


def _plot_decisions(ax, decisions, rows: dict[str, int], colors: dict) -> list:
    """The scheduler's decisions above each robot's row: a filled triangle in the colour of the
    action it commanded, a hollow one for a wait quantum; returns their legend handles, drawn
    as the plot draws them (a start's handle shows the triangles of up to 3 actions' colours)."""
    from matplotlib.lines import Line2D

    starts = [(c.time, rows[c.agent], colors[c.action]) for c in decisions
              if c.agent in rows and c.action is not None]
    waits = [(c.time, rows[c.agent]) for c in decisions if c.agent in rows and c.action is None]
    handles = []
    if starts:
        t, row, color = zip(*starts, strict=True)
        ax.scatter(t, np.asarray(row) - 0.42, marker="v", s=DECISION_SIZE, c=list(color), edgecolors="black",
                   linewidths=0.3, zorder=3, label="_decision starts")
        shown = list(dict.fromkeys(color))[:3]
        handles.append(tuple(
            Line2D([], [], marker="v", ls="", markersize=np.sqrt(DECISION_SIZE), markerfacecolor=c,
                   markeredgecolor="black", markeredgewidth=0.3) for c in shown))
    if waits:
        t, row = zip(*waits, strict=True)
        ax.scatter(t, np.asarray(row) - 0.42, marker="v", s=DECISION_WAIT_SIZE, facecolors="none",
                   edgecolors="grey", linewidths=0.5, zorder=3, label="_decision waits")
        handles.append(Line2D([], [], marker="v", ls="", markersize=np.sqrt(DECISION_WAIT_SIZE),
                              markerfacecolor="none", markeredgecolor="grey", markeredgewidth=0.5))
    labels = (["decision: start (the action's colour)"] if starts else []) + (
        ["decision: wait t_w"] if waits else [])
    return [_Labelled(h, label) for h, label in zip(handles, labels, strict=True)]


class _Labelled(tuple):
    """A legend handle with its label: a tuple of one handle or of several (HandlerTuple)."""

    def __new__(cls, handle, label: str):
        self = super().__new__(cls, handle if isinstance(handle, tuple) else (handle,))
        self.label_ = label
        return self

    def get_label(self) -> str:
        return self.label_


def time_to_next(begins: list[float], times) -> np.ndarray:
    """For each time t, the time until the first begin after t (inf when none follows)."""
    begins = np.sort(np.asarray(begins, dtype=float))
    times = np.asarray(times, dtype=float)
    k = np.searchsorted(begins, times, side="right")
    out = np.full(times.shape, np.inf)
    has = k < len(begins)
    out[has] = begins[k[has]] - times[has]
    return out


def plot_collaboration(path: Path, log: MetricsLog, end_time: float, human: str, robot: str,
                       request_action: str, collaborative_actions=(), title: str = "") -> None:
    """`collaboration_figure` saved as a PNG at `path`."""
    import matplotlib.pyplot as plt

    fig = collaboration_figure(log, end_time, human, robot, request_action, collaborative_actions, title)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def collaboration_figure(log: MetricsLog, end_time: float, human: str, robot: str, request_action: str,
                         collaborative_actions=(), title: str = ""):
    """Thesis Fig. 5.15: the activities of the human and of the robot (top: autonomous blue and
    red, `collaborative_actions` and the request green, waits hatched) and the predicted time to
    the next collaboration request, the band between the forecast's lowest and highest
    percentile and its middle level, against the true time (bottom); each panel has its legend."""
    from hrc_drake.untrusted import headless_pyplot

    plt = headless_pyplot()
    from matplotlib.patches import Patch

    spans = [i for i in intervals(log.events, end_time) if i.agent in (human, robot)]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(13, 5.5), sharex=True, gridspec_kw={"height_ratios": [1, 2]})
    bars: dict[tuple[int, str, str], list[tuple[float, float]]] = {}  # one collection per row, kind, colour
    for row, agent in enumerate((human, robot)):
        for i in spans:
            if i.agent == agent:
                collab = i.action == request_action or i.action in collaborative_actions
                color = "tab:green" if collab else ("tab:blue" if agent == human else "tab:red")
                bars.setdefault((row, i.kind, color), []).append((i.start, i.end - i.start))
    for (row, kind, color), ranges in bars.items():
        ax.broken_barh(ranges, (row - 0.3, 0.6), facecolors=color, hatch="//" if kind == "wait" else None,
                       alpha=0.35 if kind == "wait" else 0.9, edgecolors="k", linewidths=0.3)
    ax.set_yticks([0, 1], [human, robot])
    ax.set_title(title or "activities and the predicted time to collaboration")
    ax.legend(handles=[Patch(facecolor="tab:blue", alpha=0.9, edgecolor="k", linewidth=0.3,
                             label=f"{human}: autonomous actions"),
                       Patch(facecolor="tab:red", alpha=0.9, edgecolor="k", linewidth=0.3,
                             label=f"{robot}: autonomous actions"),
                       Patch(facecolor="tab:green", alpha=0.9, edgecolor="k", linewidth=0.3,
                             label=f"collaboration: '{request_action}' and the actions that assist it"),
                       Patch(facecolor="lightgrey", alpha=0.35, hatch="//", edgecolor="k", linewidth=0.3,
                             label="waiting (hatched, in the action's colour)")],
              loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    times = np.array([t for t, _ in log.forecasts], float)
    rows = []
    for _, forecast in log.forecasts:
        if request_action in forecast.actions and forecast.percentile_levels.size:
            rows.append(np.asarray(forecast.waiting_percentiles)[forecast.actions.index(request_action)])
        else:
            rows.append(np.full(1, np.inf))
    if rows and times.size:
        width = max(len(r) for r in rows)
        band = np.array([np.pad(r, (0, width - len(r)), constant_values=np.inf) for r in rows])
        finite = np.where(np.isfinite(band), band, np.nan)
        ax2.fill_between(times, finite[:, 0], finite[:, -1], color="tab:orange", alpha=0.3,
                         label="predicted (lowest to highest percentile)")
        ax2.plot(times, finite[:, width // 2], color="tab:orange", label="predicted (middle percentile)")
    begins = [e.time for e in log.events if getattr(e, "agent", "") == human and e.action == request_action
              and e.kind == "begin"]
    grid = np.linspace(0.0, end_time, 600)
    truth = time_to_next(begins, grid)
    ax2.plot(grid, np.where(np.isfinite(truth), truth, np.nan), color="k", label="true")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel(f"time to '{request_action}' (s)")
    ax2.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def robot_cycles(result, scenario) -> dict:
    """Robot cycles of thesis 9.1.3 (Fig. 9.7): the intervals between consecutive begins of the
    first action of the first arm's program (in pcb_occlusion, the left arm's pick of a board at
    the slide, L_carry). An extra-metrics function of campaigns
    (`extra_metrics: [hrc_drake.cell.metrics:robot_cycles]`): `times` the intervals (s), `mean`
    their mean (NaN with fewer than two begins), `count` how many."""
    arm = scenario.robots[0].arms[0]
    begins = sorted(e.time for e in result.log.events if getattr(e, "agent", "") == arm.agent
                    and e.action == arm.program[0] and e.kind == "begin")
    cycles = np.diff(begins) if len(begins) > 1 else np.zeros(0)
    mean = float(np.mean(cycles)) if len(cycles) else float("nan")
    return {"times": [float(c) for c in cycles], "mean": mean, "count": len(cycles)}
