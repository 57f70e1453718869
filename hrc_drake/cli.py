"""`hrc-drake` command: simulate or validate a cell scenario, run and compare campaigns of runs."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from hrc_drake.config_common import MAX_SIMULATED_DURATION, REPLAY_MAX_FRAMES, replay_fps_within
from hrc_drake.errors import EnvironmentFailure, ScenarioError

#: Exit codes: a finished run, an internal error, bad input (file or argument), the environment
#: failed (a lost Dask scheduler, a table that cannot be written, a folder another campaign
#: holds), Ctrl-C (SIGINT; SIGTERM: 143, 128 + the signal as shells report it).
EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_ENVIRONMENT, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
EXIT_TERMINATED = 143

# Each command imports what it uses when it runs, so `hrc-drake --help` loads neither pydrake
# nor scipy / scikit-learn (nor tempfile / traceback: `--help` has a 0.1 s budget, issue 18).


def _duration(text: str) -> float:
    value = _number(text)
    if not (math.isfinite(value) and 0 < value <= MAX_SIMULATED_DURATION):
        raise argparse.ArgumentTypeError(
            f"must be a finite number of seconds in (0, {MAX_SIMULATED_DURATION:g}], got {text!r}")
    return value


def _fps(text: str) -> float:
    value = _number(text)
    if not (math.isfinite(value) and 0 < value <= 120):
        raise argparse.ArgumentTypeError(f"must be a number of frames per second in (0, 120], got {text!r}")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(f"must be in [0, 2^32), got {text!r}")
    return value


def _frames(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 10 <= value <= 100_000:
        raise argparse.ArgumentTypeError(f"must be in [10, 100000], got {text!r}")
    return value


def _rate(text: str) -> float:
    value = _number(text)
    if not (math.isfinite(value) and 0 <= value <= 1000):
        raise argparse.ArgumentTypeError(f"must be in [0, 1000] (0: as fast as possible), got {text!r}")
    return value


def _recording_rate(text: str) -> float:
    """`import --rate`: the recording's frame rate, as the importer accepts it."""
    value = _number(text)
    if not (math.isfinite(value) and 0.1 <= value <= 10_000):
        raise argparse.ArgumentTypeError(f"the recording's frame rate must be in [0.1, 10000] Hz, "
                                         f"got {text!r}")
    return value


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None


SCENARIO_HELP = ("scenario YAML file, or the name of a shipped example (e.g. torch_clock; the names: "
                 "diagrams/*.yaml)")


def _check_writable_dir(option: str, path: Path) -> None:
    """`path` is, or can be made, a folder we can write in; else ScenarioError on `option`."""
    import tempfile

    if path.exists() and not path.is_dir():
        raise ScenarioError(path, option, "exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as err:
        raise ScenarioError(path, option, f"cannot write there: {err.strerror or err}") from None


def _check_writable_file(option: str, path: Path) -> None:
    """`path` can be written as a file (its folder made if needed); else ScenarioError."""
    if path.is_dir():
        raise ScenarioError(path, option, "is a folder; give a file name, e.g. replay.html")
    _check_writable_dir(option, path.parent if str(path.parent) else Path("."))
    if path.exists() and not os.access(path, os.W_OK):
        raise ScenarioError(path, option, "exists and is not writable")


class _VersionAction(argparse.Action):
    """`--version`: the package version (and git commit in a checkout), computed only when asked."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from hrc_drake.provenance import code_version

        print(code_version())
        parser.exit(EXIT_OK)


#: the top-level keys only a campaign spec has (a scenario has none of them)
CAMPAIGN_ONLY_KEYS = frozenset({"name", "scenarios", "variants", "seeds", "expect", "extra_metrics", "pooled",
                                "replays", "replay_fps"})


def _search_only_key(file) -> str | None:
    """The first top-level key of the YAML text of `file` (a line `key:`) that only a search spec
    has (`hrc_drake.search.spec.KNOWN_KEYS` less the campaign's and the scenario's), or None."""
    import dataclasses

    from hrc_drake.cell.schema import Scenario
    from hrc_drake.search.spec import KNOWN_KEYS

    search_only = set(KNOWN_KEYS) - CAMPAIGN_ONLY_KEYS - {f.name for f in dataclasses.fields(Scenario)}
    try:
        lines = Path(file).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError, TypeError):
        return None
    keys = (line.split(":", 1)[0] for line in lines if ":" in line and not line[:1].isspace())
    return next((key for key in keys if key in search_only), None)


def _wrong_kind_hint(err: ScenarioError, expected: str) -> ScenarioError:
    """`err` with a hint naming the right command when the file is of the other kind: a
    campaign spec given to simulate / validate (`expected` "scenario"), a scenario given to
    campaign ("campaign"). Recognised by the first unknown top-level key the loader named."""
    key = err.field
    if "unknown key" not in err.reason or not key or any(c in key for c in ".["):
        return err
    search_key = _search_only_key(err.file) if expected == "scenario" and key in CAMPAIGN_ONLY_KEYS else None
    if search_key:
        hint = (f"{err.file} looks like a search spec (it has '{search_key}'): run it with "
                f"`hrc-drake search {err.file} --out FOLDER`")
    elif expected == "scenario" and key in CAMPAIGN_ONLY_KEYS:
        hint = (f"{err.file} looks like a campaign spec (it has '{key}'): run it with "
                f"`hrc-drake campaign {err.file} --out FOLDER`")
    elif expected == "campaign":
        import dataclasses

        from hrc_drake.cell.schema import Scenario

        if key not in {f.name for f in dataclasses.fields(Scenario)} - CAMPAIGN_ONLY_KEYS:
            return err
        hint = (f"{err.file} looks like a scenario (it has '{key}'): run it with "
                f"`hrc-drake simulate {err.file}`, or name it under `scenarios:` in a campaign spec")
    else:
        return err
    return ScenarioError(err.file, err.field, f"{err.reason}\nhint: {hint}")


def _load_scenario(name: str, check_reachability: bool = False):
    """`load_scenario` of the file `name` (or the shipped scenario of that name, `_scenario_path`),
    with the hint of `_wrong_kind_hint`. Returns (scenario, path)."""
    from hrc_drake.cell.scenario import load_scenario

    path = _scenario_path(name)
    try:
        return load_scenario(path, check_reachability=check_reachability), path
    except ScenarioError as err:
        hinted = _wrong_kind_hint(err, "scenario")
        if hinted is err:
            raise
        raise hinted from None


def _resolved(name: str, kind: str) -> str:
    """`name` as given when a file is there, else the shipped example of `kind` of that bare name
    (`cell.shipped.resolve`, as `load_scenario` and `import --cell`: `hrc-drake simulate
    torch_clock`); else ScenarioError naming where it looked and the examples there are."""
    from hrc_drake.cell.shipped import resolve

    found = resolve(name, kind)
    return name if found == Path(name) else str(found)


def _scenario_path(name: str) -> str:
    """The scenario file `name` means (`_resolved`)."""
    return _resolved(name, "scenario")


def throughput_lines(m: dict) -> list[str]:
    """The summary's figures after the verdict: products per hour, each product type's own cycle
    time (median, p90: from its first action to its completion), then the mean time between
    products of any type (1 / throughput, not a cycle time)."""

    def s(value) -> str:
        return f"{value:.2f} s" if value is not None else "n/a"

    per_hour, n = m["products_per_hour"], m["products_finished"]
    lines = [f"products per hour {per_hour:.1f} ({n} finished in {m['simulated_time']:.1f} s)"
             if per_hour is not None else f"products finished {n}"]
    if m["products"]:
        lines.append("  cycle time of each product, from its first action to its completion:")
    for kind, p in m["products"].items():
        lines.append(f"  {kind:14s} {p['finished']:3d} finished   cycle time median "
                     f"{s(p['cycle_time_median'])}   p90 {s(p['cycle_time_p90'])}")
    warmup = m["warmup"]
    rule = f"warm-up: the first {warmup['products']} product(s)" + (
        f" after t = {warmup['time']:g} s" if warmup["time"] else "")
    lines.append(f"mean time between products {s(m['mean_time_between_products'])} (any type, "
                 f"1 / throughput; {rule})")
    return lines


def _print_files(paths) -> None:
    """The files a command wrote, one a line, at its end."""
    paths = [str(p) for p in paths]
    if paths:
        print(f"files written ({len(paths)}):")
        for p in paths:
            print(f"  {p}")


def _simulate(args, written: list | None = None) -> int:
    """`hrc-drake simulate`; the files it wrote are listed at its end, or added to `written` (a
    command that runs it as its last step lists them with its own)."""
    from hrc_drake.cell.build import kernel_groups
    from hrc_drake.kernels import compile_ahead

    # Output paths are checked before anything is built, so a bad one costs no simulation.
    if args.out:
        _check_writable_dir("--out", Path(args.out))
    if args.replay:
        _check_writable_file("--replay", Path(args.replay))
    scenario, scenario_path = _load_scenario(args.scenario)
    if args.seed is not None:
        scenario.seed = args.seed
    # a first run compiles the cell's kernels in other processes while this one builds
    with compile_ahead(kernel_groups(scenario)) as ahead:
        return _build_and_simulate(args, scenario, scenario_path, ahead, written)


def _build_and_simulate(args, scenario, scenario_path, ahead, listed: list | None = None) -> int:
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate, write_replay, write_report

    duration = args.duration if args.duration is not None else scenario.duration
    meshcat = None
    if args.meshcat or args.replay:
        from hrc_drake.cell.run import local_meshcat

        # localhost only: the live view and the replay's recorder are not for the network; a
        # replay-only run's recorder serves nothing a person could open (no "listening" line)
        meshcat = local_meshcat(quiet=not args.meshcat)
        if args.meshcat:
            print(f"Meshcat live view: {meshcat.web_url()}", flush=True)
    replay_fps = args.replay_fps
    if args.replay:
        replay_fps = replay_fps_within(args.replay_fps, duration, args.replay_max_frames)
        if replay_fps < args.replay_fps:
            print(f"replay: {duration:g} s at {args.replay_fps:g} fps would exceed {args.replay_max_frames} "
                  f"frames (--replay-max-frames); recording {replay_fps:.3g} fps", flush=True)
    print(f"Building {scenario_path} (seed {scenario.seed}) ...", flush=True)
    cell = build_cell(scenario, scenario_path, meshcat=meshcat, replay_fps=replay_fps)
    realtime_rate = args.realtime_rate if args.realtime_rate is not None else (1.0 if args.meshcat else 0.0)
    ahead.wait()
    print(f"Simulating {duration:g} s (Ctrl-C stops and reports the time simulated) ...", flush=True)
    result = simulate(
        cell, duration, progress=sys.stderr, record=bool(args.replay), realtime_rate=realtime_rate
    )
    m = result.metrics
    iso = m.get("safety") or {}
    if "verdict" in iso:  # the verdict first: the answer to "is this cell safe?"
        print(iso["verdict"])
    for line in throughput_lines(m):
        print(line)
    print(f"simulated time    {m['simulated_time']:.1f} s")
    print(f"wall time         {m['wall_time']:.2f} s")
    print(f"realtime factor   {m['realtime_factor']:.1f}x")
    for agent, a in m["agents"].items():
        print(
            f"  {agent:14s} busy {a['busy_time']:7.1f} s   waiting {a['wait_time']:7.1f} s   "
            f"idle {a['idle_time']:7.1f} s   actions {a['actions_finished']}"
        )
    if m["min_human_robot_distance"] is not None:
        print(f"closest approach  {m['min_human_robot_distance']:.3f} m (true human-robot clearance)")
    written = []
    if args.replay:
        size = write_replay(cell, Path(args.replay), result)
        print(f"replay            {args.replay} ({size / 1e6:.1f} MB): open it in a web browser")
        written.append(Path(args.replay))
    if args.out:
        written += write_report(cell, result, Path(args.out))
    if listed is None:
        _print_files(written)
    else:
        listed.extend(written)
    if result.interrupted:
        import signal

        name = signal.Signals(result.stopped_by).name
        print(f"interrupted at t = {result.simulated_time:.1f} s of {duration:g} s ({name}): the figures and "
              "files cover the time simulated so far", file=sys.stderr)
        return 128 + int(result.stopped_by)
    if args.meshcat:
        print("Meshcat is still serving the live view; press Ctrl-C to quit.", flush=True)
        try:
            import time

            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            pass
    return 0


def _validate(args) -> int:
    scenario, path = _load_scenario(args.scenario, check_reachability=True)
    n_robot_actions = sum(len(r.actions) for r in scenario.robots)
    print(
        f"{path}: OK ({len(scenario.robots)} robot(s), {n_robot_actions} robot actions, "
        f"{len(scenario.operator.actions)} operator actions, {len(scenario.flow.actions)} flow actions)"
    )
    from hrc_drake.cell.scenario import safety_departures

    departures = safety_departures(scenario, path)
    if departures:
        print(f"warning: its safety verdict will be NON-CONFORMING ({len(departures)} departure(s) from "
              "ISO/TS 15066's judging):", file=sys.stderr)
        for departure in departures:
            print(f"  - {departure}", file=sys.stderr)
    return 0


def _import(args) -> int:
    from hrc_drake.errors import check_input_file, check_input_folder
    from hrc_drake.staged_files import check_outputs_apart
    from hrc_drake.untrusted import one_line

    out = Path(args.out)
    if not out.name or out.is_dir():
        raise ScenarioError(out, "--out", "is a folder: give the skeleton CSV's file name, e.g. out/rec.csv")
    scenario_path = out.with_suffix(".yaml") if args.cell else None
    if args.replay and not args.cell:
        raise ScenarioError("", "--replay", "needs --cell SCENARIO: the cell the recording replays in "
                                            "(e.g. box_pcb_coexistence or a scenario file)")
    if out.suffix.lower() == ".json":
        raise ScenarioError(out, "--out", "the skeleton CSV needs another suffix than .json: its provenance "
                                          "is written beside it as .json")
    if args.cell and scenario_path == out:
        raise ScenarioError(out, "--out", "the skeleton CSV needs another suffix than .yaml: the "
                                          "scenario of --cell is written beside it as .yaml")
    source = Path(args.source)
    if args.format == "kth":  # the KTH hand-over set is a folder of CSV files
        check_input_folder(source, "KTH hand-over recording")
    else:
        check_input_file(source, "recording")
    columns = Path(args.columns) if args.columns else None
    if columns is not None:
        check_input_file(columns, "column map")
    cell = Path(_scenario_path(args.cell)) if args.cell else None  # a file, or a shipped cell's name
    if cell is not None:
        check_input_file(cell)
    replay = Path(args.replay) if args.replay else None
    if replay is not None:
        _check_writable_file("--replay", replay)
    check_outputs_apart(
        {"the recording": source, "--columns": columns, "--cell": cell},
        {"--out": out, "--out's provenance JSON": out.with_suffix(".json"),
         "--out's scenario (with --cell)": scenario_path, "--replay": replay})
    try:
        summary, duration = _import_staged(args, source, out, cell, scenario_path)
    except OSError as err:  # a folder that cannot hold the outputs (read-only, /proc, full)
        where = Path(err.filename) if err.filename else out
        raise ScenarioError(where, "--out", f"cannot be written: {err.strerror or err}") from None
    written = [out, out.with_suffix(".json")] + ([scenario_path] if scenario_path is not None else [])
    for line in summary:
        print(one_line(line))  # the source's name may hold control characters (a terminal's too)
    if cell is None:
        print(f"drive a cell with it: set `operator: {{recorded: {out}}}` in a scenario, or import again "
              "with --cell SCENARIO [--replay FILE.html]")
        _print_files(written)
        return 0
    print(f"scenario: {scenario_path} (the recording as the operator of {cell}, {duration:g} s); "
          f"run it with: hrc-drake simulate {scenario_path}")
    if not args.replay:
        _print_files(written)
        return 0
    replay_args = argparse.Namespace(
        scenario=str(scenario_path), duration=None, seed=None, replay=args.replay, replay_fps=10.0,
        replay_max_frames=REPLAY_MAX_FRAMES, meshcat=False, realtime_rate=None, out=None)
    try:
        return _simulate(replay_args, written=written)
    finally:
        _print_files(written)  # the replay with the rest, whether the run ended or was stopped


def _import_staged(args, source: Path, out: Path, cell: Path | None, scenario_path: Path | None):
    """The recording read and the scenario of --cell checked in memory, so that a refusal writes
    nothing; then the outputs written to temporary files, checked as written, and renamed into
    place together (`StagedFiles`). Returns (summary lines, the scenario's duration or None)."""
    from hrc_drake.human.importers import read_recording, write_recording
    from hrc_drake.staged_files import StagedFiles

    imported = read_recording(
        args.format, source, source_rate=args.rate, person=args.person, columns=args.columns,
        units=args.units, delimiter=args.delimiter, header_rows=args.header_rows, up=args.up,
        camera_rate=args.camera_rate, operator_xy=(args.operator_x, args.operator_y), facing=args.facing,
        table_height=args.table_height)
    provenance = imported.summary(out)[0]
    duration = None
    if cell is not None:
        duration = _recorded_duration(imported.resampled.times)
        text = _recorded_scenario_text(scenario_path, cell, out, provenance, duration)
        _check_recorded_scenario(text, scenario_path, cell, out)
    with StagedFiles() as staged:
        skeleton = staged.path_for(out)
        sidecar = staged.path_for(out.with_suffix(".json"))
        summary = write_recording(imported, out, write_to=(skeleton, sidecar))
        if cell is not None:
            from hrc_drake.cell.scenario import load_scenario

            # checked again as written, with the skeleton under its temporary name, before anything is kept
            draft = staged.path_for(scenario_path)
            draft.write_text(_recorded_scenario_text(draft, cell, skeleton, provenance, duration,
                                                     shown_skeleton=out), encoding="utf-8")
            load_scenario(draft)
            staged.discard(draft)
            staged.path_for(scenario_path).write_text(text, encoding="utf-8")
        staged.commit()
    return summary, duration


def _recorded_duration(times) -> float:
    """A recorded operator's scenario duration: its last frame's time, up to a tenth of a second."""
    return max(math.ceil(float(times[-1]) * 10.0) / 10.0, 0.1)


def _recorded_scenario_text(path: Path, cell: Path, skeleton: Path, provenance: str, duration: float,
                            shown_skeleton: Path | None = None) -> str:
    """The YAML of a scenario at `path` that extends `cell` with the skeleton CSV `skeleton` as its
    operator for `duration` s (paths relative to the scenario's folder), written by the YAML
    emitter; its description names `shown_skeleton` (default: `skeleton`)."""
    import yaml

    from hrc_drake.untrusted import one_line

    folder = Path(os.path.abspath(path)).parent.resolve()

    def named(target: Path) -> str:  # relative when both lie under one folder below the root
        target = Path(os.path.abspath(target)).resolve()
        shared = os.path.commonpath([target, folder])
        return os.path.relpath(target, folder) if shared != os.path.dirname(shared) else str(target)

    document = {"extends": named(cell),
                "description": f"Recorded operator ({Path(shown_skeleton or skeleton).name}) in {cell.stem}",
                "duration": duration, "operator": {"recorded": named(skeleton)}}
    header = (f"# A recorded person as the operator of {one_line(cell.name)}, written by "
              f"`hrc-drake import`:\n# {one_line(provenance)}\n"
              "# The recording holds no actions: the operator's flow actions do not happen, the robot's "
              "do.\n")
    return header + yaml.safe_dump(document, sort_keys=False, default_flow_style=False, width=1000)


def _check_recorded_scenario(text: str, path: Path, cell: Path, skeleton: Path) -> None:
    """The scenario `text` checked as the file `path` before anything is written (the skeleton it
    names is not written yet, so not opened): ScenarioError naming --cell, the field at fault and
    the reason when the cell refuses a recorded operator; the cell's own problems named in its file."""
    from hrc_drake.cell.scenario import check_scenario_text

    try:
        check_scenario_text(text, path, unwritten=[skeleton])
    except ScenarioError as err:
        if err.file != str(path):
            raise  # a problem of the cell itself (or of a file it extends), named there
        reason = (f"a recording cannot drive this cell: the scenario {path} would be refused at "
                  f"{err.field or '<top>'}: {err.reason}; nothing was written")
        raise ScenarioError(cell, "--cell", reason) from None


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 0 <= value <= 512:
        raise argparse.ArgumentTypeError(f"must be in [0, 512] (0: in this process, no Dask), got {text!r}")
    return value


def _limit(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text!r}")
    return value


def _wait(text: str) -> float:
    value = _number(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be a number of seconds >= 0, got {text!r}")
    return value


def _campaign(args) -> int:
    import time

    from hrc_drake.campaign.engine import run_campaign
    from hrc_drake.campaign.spec import load_campaign
    from hrc_drake.campaign.store import check_output_dir

    out = Path(args.out)
    check_output_dir(out, create=False)  # before the scenarios are loaded, and nothing made yet
    spec = _campaign_path(args.spec)
    try:
        campaign = load_campaign(spec)
    except ScenarioError as err:
        hinted = _wrong_kind_hint(err, "campaign")
        if hinted is err:
            raise
        raise hinted from None
    where = args.address or (f"{args.workers} local worker process(es)" if args.workers else "this process")
    print(f"{campaign.name}: {campaign.run_count} runs ({len(campaign.scenarios)} scenario(s) x "
          f"{len(campaign.variants)} variant(s) x {len(campaign.seeds)} seed(s), "
          f"{campaign.duration:g} s each) on {where}", flush=True)
    configurations = len(campaign.scenarios) * len(campaign.variants)
    if args.limit is not None:
        print(f"--limit {args.limit}: at most {args.limit} of the runs not yet done are run now, two seeds "
              f"of each scenario x variant at a time (a test needs two); --limit {2 * configurations} "
              "gives every one two seeds; the same command without --limit runs the rest", flush=True)
    started = time.time()
    try:
        outcome = run_campaign(campaign, out, workers=args.workers, address=args.address, progress=sys.stderr,
                               new_spec=args.new_spec, wait=args.wait, limit=args.limit)
    except KeyboardInterrupt as err:
        from hrc_drake.campaign.engine import quiet_interrupted_shutdown
        from hrc_drake.campaign.store import read_runs
        from hrc_drake.interrupts import exit_code

        quiet_interrupted_shutdown()  # the cluster's processes may still be closing
        try:
            kept = len(read_runs(out))
        except Exception:  # noqa: BLE001 - the message only
            kept = 0
        if kept:
            print(f"interrupted: the finished runs are in {out / 'runs.parquet'} ({kept} row(s)); run the "
                  "same command again to resume", file=sys.stderr)
        else:
            print("interrupted before any run finished: nothing was saved", file=sys.stderr)
        return exit_code(err)
    print(f"{outcome.ran} run(s) now ({outcome.failed} failed), {outcome.skipped} done before, in "
          f"{outcome.wall_time:.1f} s")
    left = outcome.total - outcome.skipped - outcome.ran
    if left > 0:
        print(f"{left} run(s) of {outcome.total} not run yet: run the same command without --limit for "
              "the rest")
    _print_results(out)
    _explain_skipped_tests(out, 2 * configurations)
    _print_files(_written_since(out, started))
    return 0


def _written_since(folder: Path, since: float) -> list[Path]:
    """The files under `folder` changed since `since` (time.time()), sorted; a folder of many
    (replays) is one line with its count. The campaign's lock and journals are not listed."""
    from hrc_drake.campaign.store import JOURNAL_FILE, LOCK_FILE

    out: list[Path] = []
    for path in sorted(folder.iterdir()):
        # the lock (removed at the end, unless a run was killed) and the journal are no results
        if path.name.startswith(".") or path.name in (LOCK_FILE, JOURNAL_FILE):
            continue
        if path.is_dir():
            fresh = [p for p in path.rglob("*") if p.is_file() and p.stat().st_mtime >= since - 1.0]
            if len(fresh) > 5:
                out.append(Path(f"{path}{os.sep} ({len(fresh)} files)"))
            else:
                out.extend(sorted(fresh))
        elif path.stat().st_mtime >= since - 1.0:
            out.append(path)
    return out


def _search(args) -> int:
    from hrc_drake.search.command import run_command

    return run_command(args)


def _campaign_path(name: str) -> str:
    """`name`, or the campaign spec of that name shipped with the package (`_resolved`)."""
    return _resolved(name, "campaign")


def _compare(args) -> int:
    from hrc_drake.campaign.analysis import compare_campaigns
    from hrc_drake.campaign.store import check_output_dir

    dirs = [Path(d) for d in args.dirs]
    for d in dirs:
        if not (d / "campaign.json").is_file() or not (d / "runs.parquet").is_file():
            raise ScenarioError(d, "", "not a campaign folder (no campaign.json and runs.parquet)")
    if args.out is None and len(dirs) > 1:
        raise ScenarioError("", "--out", "comparing several campaigns needs a folder for the result")
    out = Path(args.out) if args.out else dirs[0]
    check_output_dir(out)
    paths = compare_campaigns(dirs, out)
    print(f"{len(paths)} file(s) in {out}")
    _print_results(out)
    return 0


def _print_results(out: Path) -> None:
    """The summary and the tests of a campaign folder, as short tables."""
    import pandas as pd

    for name in ("summary.csv", "tests.csv"):
        path = out / name
        if path.is_file():
            table = pd.read_csv(path)
            if name == "tests.csv":
                table = table[table["test"].isin(("wilcoxon_signed_rank", "rank_sum_pooled"))]
            if table.empty:
                print(f"{path}: no rows (no finished run with values to summarise or test)")
                continue
            with pd.option_context("display.width", 160, "display.max_columns", 20, "display.max_rows", 60):
                print(f"{path}:\n{table.to_string(index=False, float_format=lambda x: f'{x:.4g}')}")


def _explain_skipped_tests(out: Path, runs_for_two: int) -> None:
    """Say why tests.csv skipped tests for want of seeds, and how to get them."""
    import pandas as pd

    from hrc_drake.campaign.analysis import ONE_SAMPLE

    path = out / "tests.csv"
    if not path.is_file():
        return
    notes = pd.read_csv(path)["note"].fillna("").astype(str)
    few = notes.str.contains(ONE_SAMPLE) | notes.str.contains("fewer than 2 seeds")
    if few.any():
        print(f"{int(few.sum())} test row(s) skipped for want of seeds: a test compares two groups of at "
              f"least two seeds each; run more (--limit {runs_for_two} gives every scenario x variant two, "
              "the command without --limit all of them)")


def build_parser() -> argparse.ArgumentParser:
    """The `hrc-drake` argument parser: its commands and their options."""
    parser = argparse.ArgumentParser(
        prog="hrc-drake", description=__doc__,
        epilog="Start with: hrc-drake simulate torch_clock --out out/torch --replay out/torch.html "
               "(a shipped example by name; `hrc-drake COMMAND --help` for a command's options)")
    parser.add_argument("--version", action=_VersionAction, help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sim = sub.add_parser("simulate", help="simulate a scenario and report its metrics")
    sim.add_argument("scenario", help=SCENARIO_HELP)
    sim.add_argument(
        "--duration", type=_duration, default=None, help="simulated seconds (default: the scenario's)"
    )
    sim.add_argument("--seed", type=_seed, default=None, help="override the scenario's seed (>= 0)")
    sim.add_argument("--replay", default=None, help="write a self-contained HTML replay to this file")
    sim.add_argument(
        "--replay-fps", type=_fps, default=10.0, help="frames per second of the replay (default 10)"
    )
    sim.add_argument(
        "--replay-max-frames",
        type=_frames,
        default=REPLAY_MAX_FRAMES,
        help=f"frame budget of the replay: longer runs record fewer frames per second (default "
        f"{REPLAY_MAX_FRAMES}: 10 min at 10 fps; a 2 h replay stays under 50 MB)",
    )
    sim.add_argument("--meshcat", action="store_true", help="serve a live Meshcat view on localhost")
    sim.add_argument(
        "--realtime-rate",
        type=_rate,
        default=None,
        help="pace the run: 1 = wall-clock speed (default with --meshcat), 0 = as fast as possible",
    )
    sim.add_argument("--out", default=None, help="folder for metrics.json, events.csv, gantt.png, safety.png "
                                                 "(and collaboration.png with a predictor)")
    sim.set_defaults(func=_simulate)
    val = sub.add_parser(
        "validate", help="load and check a scenario (names, durations, flow, IK reachability)"
    )
    val.add_argument("scenario", help=SCENARIO_HELP)
    val.set_defaults(func=_validate)
    camp = sub.add_parser(
        "campaign", help="run scenarios x variants x seeds on Dask; write runs.parquet, statistics, plots"
    )
    camp.add_argument("spec", help="campaign YAML file (see diagrams/campaigns/), or the name of a shipped "
                                   "one (e.g. trackers)")
    camp.add_argument("--out", required=True, help="folder for runs.parquet, summary.csv, tests.csv, *.png; "
                                                   "rerun with the same folder to resume")
    _add_cluster_arguments(camp)
    camp.add_argument("--new-spec", action="store_true",
                      help="the folder holds runs of another configuration: move them into a subfolder "
                           "(previous-<time>/) and start a new table, instead of refusing")
    camp.add_argument("--wait", nargs="?", type=_wait, const=math.inf, default=0.0, metavar="SECONDS",
                      help="another campaign is writing the folder: wait for it (at most SECONDS) instead "
                           "of refusing")
    camp.add_argument("--limit", type=_limit, default=None, metavar="N",
                      help="run at most N of the runs not yet done (try a spec on a few), two seeds of "
                           "each scenario x variant at a time so that tests can run; the same command "
                           "without --limit resumes the rest")
    camp.set_defaults(func=_campaign)
    imp = sub.add_parser("import", help="turn a real recording into a skeleton CSV placed in a cell "
                                        "(operator.recorded)")
    imp.add_argument("format", choices=("lego", "kth", "ue", "table"),
                     help="lego: a LEGO assembly trial (.txt); kth: the KTH hand-over folder; ue: a trial of "
                          "the UE reaching set (Vicon CSV; its folder's *_static.csv gives the joint "
                          "centres); table: any joint-position table with --columns")
    imp.add_argument("source", help="the recording's file (lego, ue, table) or folder (kth)")
    imp.add_argument("--out", required=True,
                     help="the skeleton CSV to write (a .json of provenance beside it)")
    imp.add_argument("--rate", type=_recording_rate, default=None,
                     help="the recording's frame rate (Hz): required for lego (its source does not state "
                          "it) and table; kth records 120 Hz")
    imp.add_argument("--person", choices=("giver", "taker"), default="giver", help="kth: whose body")
    imp.add_argument("--columns", default=None,
                     help="table: YAML file mapping skeleton points to their x, y, z columns (0-based)")
    imp.add_argument("--units", choices=("m", "cm", "mm"), default="m", help="table: coordinate units")
    imp.add_argument("--delimiter", default=None, help="table: column separator (default: whitespace)")
    imp.add_argument("--header-rows", type=int, default=0, help="table: rows to skip at the top")
    imp.add_argument("--up", default="0,0,1", help="table: the recording frame's up direction x,y,z")
    imp.add_argument("--camera-rate", type=_fps, default=30.0,
                     help="the rate to resample to (Hz, default 30)")
    imp.add_argument("--operator-x", type=_number, default=1.0,
                     help="where the operator stands (m, default 1.0)")
    imp.add_argument("--operator-y", type=_number, default=0.0, help="(m, default 0.0)")
    imp.add_argument("--facing", type=_number, default=3.141592653589793,
                     help="the operator's facing yaw (rad; default pi: toward a robot at the origin)")
    imp.add_argument("--table-height", type=_number, default=0.75, help="the table top (m, default 0.75)")
    imp.add_argument("--cell", default=None,
                     help="a cell scenario to drive with the recording (a file, or a shipped example's name, "
                          "e.g. box_pcb_coexistence): writes OUT with .yaml, a scenario that extends it with "
                          "the recording as its operator, checked before any file is written")
    imp.add_argument("--replay", default=None,
                     help="with --cell: simulate that scenario for the recording's length and write its "
                          "self-contained HTML replay to this file")
    imp.set_defaults(func=_import)
    srch = sub.add_parser("search", help="search a scenario's parameters with Optuna (falsify its safety, "
                                         "optimise its cycle time); see docs/search.md")
    srch.add_argument("spec", help="search YAML file (see diagrams/searches/), or the name of a shipped one")
    srch.add_argument("--out", required=True, help="folder for results.parquet, runs.parquet, plots, "
                                                   "report.json; rerun with the same folder to resume")
    _add_cluster_arguments(srch)
    srch.set_defaults(func=_search)
    comp = sub.add_parser("compare", help="redraw and compare finished campaigns (their runs.parquet)")
    comp.add_argument("dirs", nargs="+", help="campaign output folders")
    comp.add_argument("--out", default=None, help="folder for the comparison (default: the one campaign's)")
    comp.set_defaults(func=_compare)
    return parser


def _add_cluster_arguments(parser) -> None:
    """--workers and --address, the same for every command that runs on Dask."""
    parser.add_argument("--workers", type=_workers, default=2,
                        help="worker processes of the embedded Dask cluster (default 2; 0: in this process)")
    parser.add_argument("--address", default=None,
                        help="an existing Dask scheduler (tcp://HOST:PORT) instead of the embedded cluster")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:  # bare `hrc-drake`: the help, as a usage error (exit 2)
        parser.print_help()
        return EXIT_BAD_INPUT
    from hrc_drake.interrupts import exit_code, sigterm_raises

    # a batch system's or `kill`'s SIGTERM saves what Ctrl-C saves
    with sigterm_raises():
        try:
            return args.func(args)
        except ScenarioError as err:
            print(f"error: {err}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except EnvironmentFailure as err:
            print(f"error: {err}", file=sys.stderr)
            return EXIT_ENVIRONMENT
        except KeyboardInterrupt as err:
            print("interrupted", file=sys.stderr)
            return exit_code(err)
        except Exception as err:  # noqa: BLE001 - one line for the user, the traceback in a log
            return _internal_error(err)


def _internal_error(err: Exception) -> int:
    """Write the traceback to a log file; print one line naming it."""
    import tempfile
    import traceback

    with tempfile.NamedTemporaryFile("w", prefix="hrc-drake-error-", suffix=".log", delete=False) as log:
        log.write(traceback.format_exc())
    print(f"internal error: {type(err).__name__}: {err} (traceback in {log.name})", file=sys.stderr)
    return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
