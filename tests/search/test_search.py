"""Search specs, parameters applied to scenarios, and the ask/tell loop on a toy evaluation."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hrc_drake.cell.scenario import _load_text, _raw_document, dump_raw, merge_raw
from hrc_drake.errors import ScenarioError
from hrc_drake.search import params as P
from hrc_drake.search.engine import FunctionEvaluator, apply_values, run_search
from hrc_drake.search.report import search_and_report
from hrc_drake.search.spec import load_search

REPO = Path(__file__).resolve().parents[2]
COEXISTENCE = REPO / "diagrams" / "box_pcb_coexistence.yaml"


def write_spec(tmp_path, text: str, name="s.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text.replace("SCENARIO", str(COEXISTENCE)))
    return path


BASE = """
name: toy
scenario: SCENARIO
duration: 30
seeds: [1]
budget: {budget}
batch: 4
optimizer: !TPE {{seed: 3, n_startup_trials: 6}}
objective: {{metric: mean_time_between_products, direction: minimize}}
constraints: ["safety.violations_total == 0"]
parameters:
  - !Float {{name: x, path: "operator.base.xyz[0]", low: 1.6, high: 2.0}}
  - !Float {{name: y, path: "layout.buffers[boxes].position[1]", low: 0.2, high: 0.6}}
  - !Permutation {{name: order, path: operator.pattern}}
"""


def toy(values, seed):
    """A known optimum: x = 1.9, y = 0.35, foam first; infeasible where y > 0.55."""
    order_penalty = 0.0 if values["order"][0] == "foam" else 0.05
    return {
        "mean_time_between_products": (values["x"] - 1.9) ** 2 + (values["y"] - 0.35) ** 2 + order_penalty,
        "safety": {"violations_total": int(values["y"] > 0.55)},
    }


# ----- parameters applied to a scenario


def test_paths_parse_and_reach_values():
    raw = _raw_document(COEXISTENCE.read_text())
    assert P.get_value(raw, P.parse_path("operator.base.xyz[0]")) == 1.85
    assert P.get_value(raw, P.parse_path("layout.buffers[boxes].position[1]")) == 0.45
    assert P.get_value(raw, P.parse_path("robots[yumi].arms[yumi_left].program")) == [
        "L_pick_cap",
        "L_assemble",
        "L_store",
    ]
    with pytest.raises(KeyError, match="no element named 'nope'"):
        P.get_value(raw, P.parse_path("layout.buffers[nope].position"))
    with pytest.raises(ValueError):
        P.parse_path("operator..base")


def test_values_are_written_exactly_and_the_scenario_loads_them(tmp_path):
    search = load_search(write_spec(tmp_path, BASE.format(budget=8)))
    values = {"x": 1.7123456789, "y": 0.3, "order": ["foam", "fill", "bring", "tape"]}
    document = apply_values(search, values)
    overrides = P.overrides_of(search.document, document)
    assert set(overrides) == {"operator", "layout"}
    assert merge_raw(search.document, overrides) == document
    scenario = _load_text(COEXISTENCE, dump_raw(merge_raw(search.document, overrides)))
    assert scenario.operator.base.xyz[0] == 1.7123456789
    assert next(b for b in scenario.layout.buffers if b.name == "boxes").position[1] == 0.3
    assert scenario.operator.pattern == ["foam", "fill", "bring", "tape"]
    # the rest of the document is untouched
    assert document["robots"] == search.document["robots"]
    assert document["layout"]["goals"] == search.document["layout"]["goals"]
    # what local runs compile ahead: the base scenario's cell's kernel groups
    assert search.kernel_groups == ["geometry", "human", "perception", "motion", "safety"]


def test_flow_precedence_and_permutations_respect_it():
    raw = _raw_document(COEXISTENCE.read_text())
    pattern = ["fill", "foam", "bring", "tape"]
    pairs = P.flow_precedence(raw, pattern)
    assert pairs == {("fill", "bring"), ("fill", "tape"), ("bring", "tape")}  # foam is not in the flow
    orders = set()
    rng = np.random.default_rng(0)
    for _ in range(300):
        order = P.decode_permutation(pattern, pairs, rng.random(4))
        assert sorted(order) == sorted(pattern) and P.respects(order, pairs)
        orders.add(tuple(order))
    allowed = {o for o in itertools.permutations(pattern) if P.respects(o, pairs)}
    assert orders == allowed and len(allowed) == 4  # every order the flow allows, none other
    assert P.decode_permutation(["a", "b"], {("a", "b"), ("b", "a")}, [0, 1]) is None


# ----- bad specs are refused, naming the field


@pytest.mark.parametrize(
    "old, new, field",
    [
        ('path: "operator.base.xyz[0]"', 'path: "operator.bass.xyz[0]"', "parameters[0].path"),
        ("low: 1.6, high: 2.0", "low: 2.0, high: 2.0", "parameters[0].high"),
        ("metric: mean_time_between_products", "metric: mean_cycle_tme", "objective.metric"),
        ("metric: mean_time_between_products", "metric: safety.verdict", "objective.metric"),
        ('"safety.violations_total == 0"', '"safety.nope == 0"', "constraints[0]"),
        ('"safety.violations_total == 0"', '"safety.violations_total = 0"', "constraints[0]"),
        ("budget: 8", "budget: 0", "budget"),
        ("!TPE", "!Bayes", "optimizer"),
        ("low: 1.6, high: 2.0", "low: 1.6, high: 2.0, lo: 3", "parameters[0].lo"),
        # a range whose end breaks the scenario (the operator inside the table: a checked field)
        (
            'path: "layout.buffers[boxes].position[1]", low: 0.2, high: 0.6',
            'path: "layout.buffers[boxes].position[1]", low: 0.2, high: 60.0',
            "parameters[1]",
        ),
    ],
)
def test_a_bad_spec_is_refused_naming_the_field(tmp_path, old, new, field):
    text = BASE.format(budget=8)
    assert old in text
    with pytest.raises(ScenarioError) as err:
        load_search(write_spec(tmp_path, text.replace(old, new)))
    assert err.value.field == field, str(err.value)


def test_an_objective_named_as_before_issue_54_is_told_its_new_name(tmp_path):
    text = BASE.format(budget=8).replace("metric: mean_time_between_products", "metric: mean_cycle_time")
    with pytest.raises(ScenarioError) as err:
        load_search(write_spec(tmp_path, text))
    assert err.value.field == "objective.metric" and "renamed mean_time_between_products" in err.value.reason


def test_a_permutation_against_the_flow_is_refused(tmp_path):
    text = (
        BASE.format(budget=8) + '  - !Permutation {name: p2, path: "robots[yumi].arms[yumi_left].program"}\n'
    )
    load_search(write_spec(tmp_path, text))  # the listed order keeps the flow
    text = text.replace("p2, path", "p2, before: [[L_store, L_pick_cap]], path")
    with pytest.raises(ScenarioError) as err:
        load_search(write_spec(tmp_path, text))
    assert err.value.field == "parameters[3].precedence"


# ----- the loop


def test_a_search_finds_the_known_optimum_of_a_toy(tmp_path):
    search = load_search(write_spec(tmp_path, BASE.format(budget=60)))
    outcome = search_and_report(search, tmp_path / "out", evaluator=FunctionEvaluator(toy), progress=None)
    results = outcome.results
    assert len(results) == 60 and set(results["status"]) == {"ok"}
    feasible = results[results["feasible"]]
    best = feasible.loc[feasible["objective"].idxmin()]
    assert best["objective"] < 0.01
    assert abs(best["param.x"] - 1.9) < 0.1 and abs(best["param.y"] - 0.35) < 0.1
    assert best["param.order"].split()[0] == "foam"
    # infeasible candidates are marked and never the best
    assert not results[results["param.y"] > 0.55]["feasible"].any()
    table = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert len(table) == 60 and "metric.mean_time_between_products" in table
    runs = pd.read_parquet(tmp_path / "out" / "runs.parquet")
    assert len(runs) == 60 and set(runs["variant"]) == set(results["variant"])
    for name in ("history.png", "importances.png", "parameters.png", "report.json"):
        assert (tmp_path / "out" / name).is_file(), name


def test_the_same_seed_gives_the_same_search_and_another_seed_another(tmp_path):
    spec = load_search(write_spec(tmp_path, BASE.format(budget=12)))
    a = run_search(
        spec,
        tmp_path / "a",
        evaluator=FunctionEvaluator(toy),
        progress=None,
    ).results
    b = run_search(
        spec,
        tmp_path / "b",
        evaluator=FunctionEvaluator(toy),
        progress=None,
    ).results
    pd.testing.assert_frame_equal(a, b)
    other = load_search(write_spec(tmp_path, BASE.format(budget=12).replace("seed: 3", "seed: 4"), "o.yaml"))
    c = run_search(
        other,
        tmp_path / "c",
        evaluator=FunctionEvaluator(toy),
        progress=None,
    ).results
    assert not np.allclose(a["param.x"], c["param.x"])


class Interrupt(KeyboardInterrupt):
    pass


def test_resume_after_an_interrupt_gives_the_same_table(tmp_path):
    spec = load_search(write_spec(tmp_path, BASE.format(budget=16).replace("seeds: [1]", "seeds: [1, 2]")))
    whole = run_search(
        spec,
        tmp_path / "whole",
        evaluator=FunctionEvaluator(toy),
        progress=None,
    ).results

    class Stopping(FunctionEvaluator):
        """Ctrl-C after 6 runs: inside the second batch (4 candidates x 2 seeds a batch)."""

        runs = 0

        def run(self, jobs, store, out_dir, done):
            for job in jobs:
                if Stopping.runs == 6:
                    raise Interrupt()
                Stopping.runs += 1
                super().run([job], store, out_dir, done)

    with pytest.raises(Interrupt):
        run_search(spec, tmp_path / "cut", evaluator=Stopping(toy), progress=None)
    assert len(pd.read_parquet(tmp_path / "cut" / "runs.parquet")) == 6  # what was done is kept
    ran = []

    def counted(values, seed):
        ran.append(seed)
        return toy(values, seed)

    resumed = run_search(
        spec,
        tmp_path / "cut",
        evaluator=FunctionEvaluator(counted),
        progress=None,
    ).results
    assert len(ran) == 16 - 6  # only the runs not stored
    pd.testing.assert_frame_equal(resumed, whole)


def test_a_folder_of_another_search_is_refused(tmp_path):
    spec = load_search(write_spec(tmp_path, BASE.format(budget=4)))
    run_search(spec, tmp_path / "out", evaluator=FunctionEvaluator(toy), progress=None)
    other = load_search(
        write_spec(tmp_path, BASE.format(budget=4).replace("high: 2.0", "high: 1.95"), "o.yaml")
    )
    with pytest.raises(ScenarioError) as err:
        run_search(other, tmp_path / "out", evaluator=FunctionEvaluator(toy), progress=None)
    assert err.value.field == "--out"


def test_failed_runs_are_failed_candidates_not_a_lost_search(tmp_path):
    spec = load_search(write_spec(tmp_path, BASE.format(budget=8)))

    def breaks(values, seed):
        if values["x"] > 1.8:
            raise RuntimeError("boom")
        return toy(values, seed)

    results = run_search(
        spec,
        tmp_path / "out",
        evaluator=FunctionEvaluator(breaks),
        progress=None,
    ).results
    failed = results[results["param.x"] > 1.8]
    assert len(failed) and (failed["status"] == "failed").all() and failed["objective"].map(math.isnan).all()
    assert "boom" in failed["error"].iloc[0]


RANGES = """
name: ranges
scenario: SCENARIO
duration: 30
seeds: [1]
budget: 24
batch: 4
optimizer: OPTIMIZER
objective: {metric: mean_time_between_products, direction: minimize}
parameters:
  - !Float {name: bring, path: "operator.actions[bring].duration.mean", low: 1.6, high: 4.0, log: true}
  - !Float {name: tape, path: "operator.actions[tape].duration.mean", low: 3.0, high: 8.0, step: 0.5}
  - !Int {name: filled, path: "layout.buffers[filled_box].capacity", low: 1, high: 4}
  - !Int {name: station, path: "layout.buffers[human_station].capacity", low: 1, high: 7, step: 2}
  - !Choice
    name: safety
    path: safety
    choices:
      - !SpeedSeparationMonitoring {position_uncertainty: camera}
      - !PowerForceLimiting {position_uncertainty: camera}
      - !NoSafety {}
  - !Permutation {name: order, path: operator.pattern}
"""


@pytest.mark.parametrize(
    "optimizer", ["!TPE {seed: 1, n_startup_trials: 4}", "!CmaEs {seed: 1}", "!Random {seed: 1}"]
)
def test_every_candidate_is_in_its_ranges_and_written_exactly(tmp_path, optimizer):
    """Each sampler's candidates: floats within [low, high] (on the step's grid), integers on their
    step, one of the choices, orders that keep the flow; and the scenario loaded with a candidate's
    values holds exactly those values at their paths."""
    search = load_search(write_spec(tmp_path, RANGES.replace("OPTIMIZER", optimizer)))
    seen = []

    def record(values, seed):
        seen.append(values)
        return {"mean_time_between_products": values["bring"] + values["tape"] - values["filled"]}

    results = run_search(search, tmp_path / "out", evaluator=FunctionEvaluator(record), progress=None).results
    assert len(seen) == 24 and set(results["status"]) == {"ok"}
    pairs = next(p for p in search.parameters if p.name == "order").precedence
    safeties = set()
    for values in seen:
        assert 1.6 <= values["bring"] <= 4.0 and 3.0 <= values["tape"] <= 8.0
        assert (values["tape"] - 3.0) / 0.5 == pytest.approx(round((values["tape"] - 3.0) / 0.5))
        assert type(values["filled"]) is int and 1 <= values["filled"] <= 4
        assert values["station"] in (1, 3, 5, 7)
        assert sorted(values["order"]) == sorted(search.document["operator"]["pattern"])
        assert P.respects(values["order"], pairs)
        safeties.add(values["safety"].tag)
        scenario = _load_text(COEXISTENCE, dump_raw(apply_values(search, values)))
        actions = {a.name: a for a in scenario.operator.actions}
        assert actions["bring"].duration.mean == values["bring"]
        assert actions["tape"].duration.mean == values["tape"]
        buffers = {b.name: b for b in scenario.layout.buffers}
        assert buffers["filled_box"].capacity == values["filled"]
        assert buffers["human_station"].capacity == values["station"]
        assert type(scenario.safety).__name__ == values["safety"].tag
        assert scenario.operator.pattern == values["order"]
    assert safeties <= {"SpeedSeparationMonitoring", "PowerForceLimiting", "NoSafety"} and len(safeties) >= 2


@pytest.mark.parametrize("old, new, accepted", [
    ("low: 3.0, high: 8.0, step: 0.5", "low: 3.0, high: 8.0, step: 0.7", False),  # 7.14 steps
    ("low: 3.0, high: 8.0, step: 0.5", "low: 3.0, high: 8.0, step: 6.0", False),  # less than one
    ("low: 3.0, high: 8.0, step: 0.5", "low: 3.0, high: 8.0, step: 5.0", True),  # exactly one
    ("low: 3.0, high: 8.0, step: 0.5", "low: 0.1, high: 0.7, step: 0.1", True),  # 6, in floats 5.999..
    ("low: 1, high: 7, step: 2", "low: 1, high: 8, step: 2", False),  # 3.5 integer steps
])
def test_a_step_must_divide_its_range(tmp_path, old, new, accepted):
    """Optuna's grid starts at low: a step that does not divide the range only warned there, and
    every candidate got the range's low end (issue 55, item 8)."""
    assert old in RANGES
    path = write_spec(tmp_path, RANGES.replace(old, new).replace("OPTIMIZER", "!Random {seed: 1}"))
    if accepted:
        load_search(path)
        return
    with pytest.raises(ScenarioError, match=r"parameters\[\d\]\.step: .* does not divide the range"):
        load_search(path)
