"""Searches that simulate: the shipped specs found by name (package data), a falsification on the
address of a Dask scheduler started here, and the optimise preset's outputs (the best scenario a
`hrc-drake simulate` runs as it is, compared with the shipped one over fresh seeds)."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pandas as pd
import pytest

from hrc_drake.campaign.spec import _read_raw
from hrc_drake.cell.scenario import load_scenario
from hrc_drake.cli import main
from hrc_drake.errors import ScenarioError
from hrc_drake.search import params as P
from hrc_drake.search.command import search_path, shipped_search_names
from hrc_drake.search.engine import FunctionEvaluator, run_search
from hrc_drake.search.report import FRESH_SEED_BASE, search_and_report
from hrc_drake.search.spec import load_search, make_search, random_search_seed
from tests.conftest import DIAGRAMS, REPO

SEARCHES = DIAGRAMS / "searches"


def test_the_shipped_specs_are_package_data_found_by_name_and_load():
    names = sorted(p.stem for p in SEARCHES.glob("*.yaml"))
    assert names == shipped_search_names() and "falsify_pcb_ic" in names
    for name in names:
        path = search_path(name)
        assert path.resolve() == (SEARCHES / f"{name}.yaml").resolve()
        assert load_search(path).name == name
    # a wheel holds them as hrc_drake/diagrams/searches/*.yaml, as it holds the scenarios
    setuptools = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert setuptools["package-dir"]["hrc_drake.diagrams"] == "diagrams"
    assert "searches/*.yaml" in setuptools["package-data"]["hrc_drake.diagrams"]
    with pytest.raises(ScenarioError, match="falsify_pcb_ic"):  # an unknown name lists the shipped ones
        search_path("falsify_nothing")


def test_random_search_beside_an_optimiser_has_a_seed_of_its_own(tmp_path):
    """With one seed, TPE's startup candidates (random draws from its seed) and random search's
    would be the same candidates: the comparison would start degenerate."""
    seeds = {random_search_seed(s) for s in range(50)}
    assert len(seeds) == 50 and not seeds & set(range(50))
    document = _read_raw(SEARCHES / "falsify_coexistence.yaml")
    search = make_search({**document, "budget": 4, "batch": 4}, SEARCHES / "falsify_coexistence.yaml")
    results = run_search(
        search,
        tmp_path / "out",
        evaluator=FunctionEvaluator(lambda v, s: {"safety": {"margin_m": v["stand_x"]}}),
        progress=None,
    ).results
    optimizer = results[results["search"] == "optimizer"]["param.stand_x"].to_numpy()
    random = results[results["search"] == "random"]["param.stand_x"].to_numpy()
    assert len(optimizer) == len(random) == 4 and not set(optimizer) & set(random)


def test_a_falsification_runs_on_the_address_of_a_dask_scheduler(tmp_path, capsys):
    """`hrc-drake search SPEC --address tcp://...` on a LocalCluster started here (2 processes):
    both searches, the report, the worst candidate's replay and scenario."""
    from distributed import LocalCluster

    spec = tmp_path / "falsify.yaml"
    text = (SEARCHES / "falsify_coexistence.yaml").read_text()
    changes = [("budget: 8", "budget: 2"), ("duration: 30", "duration: 4")]
    changes.append(("scenario: ../", f"scenario: {DIAGRAMS}/"))
    for old, new in changes:
        assert old in text
        text = text.replace(old, new)
    spec.write_text(text)
    out = tmp_path / "out"
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        code = main(["search", str(spec), "--out", str(out), "--address", cluster.scheduler_address])
    assert code == 0, capsys.readouterr().err
    results = pd.read_parquet(out / "results.parquet")
    assert sorted(results["variant"]) == ["o00000", "o00001", "r00000", "r00001"]
    assert set(results["status"]) == {"ok"}
    runs = pd.read_parquet(out / "runs.parquet")
    assert len(runs) == 4 and runs["worker"].str.startswith("tcp://127.0.0.1:").all()
    report = json.loads((out / "report.json").read_text())
    # the preset minimises the margin of the cell's declared mode: PFL's contact margin (issue 52)
    assert set(report["searches"]) == {"optimizer", "random"}
    assert report["objective"] == "safety.contact_margin"
    assert (out / "worst_replay.html").stat().st_size > 10_000
    assert load_scenario(out / "worst_scenario.yaml").duration == 4.0


def test_the_optimise_preset_writes_a_best_scenario_that_simulate_runs_as_it_is(tmp_path, capsys):
    """The best feasible candidate's values in a standalone file (loaded, it has them at their
    paths), and the best and the shipped scenario over fresh seeds (never the search's)."""
    path = SEARCHES / "optimise_pcb_ic.yaml"
    search = make_search({**_read_raw(path), "budget": 16, "batch": 4, "fresh_seeds": 3}, path)

    def cycle(values, seed):
        """A toy cell: the cycle shortest with the operator at x = 0.95; unsafe for tray_y > -0.3."""
        shipped = abs(values["stand_x"] - 0.98) < 1e-9 and abs(values["tray_y"] + 0.32) < 1e-9
        return {
            "mean_time_between_products": 30.0 + 100 * (values["stand_x"] - 0.95) ** 2
                                          + (1.0 if shipped else 0.0),
            "products_finished": 3,
            "safety": {"violations_total": int(values["tray_y"] > -0.3)},
        }

    seen = []

    def recorded(values, seed):
        seen.append(seed)
        return cycle(values, seed)

    search_and_report(search, tmp_path / "out", evaluator=FunctionEvaluator(recorded), progress=None)
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    best = report["best_scenario"]
    fresh = [FRESH_SEED_BASE + k for k in range(3)]
    assert best["fresh_seeds"] == fresh and seen[-6:] == fresh * 2 and not set(seen[:-6]) & set(fresh)
    assert best["best_fresh"]["feasible"] and best["best_fresh"]["metrics"]["safety.violations_total"] == 0
    assert best["best_fresh"]["objective"] < best["shipped_fresh"]["objective"]
    paired = best["paired"]  # seed by seed: 3 pairs, each better, the exact one-sided p of 3 signs
    assert len(paired["differences"]) == 3 and all(d < 0 for d in paired["differences"])
    assert paired["wilcoxon_p"] == pytest.approx(1 / 8)
    results = pd.read_parquet(tmp_path / "out" / "results.parquet")
    row = results[results["variant"] == best["variant"]].iloc[0]
    assert row["feasible"] and row["param.tray_y"] <= -0.3
    # the file: the base scenario with the best values at their paths, loadable as it is
    written = tmp_path / "out" / "best_scenario.yaml"
    scenario = load_scenario(written)
    assert scenario.operator.base.xyz[0] == row["param.stand_x"]
    assert next(g for g in scenario.layout.goals if g.name == "tray").center[1] == row["param.tray_y"]
    assert scenario.operator.pattern == row["param.order"].split()
    raw = _read_raw(written)
    assert P.get_value(raw, P.parse_path("layout.goals[ic_station].center[0]")) == row["param.ic_station_x"]
    assert main(["simulate", str(written), "--duration", "2", "--out", str(tmp_path / "sim")]) == 0
    assert json.loads((tmp_path / "sim" / "metrics.json").read_text())["simulated_time"] == pytest.approx(2.0)
    capsys.readouterr()


def test_search_by_name_on_the_command_line(tmp_path, capsys, monkeypatch):
    """A bare name finds the shipped spec (as `hrc-drake simulate pcb_ic` does the scenario); a bad
    name is bad input (exit 2)."""
    monkeypatch.chdir(tmp_path)
    assert main(["search", "no_such_search", "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    assert "falsify_coexistence" in capsys.readouterr().err
    assert Path(search_path("optimise_pcb_ic")).is_file()


def test_a_margin_below_zero_is_told_apart_from_a_violation_of_the_mode(tmp_path):
    """report.json: runs to the first margin below 0 (a contact the person made counts) and to the
    first violation the judge holds against the robot (`safety.violations_total` > 0)."""
    path = SEARCHES / "falsify_pcb_ic.yaml"
    search = make_search({**_read_raw(path), "budget": 12, "batch": 4}, path)

    def cell(values, seed):
        margin = values["stand_x"] - 0.95  # below 0 standing closer than 0.95 m
        return {"safety": {"contact_margin": margin, "violations_total": int(values["stand_x"] < 0.88)}}

    search_and_report(search, tmp_path / "out", evaluator=FunctionEvaluator(cell), progress=None)
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    results = pd.read_parquet(tmp_path / "out" / "results.parquet")
    for label, figures in report["searches"].items():
        part = results[results["search"] == label].sort_values("number")
        below = part[part["param.stand_x"] < 0.95]["runs"]
        mode = part[part["param.stand_x"] < 0.88]["runs"]
        assert figures["runs_to_first_violation"] == (int(below.iloc[0]) if len(below) else None)
        assert figures["runs_to_first_mode_violation"] == (int(mode.iloc[0]) if len(mode) else None)
    assert "worst_replay" not in report  # no simulation to replay


def test_the_paired_fresh_comparison_needs_pairs_with_a_difference():
    from types import SimpleNamespace

    from hrc_drake.search.command import _paired_verdict
    from hrc_drake.search.report import paired_fresh

    search = SimpleNamespace(objective=SimpleNamespace(metric="mean_time_between_products",
                                                       direction="minimize"))
    rows = [{"variant": v, "seed": s, "status": "ok", "mean_time_between_products": 30.0}
            for v in ("best_fresh", "shipped_fresh") for s in (1, 2, 3)]
    same = paired_fresh(search, rows, [1, 2, 3])
    assert same["differences"] == [0.0, 0.0, 0.0] and same["wilcoxon_p"] is None
    assert _paired_verdict(same) == "no paired test (the same figure on every fresh seed)"
    one = paired_fresh(search, rows, [1])
    assert _paired_verdict(one) == "no paired test (1 fresh seed(s) with a figure for both)"
    # seed 2 has no pair
    rows[0]["mean_time_between_products"], rows[1]["mean_time_between_products"] = 29.0, float("nan")
    unpaired = {"variant": "best_fresh", "seed": 4, "status": "ok", "mean_time_between_products": 1.0}
    partial = paired_fresh(search, rows + [unpaired], [1, 2, 3])
    assert partial["differences"] == [-1.0, 0.0] and partial["wilcoxon_p"] is not None
    search.objective.direction = "maximize"
    assert paired_fresh(search, rows, [1, 3])["wilcoxon_p"] > 0.5  # lower is worse when maximising
