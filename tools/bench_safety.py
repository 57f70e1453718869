"""The cost of safety: every shipped cell under no safety system and the ISO/TS 15066 modes.

Issue 36, item 5. For every scenario in `diagrams/` (or those named) and every mode of
`MODES` (`declared`: the cell as shipped; `none`, `ssm`, `pfl`, `hybrid`: its `safety` field
replaced by that mode with default parameters but the declared mode's `speed_profile` (issue 52:
modes compared with the same speed planning), Z_d from the cell's tracker or, without one, its
camera's noise; `hybrid` takes the layout's collaborative zones, or one sphere over the table
where the layout declares none; `reactive`, `predictive` (issue 52): the declared mode with that
`speed_profile`), runs the cell over seeds and reports products, mean cycle time,
the verdict code and the violations by kind of the standard ISO/TS 15066 judge (`safety.judge`),
the worst ratio to the ISO limits per body region, protective stops, the time in an SSM breach,
contacts, and the CPU share of the PFL part of the safety controller (effective masses and
permissible speeds).

    python tools/bench_safety.py --quick            # 20 s runs, one seed: under 5 minutes
    python tools/bench_safety.py --duration 300 --seeds 2 --declared-seeds 5 \
        --falsify OUT/falsify_pcb_ic/report.json ...   # issue 51's bench (about an hour on 2 cores)
    python tools/bench_safety.py diagrams/torch_clock.yaml --modes declared,none
    python tools/bench_safety.py --smoke          # seconds: one small cell, 2 s, declared and none

Last line: one JSON object with `cells_with_violations` (cells in whose declared mode the standard
judge finds violations), `violations.<cell>`, `worst_ratio.<cell>` (declared mode, max over regions and seeds;
null: no contact), `products.<cell>.<mode>` and `cycle_s.<cell>.<mode>` (means over the seeds),
`stops.<cell>.<mode>` (protective stops per run), `slowed_s.<cell>.<mode>` (time the override
was under 0.99, per run), `pfl_share.<cell>` (CPU share of effective masses and PFL speeds in the
declared mode), `judge_cpu_share.<cell>` (CPU share of the judge, the `SafetyMonitor`: its
sampling of the truth and `Judge.step`, not its reading of the skeleton estimate, which computes
the controller's input),
`ssm_breach_s.<cell>` (declared mode, summed over the seeds), `verdict.<cell>` (the worst seed's
code) and `verdicts.<cell>`, `stop_ratio_worst.<cell>` (measured / assumed stopping distance or
time, worst over the seeds; null: no stop), `effective_mass_kg.gripper` (the YuMi's right gripper
at its home pose along +x, the plant with the URDF's drives; `gripper_min`, `gripper_max` over
directions, `iso` the standard's M/2), `falsify.<cell>.violations` and `.verdict` (the judged worst
candidate of each `--falsify` report) and `.candidates_with_violations.<search>`,
`pfl_speed_mps.<region>` and `pfl_speed_quasi_static_mps.<region>` (eq. A.6 for
m_R = 3 kg), `effective_mass_us` (one evaluation on a fresh YuMi state: Jacobian, mass matrix,
factorisation) and `effective_mass_cached_us` (another point of the same body and state), and
`kept_pct.<cell>` (issue 52: declared-mode products as a percentage of the products without a
safety system; null without both); a cell whose declared mode plans its speed
(`speed_profile: predictive`) has its declared figures under `predictive` too, unless that mode
was run itself. `--plot FILE` draws the products per cell and mode as bars,
each declared bar labelled with its verdict (the before/after picture of docs/safety.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

MODES = ("declared", "none", "ssm", "pfl", "hybrid", "predictive", "reactive")
#: the tag of each mode override
MODE_TAGS = {"ssm": "SpeedSeparationMonitoring", "pfl": "PowerForceLimiting", "hybrid": "Hybrid"}


def mode_overrides(path: str, mode: str) -> dict:
    """The raw overrides that put the cell of `path` under `mode` ({} for `declared`)."""
    from hrc_drake.cell.scenario import Tagged, load_scenario
    from hrc_drake.perception.config import NoTracker
    from hrc_drake.safety.config import NoSafety

    if mode == "declared":
        return {}
    if mode == "none":
        return {"safety": Tagged("NoSafety", {})}
    scenario = load_scenario(path)
    if mode in ("predictive", "reactive"):
        # the declared mode with the other speed profile (a cell with no safety system has none)
        if isinstance(scenario.safety, NoSafety):
            return {}
        fields = {**dataclasses.asdict(scenario.safety), "speed_profile": mode}
        return {"safety": Tagged(type(scenario.safety).__name__, fields)}
    uncertainty = "camera" if isinstance(scenario.tracker, NoTracker) else "tracker"
    fields = {"position_uncertainty": uncertainty}
    if not isinstance(scenario.safety, NoSafety):
        fields["speed_profile"] = scenario.safety.speed_profile
    out = {"safety": Tagged(MODE_TAGS[mode], fields)}
    if mode == "hybrid" and not scenario.layout.collaborative_zones:
        table = scenario.layout.table
        center = [table.center[0], table.center[1], table.height + 0.25]
        radius = 0.5 * (table.size[0] ** 2 + table.size[1] ** 2) ** 0.5
        out["layout"] = {"collaborative_zones": [{"name": "table", "center": center, "radius": radius}]}
    return out


def run(path: str, mode: str, seed: int, duration: float) -> dict:
    """One seeded run of a cell under one mode: its figures."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario_with
    from hrc_drake.safety import rules
    from hrc_drake.safety.systems import SafetyMonitor

    warnings.filterwarnings("ignore")
    scenario = load_scenario_with(path, mode_overrides(path, mode))
    scenario.seed = int(seed)
    pfl_time = [0.0]
    judge_time = [0.0]

    def judged(function, sign=1.0):
        def wrapper(*args, **kwargs):
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                judge_time[0] += sign * (time.thread_time() - start)
        return wrapper

    # the monitor binds its periodic event at construction: time it from there. Its reading of the
    # skeleton estimate (`_measured`) is left out: that evaluation computes the controller's input
    # (the camera and the tracker), which the controller's update at the same time then reuses
    original_record, original_measured = SafetyMonitor._record, SafetyMonitor._measured
    SafetyMonitor._record = judged(original_record)
    try:
        cell = build_cell(scenario, path)
    finally:
        SafetyMonitor._record = original_record

    def timed(function):
        def wrapper(*args, **kwargs):
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                pfl_time[0] += time.thread_time() - start
        return wrapper

    original = rules.SafetyRules.robot_masses, rules.SafetyRules.pfl_speeds
    rules.SafetyRules.robot_masses, rules.SafetyRules.pfl_speeds = timed(original[0]), timed(original[1])
    SafetyMonitor._measured = judged(original_measured, -1.0)
    start = time.thread_time()
    try:
        result = simulate(cell, duration, progress=None)
    finally:
        rules.SafetyRules.robot_masses, rules.SafetyRules.pfl_speeds = original
        SafetyMonitor._measured = original_measured
    cpu = time.thread_time() - start
    metrics = result.metrics
    safety = metrics["safety"]
    ratios = [v for v in safety["worst_ratio"].values() if v != 0.0]  # 0: no contact with that region
    return {"scenario": Path(path).stem, "mode": mode, "declared": safety["mode"], "seed": scenario.seed,
            "speed_profile": getattr(scenario.safety, "speed_profile", None),
            "cpu_s": round(cpu, 2), "pfl_share": round(pfl_time[0] / cpu, 4) if cpu > 0 else None,
            "judge_share": round(judge_time[0] / cpu, 4) if cpu > 0 else None,
            "stop_ratio_worst": safety.get("stop_ratio_worst"),
            "products": int(metrics.get("products_finished") or 0),
            "cycle_s": metrics.get("mean_time_between_products"),
            "verdict": safety["verdict_code"], "violations": safety["violations_total"],
            "by_kind": safety["violations"],
            # a region where no contact is permitted has ratio null (infinite)
            "worst_ratio": (None if not ratios else (max(ratios) if all(r is not None for r in ratios)
                                                     else "inf")),
            "worst_by_region": safety["worst_ratio"], "stops": safety["protective_stops"],
            "breach_s": safety["ssm_breach_s"], "contacts": safety["contact_count"],
            "slowed_s": metrics.get("time_slowed_s"),
            "min_distance_m": metrics.get("min_human_robot_distance")}


def _run(job):
    return run(*job)


def pfl_speeds(robot_mass: float = 3.0) -> tuple[dict, dict]:
    """Eq. (A.6) for `robot_mass` per body region of the packaged table: transient, quasi-static."""
    from hrc_drake.safety.limits import BODY_REGIONS, load_limits, permissible_speed

    limits = load_limits()
    transient = {r: round(permissible_speed(limits[r], robot_mass), 4) for r in BODY_REGIONS}
    quasi = {r: round(permissible_speed(limits[r], robot_mass, clamped=True), 4) for r in BODY_REGIONS}
    return transient, quasi


def time_effective_mass(repeats: int = 400) -> tuple[float, float]:
    """Median microseconds of one effective-mass evaluation on the YuMi of torch_clock: on a fresh
    state (the body's Jacobian, the mass matrix and its factorisation) and again on the same one."""
    import numpy as np

    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.robots.description import robot_record
    from hrc_drake.robots.models import RobotCapsuleKinematics
    from hrc_drake.safety.systems import RobotPointDynamics

    path = REPO / "diagrams" / "torch_clock.yaml"
    scenario = load_scenario(path)
    plant = build_cell(scenario, path).plant
    kinematics = RobotCapsuleKinematics(plant, [(plant.GetModelInstanceByName(r.name), robot_record(r, path))
                                                for r in scenario.robots])
    dynamics = RobotPointDynamics(plant, kinematics)
    rng = np.random.default_rng(0)
    k = next(i for i, name in enumerate(dynamics.names) if "gripper_r" in name)
    fresh, cached = [], []
    for _ in range(repeats):
        dynamics.set_state(rng.uniform(-0.5, 0.5, plant.num_positions()), np.zeros(plant.num_velocities()))
        (start, end, _), _ = dynamics.capsules()
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        t0 = time.perf_counter()
        dynamics.effective_mass([k], start[k], u)
        t1 = time.perf_counter()
        dynamics.effective_mass([k], end[k], u)
        t2 = time.perf_counter()
        fresh.append(t1 - t0)
        cached.append(t2 - t1)
    return round(1e6 * float(np.median(fresh)), 1), round(1e6 * float(np.median(cached)), 1)


def separation_at_rest(path: str, horizon: float = 0.3) -> dict:
    """How far the worst-case volume of [107] reaches from the resting operator, and how near
    the robot's targets are: speed and separation monitoring can only let the robot work where
    `nearest_robot_target_m` > `rest_reach_m` + clearance (+ the robot's capsule radius).

    rest_reach_m: the farthest the 0.3 s worst-case volume (default limits, from rest) reaches
    ahead of the resting wrists; nearest_robot_target_m: horizontal distance from a resting
    wrist to the nearest tool position of the robots' poses (targets and joint poses alike).
    """
    import numpy as np

    from hrc_drake.cell.scenario import load_scenario, operator_places
    from hrc_drake.human.body import BodyModel
    from hrc_drake.human.operator import SyntheticOperator, tasks_from_schema
    from hrc_drake.motion.reactive import ReactiveMotionPredictor, worst_case_excursions
    from hrc_drake.robots.poses import tool_positions

    scenario = load_scenario(path)
    op = scenario.operator
    if op.recorded:
        return {"rest_reach_m": None, "nearest_robot_target_m": None}
    body = BodyModel()
    yaw = op.base.rpy[2]
    operator = SyntheticOperator(body, tasks_from_schema(op, operator_places(scenario)), list(op.pattern),
                                 body.rest_q(base_xy=op.base.xyz[:2], yaw=yaw), 0, agent=op.name)
    predictor = ReactiveMotionPredictor(body, kind="worst_case", horizon=horizon)
    for _ in range(predictor.order + 2):
        predictor.update_q(operator.rest_config, 1e-3)
    plus, minus = worst_case_excursions(np.zeros(12), predictor.horizon, predictor.v_max, predictor.a_max)
    volumes = predictor.swept_volumes(0.0, plus, minus)
    forward = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    wrists = np.array(list(operator.rest_wrists.values()))
    ends = np.vstack([volumes.start, volumes.end])
    radius = np.concatenate([volumes.radius, volumes.radius])
    reach = float((ends @ forward + radius).max() - (wrists @ forward).max())
    # every pose's tool position: a Cartesian target's or a joint pose's (poses given in joints)
    targets = np.array(list(tool_positions(scenario.robots, path).values()))
    nearest = None
    if len(targets):
        gaps = np.linalg.norm(targets[None, :, :2] - wrists[:, None, :2], axis=2)
        nearest = float(gaps.min())
    return {"rest_reach_m": round(reach, 3), "nearest_robot_target_m": None if nearest is None
            else round(nearest, 3)}


#: the cell of --smoke: the quickest shipped cell to build and simulate
SMOKE_CELL = REPO / "diagrams" / "box_usb.yaml"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", help="scenario files (default: every diagrams/*.yaml)")
    parser.add_argument("--duration", type=float, default=120.0, help="simulated s per run (default 120)")
    parser.add_argument("--seeds", type=int, default=2,
                        help="runs per (cell, mode): the scenario's seed, then seed + 1, ... (default 2)")
    parser.add_argument("--modes", default=",".join(MODES), help=f"comma-separated subset of {MODES}")
    parser.add_argument("--workers", type=int, default=2,
                        help="worker processes (default 2; 1: the runs in this process)")
    parser.add_argument("--declared-seeds", type=int, default=None,
                        help="runs of the declared mode (default: --seeds)")
    parser.add_argument("--falsify", nargs="*", default=(), metavar="REPORT",
                        help="report.json files of falsification searches, for the falsify.* keys")
    parser.add_argument("--quick", action="store_true", help="20 s runs, one seed (under 5 minutes)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--plot", type=Path, default=None, metavar="PNG",
                        help="draw the products per cell and mode (bars) to this file")
    parser.add_argument("--before", type=Path, default=None, metavar="LOG",
                        help="an earlier run's output (its last line): its declared products drawn as a "
                             "'before' bar beside this run's (the before/after picture)")
    parser.add_argument("--figures", type=Path, default=None, metavar="LOG",
                        help="run nothing: plot the figures of an earlier run's output (its last line)")
    args = parser.parse_args(argv)
    before = None if args.before is None else last_json(args.before)["products"]
    if args.figures is not None:
        if args.plot is None:
            parser.error("--figures needs --plot")
        plot_products(last_json(args.figures), args.plot, before)
        print(f"products per cell and mode drawn to {args.plot}", flush=True)
        return
    if args.quick:
        args.duration, args.seeds = 20.0, 1
    if args.smoke:  # one small cell with and without its safety system, in this process
        args.duration, args.seeds, args.declared_seeds, args.workers = 2.0, 1, 1, 1
        args.modes = "declared,none"
        args.scenarios = args.scenarios or [str(SMOKE_CELL)]
    modes = [m for m in args.modes.split(",") if m]
    unknown = sorted(set(modes) - set(MODES))
    if unknown:
        parser.error(f"unknown modes {unknown}; choose among {MODES}")
    paths = [Path(p) for p in args.scenarios] or sorted((REPO / "diagrams").glob("*.yaml"))
    from hrc_drake.cell.scenario import load_scenario

    jobs = []
    for path in paths:
        base_seed = load_scenario(path).seed
        jobs += [(str(path), mode, base_seed + k, args.duration) for mode in modes
                 for k in range((args.declared_seeds or args.seeds) if mode == "declared" else args.seeds)]
    print(f"{len(jobs)} runs of {args.duration:.0f} s on {args.workers} workers ...", flush=True)
    print(f"{'scenario':<24} {'mode':<9} {'seed':>4} {'products':>8} {'cycle s':>8} {'violations':>10} "
          f"{'worst':>6} {'stops':>6} {'breach s':>8} {'contacts':>8} {'PFL cpu':>7} {'cpu s':>6}",
          flush=True)
    rows = []
    # one worker: the runs in this process, one after the other (no process to start)
    with nullcontext(None) if args.workers <= 1 else ProcessPoolExecutor(args.workers) as pool:
        for row in map(_run, jobs) if pool is None else pool.map(_run, jobs):
            rows.append(row)
            worst = row["worst_ratio"]
            worst = "-" if worst is None else (worst if isinstance(worst, str) else f"{worst:.2f}")
            cycle = "-" if row["cycle_s"] is None else f"{row['cycle_s']:.1f}"
            mode = row["mode"] if row["mode"] != "declared" else f"={row['declared']}"
            print(f"{row['scenario']:<24} {mode:<9} {row['seed']:>4} {row['products']:>8} {cycle:>8} "
                  f"{row['violations']:>10} {worst:>6} {row['stops']:>6} {row['breach_s']:>8.1f} "
                  f"{row['contacts']:>8} {100 * (row['pfl_share'] or 0):>6.1f}% {row['cpu_s']:>6.1f}",
                  flush=True)
    out = figures(rows, args)
    if args.plot is not None:
        plot_products(out, args.plot, before)
        print(f"products per cell and mode drawn to {args.plot}", flush=True)
    print(json.dumps(out))


#: verdict codes from the worst: a cell's verdict over its seeds is its worst seed's
VERDICT_ORDER = ("unsafe", "non_conforming", "no_safety_system", "safe")


def worst_verdict(codes) -> str:
    """The worst of a cell's verdict codes over its seeds (`VERDICT_ORDER`)."""
    codes = list(codes)
    return min(codes, key=VERDICT_ORDER.index) if codes else None


def gripper_effective_mass() -> dict:
    """m_R (kg) of the YuMi's right gripper (its tool point) at torch_clock's home pose from the
    plant with the drives of the URDF: `gripper` along +x (toward an operator across the table),
    `gripper_min` and `gripper_max` over 2000 directions, and `iso` the standard's M/2 of that arm."""
    import numpy as np

    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.robots.description import robot_record
    from hrc_drake.robots.models import RobotCapsuleKinematics
    from hrc_drake.safety.systems import RobotPointDynamics, arm_masses

    path = REPO / "diagrams" / "torch_clock.yaml"
    scenario = load_scenario(path)
    plant = build_cell(scenario, path).plant
    robot = scenario.robots[0]
    instance = plant.GetModelInstanceByName(robot.name)
    kinematics = RobotCapsuleKinematics(plant, [(instance, robot_record(robot, path))])
    dynamics = RobotPointDynamics(plant, kinematics)
    q = plant.GetPositions(plant.CreateDefaultContext())
    poses = {p.name: p for p in robot.poses}
    model = robot_record(robot, path)
    for arm in robot.arms:
        for name, value in zip(model.arm(arm.arm).joints, poses[arm.home].joints, strict=True):
            q[plant.GetJointByName(name, instance).position_start()] = value
    dynamics.set_state(q, np.zeros(plant.num_velocities()))
    (_, ends, _), _ = dynamics.capsules()
    k = list(dynamics.names).index(f"{robot.name}/gripper_r_base")
    directions = np.random.default_rng(0).normal(size=(2000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points = np.repeat(ends[k][None], len(directions), 0)
    masses = dynamics.effective_mass(np.full(len(directions), k), points, directions)
    along_x = float(dynamics.effective_mass([k], ends[k][None], np.array([[1.0, 0.0, 0.0]]))[0])
    iso = 0.5 * float(arm_masses(plant, kinematics.capsule_bodies)[k])
    return {"gripper": round(along_x, 3), "gripper_min": round(float(masses.min()), 3),
            "gripper_max": round(float(masses.max()), 3), "iso": round(iso, 3)}


def falsified(report_path: Path) -> dict:
    """falsify.<cell>.* of a falsification search's report.json (`hrc-drake search ... --out DIR`):
    the standard judge's violations of its worst candidate run again (`violations`, `verdict`), and
    the candidates the judge found violations in, per search (optimiser, random)."""
    if not report_path.is_file():
        print(f"no falsification report at {report_path}: its falsify.* keys are left out", file=sys.stderr)
        return {}
    report = json.loads(report_path.read_text())
    cell = report["name"].removeprefix("falsify_")
    worst = report.get("worst_replay") or {}
    out = {f"falsify.{cell}.violations": worst.get("violations"),
           f"falsify.{cell}.verdict": worst.get("verdict")}
    for label, search in report.get("searches", {}).items():
        out[f"falsify.{cell}.candidates_with_violations.{label}"] = search.get("candidates_with_violations")
        out[f"falsify.{cell}.candidates.{label}"] = search.get("candidates")
    return out


def figures(rows: list[dict], args) -> dict:
    """The bench's JSON: the keys of the module docstring."""
    import numpy as np

    def mean(values):
        values = [v for v in values if v is not None]
        return round(float(np.mean(values)), 3) if values else None

    out: dict = {"duration_s": args.duration, "seeds": args.seeds}
    cells = sorted({r["scenario"] for r in rows})
    declared = {c: [r for r in rows if r["scenario"] == c and r["mode"] == "declared"] for c in cells}
    out["declared_mode"] = {c: rs[0]["declared"] for c, rs in declared.items() if rs}
    out["violations"] = {c: sum(r["violations"] for r in rs) for c, rs in declared.items() if rs}
    out["cells_with_violations"] = sum(1 for v in out["violations"].values() if v)
    worst = {}
    for c, rs in declared.items():
        ratios = [r["worst_ratio"] for r in rs if r["worst_ratio"] is not None]
        worst[c] = None if not ratios else ("inf" if "inf" in ratios else round(max(ratios), 4))
    out["worst_ratio"] = worst
    for key, field in (("products", "products"), ("cycle_s", "cycle_s"), ("stops", "stops"),
                       ("slowed_s", "slowed_s")):
        out[key] = {c: {m: mean(r[field] for r in rows if r["scenario"] == c and r["mode"] == m)
                        for m in sorted({r["mode"] for r in rows if r["scenario"] == c})} for c in cells}
    out["pfl_share"] = {c: mean(r["pfl_share"] for r in rs) for c, rs in declared.items() if rs}
    out["judge_cpu_share"] = {c: mean(r["judge_share"] for r in rs) for c, rs in declared.items() if rs}
    out["ssm_breach_s"] = {c: round(sum(r["breach_s"] for r in rs), 3) for c, rs in declared.items() if rs}
    out["verdict"] = {c: worst_verdict(r["verdict"] for r in rs) for c, rs in declared.items() if rs}
    out["verdicts"] = {c: [r["verdict"] for r in rs] for c, rs in declared.items() if rs}
    out["stop_ratio_worst"] = {c: max((r["stop_ratio_worst"] for r in rs
                                       if r["stop_ratio_worst"] is not None),
                                      default=None) for c, rs in declared.items() if rs}
    add_predictive_figures(out, {c: rs[0].get("speed_profile") for c, rs in declared.items() if rs})
    out["kept_pct"] = {c: kept_percentage(out["products"][c]) for c in cells}
    out["effective_mass_kg"] = gripper_effective_mass()
    for report in getattr(args, "falsify", None) or ():
        out.update(falsified(Path(report)))
    transient, quasi = pfl_speeds(3.0)
    out["pfl_speed_mps"] = transient
    out["pfl_speed_quasi_static_mps"] = quasi
    repeats = 4 if getattr(args, "smoke", False) else 400
    out["effective_mass_us"], out["effective_mass_cached_us"] = time_effective_mass(repeats)
    return out


def add_predictive_figures(out: dict, profiles: dict) -> None:
    """The declared mode of a cell that plans its speed (`profiles[cell] == "predictive"`) is its
    predictive mode: its products, cycle, stops and time slowed are also given under `predictive`
    (the issue-52 keys), unless that mode was run itself."""
    for cell, profile in profiles.items():
        if profile != "predictive":
            continue
        for key in ("products", "cycle_s", "stops", "slowed_s"):
            figures = out[key][cell]
            if "declared" in figures:
                figures.setdefault("predictive", figures["declared"])


def kept_percentage(products: dict):
    """Declared-mode products as a percentage of those without a safety system (`products.<cell>`),
    or None without both runs or with no product unsafeguarded."""
    declared, unsafeguarded = products.get("declared"), products.get("none")
    if declared is None or not unsafeguarded:
        return None
    return round(100.0 * declared / unsafeguarded, 1)


#: the bars of each cell, in this order, and their colours
PLOT_MODES = (("none", "0.75"), ("ssm", "tab:blue"), ("pfl", "tab:orange"), ("hybrid", "tab:green"),
              ("reactive", "tab:red"), ("predictive", "tab:purple"), ("declared", "black"))


def last_json(path: Path) -> dict:
    """The JSON object on the last line of a bench's output."""
    lines = [line for line in Path(path).read_text(encoding="utf-8").splitlines() if line.strip()]
    if not lines:
        raise SystemExit(f"{path}: empty, no bench output")
    try:
        out = json.loads(lines[-1])
    except json.JSONDecodeError as err:
        raise SystemExit(f"{path}: its last line is not the bench's JSON ({err})") from None
    if not isinstance(out, dict) or not isinstance(out.get("products"), dict):
        raise SystemExit(f"{path}: its last line has no products per cell")
    return out


def plot_products(figures_out: dict, path: Path, before: dict | None = None) -> None:
    """Grouped bars: products per run of each cell under each mode it ran, the declared bar
    labelled with the cell's verdict and kept percentage; `before`: an earlier run's products per
    cell and mode, whose declared products are drawn first as "before" (hatched)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    products = {c: dict(v) for c, v in figures_out["products"].items()}
    cells = sorted(products)
    modes = [(m, colour) for m, colour in PLOT_MODES if any(m in products[c] for c in cells)]
    if before:
        for c in cells:
            earlier = before.get(c, {}).get("declared")
            if earlier is not None:
                products[c]["before"] = earlier
        modes.insert(1 if modes and modes[0][0] == "none" else 0, ("before", "0.45"))
    width = 0.8 / max(len(modes), 1)
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(cells)), 4.5))
    for j, (mode, colour) in enumerate(modes):
        xs = [i + (j - (len(modes) - 1) / 2) * width for i in range(len(cells))]
        heights = [products[c].get(mode) or 0.0 for c in cells]
        label = "declared before this run" if mode == "before" else mode
        ax.bar(xs, heights, width, label=label, color=colour, hatch="//" if mode == "before" else None)
        if mode == "declared":
            for x, c, h in zip(xs, cells, heights, strict=True):
                verdict = figures_out.get("verdict", {}).get(c) or ""
                kept = figures_out.get("kept_pct", {}).get(c)
                label = verdict.upper() + ("" if kept is None else f" {kept:.0f} %")
                ax.text(x, h, label, rotation=90, ha="center", va="bottom", fontsize=7)
    ax.set_xticks(range(len(cells)), cells, rotation=45, ha="right", fontsize=8)
    tallest = max((products[c].get(m) or 0.0 for c in cells for m, _ in modes), default=0.0)
    ax.set_ylim(0.0, 1.3 * tallest + 1.0)  # room for the verdict labels above the tallest bars
    ax.set_ylabel("products per run")
    ax.set_title(f"The cost of safety ({figures_out.get('duration_s', 0):.0f} s runs)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
