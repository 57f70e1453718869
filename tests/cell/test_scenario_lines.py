"""A bad scenario or spec names `file:line:column` (issue 54, item 6): a YAML syntax error where
the parser stopped, a field's error where the file writes that field."""

from __future__ import annotations

import pytest

from hrc_drake.cell.scenario import ScenarioError, load_scenario, load_scenario_with
from tests.conftest import DIAGRAMS

TORCH = DIAGRAMS / "torch_clock.yaml"


def refused(path, load=load_scenario) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        load(path)
    return info.value


def test_a_yaml_syntax_error_names_its_line_and_column(tmp_path):
    path = tmp_path / "broken.yaml"
    # line 3 opens a flow list that line 4 never closes: the parser stops at line 5, column 1
    path.write_text("seed: 3\nduration: 20\nlayout: {table: {size: [1, 2]\n  }\n")
    err = refused(path)
    assert (err.line, err.column) == (5, 1)
    assert str(err).startswith(f"{path}:5:1: not valid YAML: ") and "(line" not in str(err)


@pytest.mark.parametrize("text, field, line, column", [
    # the value on its key's line: the value's column
    ("extends: {torch}\nseed: 3\nmetrics: {{warmup_products: -2}}\n", "metrics.warmup_products", 3, 28),
    # an unknown key, on its line
    ("extends: {torch}\n\n# a comment\nsead: 4\n", "sead", 4, 7),
    # a value inside a flow mapping of a list's second item
    ("extends: {torch}\nlayout:\n  buffers:\n    - {{name: a, kind: raw}}\n"
     "    - {{name: b, kind: intermediate, capacity: 0}}\n", "layout.buffers[1].capacity", 5, 47),
])
def test_a_fields_error_names_the_line_and_column_that_write_it(tmp_path, text, field, line, column):
    path = tmp_path / "bad.yaml"
    path.write_text(text.format(torch=TORCH))
    err = refused(path)
    assert err.field == field and (err.line, err.column) == (line, column), str(err)
    assert str(err).startswith(f"{path}:{line}:{column}: {field}: ")


def test_a_value_left_at_its_default_is_placed_at_its_parent(tmp_path):
    """The operator's `pattern` is not written (its default, no action): the operator's entry,
    which the file writes, is the place; the target torch_clock gives the camera equals the position
    written here."""
    path = tmp_path / "bad.yaml"
    path.write_text("seed: 1\noperator:\n  name: human\n")
    err = refused(path)
    assert err.field == "operator.pattern" and (err.line, err.column) == (2, 1), str(err)
    path.write_text(f"extends: {TORCH}\nlayout:\n  camera: {{position: [1.0, 0.0, 1.0]}}\n")
    err = refused(path)
    assert err.field == "layout.camera.target" and (err.line, err.column) == (3, 11), str(err)


def test_a_field_the_file_does_not_write_has_no_line_and_a_base_files_error_is_its_own(tmp_path):
    base = tmp_path / "base.yaml"
    base.write_text(f"extends: {TORCH}\n\nseed: -1\n")
    child = tmp_path / "child.yaml"
    child.write_text(f"extends: {base}\nduration: 30\n")
    err = refused(child)
    assert err.file == str(base) and err.field == "seed" and (err.line, err.column) == (3, 7)
    # overrides are no lines of the file: the merged text's places would mislead
    with pytest.raises(ScenarioError) as info:
        load_scenario_with(TORCH, {"seed": -1})
    assert info.value.field == "seed" and info.value.line is None and str(info.value).startswith(f"{TORCH}: ")


def test_a_campaign_spec_names_the_line_and_column_of_its_errors(tmp_path):
    from hrc_drake.campaign.spec import load_campaign

    spec = tmp_path / "spec.yaml"
    spec.write_text(f"name: c\nduration: 5\nseeds: [1, 2]\nscenarios: [{TORCH}]\n"
                    "variants:\n  slow: {scheduler: !FuzzyScheduler {horizon: -1}}\n")
    err = refused(spec, load_campaign)
    assert err.field == "variants.slow.scheduler.horizon" and (err.line, err.column) == (6, 47), str(err)
    spec.write_text("name: c\nduration: [5\n")
    err = refused(spec, load_campaign)
    assert str(err).startswith(f"{spec}:3:1: not valid YAML")


def test_a_search_spec_names_the_line_of_its_errors(tmp_path):
    from hrc_drake.search.spec import load_search

    spec = tmp_path / "search.yaml"
    spec.write_text(f"name: s\nscenario: {TORCH}\npreset: optimise\nbudgte: 3\n")
    err = refused(spec, load_search)
    assert err.field == "budgte" and (err.line, err.column) == (4, 9), str(err)
