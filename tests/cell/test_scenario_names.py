"""One way to name a scenario (issue "One way to name things", item 4): `load_scenario`, every
command and `import --cell` take a file or the bare name of a shipped example, resolved in one
place (`cell.shipped`); a name that is not bare never reaches a file of the package; a loaded
`Scenario` remembers the file it was read from, so `build_cell(load_scenario(path))` needs no
second path, and a scenario file cannot set that."""

from __future__ import annotations

import copy
import os

import pytest

from hrc_drake.cell.scenario import load_scenario, load_scenario_with
from hrc_drake.cell.shipped import example_names, resolve
from hrc_drake.cli import EXIT_BAD_INPUT, main
from hrc_drake.errors import ScenarioError
from tests.conftest import DIAGRAMS

TORCH = DIAGRAMS / "torch_clock.yaml"


# adversarial names first: each would reach a file of the package if it were joined to the
# examples' folder (variants/..., campaigns/..., ../diagrams/...), or is a shipped name with
# something around it; none is a file in the working folder, so each is "no such file"
@pytest.mark.parametrize("name", [
    "../diagrams/torch_clock", "../diagrams/torch_clock.yaml", "variants/box_pcb_coexistence_swept_volumes",
    "campaigns/trackers", "./torch_clock", "torch_clock/", "torch_clock\n", "\ntorch_clock", "torch_clock\r",
    "torch_clock\x00", "torch_clock\u2028", "torch_clock\x1b[2J", " torch_clock", ".hidden", ".torch_clock",
    "..torch_clock", "torch..clock", "torch_clock.yaml", "torch_clock.yml", "TORCH_CLOCK", "",
])
def test_a_name_that_is_not_bare_never_resolves_into_the_package(tmp_path, monkeypatch, name):
    (tmp_path / "here").mkdir()
    monkeypatch.chdir(tmp_path / "here")  # '../diagrams' does not exist from here
    with pytest.raises(ScenarioError) as info:
        load_scenario(name)
    message = str(info.value)
    assert "no such file" in message and "pcb_collab" in message  # the examples named
    assert "\n" not in message and "\x1b" not in message and "\x00" not in message  # one printable line


def test_the_bad_names_are_refused_so_from_the_real_parent_folder_too(monkeypatch):
    """From tests/, '../diagrams/torch_clock' would be the repository's diagrams/torch_clock.yaml if
    a suffix were added: it is not, and the file without a suffix does not exist."""
    monkeypatch.chdir(DIAGRAMS.parent / "tests")
    with pytest.raises(ScenarioError, match="no such file"):
        load_scenario("../diagrams/torch_clock")
    assert load_scenario("../diagrams/torch_clock.yaml").source_path == TORCH  # a real path works as before


def test_a_bare_name_that_is_not_shipped_says_where_it_looked_and_lists_the_examples(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ScenarioError) as info:
        load_scenario("no_such_cell")
    message = str(info.value)
    assert message.startswith(f"no_such_cell: no such file in {os.getcwd()}, and no shipped example scenario")
    assert all(name in message for name in example_names())


def test_a_missing_path_says_no_such_file_and_lists_the_examples(tmp_path):
    with pytest.raises(ScenarioError) as info:
        load_scenario(tmp_path / "missing.yaml")
    message = str(info.value)
    assert message.startswith(f"{tmp_path / 'missing.yaml'}: no such file (or give the bare name")
    assert "torch_clock" in message


def test_a_file_or_folder_in_the_working_folder_wins_over_a_shipped_example(tmp_path, monkeypatch):
    """The precedence `hrc-drake simulate` has always had: what is there is what is meant."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "torch_clock").write_text(f"extends: {TORCH}\nseed: 7\n")
    scenario = load_scenario("torch_clock")
    assert scenario.seed == 7 and scenario.source_path == tmp_path / "torch_clock"
    (tmp_path / "torch_clock").unlink()
    (tmp_path / "torch_clock").mkdir()
    with pytest.raises(ScenarioError, match="is a folder"):
        load_scenario("torch_clock")


def test_load_scenario_takes_a_shipped_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # not the repository: the name is no path here
    by_name = load_scenario("torch_clock")
    assert by_name == load_scenario(TORCH)
    assert by_name.source_path.resolve() == TORCH.resolve() and by_name.source_path.is_absolute()
    assert load_scenario(type(tmp_path)("torch_clock")) == by_name  # a Path of a bare name too
    assert load_scenario_with("torch_clock", {"seed": 3}).seed == 3
    assert resolve("trackers", "campaign").name == "trackers.yaml"
    assert resolve("falsify_pcb_ic", "search").name == "falsify_pcb_ic.yaml"
    with pytest.raises(ScenarioError, match="no shipped example campaign"):
        resolve("torch_clock", "campaign")  # a name means an example of the kind asked for


def test_every_command_takes_the_same_names(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["validate", "torch_clock"]) == 0
    assert "torch_clock.yaml: OK" in capsys.readouterr().out
    for name in ("variants/box_pcb_coexistence_swept_volumes", "torch_clock\n", "../torch_clock"):
        assert main(["validate", name]) == EXIT_BAD_INPUT
        assert "no such file" in capsys.readouterr().err
    assert main(["campaign", "campaigns/trackers", "--out", str(tmp_path / "c"), "--workers", "0"]) \
        == EXIT_BAD_INPUT
    assert "no such file" in capsys.readouterr().err


# the source path: not a field, so not something a file can say
@pytest.mark.parametrize("key", ["source_path", "source"])
def test_a_scenario_file_cannot_set_its_source_path(tmp_path, key):
    path = tmp_path / "sneaky.yaml"
    path.write_text(f"extends: {TORCH}\n{key}: /etc/passwd\n")
    with pytest.raises(ScenarioError, match=f"unknown key '{key}'"):
        load_scenario(path)


def test_the_source_is_the_file_loaded_not_the_base_it_extends(tmp_path):
    child = tmp_path / "child.yaml"
    child.write_text(f"extends: {TORCH}\nseed: 5\n")
    assert load_scenario(child).source_path == child
    assert load_scenario_with(child, {"seed": 6}).source_path == child
    assert load_scenario(TORCH).source_path == TORCH
    assert copy.deepcopy(load_scenario(child)).source_path == child


def test_build_cell_reads_the_scenario_s_files_from_where_it_was_loaded(tmp_path, monkeypatch):
    """lego_real_operator names its recording relative to diagrams/: built from another working
    folder without a path, it is found through the remembered source; forgotten, it is not."""
    from hrc_drake.cell.build import build_cell

    monkeypatch.chdir(tmp_path)
    path = DIAGRAMS / "lego_real_operator.yaml"
    scenario = load_scenario(path)
    forgotten = copy.deepcopy(scenario)
    forgotten.source_path = None
    with pytest.raises(ScenarioError, match="operator.recorded"):
        build_cell(forgotten)
    cell = build_cell(scenario)
    assert cell.scenario_path == str(path)
    assert cell.has_system("safety_monitor")
