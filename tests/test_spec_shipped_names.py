"""Issue 54 item 4: a campaign or a search spec names its scenarios as every command does: a file
relative to the spec, else a shipped scenario's bare name; anything else is refused naming the
field and listing the shipped names."""

from __future__ import annotations

import json

import pytest

from hrc_drake.campaign.spec import load_campaign
from hrc_drake.errors import ScenarioError
from hrc_drake.search.spec import load_search
from tests.conftest import DIAGRAMS


def _copy(source, tmp_path, old, new):
    text = source.read_text()
    assert old in text
    path = tmp_path / source.name
    path.write_text(text.replace(old, new, 1))
    return path


def test_a_campaign_names_a_shipped_scenario_by_its_bare_name(tmp_path):
    source = DIAGRAMS / "campaigns" / "trackers.yaml"
    text = source.read_text()
    start = text.index("scenarios:")
    line = text[start:text.index("\n", start)]
    campaign = load_campaign(_copy(source, tmp_path, line, "scenarios: [pcb_occlusion]"))
    assert [p.name for p in campaign.scenarios.values()] == ["pcb_occlusion.yaml"]


@pytest.mark.parametrize("name", ["pcb_occlusio", "../pcb_occlusion", "pcb\x1b[2Jic"])
def test_a_campaign_refuses_a_name_that_is_neither(tmp_path, name):
    source = DIAGRAMS / "campaigns" / "trackers.yaml"
    text = source.read_text()
    start = text.index("scenarios:")
    line = text[start:text.index("\n", start)]
    path = tmp_path / "spec.yaml"
    # a JSON string is a YAML flow scalar, control characters escaped
    path.write_text(text.replace(line, f"scenarios: [{json.dumps(name)}]"))
    with pytest.raises(ScenarioError) as err:
        load_campaign(path)
    assert err.value.field == "scenarios[0]" and "pcb_occlusion" in err.value.reason
    assert "\x1b" not in str(err.value)


def test_a_search_names_a_shipped_scenario_by_its_bare_name(tmp_path):
    source = DIAGRAMS / "searches" / "optimise_pcb_ic.yaml"
    text = source.read_text()
    start = text.index("\nscenario:") + 1
    line = text[start:text.index("\n", start)]
    search = load_search(_copy(source, tmp_path, line, "scenario: pcb_ic"))
    assert search.scenario.name == "pcb_ic.yaml"
