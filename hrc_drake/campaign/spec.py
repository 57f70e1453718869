"""Campaign files: which scenarios, variants (overrides of a scenario's fields), seeds and
simulated duration a campaign runs, which metrics it compares and which variant should win.

Read like scenarios: a raw walk names unknown keys, pydrake's typed loader reads the typed part,
and every problem is a `ScenarioError(file, field path, reason)`. `load_campaign` also loads
every scenario x variant with its overrides (`load_scenario_with`), so a bad override is found
before any run starts, named by the campaign file, the variant and the field.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations as
real types at run time.
"""

import dataclasses
import fnmatch
import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from hrc_drake.campaign.extras import resolve_extra_metrics
from hrc_drake.cell.build import kernel_groups
from hrc_drake.cell.scenario import (
    MAX_SCENARIO_BYTES,
    Tagged,
    _check_keys,
    _raw_document,
    dump_raw,
    load_scenario,
    load_scenario_with,
    load_typed,
    located,
)
from hrc_drake.cell.schema import Scenario
from hrc_drake.config_common import MAX_SIMULATED_DURATION
from hrc_drake.errors import ScenarioError, check_input_file, yaml_syntax_error

#: the most runs one campaign may hold (scenarios x variants x seeds): 100,000 runs of a fast
#: 120 s cell are ~3 CPU-days; a larger study is several campaigns (each folder's table and
#: resume stay quick: the table is rewritten whole, ~12 s at this size)
MAX_RUNS = 100_000
#: a variant's or a scenario's label: it names files and table cells
LABEL = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]*$")
#: the metrics a campaign compares unless its file says which (`*` matches any agent or product)
DEFAULT_METRICS = ("products_per_hour", "products.*.cycle_time_median", "agents.*.idle_time",
                   "min_human_robot_distance", "safety.time_below_s")
#: metrics.json's names before issue 54 -> their names now (a spec naming an old one is told)
RENAMED_METRICS = {
    "mean_cycle_time": "mean_time_between_products (the mean interval between products of any type; "
                       "a product's own cycle time is products.<type>.cycle_time_median)",
    "cycle_times": "times_between_products",
}


def renamed_hint(metric: str) -> str:
    """"; ... was renamed ..." for a metric name metrics.json used before issue 54, else ""."""
    last = metric.rsplit(".", 1)[-1]
    if metric in RENAMED_METRICS:
        return f"; '{metric}' was renamed {RENAMED_METRICS[metric]}"
    if metric.startswith("products.") and last == "mean_cycle_time":
        return f"; '{metric}' was renamed {metric[:-len(last)]}mean_time_between (its own cycle time: " \
               f"{metric[:-len(last)]}cycle_time_median)"
    return ""


#: metrics where a larger value is the better one (the rest: smaller is better, e.g. times)
LARGER_IS_BETTER = (
    "min_human_robot_distance",
    "products_finished",
    "products_per_hour",
    "products.*.per_hour",
    "mean_speed_override",
    "agents.*.utilisation",
    "agents.*.busy_time",
    "agents.*.actions_finished",
    "products.*.finished",
)


@dataclass
class SeedRange:
    """`count` consecutive seeds from `first`."""

    count: int = 0
    first: int = 0


@dataclass
class Expectation:
    """A one-sided claim: variant `better` beats variant `than` on `metrics` (in every scenario)."""

    better: str = ""
    than: str = ""
    #: metric names (patterns with `*`); empty: every metric of the campaign
    metrics: list[str] = field(default_factory=list)


@dataclass
class PooledSamples:
    """Per-run samples pooled over a group's runs and tested as one sample (the thesis's tests on
    per-product waits, 7.5.3): `metric` a list-valued extra column (`per_product.operator_wait`),
    the first `first` values of each run (0: all of them)."""

    metric: str = ""
    first: int = 0

    @property
    def label(self) -> str:
        """The name of the pooled metric in summary.csv and tests.csv (`metric[:first]`)."""
        return f"{self.metric}[:{self.first or ''}]"


@dataclass
class ReplayRequest:
    """One run whose meshcat replay is written to DIR/replays/ (a run is recorded only when asked)."""

    variant: str = ""
    seed: int = 0
    #: the scenario's label (its file name without .yaml); may be left out with one scenario
    scenario: str = ""


@dataclass
class CampaignFile:
    """The typed fields of a campaign file (`variants` and `seeds` are read by hand: overrides are
    raw scenario fragments, and seeds are a list or a `SeedRange`)."""

    name: str = ""
    description: str = ""
    #: simulated time of every run (s)
    duration: float = 0.0
    #: scenario files, relative to the campaign file
    scenarios: list[str] = field(default_factory=list)
    #: compared metrics: flattened names of metrics.json (`agents.human.idle_time`), `*` allowed
    metrics: list[str] = field(default_factory=list)
    expect: list[Expectation] = field(default_factory=list)
    replays: list[ReplayRequest] = field(default_factory=list)
    #: frames per second of the replays
    replay_fps: float = 10.0
    #: extra columns per run (`campaign.extras`): registered names or `module:function` paths
    extra_metrics: list[str] = field(default_factory=list)
    #: list-valued extra columns pooled over each group's runs and tested as one sample
    pooled: list[PooledSamples] = field(default_factory=list)


HAND_READ = ("variants", "seeds")
KNOWN_KEYS = tuple(f.name for f in dataclasses.fields(CampaignFile)) + HAND_READ


@dataclass(frozen=True)
class RunTask:
    """One run of a campaign, sent to a worker: everything it needs, in plain values."""

    scenario: str
    scenario_path: str
    variant: str
    #: the variant's overrides (a raw document, `merge_raw`); empty for the scenario as it is
    overrides: dict
    seed: int
    duration: float
    #: hash of the scenario text, the overrides and the duration: a finished row counts on
    #: resume only if its run had the same configuration
    config_hash: str
    replay: bool = False
    replay_fps: float = 10.0
    #: extra-metrics functions whose columns the row gets (`campaign.extras`)
    extra_metrics: tuple[str, ...] = ()

    @property
    def key(self) -> tuple:
        return (self.scenario, self.variant, self.seed, self.duration)


@dataclass
class Campaign:
    """A loaded and checked campaign file."""

    file: Path
    name: str
    description: str
    duration: float
    seeds: list[int]
    #: scenario label -> its file
    scenarios: dict[str, Path]
    #: variant name -> overrides (raw document); {"base": {}} when the file names none
    variants: dict[str, dict]
    #: compared metric names as given (patterns)
    metrics: list[str]
    expect: list[Expectation]
    #: (scenario, variant, seed) of the runs to record as replays
    replays: set[tuple[str, str, int]]
    replay_fps: float = 10.0
    #: scenario label -> the metric names its runs report
    metric_names: dict[str, list[str]] = field(default_factory=dict)
    #: extra-metrics functions run after every run (`campaign.extras`)
    extra_metrics: list[str] = field(default_factory=list)
    #: list-valued extra columns pooled over each group's runs (`PooledSamples`)
    pooled: list[PooledSamples] = field(default_factory=list)
    #: the kernel groups its cells run (`cell.build.kernel_groups`), compiled ahead of local runs
    kernel_groups: list[str] = field(default_factory=list)

    @property
    def run_count(self) -> int:
        return len(self.seeds) * len(self.scenarios) * len(self.variants)

    def config_hashes(self) -> dict[tuple[str, str], str]:
        """(scenario, variant) -> the hash of its configuration (`RunTask.config_hash`)."""
        return {
            (s, v): _config_hash(self.scenarios[s], self.variants[v], self.duration, self.extra_metrics)
            for s in self.scenarios
            for v in self.variants
        }

    def iter_tasks(self):
        """Every run, seed by seed (an interrupted campaign holds whole seeds of every variant),
        made as they are asked for."""
        hashes = self.config_hashes()
        for seed in self.seeds:
            for s in self.scenarios:
                for v in self.variants:
                    yield self._task(s, v, seed, hashes)

    def iter_tasks_in_pairs(self):
        """Every run, two seeds at a time: for each pair of seeds, each scenario x variant runs
        both before the next starts. `--limit` takes runs in this order, so the runs it makes
        give each scenario x variant they reach the two seeds a test needs (with a limit of
        2 x scenarios x variants, the same runs as `iter_tasks`'s first two seeds)."""
        hashes = self.config_hashes()
        for k in range(0, len(self.seeds), 2):
            for s in self.scenarios:
                for v in self.variants:
                    for seed in self.seeds[k:k + 2]:
                        yield self._task(s, v, seed, hashes)

    def _task(self, s: str, v: str, seed: int, hashes: dict) -> RunTask:
        return RunTask(
            scenario=s,
            scenario_path=str(self.scenarios[s]),
            variant=v,
            overrides=self.variants[v],
            seed=seed,
            duration=self.duration,
            config_hash=hashes[s, v],
            replay=(s, v, seed) in self.replays,
            replay_fps=self.replay_fps,
            extra_metrics=tuple(self.extra_metrics),
        )

    def tasks(self) -> list[RunTask]:
        """Every run, as `iter_tasks` makes them."""
        return list(self.iter_tasks())

    def describe(self) -> dict:
        """The campaign as plain values, for DIR/campaign.json and `hrc-drake compare`."""
        return {
            "name": self.name,
            "description": self.description,
            "file": str(self.file),
            "duration": self.duration,
            "seeds": _compact_seeds(self.seeds),
            "scenarios": {k: str(v) for k, v in self.scenarios.items()},
            "variants": {k: dump_raw(v) for k, v in self.variants.items()},
            "metrics": self.metrics,
            "expect": [dataclasses.asdict(e) for e in self.expect],
            "extra_metrics": self.extra_metrics,
            "pooled": [dataclasses.asdict(x) for x in self.pooled],
        }


def _compact_seeds(seeds: list[int]):
    """The seeds as {first, count} when they are consecutive (campaign.json stays small)."""
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return {"first": seeds[0], "count": len(seeds)}
    return list(seeds)


def _config_hash(scenario_path: Path, overrides: dict, duration: float, extra_metrics=()) -> str:
    text = Path(scenario_path).read_bytes() + dump_raw(overrides).encode() + repr(float(duration)).encode()
    if extra_metrics:  # a row without the extra columns asked for is not done
        text += repr(list(extra_metrics)).encode()
    return hashlib.sha256(text).hexdigest()[:16]


def load_spec(path: str | Path, kind: str, make):
    """`make(document, path)` on the spec file `path` (a campaign or a search), its errors placed at
    the line and column where the file writes the field."""
    path = Path(path)
    check_input_file(path, kind)
    marks: dict = {}
    try:
        return make(_read_raw(path, marks), path)
    except ScenarioError as err:
        located(err, path, marks)
        raise


def load_campaign(path: str | Path) -> Campaign:
    """Read and check a campaign file, and load every scenario x variant; `ScenarioError` on any problem."""
    return load_spec(path, "campaign", make_campaign)


def make_campaign(document: dict, file: str | Path) -> Campaign:
    """A campaign from its document (the fields of a campaign file as plain values; overrides may
    hold `Tagged` nodes for `!Tag` fields), checked as `load_campaign` checks a file. `file` names
    the campaign in errors and relative scenario paths resolve from its folder (it need not exist)."""
    path = Path(file)
    if not isinstance(document, dict) or isinstance(document, Tagged):
        raise ScenarioError(path, "", "the top level must be a mapping of campaign fields")
    raw = document
    for key in raw:
        if key not in KNOWN_KEYS:
            raise ScenarioError(
                path, str(key), f"unknown key '{key}' (known keys: {', '.join(sorted(KNOWN_KEYS))})"
            )
    typed_part = {k: v for k, v in raw.items() if k not in HAND_READ}
    if isinstance(typed_part.get("expect"), dict):
        typed_part["expect"] = [typed_part["expect"]]  # one claim may be written without a list
    _check_keys(typed_part, CampaignFile, "", str(path))
    try:
        spec = load_typed(CampaignFile, dump_raw(typed_part))
    except (RuntimeError, ValueError, TypeError) as err:
        raise ScenarioError(path, "", f"cannot be read as a campaign: {err}") from err
    if not spec.name or not LABEL.match(spec.name):
        raise ScenarioError(
            path, "name", f"needs a name of letters, digits, '_', '-', '.', got {spec.name!r}"
        )
    if not (math.isfinite(spec.duration) and 0 < spec.duration <= MAX_SIMULATED_DURATION):
        raise ScenarioError(
            path,
            "duration",
            f"must be a number of simulated seconds in (0, "
            f"{MAX_SIMULATED_DURATION:g}], got {spec.duration!r}",
        )
    if not 0 < spec.replay_fps <= 120:
        raise ScenarioError(path, "replay_fps", f"must be in (0, 120], got {spec.replay_fps!r}")
    seeds = _seeds(path, raw.get("seeds"))
    scenarios = _scenarios(path, spec.scenarios)
    variants = _variants(path, raw.get("variants"))
    if len(seeds) * len(scenarios) * len(variants) > MAX_RUNS:
        raise ScenarioError(
            path, "seeds", f"{len(seeds) * len(scenarios) * len(variants)} runs: at most {MAX_RUNS} "
            "per campaign (split the seeds over several campaigns)"
        )
    metric_names = {}
    groups: dict[str, None] = {}
    for label, scenario_path in scenarios.items():
        load_scenario(scenario_path)  # the scenario's own problems are named by its own file
        for name, overrides in variants.items():
            try:
                scenario = load_scenario_with(scenario_path, overrides, check_file_alone=False)
            except ScenarioError as err:
                where = f"variants.{name}" + (f".{err.field}" if err.field else "")
                raise ScenarioError(path, where, f"{err.reason} (applied to {scenario_path})") from None
            metric_names[label] = sorted(
                set(metric_names.get(label, [])) | set(scenario_metric_names(scenario))
            )
            groups.update(dict.fromkeys(kernel_groups(scenario)))
    for k, name in enumerate(spec.extra_metrics):
        try:
            resolve_extra_metrics(name)
        except KeyError as err:
            raise ScenarioError(path, f"extra_metrics[{k}]", err.args[0]) from None
    known = sorted({m for names in metric_names.values() for m in names})
    # the defaults a cell has (one that makes no product has no product's cycle time)
    metrics = list(spec.metrics) or [m for m in DEFAULT_METRICS if fnmatch.filter(known, m)]
    for k, pattern in enumerate(metrics):
        if not fnmatch.filter(known, pattern):
            raise ScenarioError(
                path, f"metrics[{k}]",
                f"unknown metric '{pattern}'{renamed_hint(pattern)} (known: {', '.join(known)})"
            )
    for k, sample in enumerate(spec.pooled):
        extra = sample.metric.split(".", 1)[0]
        if extra not in spec.extra_metrics or "." not in sample.metric:
            raise ScenarioError(
                path, f"pooled[{k}].metric",
                f"'{sample.metric}' is not a column of the campaign's extra_metrics {spec.extra_metrics} "
                f"(e.g. per_product.operator_wait with extra_metrics: [per_product])")
        if isinstance(sample.first, bool) or not isinstance(sample.first, int) or sample.first < 0:
            raise ScenarioError(path, f"pooled[{k}].first", f"must be an integer >= 0, got {sample.first!r}")
    pooled_names = [x.metric for x in spec.pooled]
    for k, claim in enumerate(spec.expect):
        for key in ("better", "than"):
            if getattr(claim, key) not in variants:
                raise ScenarioError(
                    path,
                    f"expect[{k}].{key}",
                    f"unknown variant '{getattr(claim, key)}' ({', '.join(variants)})",
                )
        if claim.better == claim.than:
            raise ScenarioError(path, f"expect[{k}]", f"a variant cannot beat itself ('{claim.better}')")
        for j, pattern in enumerate(claim.metrics):
            if not any(fnmatch.fnmatch(m, pattern) for m in expand_metrics(metrics, known) + pooled_names):
                raise ScenarioError(
                    path,
                    f"expect[{k}].metrics[{j}]",
                    f"'{pattern}' is not one of the campaign's metrics {metrics}",
                )
    replays = set()
    for k, request in enumerate(spec.replays):
        label = request.scenario or (next(iter(scenarios)) if len(scenarios) == 1 else "")
        if label not in scenarios:
            raise ScenarioError(
                path,
                f"replays[{k}].scenario",
                f"unknown scenario '{request.scenario}' ({', '.join(scenarios)})",
            )
        if request.variant not in variants:
            raise ScenarioError(
                path, f"replays[{k}].variant", f"unknown variant '{request.variant}' ({', '.join(variants)})"
            )
        if request.seed not in seeds:
            raise ScenarioError(
                path, f"replays[{k}].seed", f"seed {request.seed} is not one of the campaign's"
            )
        replays.add((label, request.variant, request.seed))
    return Campaign(
        file=path,
        name=spec.name,
        description=spec.description,
        duration=float(spec.duration),
        seeds=seeds,
        scenarios=scenarios,
        variants=variants,
        metrics=metrics,
        expect=list(spec.expect),
        replays=replays,
        replay_fps=spec.replay_fps,
        metric_names=metric_names,
        kernel_groups=list(groups),
        extra_metrics=list(spec.extra_metrics),
        pooled=list(spec.pooled),
    )


def _read_raw(path: Path, marks: dict | None = None) -> dict:
    """A spec file's raw document (`_raw_document`), `marks` filled with its fields' places."""
    if not path.is_file():
        raise ScenarioError(path, "", "no such file")
    if path.stat().st_size > MAX_SCENARIO_BYTES:
        raise ScenarioError(path, "", "too large for a campaign file")
    try:
        raw = _raw_document(path.read_bytes().decode("utf-8"), path, marks)  # refuses alias bombs
    except UnicodeDecodeError as err:
        raise ScenarioError(path, "", f"not UTF-8 text (byte {err.start})") from None
    except yaml.YAMLError as err:
        raise yaml_syntax_error(path, err) from None
    if not isinstance(raw, dict) or isinstance(raw, Tagged):
        raise ScenarioError(path, "", "the top level must be a mapping of campaign fields")
    return raw


def _seeds(path: Path, node) -> list[int]:
    """A list of distinct seeds, or {count, first}."""

    def seed_ok(value) -> bool:
        return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 2**32

    if isinstance(node, dict) and not isinstance(node, Tagged):
        _check_keys(node, SeedRange, "seeds", str(path))
        count, first = node.get("count", 0), node.get("first", 0)
        if not 1 <= count <= MAX_RUNS:
            raise ScenarioError(path, "seeds.count", f"must be an integer in [1, {MAX_RUNS}], got {count!r}")
        if not (seed_ok(first) and first + count <= 2**32):
            raise ScenarioError(path, "seeds.first", f"seeds must lie in [0, 2^32), got first {first!r}")
        return list(range(first, first + count))
    if not isinstance(node, list):
        raise ScenarioError(path, "seeds", "needs a list of seeds or {count: N, first: S}")
    if not node:
        raise ScenarioError(path, "seeds", "the list of seeds is empty")
    seen = set()
    for k, value in enumerate(node):
        if not seed_ok(value):
            raise ScenarioError(path, f"seeds[{k}]", f"must be an integer in [0, 2^32), got {value!r}")
        if value in seen:
            raise ScenarioError(path, f"seeds[{k}]", f"seed {value} is listed twice")
        seen.add(value)
    return list(node)


def spec_scenario_file(spec_path: Path, name, field: str) -> Path:
    """The scenario a campaign or search spec names: a file relative to the spec, else a shipped
    scenario's bare name (`ScenarioError` naming the spec's field)."""
    from hrc_drake.cell.shipped import example_names, example_path, is_bare_name
    from hrc_drake.untrusted import one_line

    if not isinstance(name, str) or not name:
        raise ScenarioError(spec_path, field, f"must name a scenario file, got {name!r}")
    file = (spec_path.parent / name).resolve()
    if file.is_file():
        return file
    shipped = example_path(name) if is_bare_name(name) else None
    if shipped is not None:
        return shipped
    raise ScenarioError(spec_path, field, f"no such scenario file: {one_line(str(file))} (or the bare name "
                        f"of a shipped scenario: {', '.join(example_names())})")


def _scenarios(path: Path, names: list[str]) -> dict[str, Path]:
    if not names:
        raise ScenarioError(path, "scenarios", "names no scenario file")
    out: dict[str, Path] = {}
    for k, name in enumerate(names):
        file = spec_scenario_file(path, name, f"scenarios[{k}]")
        label = file.stem
        if label in out:
            raise ScenarioError(path, f"scenarios[{k}]", f"two scenarios are called '{label}'")
        out[label] = file
    return out


def _variants(path: Path, node) -> dict[str, dict]:
    if node is None:
        return {"base": {}}
    if not isinstance(node, dict) or isinstance(node, Tagged) or not node:
        raise ScenarioError(
            path, "variants", "needs a mapping of variant name -> scenario fields to override"
        )
    out = {}
    for name, overrides in node.items():
        if not isinstance(name, str) or not LABEL.match(name):
            raise ScenarioError(
                path, f"variants.{name}", "a variant's name is letters, digits, '_', '-', '.'"
            )
        if overrides is None:
            overrides = {}
        if not isinstance(overrides, dict) or isinstance(overrides, Tagged):
            raise ScenarioError(
                path, f"variants.{name}", f"needs a mapping of scenario fields, got {overrides!r}"
            )
        for key in ("seed", "duration", "extends"):
            if key in overrides:
                raise ScenarioError(
                    path, f"variants.{name}.{key}", f"'{key}' is set by the campaign, not a variant"
                )
        unknown = [k for k in overrides if k not in {f.name for f in dataclasses.fields(Scenario)}]
        if unknown:
            raise ScenarioError(
                path, f"variants.{name}.{unknown[0]}", f"unknown scenario field '{unknown[0]}'"
            )
        out[name] = overrides
    return out


def scenario_metric_names(scenario: Scenario) -> list[str]:
    """The flattened scalar metrics (`worker.flatten_metrics`) a run of `scenario` reports;
    `detection.*` only where it has an action detector."""
    agents = [scenario.operator.name] + [arm.agent for robot in scenario.robots for arm in robot.arms]
    made = {b for action in scenario.flow.actions for b in action.outputs}
    products = [b.name for b in scenario.layout.buffers if b.kind == "product" and b.name in made]
    names = [
        "simulated_time",
        "products_per_hour",
        "products_finished",
        "mean_time_between_products",
        "min_human_robot_distance",
        "mean_speed_override",
        "time_slowed_s",
        "wall_time",
        "realtime_factor",
        "warmup.products",
        "warmup.time",
        "safety.safety_distance",
        "safety.time_below_s",
        "safety.fraction_below",
        "safety.time_below_not_stopped_s",
        "safety.below",
        "safety.mode",
        "safety.standard",
        "safety.verdict_code",
        "safety.verdict",
        "safety.protective_stops",
        "safety.judge.conforming",
        "safety.judge.reaction_time_s",
        "safety.judge.deceleration_m_s2",
    ]
    from hrc_drake.safety.judge import VIOLATION_KINDS
    from hrc_drake.safety.limits import BODY_REGIONS
    from hrc_drake.safety.systems import controller_departures

    # the standard judge's figures (`safety.verdict.judged_figures`), and the same of the changed
    # judge or the controller's own model (`own_model`, null in a conforming run) beside them
    judged = [
        "violations_total",
        "ssm_breach_s",
        "violation_margin_m",
        "margin_m",
        "contact_margin",
        "contact_violation_s",
        "contact_count",
        "stops_measured",
        "stop_ratio_worst",
        "unobserved_s",
        "unobserved_longest_s",
        "reach_growth_m",
        "closest_approach_m",
    ]
    judged += [f"violations.{kind}" for kind in VIOLATION_KINDS]
    judged += [f"worst_ratio.{region}" for region in BODY_REGIONS]
    names += [f"safety.{name}" for name in judged]
    from hrc_drake.cell.scenario import judge_values

    changed_judge = judge_values(scenario, scenario.source_path or "<scenario>")[1] is not None
    if changed_judge or controller_departures(scenario.safety):
        names += [f"safety.own_model.{name}" for name in judged]
    else:
        names.append("safety.own_model")
    names += [
        f"agents.{a}.{k}"
        for a in agents
        for k in ("busy_time", "wait_time", "idle_time", "utilisation", "actions_finished")
    ]
    names += [f"products.{p}.{k}" for p in products
              for k in ("finished", "per_hour", "cycle_time_median", "cycle_time_p90", "mean_time_between")]
    if type(scenario.action_detector).__name__ != "NoActionDetector":
        names += ["detection.*"]
    return names


def expand_metrics(patterns: list[str], columns) -> list[str]:
    """The columns matched by `patterns`, in the patterns' order, each once."""
    out: list[str] = []
    for pattern in patterns:
        out += [c for c in sorted(columns) if fnmatch.fnmatch(c, pattern) and c not in out]
    return out


def larger_is_better(metric: str) -> bool:
    return any(fnmatch.fnmatch(metric, p) for p in LARGER_IS_BETTER)
