"""Search files: a base scenario, the parameters to search (paths into it), an objective and
constraints on the metrics of metrics.json, seeds per candidate, a budget of runs, an optimiser.

Read as campaign files are: the raw document (safe YAML, `!Tag` kept) is walked against these
dataclasses (unknown keys, wrong shapes named by field path), the typed parts go through
pydrake's typed loader, and every problem is a `ScenarioError(file, field path, reason)`. Each
parameter is applied to the scenario at both ends of its range (each choice, the listed order) and
the scenario loaded and checked, so a bad path or range is found before any run, named by
`parameters[k]`.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations.
"""

import dataclasses
import math
import re
import typing
from dataclasses import dataclass, field
from pathlib import Path

from hrc_drake.campaign.spec import (
    LABEL,
    MAX_RUNS,
    _seeds,
    load_spec,
    renamed_hint,
    scenario_metric_names,
    spec_scenario_file,
)
from hrc_drake.cell.build import kernel_groups
from hrc_drake.cell.scenario import (
    Tagged,
    _check_keys,
    _raw_document,
    dump_raw,
    load_scenario,
    load_typed,
)
from hrc_drake.config_common import MAX_SIMULATED_DURATION
from hrc_drake.errors import ScenarioError
from hrc_drake.search import params as P

PRESETS = ("", "falsify", "optimise")
DIRECTIONS = ("minimize", "maximize")
OVER_SEEDS = ("mean", "worst", "median")
CONSTRAINT = re.compile(r"^\s*([A-Za-z0-9_.*-]+)\s*(<=|>=|==)\s*([-+0-9.eE]+|inf|-inf)\s*$")
#: metrics.json figures that are not numbers (cannot be an objective or a constraint); `own_model`
#: is null in a conforming run (its figures are `safety.own_model.*` where it has one)
TEXT_METRICS = ("safety.mode", "safety.standard", "safety.verdict_code", "safety.verdict", "safety.below",
                "safety.own_model")


@dataclass
class Float:
    """A real value in [low, high] at `path` (log: searched on a log scale; step: a grid)."""

    path: str = ""
    low: float = math.nan
    high: float = math.nan
    log: bool = False
    step: float = 0.0
    #: the column's name in results.parquet (default: the path)
    name: str = ""


@dataclass
class Int:
    """An integer in [low, high] at `path`."""

    path: str = ""
    low: int = 0
    high: int = -1
    log: bool = False
    step: int = 1
    name: str = ""


@dataclass
class Choice:
    """One of `choices` (any YAML values, `!Tag` systems too) at `path`; read by hand."""

    path: str = ""
    name: str = ""


@dataclass
class Permutation:
    """An order of the list at `path` (action names) that keeps `precedence`: `flow` (an action
    after the flow actions that feed it, directly or not), `none`, plus any `before` pairs."""

    path: str = ""
    precedence: str = "flow"
    before: list[list[str]] = field(default_factory=list)
    name: str = ""


Parameter = typing.Union[Float, Int, Choice, Permutation]  # noqa: UP007 - the loader reads a typing.Union


@dataclass
class TPE:
    """Optuna's TPESampler (constraints through its `constraints_func`)."""

    seed: int = 0
    n_startup_trials: int = 8
    multivariate: bool = True


@dataclass
class CmaEs:
    """Optuna's CmaEsSampler (constraints as a penalty on the value it is told); sigma0 0: its default."""

    seed: int = 0
    sigma0: float = 0.0
    popsize: int = 0


@dataclass
class Random:
    """Optuna's RandomSampler."""

    seed: int = 0


Optimizer = typing.Union[TPE, CmaEs, Random]  # noqa: UP007


@dataclass
class Objective:
    """A metric of metrics.json (a dotted name, `safety.margin_m`), to minimise or maximise, over a
    candidate's seeds by their mean, median or worst value."""

    metric: str = ""
    direction: str = "minimize"
    over_seeds: str = "mean"


@dataclass
class SearchFile:
    """The typed fields of a search file (`parameters`, `seeds`, `objective`, `optimizer` are read
    with their own checks)."""

    name: str = ""
    description: str = ""
    #: the base scenario, relative to the search file
    scenario: str = ""
    #: simulated time of every run (s)
    duration: float = 0.0
    #: runs in all (candidates x seeds per candidate), for the optimiser and for random search each
    budget: int = 0
    #: candidates asked at a time (evaluated in parallel, then told): fixed, so the search does not
    #: depend on the number of workers
    batch: int = 4
    #: `falsify` or `optimise` (fills the objective, constraints and outputs; see docs/search.md)
    preset: str = ""
    #: each a `metric <=|>=|== value`, over every seed of a candidate
    constraints: list[str] = field(default_factory=list)
    #: run random search at the same budget beside the optimiser (falsify: always)
    compare_random: bool = False
    #: candidates listed as the worst (falsify) or best (optimise)
    report: int = 5
    #: CMA-ES only: the told value is the objective plus this times the constraints' violation
    penalty: float = 1000.0
    #: optimise: seeds of the fresh runs comparing the best scenario with the shipped one
    fresh_seeds: int = 4
    #: frames per second of the replay of the worst (falsify) or best candidate
    replay_fps: float = 10.0


HAND_READ = ("parameters", "seeds", "objective", "optimizer")
KNOWN_KEYS = tuple(f.name for f in dataclasses.fields(SearchFile)) + HAND_READ


@dataclass(frozen=True)
class Constraint:
    metric: str
    op: str
    value: float

    def violation(self, x: float) -> float:
        """Optuna's constraint value: <= 0 when `x` satisfies it (its distance otherwise); a
        missing value (NaN) violates it by inf."""
        if x is None or not math.isfinite(float(x)) and not (math.isinf(float(x)) and math.isinf(self.value)):
            return math.inf
        x = float(x)
        if self.op == "<=":
            return x - self.value
        if self.op == ">=":
            return self.value - x
        return abs(x - self.value)

    def __str__(self) -> str:
        return f"{self.metric} {self.op} {self.value:g}"


@dataclass
class SearchParameter:
    """A checked parameter: its column name, steps into the document, kind and range."""

    name: str
    path: str
    steps: tuple
    kind: str  # float, int, choice, permutation
    low: float = 0.0
    high: float = 0.0
    log: bool = False
    step: float = 0.0
    choices: list = field(default_factory=list)
    #: permutation: the listed elements and the precedence pairs
    elements: list = field(default_factory=list)
    precedence: frozenset = frozenset()

    def optuna_names(self) -> list[str]:
        if self.kind == "permutation":
            return [f"{self.name}.key.{e}" for e in self.elements]
        return [self.name]


@dataclass
class Search:
    """A loaded and checked search file."""

    file: Path
    name: str
    description: str
    scenario: Path
    duration: float
    seeds: list[int]
    budget: int
    batch: int
    preset: str
    parameters: list[SearchParameter]
    objective: Objective
    constraints: list[Constraint]
    optimizer: object
    compare_random: bool
    report: int
    penalty: float
    fresh_seeds: int
    replay_fps: float
    #: the base scenario's raw document
    document: dict = field(default_factory=dict)
    metric_names: list[str] = field(default_factory=list)
    #: the kernel groups the base scenario's cell runs (`cell.build.kernel_groups`), compiled
    #: ahead of local runs
    kernel_groups: list[str] = field(default_factory=list)

    @property
    def candidates(self) -> int:
        """Candidates per search: the budget in whole candidates."""
        return self.budget // len(self.seeds)

    def describe(self) -> dict:
        return {
            "name": self.name,
            "file": str(self.file),
            "scenario": str(self.scenario),
            "duration": self.duration,
            "seeds": self.seeds,
            "budget": self.budget,
            "batch": self.batch,
            "preset": self.preset,
            "parameters": [
                {
                    "name": p.name,
                    "path": p.path,
                    "kind": p.kind,
                    "low": p.low,
                    "high": p.high,
                    "log": p.log,
                    "choices": [dump_raw(c).strip() for c in p.choices],
                    "elements": p.elements,
                    "precedence": sorted(p.precedence),
                }
                for p in self.parameters
            ],
            "objective": dataclasses.asdict(self.objective),
            "constraints": [str(c) for c in self.constraints],
            "optimizer": {"kind": type(self.optimizer).__name__, **dataclasses.asdict(self.optimizer)},
            "compare_random": self.compare_random,
            "random_seed": random_search_seed(self.optimizer.seed) if self.compare_random else None,
        }


def random_search_seed(seed: int) -> int:
    """The seed of the random search run beside an optimiser seeded `seed`: drawn from
    `numpy.random.SeedSequence([seed, 1])`, so it differs from the optimiser's (a TPE's startup
    candidates are random draws from its own seed: with one seed both searches would start with
    the same candidates) and from the optimiser of any other seed."""
    import numpy as np

    return int(np.random.SeedSequence([int(seed), 1]).generate_state(1)[0])


def load_search(path: str | Path) -> Search:
    """Read and check a search file; `ScenarioError` on any problem."""
    return load_spec(path, "search", make_search)


def _typed(cls, node, where: str, path: Path, hand_read=()):
    """`node` (a mapping) read into `cls` by pydrake's typed loader after the key walk."""
    if node is None:
        node = {}
    if not isinstance(node, dict):
        raise ScenarioError(path, where, f"expected a mapping of {cls.__name__} fields, got {node!r}")
    typed = {k: v for k, v in node.items() if k not in hand_read}
    for key in typed:
        if key not in {f.name for f in dataclasses.fields(cls)}:
            known = ", ".join(sorted({f.name for f in dataclasses.fields(cls)} | set(hand_read)))
            raise ScenarioError(
                path, f"{where}.{key}" if where else key, f"unknown key '{key}' (known keys: {known})"
            )
    _check_keys(dict(typed), cls, where, str(path))
    try:
        return load_typed(cls, dump_raw(dict(typed)))
    except (RuntimeError, ValueError, TypeError) as err:
        raise ScenarioError(path, where, f"cannot be read as {cls.__name__}: {err}") from None


def _tagged(node, kinds, where: str, path: Path, default=None):
    if node is None and default is not None:
        return default
    if not isinstance(node, Tagged):
        names = ", ".join(f"!{k.__name__}" for k in kinds)
        raise ScenarioError(path, where, f"needs one of {names} {{...}}, got {node!r}")
    for kind in kinds:
        if node.tag == kind.__name__:
            return _typed(kind, dict(node), where, path, hand_read=("choices",) if kind is Choice else ())
    raise ScenarioError(
        path, where, f"unknown kind !{node.tag} (known: {', '.join('!' + k.__name__ for k in kinds)})"
    )


def make_search(document: dict, file: str | Path) -> Search:
    """A search from its document (as `load_search` reads a file); `file` names it in errors."""
    path = Path(file)
    if not isinstance(document, dict) or isinstance(document, Tagged):
        raise ScenarioError(path, "", "the top level must be a mapping of search fields")
    for key in document:
        if key not in KNOWN_KEYS:
            raise ScenarioError(
                path, str(key), f"unknown key '{key}' (known keys: {', '.join(sorted(KNOWN_KEYS))})"
            )
    spec = _typed(SearchFile, document, "", path, hand_read=HAND_READ)
    if not spec.name or not LABEL.match(spec.name):
        raise ScenarioError(
            path, "name", f"needs a name of letters, digits, '_', '-', '.', got {spec.name!r}"
        )
    if spec.preset not in PRESETS:
        raise ScenarioError(
            path, "preset", f"must be one of {', '.join(p for p in PRESETS if p)}, got {spec.preset!r}"
        )
    if not (math.isfinite(spec.duration) and 0 < spec.duration <= MAX_SIMULATED_DURATION):
        raise ScenarioError(
            path,
            "duration",
            f"must be simulated seconds in (0, {MAX_SIMULATED_DURATION:g}], got {spec.duration!r}",
        )
    seeds = _seeds(path, document.get("seeds"))
    if not 1 <= spec.batch <= 256:
        raise ScenarioError(path, "batch", f"must be an integer in [1, 256], got {spec.batch!r}")
    if not len(seeds) <= spec.budget <= MAX_RUNS:
        raise ScenarioError(
            path,
            "budget",
            f"must hold at least one candidate ({len(seeds)} seed(s)) and at "
            f"most {MAX_RUNS} runs, got {spec.budget!r}",
        )
    if not 1 <= spec.report <= 100:
        raise ScenarioError(path, "report", f"must be in [1, 100], got {spec.report!r}")
    if not (math.isfinite(spec.penalty) and spec.penalty >= 0):
        raise ScenarioError(path, "penalty", f"must be a finite number >= 0, got {spec.penalty!r}")
    if not 1 <= spec.fresh_seeds <= 1000:
        raise ScenarioError(path, "fresh_seeds", f"must be in [1, 1000], got {spec.fresh_seeds!r}")
    if not 0 < spec.replay_fps <= 120:
        raise ScenarioError(path, "replay_fps", f"must be in (0, 120], got {spec.replay_fps!r}")
    if not spec.scenario:
        raise ScenarioError(path, "scenario", "names no scenario file")
    scenario_path = spec_scenario_file(path, spec.scenario, "scenario")
    scenario = load_scenario(scenario_path)  # its own problems named by its own file
    raw = _raw_document(scenario_path.read_bytes().decode("utf-8"), scenario_path)
    metric_names = scenario_metric_names(scenario)
    numeric = [m for m in metric_names if m not in TEXT_METRICS and "*" not in m]

    optimizer = _tagged(document.get("optimizer"), (TPE, CmaEs, Random), "optimizer", path, default=TPE())
    if optimizer.seed < 0 or optimizer.seed >= 2**32:
        raise ScenarioError(path, "optimizer.seed", f"must be in [0, 2^32), got {optimizer.seed}")
    objective = _objective(document.get("objective"), spec.preset, scenario, numeric, path)
    constraints = [
        _constraint(text, f"constraints[{k}]", numeric, path) for k, text in enumerate(spec.constraints)
    ]
    if spec.preset == "optimise" and not any(c.metric == "safety.violations_total" for c in constraints):
        constraints.append(Constraint("safety.violations_total", "==", 0.0))
    nodes = document.get("parameters")
    if not isinstance(nodes, list) or not nodes:
        raise ScenarioError(
            path, "parameters", "needs a list of parameters (!Float, !Int, !Choice, !Permutation)"
        )
    parameters = [
        _parameter(node, f"parameters[{k}]", raw, path, scenario_path) for k, node in enumerate(nodes)
    ]
    names = [p.name for p in parameters]
    for k, name in enumerate(names):
        if name in names[:k]:
            raise ScenarioError(path, f"parameters[{k}].name", f"two parameters are called '{name}'")
    for k, p in enumerate(parameters):
        if any(p.steps == q.steps for q in parameters[:k]):
            raise ScenarioError(path, f"parameters[{k}].path", f"'{p.path}' is searched twice")
    return Search(
        file=path,
        name=spec.name,
        description=spec.description,
        scenario=scenario_path,
        duration=float(spec.duration),
        seeds=seeds,
        budget=int(spec.budget),
        batch=int(spec.batch),
        preset=spec.preset,
        parameters=parameters,
        objective=objective,
        constraints=constraints,
        optimizer=optimizer,
        compare_random=bool(spec.compare_random or spec.preset == "falsify"),
        report=int(spec.report),
        penalty=float(spec.penalty),
        fresh_seeds=int(spec.fresh_seeds),
        replay_fps=float(spec.replay_fps),
        document=raw,
        metric_names=numeric,
        kernel_groups=kernel_groups(scenario),
    )


def mode_margin(scenario) -> str:
    """The single margin figure of the scenario's declared safety mode (docs/search.md): SSM and
    hybrid (SSM governs head and torso) `safety.margin_m`, PFL `safety.contact_margin`."""
    from hrc_drake.safety.config import mode_name

    mode = mode_name(scenario.safety)
    if mode == "none":
        return ""
    return "safety.contact_margin" if mode == "pfl" else "safety.margin_m"


def _objective(node, preset: str, scenario, numeric, path: Path) -> Objective:
    if node is None and preset == "falsify":
        metric = mode_margin(scenario)
        if not metric:
            raise ScenarioError(
                path,
                "preset",
                "falsify needs a scenario with a safety mode (its `safety:` is "
                "!NoSafety): there is no margin to minimise",
            )
        return Objective(metric=metric, direction="minimize", over_seeds="worst")
    if node is None and preset == "optimise":
        return Objective(metric="mean_time_between_products", direction="minimize", over_seeds="mean")
    objective = _typed(Objective, node, "objective", path)
    if objective.direction not in DIRECTIONS:
        raise ScenarioError(
            path, "objective.direction", f"must be minimize or maximize, got {objective.direction!r}"
        )
    if objective.over_seeds not in OVER_SEEDS:
        raise ScenarioError(
            path,
            "objective.over_seeds",
            f"must be one of {', '.join(OVER_SEEDS)}, got {objective.over_seeds!r}",
        )
    if objective.metric not in numeric:
        raise ScenarioError(
            path,
            "objective.metric",
            f"'{objective.metric}' is not a numeric metric of "
            f"metrics.json for this scenario{renamed_hint(objective.metric)} (known: {', '.join(numeric)})",
        )
    return objective


def _constraint(text, where: str, numeric, path: Path) -> Constraint:
    match = CONSTRAINT.match(text) if isinstance(text, str) else None
    if not match:
        raise ScenarioError(path, where, f"needs 'metric <=|>=|== number', got {text!r}")
    metric, op, value = match.groups()
    if metric not in numeric:
        raise ScenarioError(
            path,
            where,
            f"'{metric}' is not a numeric metric of metrics.json for this scenario{renamed_hint(metric)} "
            f"(known: {', '.join(numeric)})",
        )
    return Constraint(metric, op, float(value))


def _parameter(node, where: str, raw: dict, path: Path, scenario_path: Path) -> SearchParameter:
    spec = _tagged(node, (Float, Int, Choice, Permutation), where, path)
    try:
        steps = P.parse_path(spec.path)
    except ValueError as err:
        raise ScenarioError(path, f"{where}.path", str(err)) from None
    if steps[0].key in ("seed", "duration", "extends"):
        raise ScenarioError(path, f"{where}.path", f"'{steps[0].key}' is set by the search, not a parameter")
    try:
        current = P.get_value(raw, steps, allow_missing_last=not isinstance(spec, Permutation))
    except KeyError as err:
        raise ScenarioError(path, f"{where}.path", f"unknown path '{spec.path}': {err.args[0]}") from None
    name = spec.name or spec.path
    if not LABEL.match(name.replace("[", "_").replace("]", "_")):
        raise ScenarioError(path, f"{where}.name", f"'{name}' cannot name a column")
    kind = type(spec).__name__.lower()
    p = SearchParameter(name=name, path=spec.path, steps=steps, kind=kind)
    if isinstance(spec, (Float, Int)):
        low, high = spec.low, spec.high
        if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
            raise ScenarioError(
                path, f"{where}.high", f"the range [{low!r}, {high!r}] is empty (needs low < high)"
            )
        if spec.log and low <= 0:
            raise ScenarioError(path, f"{where}.low", f"a log range needs low > 0, got {low!r}")
        if spec.step and (spec.step < 0 or spec.log):
            raise ScenarioError(path, f"{where}.step", "must be > 0, and cannot be used with log")
        if isinstance(spec, Int) and spec.step < 1:
            raise ScenarioError(path, f"{where}.step", f"must be an integer >= 1, got {spec.step!r}")
        if spec.step:
            # Optuna's grid runs from low by step to high: a step that does not divide the range
            # only warns there, and every candidate got the range's low end
            count = (high - low) / spec.step
            if count < 1 - 1e-9 or abs(count - round(count)) > 1e-9 * max(1.0, count):
                raise ScenarioError(path, f"{where}.step", f"{spec.step!r} does not divide the range "
                                                           f"[{low!r}, {high!r}] into whole steps "
                                                           f"({count:.6g} of them): change step, low or high")
        if current is not None and (isinstance(current, bool) or not isinstance(current, (int, float))):
            raise ScenarioError(path, f"{where}.path", f"'{spec.path}' holds {current!r}, not a number")
        p.low, p.high, p.log, p.step = low, high, spec.log, spec.step
        corners = [low, high]
        if isinstance(spec, Int):
            corners = [int(low), int(high)]
    elif isinstance(spec, Choice):
        choices = node.get("choices")
        if not isinstance(choices, list) or not choices:
            raise ScenarioError(path, f"{where}.choices", "needs a non-empty list of values")
        if len(choices) > 1000:
            raise ScenarioError(path, f"{where}.choices", "at most 1000 choices")
        p.choices = choices
        corners = choices
    else:
        if not isinstance(current, list) or not current or not all(isinstance(e, str) for e in current):
            raise ScenarioError(
                path, f"{where}.path", f"'{spec.path}' is not a list of names, got {current!r}"
            )
        if len(set(current)) != len(current):
            raise ScenarioError(path, f"{where}.path", f"'{spec.path}' names an element twice: {current}")
        if spec.precedence not in ("flow", "none"):
            raise ScenarioError(path, f"{where}.precedence", f"must be flow or none, got {spec.precedence!r}")
        pairs = P.flow_precedence(raw, current) if spec.precedence == "flow" else set()
        for j, pair in enumerate(spec.before):
            if len(pair) != 2 or not set(pair) <= set(current) or pair[0] == pair[1]:
                raise ScenarioError(
                    path, f"{where}.before[{j}]", f"needs two different elements of {current}, got {pair}"
                )
            pairs.add((pair[0], pair[1]))
        if not P.acyclic(current, pairs):
            raise ScenarioError(
                path,
                f"{where}.precedence",
                f"the precedence {sorted(pairs)} has a cycle: no order "
                "keeps it (use precedence: none and `before` pairs)",
            )
        if not P.respects(current, pairs):
            raise ScenarioError(
                path, f"{where}.path", f"the listed order {current} breaks the precedence {sorted(pairs)}"
            )
        p.elements, p.precedence = list(current), frozenset(pairs)
        # the order furthest from the listed one: each step the last-listed element that may go
        corners = [P.decode_permutation(current, pairs, list(range(len(current), 0, -1)))]
    for value in corners:  # the scenario must load with each end of the range
        _check_applied(raw, p, value, where, path, scenario_path)
    return p


def _check_applied(raw, p: SearchParameter, value, where, path: Path, scenario_path: Path) -> None:
    from hrc_drake.cell.scenario import _load_text, merge_raw

    document = P.set_value(raw, p.steps, value)
    try:
        _load_text(scenario_path, dump_raw(merge_raw(raw, P.overrides_of(raw, document))))
    except ScenarioError as err:
        shown = dump_raw(value).strip().replace("\n", " ")
        raise ScenarioError(
            path, where, f"the scenario does not load with {p.path} = {shown}: {err.field}: {err.reason}"
        ) from None
