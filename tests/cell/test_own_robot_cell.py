"""Issue 54 item 1: a scenario whose robot is a URDF outside the package runs a cell (here the
shipped UR5e's URDF copied to a temporary folder, named relative to the scenario), and a faster
stop than the shipped robots assume is a changed judge (NON-CONFORMING), never the standard's."""

from __future__ import annotations

import shutil

import pytest
import yaml

from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate
from hrc_drake.cell.scenario import ScenarioError, judge_values, load_scenario, safety_departures
from tests.conftest import DIAGRAMS, REPO


class _TaggedLoader(yaml.SafeLoader):
    """Reads the shipped scenario's tagged blocks (`!PredictiveRobotScheduler`) as plain mappings."""


_TaggedLoader.add_multi_constructor("!", lambda loader, suffix, node: loader.construct_mapping(node))
SHIPPED = yaml.load((DIAGRAMS / "pcb_ic_ur5e.yaml").read_text(), Loader=_TaggedLoader)  # noqa: S506 (safe)


def _own_cell(tmp_path, **robot_fields):
    """pcb_ic_ur5e with its robot described by the scenario: `urdf:` beside it, the arm's chain."""
    shutil.copy(REPO / "models" / "ur5e.urdf", tmp_path / "my_cobot.urdf")
    robot = dict(SHIPPED["robots"][0])
    del robot["model"]
    robot.update(urdf="my_cobot.urdf", capsule_margin=0.03,
                 chains=[{"name": "arm", "tool_frame": "ur5e_tool",
                          "gripper_joints": ["ur5e_finger_joint_l", "ur5e_finger_joint_r"],
                          "gripper_stroke": 0.0425}], **robot_fields)
    scenario = {"extends": str(DIAGRAMS / "pcb_ic_ur5e.yaml"), "robots": [robot]}
    path = tmp_path / "my_cell.yaml"
    path.write_text(yaml.safe_dump(scenario))
    return path


def test_a_urdf_outside_the_package_runs_a_cell(tmp_path):
    path = _own_cell(tmp_path)
    cell = build_cell(load_scenario(path))
    instance = cell.plant.GetModelInstanceByName("ur5e")
    assert cell.plant.num_positions(instance) == 8  # six arm joints and two fingers
    result = simulate(cell, 6.0)
    safety = result.metrics["safety"]
    assert safety["verdict_code"] == "safe", safety["verdict"]
    assert judge_values(load_scenario(path), path)[1] is None  # the standard judge, unchanged


def test_a_faster_stop_than_assumed_is_the_scenarios_claim(tmp_path):
    path = _own_cell(tmp_path, stopping_deceleration=8.0)
    scenario = load_scenario(path)
    standard, changed = judge_values(scenario, path)
    assert standard.deceleration == 5.0 and changed.deceleration == 8.0
    assert any("deceleration 8" in d for d in safety_departures(scenario, path))


def test_a_slower_stop_makes_the_standard_judge_stricter(tmp_path):
    path = _own_cell(tmp_path, stopping_deceleration=2.5)
    standard, changed = judge_values(load_scenario(path), path)
    assert standard.deceleration == 2.5 and changed is None


@pytest.mark.parametrize("fields, where", [
    ({"urdf": "nowhere.urdf"}, "robots[0].urdf"),
    ({"model": "ur5e"}, "robots[0].model"),
    ({"chains": [{"name": "arm", "tool_frame": "tool9"}]}, "robots[0].chains[0].tool_frame"),
    ({"mode": "dynamic", "urdf": "stripped.urdf"}, "robots[0].mode"),
])
def test_validate_refuses_a_bad_own_robot_naming_the_field(tmp_path, fields, where):
    path = _own_cell(tmp_path)
    text = (tmp_path / "my_cobot.urdf").read_text()
    start, end = text.index("<transmission"), text.rindex("</transmission>") + len("</transmission>")
    (tmp_path / "stripped.urdf").write_text(text[:start] + text[end:])
    data = yaml.safe_load(path.read_text())
    data["robots"][0].update(fields)
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert err.value.field == where, str(err.value)


def test_what_the_judge_takes_unchecked_makes_the_verdict_non_conforming(tmp_path):
    """Masses far lighter than the robot's capsules (placeholder inertials, or a scenario making
    its robot's effective mass small) are the scenario's claim: named, and the verdict says so."""
    import re

    path = _own_cell(tmp_path)
    urdf = tmp_path / "my_cobot.urdf"
    urdf.write_text(re.sub(r'<mass value="[0-9.e-]+"/>', '<mass value="0.01"/>', urdf.read_text()))
    scenario = load_scenario(path)
    claims = [d for d in safety_departures(scenario, path) if "kg/m^3" in d]
    assert len(claims) == 1 and claims[0].startswith("robot 'ur5e'")
    result = simulate(build_cell(scenario), 2.0)
    safety = result.metrics["safety"]
    assert safety["verdict_code"] == "non_conforming" and "kg/m^3" in safety["verdict"]
