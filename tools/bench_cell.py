"""Benchmark: realtime factor of every cell in diagrams/, current code against a baseline, side by side.

For each scenario `diagrams/<name>.yaml` (found by glob) the script measures the current checkout
and a baseline revision (default 71681c9, main before the realtime work of issue 18) in the
same run. The baseline is checked out with `git worktree add --detach` into a temporary directory,
which is removed at the end (also on error or Ctrl-C). Each tree is measured with its own
`diagrams/<name>.yaml` (the scenario format changed between the versions; the cells are the same).

One measurement is a fresh subprocess (`sys.executable -c ...`, PYTHONPATH and cwd = the tree)
that loads the scenario, builds the cell (robots as the scenario says: kinematic by default) and
times `simulate(cell, duration, progress=None)` with `time.perf_counter()` (wall) and
`time.process_time()` (CPU of that process), then prints one JSON line. Import and build times are
not included. Runs are interleaved (for each repeat, for each scenario: current, then baseline)
so that load on the shared machine hits both alike; the median of wall seconds and of CPU seconds
are kept separately. RTF = simulated seconds / median seconds. `cpu_change_percent_<name>` =
100 * (current CPU s / baseline CPU s - 1): positive means the current code is slower.

For the current code it also reports the per-update copy cost of the largest abstract state: after
20 s of simulation (in the first current-code subprocess of each scenario, after its timed run), it
walks the diagram's leaf systems, times `copy.deepcopy(value)` of every abstract state value (Drake
does this twice per unrestricted update) and `thaw()` of every `Frozen` value in it or in its
attributes (the copy-on-write copy an update makes), medians over many repeats, in microseconds.

With `--instructions S` it also counts, for every scenario and tree, the machine instructions
executed inside Drake's `Simulator::AdvanceTo` over S simulated seconds (one run under valgrind's
callgrind, collection switched on only inside AdvanceTo, so import and build are left out; the
two trees run side by side). The count does not depend on the load of a shared machine, where
single wall-time runs vary by +-20 %: it is the figure to compare two versions by a few percent
(a run takes ~50x its native time; valgrind must be installed: `apt-get install valgrind`).
Keys `instructions_g_<name>` (10^9 instructions), `baseline_instructions_g_<name>` and
`instructions_change_percent_<name>` = 100 * (current / baseline - 1).

A scenario the baseline tree does not have (e.g. diagrams/full_pipeline.yaml, the cell with
every stage on) is measured there with the current tree's file, when the baseline code can load
it. Start-up of each tree is timed too, as the median of 7 fresh interpreters: `help_s`, the
wall time of `python -m hrc_drake.cli --help`; `import_s`, the wall time of `python -c "import
hrc_drake"` minus that of `python -c pass`; `cell_import_s`, the time to import what a
simulation needs (scenario loader, builder, simulate), measured inside the interpreter;
`interpreter_s`, `python -c pass` (the floor on this machine). Then the numba kernels, each
figure from empty caches (NUMBA_CACHE_DIR a new temporary folder): `kernel_compile_s` and
`kernel_load_s`, the seconds `hrc_drake.kernels.warm_up()` takes to compile every kernel and to
load them all from the cache; `kernel_compile_s.<group>` (geometry, human, motion, perception,
intention, prediction, scheduling, safety: `kernels.GROUPS`), one group's compile time in its own
interpreter, callees of other files included (a cell compiles only the groups its systems call,
when first called); and `first_run_s.torch_clock`, the wall time of `python -m hrc_drake.cli
simulate diagrams/torch_clock.yaml --duration 20` with an empty cache: a fresh machine's first
run, interpreter to report. The timed simulations warm the kernels up before their clock starts.

The goals (issue 41) are `rtf_<name>` >= 50 (CPU-based) for a cell without a GP motion predictor,
>= 20 for one with it (a system "human_motion_predictor"), >= 10 for a rendered-camera cell, and
`help_s` <= 0.1: `goal_rtf_<name>` gives each cell's, `below_goal` lists the cells that miss.
`--profile` runs cProfile on every cell below its goal (current code, the same duration) and
prints its 25 largest functions by own time and by cumulative time. `--breakdown` runs every cell
once more with each system's callbacks (output calculations, periodic events) timed, leaving out
the callbacks they call in turn, and gives `breakdown_<name>`: the largest systems' shares of the
run's CPU time (%), "other systems", and "drake and glue" (the simulator loop, the plant's
kinematics, Python between callbacks).

Prints progress lines, a table, then as its last line one JSON object with the figures: per
scenario `rtf_<name>` (CPU RTF, current), `rtf_wall_<name>`, `baseline_rtf_<name>`,
`baseline_rtf_wall_<name>`, `cpu_change_percent_<name>`, `products_<name>`,
`min_distance_<name>` (and their `baseline_` twins: results must agree up to seed noise), and
`help_s`, `import_s`, `cell_import_s`, `interpreter_s`, `kernel_compile_s`, `kernel_load_s`,
`kernel_compile_s.<group>`, `first_run_s.torch_clock` (and their `baseline_` twins).

Usage:
    PYTHONPATH=. python3 tools/bench_cell.py [--quick | --smoke] [--duration S] [--repeats N]
                                             [--only NAME ...] [--baseline REV | --no-baseline]
                                             [--instructions S] [--profile] [--breakdown] [--startup-only]

--quick: 20 s of simulated time and 1 repeat: about 45 s on a 2-core machine (4 scenarios x 2
trees x (~2-3 s of interpreter start-up, Drake import and cell build + 0.5-6 s of simulation)).
A full run (120 s, 3 repeats, 12 cells, two trees, --profile) took 18 minutes on 2 cores (2026-12-04).
--startup-only: the start-up figures alone, of the current tree (and of --baseline REV when
given), then the JSON line: about 2 minutes per tree on 2 cores.
--smoke: the whole path once in ~12 s, figures meaningless: torch_clock for 1 s on the current tree
only (no baseline worktree), the state copies probed after that 1 s, one interpreter per start-up
figure, the kernel figures of one group, no first run (`SMOKE_STARTUP`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT_BASELINE = "71681c9"  # main before issue 18 (the realtime work)
PROBE_DURATION = 20.0

# Run in a fresh interpreter with PYTHONPATH and cwd = the tree measured. argv: scenario path,
# duration, probe flag ("1": also time the copies of the abstract state, current code only), and
# optionally the simulated s after which the probe runs (default PROBE_DURATION).
MEASURE_CODE = r"""
import copy, json, statistics, sys, time, warnings
warnings.simplefilter("ignore")
from hrc_drake.cell.scenario import load_scenario
from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate

path, duration, probe = sys.argv[1], float(sys.argv[2]), sys.argv[3] == "1"
probe_duration = float(sys.argv[4]) if len(sys.argv) > 4 else PROBE_DURATION
scenario = load_scenario(path)
cell = build_cell(scenario, path)
try:  # kernels compile (or load) when first called: do it here, outside the timed run
    from hrc_drake import kernels
    kernels.warm_up()
except ImportError:  # a tree without kernels
    pass
wall0, cpu0 = time.perf_counter(), time.process_time()
result = simulate(cell, duration, progress=None)
wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
out = {
    "wall_s": wall,
    "cpu_s": cpu,
    "products": result.metrics["products_finished"],
    "min_distance": result.metrics["min_human_robot_distance"],
    "robot_modes": [str(getattr(r, "mode", "?")) for r in scenario.robots],
    # a baseline tree's cell may not expose its diagram: then no GP predictor is known
    "gp_predictor": any(s.get_name() == "human_motion_predictor"
                        for s in getattr(getattr(cell, "diagram", None), "GetSystems", list)()),
}


def median_us(fn, budget=0.2, max_reps=300):
    start = time.perf_counter()
    fn()
    first = time.perf_counter() - start
    reps = int(min(max_reps, max(7, budget / max(first, 1e-7))))
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e6 * statistics.median(times)


def frozen_parts(value):
    # The values with a thaw() method: the value itself, else its attributes (one level, and the
    # items of tuple/list attributes).
    if callable(getattr(value, "thaw", None)):
        return [value]
    attrs = []
    if isinstance(value, (tuple, list)):
        attrs = list(value)
    else:
        names = set(getattr(value, "__dict__", {}))
        for klass in type(value).__mro__:
            slots = klass.__dict__.get("__slots__", ())
            names.update([slots] if isinstance(slots, str) else slots)
        attrs = [getattr(value, n) for n in sorted(names) if hasattr(value, n)]
    parts = []
    for a in attrs:
        items = a if isinstance(a, (tuple, list)) else [a]
        parts += [x for x in items if callable(getattr(x, "thaw", None))]
    return parts


if probe:
    from pydrake.systems.framework import LeafSystem
    if duration != probe_duration:
        result = simulate(cell, probe_duration, progress=None)
    states = []
    for system in cell.diagram.GetSystems():
        if not isinstance(system, LeafSystem):
            continue
        ctx = system.GetMyContextFromRoot(result.context)
        for i in range(ctx.num_abstract_states()):
            value = ctx.get_abstract_state(i).get_value()
            parts = frozen_parts(value)
            entry = {
                "system": system.get_name(),
                "index": i,
                "type": type(value).__name__,
                "deepcopy_us": median_us(lambda: copy.deepcopy(value)),
                "clone_us": None,
                "frozen": [repr(p) for p in parts],
            }
            if parts:
                entry["clone_us"] = median_us(lambda: [p.thaw() for p in parts])
            states.append(entry)
    out["states"] = states
print(json.dumps(out))
""".replace("PROBE_DURATION", repr(PROBE_DURATION))


# Run in a fresh interpreter: the time to import what a simulation needs, measured inside.
IMPORT_CODE = r"""
import json, time
start = time.perf_counter()
from hrc_drake.cell.scenario import load_scenario
from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate
print(json.dumps({"cell_import_s": time.perf_counter() - start}))
"""

#: the first run on a machine: `hrc-drake simulate` of this cell for this many simulated seconds,
#: with an empty numba cache (`first_run_s.<cell>`)
FIRST_RUN_SCENARIO = "torch_clock"
FIRST_RUN_DURATION = 20.0

#: fresh interpreters per start-up figure
STARTUP_REPEATS = 7

#: --smoke: one cell for 1 s on the current tree only, one interpreter per start-up figure, the
#: kernel group quickest to compile, and no first run (from an empty cache it compiles the cell's
#: kernels: ~15 s)
SMOKE_SCENARIO, SMOKE_DURATION = "torch_clock", 1.0
SMOKE_STARTUP = {"repeats": 1, "kernel_groups": ("prediction",), "first_run": False}


def median(values: list[float]) -> float:
    """The median of a non-empty list."""
    return statistics.median(values)


def last_json_line(text: str) -> dict:
    """The JSON object on the last non-empty line of `text`."""
    lines = [line for line in text.splitlines() if line.strip()]
    if not lines:
        raise ValueError("no output")
    return json.loads(lines[-1])


def change_percent(current_s: float, baseline_s: float) -> float:
    """100 * (current / baseline - 1): positive when the current code takes longer."""
    return 100.0 * (current_s / baseline_s - 1.0)


def summarize_runs(runs: list[dict], duration: float) -> dict:
    """Median wall and CPU seconds of `runs` (separately), their RTFs, and the products seen."""
    wall = median([r["wall_s"] for r in runs])
    cpu = median([r["cpu_s"] for r in runs])
    products = [r["products"] for r in runs]
    return {
        "wall_s": wall,
        "cpu_s": cpu,
        "rtf": duration / wall,
        "rtf_cpu": duration / cpu,
        "products": int(median(products)),
        "products_all": products,
        "min_distance": median([r["min_distance"] for r in runs]),
        "robot_modes": sorted({m for r in runs for m in r.get("robot_modes", [])}),
        "gp_predictor": any(r.get("gp_predictor", False) for r in runs),
    }


def largest_states(states: list[dict]) -> tuple[dict | None, dict | None]:
    """The abstract state with the largest deepcopy time, and the one with the largest clone time."""
    by_copy = max(states, key=lambda s: s["deepcopy_us"], default=None)
    cloned = [s for s in states if s.get("clone_us") is not None]
    by_clone = max(cloned, key=lambda s: s["clone_us"], default=None)
    return by_copy, by_clone


def figures_json(
    names: list[str],
    current: dict[str, dict],
    baseline: dict[str, dict] | None,
    states: list[dict],
    duration: float,
    repeats: int,
    baseline_rev: str | None,
    load_start: float,
    load_end: float,
    startup: dict[str, dict] | None = None,
) -> dict:
    """The last line's figures. `current`/`baseline`: {scenario: summarize_runs(...)}; `states`:
    the probe entries of every scenario, each with "system" already prefixed by its scenario;
    `startup`: {"current": startup_times(...), "baseline": ...} where measured."""
    out: dict = {}
    for name in names:
        cur = current[name]
        base = baseline.get(name) if baseline is not None else None
        out[f"rtf_{name}"] = round(cur["rtf_cpu"], 2)
        out[f"rtf_wall_{name}"] = round(cur["rtf"], 2)
        if base is not None:
            out[f"baseline_rtf_{name}"] = round(base["rtf_cpu"], 2)
            out[f"baseline_rtf_wall_{name}"] = round(base["rtf"], 2)
            out[f"cpu_change_percent_{name}"] = round(change_percent(cur["cpu_s"], base["cpu_s"]), 1)
        out[f"products_{name}"] = cur["products"]
        out[f"min_distance_{name}"] = round(cur["min_distance"], 4)
        if base is not None:
            out[f"baseline_products_{name}"] = base["products"]
            out[f"baseline_min_distance_{name}"] = round(base["min_distance"], 4)
    if startup:
        out.update(startup_figures(startup, load_start, load_end))
    for name in names:
        out[f"goal_rtf_{name}"] = goal_rtf(name, current[name])
    out["below_goal"] = [n for n in names if current[n]["rtf_cpu"] < goal_rtf(n, current[n])]
    out["goal_help_s"] = GOAL_HELP_S
    by_copy, by_clone = largest_states(states)
    out["deepcopy_us_largest_state"] = round(by_copy["deepcopy_us"], 2) if by_copy else None
    out["deepcopy_largest_state_system"] = by_copy["system"] if by_copy else None
    out["clone_us_largest_state"] = round(by_clone["clone_us"], 2) if by_clone else None
    out["clone_largest_state_system"] = by_clone["system"] if by_clone else None
    out["duration_s"] = duration
    out["repeats"] = repeats
    out["baseline_rev"] = baseline_rev
    out["load_average_1min"] = {"start": round(load_start, 2), "end": round(load_end, 2)}
    return out


def format_table(names: list[str], current: dict[str, dict], baseline: dict[str, dict] | None) -> str:
    """The readable table: one row per scenario, RTF = simulated s / median s."""

    def num(x, fmt):
        return format(x, fmt) if x is not None else "-"

    head = (
        f"{'scenario':22s} {'cur RTF':>8s} {'cur CPU':>8s} {'base RTF':>8s} {'base CPU':>8s} "
        f"{'CPU chg %':>9s} {'products cur/base':>17s} {'min dist cur/base m':>19s}"
    )
    rows = [head, "-" * len(head)]
    for name in names:
        cur = current[name]
        base = baseline.get(name) if baseline is not None else None
        chg = change_percent(cur["cpu_s"], base["cpu_s"]) if base else None
        products = f"{cur['products']}/{base['products'] if base else '-'}"
        dist = f"{cur['min_distance']:.3f}/{num(base['min_distance'] if base else None, '.3f')}"
        rows.append(
            f"{name:22s} {cur['rtf']:8.1f} {cur['rtf_cpu']:8.1f} "
            f"{num(base['rtf'] if base else None, '8.1f'):>8s} "
            f"{num(base['rtf_cpu'] if base else None, '8.1f'):>8s} "
            f"{num(chg, '+9.1f'):>9s} {products:>17s} {dist:>19s}"
        )
    return "\n".join(rows)


def measure(tree: Path, scenario: Path, duration: float, probe: bool = False,
            probe_duration: float = PROBE_DURATION) -> dict:
    """One measurement in a fresh subprocess running the code of `tree`; with `probe`, the copy
    costs of the abstract state after `probe_duration` simulated s."""
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONWARNINGS="ignore")
    proc = subprocess.run(
        [sys.executable, "-c", MEASURE_CODE, str(scenario), repr(duration), "1" if probe else "0",
         repr(probe_duration)],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        tail = "\n".join(proc.stderr.strip().splitlines()[-15:])
        raise RuntimeError(f"measurement of {scenario} in {tree} failed (exit {proc.returncode}):\n{tail}")
    return last_json_line(proc.stdout)


def startup_times(tree: Path, first_run: bool = True, repeats: int = STARTUP_REPEATS,
                  kernel_groups: tuple[str, ...] | None = None) -> dict:
    """Medians over `repeats` fresh interpreters of `tree`'s code: `help_s` (wall of
    `python -m hrc_drake.cli --help`), `import_s` (wall of `python -c "import hrc_drake"` minus
    that of `python -c pass`), `cell_import_s` (inside the interpreter, see IMPORT_CODE) and
    `interpreter_s` (wall of `python -c pass`); then the kernels' compile and load times
    (`kernel_times` of `kernel_groups`, None: all) and, with `first_run`, `first_run_s.<cell>`
    (`first_run_time`)."""
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONWARNINGS="ignore")

    def wall(cmd: list[str]) -> float:
        start = time.perf_counter()
        proc = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
        elapsed = time.perf_counter() - start
        if proc.returncode != 0:
            raise RuntimeError(f"{cmd[1:]} in {tree} failed (exit {proc.returncode}): {proc.stderr[-500:]}")
        return elapsed

    def imported() -> float:
        proc = subprocess.run([sys.executable, "-c", IMPORT_CODE], cwd=tree, env=env,
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"import of the cell modules in {tree} failed: {proc.stderr[-500:]}")
        return last_json_line(proc.stdout)["cell_import_s"]

    help_s, package_s, cell_import_s, interpreter_s = [], [], [], []
    for _ in range(repeats):  # interleaved, so that load hits them alike
        help_s.append(wall([sys.executable, "-m", "hrc_drake.cli", "--help"]))
        package_s.append(wall([sys.executable, "-c", "import hrc_drake"]))
        cell_import_s.append(imported())
        interpreter_s.append(wall([sys.executable, "-c", "pass"]))
    out = {"help_s": median(help_s), "import_s": median(package_s) - median(interpreter_s),
           "cell_import_s": median(cell_import_s), "interpreter_s": median(interpreter_s),
           **kernel_times(tree, env, kernel_groups)}
    if first_run:
        out.update(first_run_time(tree, env))
    return out


# Run in a fresh interpreter: compile (or load) the kernel groups named in argv (all without).
KERNEL_CODE = r"""
import json, sys
from hrc_drake import kernels
groups = sys.argv[1:]
print(json.dumps({"warm_up_s": kernels.warm_up(groups) if groups else kernels.warm_up()}))
"""


def kernel_times(tree: Path, env: dict, groups: tuple[str, ...] | None = None) -> dict:
    """`kernel_compile_s`: `kernels.warm_up()` of every kernel with an empty numba cache (all
    the kernels a fresh machine could compile); `kernel_load_s`: the same again, loading what
    it cached; `kernel_compile_s.<group>` (trees with `kernels.GROUPS`): one group's kernels from
    its own empty cache in its own interpreter, the kernels of other files it calls included
    (a cell compiles only the groups its systems use). groups: these groups only, in each figure
    (None: all). {} for a tree without kernels."""
    if not (tree / "hrc_drake" / "kernels.py").exists():
        return {}

    def warm_up(cache: str, groups: list[str]) -> float:
        proc = subprocess.run([sys.executable, "-c", KERNEL_CODE, *groups], cwd=tree,
                              env=dict(env, NUMBA_CACHE_DIR=cache), capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"kernels.warm_up({groups}) in {tree} failed: {proc.stderr[-500:]}")
        return last_json_line(proc.stdout)["warm_up_s"]

    out = {}
    with tempfile.TemporaryDirectory(prefix="hrc_numba_cache_") as cache:
        out["kernel_compile_s"] = warm_up(cache, list(groups or []))
        out["kernel_load_s"] = warm_up(cache, list(groups or []))
    proc = subprocess.run([sys.executable, "-c", "import json; from hrc_drake import kernels; "
                           "print(json.dumps(list(getattr(kernels, 'GROUPS', {}))))"],
                          cwd=tree, env=env, capture_output=True, text=True)
    for group in last_json_line(proc.stdout) if proc.returncode == 0 else []:
        if groups is not None and group not in groups:
            continue
        with tempfile.TemporaryDirectory(prefix="hrc_numba_cache_") as cache:
            out[f"kernel_compile_s.{group}"] = warm_up(cache, [group])
    return out


def first_run_time(tree: Path, env: dict) -> dict:
    """`first_run_s.<cell>`: wall seconds of `python -m hrc_drake.cli simulate <cell> --duration
    FIRST_RUN_DURATION` with NUMBA_CACHE_DIR an empty folder, what a first run on a fresh machine
    takes (interpreter, imports, build, kernel compilation, simulation). {} when the tree's CLI
    cannot run it."""
    scenario = tree / "diagrams" / f"{FIRST_RUN_SCENARIO}.yaml"
    with tempfile.TemporaryDirectory(prefix="hrc_numba_cache_") as cache:
        start = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "hrc_drake.cli", "simulate", str(scenario), "--duration",
                               f"{FIRST_RUN_DURATION:g}"], cwd=tree, env=dict(env, NUMBA_CACHE_DIR=cache),
                              capture_output=True, text=True)
        elapsed = time.perf_counter() - start
    if proc.returncode != 0:
        print(f"  first run of {FIRST_RUN_SCENARIO} in {tree} failed (exit {proc.returncode}): "
              f"{proc.stderr.strip().splitlines()[-1:]}", flush=True)
        return {}
    return {f"first_run_s.{FIRST_RUN_SCENARIO}": elapsed}


def startup_figures(startup: dict[str, dict], load_start: float, load_end: float) -> dict:
    """The last line's figures of a `--startup-only` run: the start-up keys of each tree
    (`baseline_` before the baseline's), rounded, and the load average."""
    out: dict = {}
    for label, prefix in (("current", ""), ("baseline", "baseline_")):
        for key, value in (startup.get(label) or {}).items():
            out[prefix + key] = round(value, 4)
    out["load_average_1min"] = {"start": round(load_start, 2), "end": round(load_end, 2)}
    return out


# Run in a fresh interpreter of the current code: cProfile of one simulation, the top functions.
PROFILE_CODE = r"""
import cProfile, io, pstats, sys, warnings
warnings.simplefilter("ignore")
from hrc_drake.cell.scenario import load_scenario
from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate

path, duration = sys.argv[1], float(sys.argv[2])
cell = build_cell(load_scenario(path), path)
profile = cProfile.Profile()
profile.enable()
simulate(cell, duration, progress=None)
profile.disable()
for key in ("tottime", "cumulative"):
    text = io.StringIO()
    pstats.Stats(profile, stream=text).strip_dirs().sort_stats(key).print_stats(25)
    print(text.getvalue())
"""


def profile_cell(scenario: Path, duration: float) -> str:
    """cProfile's report (by own and by cumulative time) of one run of `scenario`, current code."""
    env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONWARNINGS="ignore")
    proc = subprocess.run([sys.executable, "-c", PROFILE_CODE, str(scenario), repr(duration)],
                          cwd=REPO, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"profile of {scenario} failed (exit {proc.returncode}): {proc.stderr[-800:]}")
    return proc.stdout


# Run in a fresh interpreter of the current code: the CPU seconds of each system's own callbacks.
# Every output calculation and periodic event a LeafSystem declares is wrapped (before the cell is
# built) with a timer that leaves out the callbacks it calls in turn (a port it evaluates), so
# each second is counted once, by the system whose Python code ran; the rest of the run is
# Drake's own work (the simulator loop, the plant's kinematics) and Python glue between them.
BREAKDOWN_CODE = r"""
import json, sys, time, warnings
warnings.simplefilter("ignore")
from pydrake.systems.framework import LeafSystem
from hrc_drake.cell.scenario import load_scenario
from hrc_drake.cell.build import build_cell  # pydrake's own modules first: they extend LeafSystem
from hrc_drake.cell.run import simulate
from hrc_drake import kernels
own, stack, systems = {}, [], {}
process_time = time.process_time


def timed(system, fn):
    key = id(system)
    systems[key] = system

    def inner(*args):
        start = process_time()
        stack.append(0.0)
        try:
            return fn(*args)
        finally:
            elapsed = process_time() - start
            nested = stack.pop()
            own[key] = own.get(key, 0.0) + elapsed - nested
            if stack:
                stack[-1] += elapsed
    return inner


def wrap(method, at):
    original = getattr(LeafSystem, method)

    def declare(self, *args, **kwargs):
        args = list(args)
        if len(args) > at and callable(args[at]):
            args[at] = timed(self, args[at])
        return original(self, *args, **kwargs)
    setattr(LeafSystem, method, declare)


for method in ("DeclareAbstractOutputPort", "DeclareVectorOutputPort", "DeclarePeriodicPublishEvent",
               "DeclarePeriodicUnrestrictedUpdateEvent", "DeclarePeriodicDiscreteUpdateEvent"):
    wrap(method, 2)

path, duration = sys.argv[1], float(sys.argv[2])
cell = build_cell(load_scenario(path), path)
kernels.warm_up()
own.clear()
start = process_time()
simulate(cell, duration, progress=None)
total = process_time() - start
by_name = {}
for key, seconds in own.items():
    name = systems[key].get_name()
    by_name[name] = by_name.get(name, 0.0) + seconds
print(json.dumps({"total_s": total, "systems_s": by_name}))
"""


def breakdown_cell(scenario: Path, duration: float) -> dict:
    """{"total_s": CPU s of the run, "systems_s": {system: CPU s of its own callbacks}} of one run of
    `scenario` (current code; `BREAKDOWN_CODE`)."""
    env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONWARNINGS="ignore")
    proc = subprocess.run([sys.executable, "-c", BREAKDOWN_CODE, str(scenario), repr(duration)],
                          cwd=REPO, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"breakdown of {scenario} failed (exit {proc.returncode}): {proc.stderr[-800:]}")
    return last_json_line(proc.stdout)


def breakdown_shares(breakdown: dict, top: int = 6) -> dict[str, float]:
    """The `top` systems' shares of the run's CPU time (%), largest first, then "other systems" and
    "drake and glue" (the time no system's callback ran)."""
    total = breakdown["total_s"]
    systems = sorted(breakdown["systems_s"].items(), key=lambda item: -item[1])
    shares = {name: round(100.0 * seconds / total, 1) for name, seconds in systems[:top]}
    shares["other systems"] = round(100.0 * sum(s for _, s in systems[top:]) / total, 1)
    shares["drake and glue"] = round(100.0 * (total - sum(s for _, s in systems)) / total, 1)
    return shares


def is_rendered(name: str) -> bool:
    """A cell with the rendered depth camera (its goal is `GOAL_RTF_RENDERED`)."""
    return name.endswith("_rendered")


#: issue 41's goals: CPU RTF of a cell, of a cell with a GP motion predictor, of a rendered-camera
#: cell; --help's seconds
GOAL_RTF, GOAL_RTF_GP, GOAL_RTF_RENDERED, GOAL_HELP_S = 50.0, 20.0, 10.0, 0.1


def goal_rtf(name: str, summary: dict) -> float:
    """The CPU RTF goal of cell `name` (its run `summary` says whether it has a GP predictor)."""
    if is_rendered(name):
        return GOAL_RTF_RENDERED
    return GOAL_RTF_GP if summary.get("gp_predictor") else GOAL_RTF


#: valgrind's callgrind counting instructions only inside Simulator::AdvanceTo
CALLGRIND = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=*Simulator*AdvanceTo*"]


def collected_instructions(valgrind_stderr: str) -> int:
    """The "Collected : N" count of a callgrind run's report."""
    for line in valgrind_stderr.splitlines():
        if "Collected" in line and ":" in line:
            return int(line.split(":")[-1].strip().replace(",", ""))
    raise ValueError("no 'Collected' line in the valgrind report")


def start_instruction_count(tree: Path, scenario: Path, duration: float, out_dir: Path) -> subprocess.Popen:
    """Start one callgrind run of `scenario` in `tree` (a subprocess; see `collected_instructions`)."""
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONWARNINGS="ignore")
    out_file = out_dir / f"callgrind.{tree.name}.{scenario.stem}.out"
    return subprocess.Popen(
        [*CALLGRIND, f"--callgrind-out-file={out_file}", sys.executable, "-c", MEASURE_CODE,
         str(scenario), repr(duration), "0"],
        cwd=tree, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def count_instructions(
    trees: dict[str, Path], names: list[str], duration: float
) -> dict[str, dict[str, int]]:
    """{label: {scenario: instructions in AdvanceTo}}, the trees of one scenario run side by side."""
    counts: dict[str, dict[str, int]] = {label: {} for label in trees}
    with tempfile.TemporaryDirectory(prefix="bench_cell_callgrind_") as out_dir:
        for name in names:
            start = time.perf_counter()
            procs = {label: start_instruction_count(tree, tree / "diagrams" / f"{name}.yaml", duration,
                                                    Path(out_dir))
                     for label, tree in trees.items() if (tree / "diagrams" / f"{name}.yaml").is_file()}
            for label, proc in procs.items():
                _, err = proc.communicate()
                if proc.returncode != 0:
                    tail = "\n".join(err.strip().splitlines()[-15:])
                    raise RuntimeError(
                        f"callgrind run of {name} ({label}) failed (exit {proc.returncode}):\n{tail}"
                    )
                counts[label][name] = collected_instructions(err)
            line = "  ".join(f"{label} {counts[label][name] / 1e9:8.4f} G" for label in procs)
            print(f"  instructions {name:22s} {line}  ({time.perf_counter() - start:5.0f} s)", flush=True)
    return counts


def instruction_figures(names: list[str], counts: dict[str, dict[str, int]], duration: float) -> dict:
    """The JSON keys of `--instructions`: counts in 10^9 and the change against the baseline."""
    out: dict = {"instructions_duration_s": duration}
    for name in names:
        cur = counts["current"][name]
        out[f"instructions_g_{name}"] = round(cur / 1e9, 4)
        if name in counts.get("baseline", {}):
            base = counts["baseline"][name]
            out[f"baseline_instructions_g_{name}"] = round(base / 1e9, 4)
            out[f"instructions_change_percent_{name}"] = round(change_percent(cur, base), 2)
    return out


@contextlib.contextmanager
def baseline_tree(rev: str) -> Iterator[Path]:
    """A temporary detached worktree of `rev`, removed on exit (also on error)."""
    tmp = Path(tempfile.mkdtemp(prefix="bench_cell_baseline_"))
    tree = tmp / "tree"
    try:
        add = subprocess.run(
            ["git", "-C", str(REPO), "worktree", "add", "--detach", "--quiet", str(tree), rev],
            capture_output=True,
            text=True,
        )
        if add.returncode != 0:
            raise RuntimeError(f"git worktree add of {rev!r} failed: {add.stderr.strip()}")
        yield tree
    finally:
        subprocess.run(
            ["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], capture_output=True
        )
        shutil.rmtree(tmp, ignore_errors=True)


def _sigterm(signum, frame):
    raise SystemExit(128 + signum)


def startup_only(rev: str | None, startup_options: dict) -> None:
    """`--startup-only`: the start-up figures of the current tree (and of `rev`), a short report,
    then one JSON line. startup_options: `startup_times`'s settings."""
    load_start = os.getloadavg()[0]
    t_start = time.perf_counter()
    print(f"bench_cell --startup-only: current tree{f' and baseline {rev}' if rev else ''}, "
          f"load average {load_start:.2f}", flush=True)
    startup = {}
    with contextlib.ExitStack() as stack:
        trees = {"current": REPO}
        if rev is not None:
            trees["baseline"] = stack.enter_context(baseline_tree(rev))
        for label, tree in trees.items():
            startup[label] = startup_times(tree, **startup_options)
            for key, value in startup[label].items():
                print(f"  {label:8s} {key:32s} {value:8.3f} s", flush=True)
    load_end = os.getloadavg()[0]
    print(f"total {time.perf_counter() - t_start:.0f} s, load average {load_start:.2f} -> {load_end:.2f}")
    print(json.dumps(startup_figures(startup, load_start, load_end)))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="20 s of simulated time, 1 repeat")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--duration", type=float, default=None, help="simulated s per run (default 120)")
    parser.add_argument("--repeats", type=int, default=None, help="runs per scenario and tree (default 3)")
    parser.add_argument("--baseline", default=None,
                        help=f"baseline git revision (default {DEFAULT_BASELINE}; none with --startup-only)")
    parser.add_argument("--no-baseline", action="store_true", help="measure the current code only")
    parser.add_argument("--instructions", type=float, default=0.0, metavar="S",
                        help="also count instructions in AdvanceTo over S simulated s (valgrind)")
    parser.add_argument("--only", nargs="+", default=None, metavar="NAME",
                        help="measure only these scenarios of diagrams/ (names without .yaml)")
    parser.add_argument("--profile", action="store_true",
                        help="also profile every cell below its goal (current code, cProfile)")
    parser.add_argument("--breakdown", action="store_true",
                        help="also give each cell's CPU time by system (current code, one more run each)")
    parser.add_argument("--startup-only", action="store_true",
                        help="measure only the start-up figures (import_s, first_run_s.*, "
                             "kernel_compile_s.*) of the current code (and of --baseline REV when given "
                             "with it): ~2 minutes")
    args = parser.parse_args(argv)
    duration = args.duration or (SMOKE_DURATION if args.smoke else 20.0 if args.quick else 120.0)
    repeats = args.repeats or (1 if args.quick or args.smoke else 3)
    if duration <= 0 or repeats < 1:
        parser.error("--duration must be positive and --repeats at least 1")
    if not (args.instructions >= 0 and args.instructions < float("inf")):
        parser.error("--instructions takes a finite number of simulated seconds >= 0")
    if args.instructions and shutil.which("valgrind") is None:
        parser.error("--instructions needs valgrind on PATH (apt-get install valgrind)")
    startup_options = SMOKE_STARTUP if args.smoke else {}
    without_baseline = args.no_baseline or args.smoke  # the smoke run makes no worktree
    # SIGTERM raises SystemExit, so that the baseline worktree is removed; the caller's handler after
    previous_handler = signal.signal(signal.SIGTERM, _sigterm)
    try:
        if args.startup_only:
            startup_only(None if without_baseline else args.baseline, startup_options)
            return
        names = scenario_names(parser, args.only or ([SMOKE_SCENARIO] if args.smoke else None))
        rev = None if without_baseline else (args.baseline or DEFAULT_BASELINE)
        # the smoke run probes the state copies after its own short run, not after PROBE_DURATION
        probe_duration = duration if args.smoke else PROBE_DURATION
        measure_cells(args, names, duration, repeats, rev, probe_duration, startup_options)
    finally:
        signal.signal(signal.SIGTERM, previous_handler)


def scenario_names(parser: argparse.ArgumentParser, only: list[str] | None) -> list[str]:
    """The scenarios of diagrams/ (names without .yaml), only those of `only` when given."""
    names = sorted(p.stem for p in (REPO / "diagrams").glob("*.yaml"))
    if not names:
        sys.exit(f"no scenarios in {REPO / 'diagrams'}")
    if only:
        unknown = sorted(set(only) - set(names))
        if unknown:
            parser.error(f"--only: no such scenario in diagrams/: {unknown} (there are {names})")
        names = [n for n in names if n in only]
    return names


def measure_cells(args: argparse.Namespace, names: list[str], duration: float, repeats: int,
                  rev: str | None, probe_duration: float, startup_options: dict) -> None:
    """The cells' measurements (module docstring), the report and the JSON line; `rev`: the
    baseline revision (None: the current code only)."""
    load_start = os.getloadavg()[0]
    t_start = time.perf_counter()
    print(
        f"bench_cell: {len(names)} scenarios {names}, {duration:g} s simulated, {repeats} repeat(s), "
        f"baseline {rev or 'none'}, load average {load_start:.2f}",
        flush=True,
    )

    runs: dict[str, dict[str, list[dict]]] = {
        label: {n: [] for n in names} for label in ("current", "baseline")
    }
    states: list[dict] = []
    with contextlib.ExitStack() as stack:
        trees = {"current": REPO}
        if rev is not None:
            trees["baseline"] = stack.enter_context(baseline_tree(rev))
            print(f"baseline {rev} checked out in {trees['baseline']}", flush=True)
        startup = {}
        for label, tree in trees.items():
            startup[label] = startup_times(tree, **startup_options)
            print(f"  start-up {label:8s} " + "  ".join(f"{k} {v:.3f}" for k, v in startup[label].items()),
                  flush=True)
        skipped: set[tuple[str, str]] = set()
        for k in range(repeats):
            for name in names:
                for label, tree in trees.items():
                    if (label, name) in skipped:
                        continue
                    scenario = tree / "diagrams" / f"{name}.yaml"
                    if not scenario.is_file():
                        # a cell new since the baseline: the baseline code runs the current file
                        scenario = REPO / "diagrams" / f"{name}.yaml"
                        if k == 0:
                            print(f"  {name}: not in the {label} tree, which runs the current file")
                    probe = label == "current" and k == 0
                    start = time.perf_counter()
                    try:
                        r = measure(tree, scenario, duration, probe=probe, probe_duration=probe_duration)
                    except RuntimeError as err:
                        if label == "current":
                            raise
                        print(f"  {name}: the {label} code cannot run it, measured on the current code "
                              f"only ({str(err).splitlines()[-1]})", flush=True)
                        skipped.add((label, name))
                        continue
                    runs[label][name].append(r)
                    for s in r.pop("states", []):
                        states.append(dict(s, system=f"{name}:{s['system']}"))
                    print(
                        f"  [{k + 1}/{repeats}] {name:22s} {label:8s} sim {r['wall_s']:6.1f} s wall "
                        f"{r['cpu_s']:6.1f} s CPU  RTF {duration / r['wall_s']:6.1f}  "
                        f"products {r['products']:3d}  (subprocess {time.perf_counter() - start:5.1f} s"
                        f"{', + state copy probe' if probe else ''})",
                        flush=True,
                    )
        counts = count_instructions(trees, names, args.instructions) if args.instructions else None

    current = {n: summarize_runs(runs["current"][n], duration) for n in names}
    # a scenario the baseline revision does not have is measured on the current code only
    baseline = {n: summarize_runs(runs["baseline"][n], duration) for n in names if runs["baseline"][n]} \
        if rev else None
    load_end = os.getloadavg()[0]

    print()
    print(f"Realtime factors (simulated s / median s, {repeats} run(s) of {duration:g} s), kinematic robots")
    print(format_table(names, current, baseline))
    for label, times in startup.items():
        print(f"start-up ({label}): --help {times['help_s']:.3f} s, "
              f"import hrc_drake {times['import_s']:.3f} s, cell imports {times['cell_import_s']:.3f} s, "
              f"bare interpreter {times['interpreter_s']:.3f} s (goal: --help <= {GOAL_HELP_S:g} s)")
    by_copy, by_clone = largest_states(states)
    print()
    print(f"Per-update copy cost of abstract state (current code, after {probe_duration:g} s), median us:")
    for s in sorted(states, key=lambda s: -s["deepcopy_us"])[:5]:
        clone = f"{s['clone_us']:9.1f}" if s["clone_us"] is not None else "        -"
        print(f"  deepcopy {s['deepcopy_us']:9.2f}  thaw {clone}  {s['system']}[{s['index']}] {s['type']}")
    if by_clone is not None:
        print(f"  largest thaw/clone: {by_clone['clone_us']:.1f} us  {by_clone['system']} "
              f"{by_clone['frozen']}")
    notes = []
    for name in names:
        base = (baseline or {}).get(name)
        modes = set(current[name]["robot_modes"]) | set(base["robot_modes"] if base else [])
        if modes - {"kinematic"}:
            notes.append(f"{name}: robot modes {sorted(modes)} (not all kinematic)")
        if base is not None and current[name]["products"] != base["products"]:
            notes.append(
                f"{name}: products differ, current {current[name]['products_all']} vs baseline "
                f"{baseline[name]['products_all']}"
            )
    for note in notes:
        print(f"note: {note}")
    figures = figures_json(names, current, baseline, states, duration, repeats, rev, load_start, load_end,
                           startup)
    if args.profile:
        for name in figures["below_goal"]:
            print()
            print(f"Profile of {name} ({current[name]['rtf_cpu']:.1f}x CPU, goal "
                  f"{goal_rtf(name, current[name]):g}x), {duration:g} s simulated, current code "
                  "(cProfile adds its own overhead):")
            print(profile_cell(REPO / "diagrams" / f"{name}.yaml", duration), flush=True)
        figures["profiled"] = figures["below_goal"]
    if args.breakdown:
        print()
        print(f"CPU time by system (own callbacks; current code, one run of {duration:g} s each):")
        for name in names:
            shares = breakdown_shares(breakdown_cell(REPO / "diagrams" / f"{name}.yaml", duration))
            figures[f"breakdown_{name}"] = shares
            print(f"  {name:22s} " + ", ".join(f"{system} {share:.1f} %" for system, share in shares.items()),
                  flush=True)
    if counts is not None:
        print()
        print(f"Instructions in Simulator::AdvanceTo over {args.instructions:g} simulated s "
              "(callgrind), 10^9:")
        for name in names:
            base = counts.get("baseline", {}).get(name)
            chg = f"{change_percent(counts['current'][name], base):+6.2f} %" if base else ""
            base_text = f"{base / 1e9:9.4f}" if base else "        -"
            print(f"  {name:22s} current {counts['current'][name] / 1e9:9.4f}  baseline {base_text}  {chg}")
        figures.update(instruction_figures(names, counts, args.instructions))
    print(f"total {time.perf_counter() - t_start:.0f} s, load average {load_start:.2f} -> {load_end:.2f}")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
