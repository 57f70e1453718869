"""tools/pick_clear_postures.py: its distance helper by hand, and its picks on box_usb's right arm
reach the poses' tool positions with the clearance it reports."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import load_tool

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tool():
    module = load_tool("pick_clear_postures")
    return module


def test_point_segment_distances_by_hand(tool):
    starts = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    ends = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # the second: a point
    points = np.array([[0.5, 0.3, 0.0], [2.0, 0.0, 0.0], [-1.0, 0.0, 0.4]])
    expected = np.array([[0.3, np.hypot(0.5, 0.3)], [1.0, 2.0], [np.hypot(1.0, 0.4)] * 2])
    assert np.allclose(tool.point_segment_distances(points, starts, ends), expected)


def test_picks_reach_the_tool_positions_with_the_reported_clearance(tool, capsys):
    from pydrake.multibody.plant import MultibodyPlant

    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.robots.models import add_robots
    from hrc_drake.robots.poses import solve_named_poses, tool_position

    scenario_path = REPO / "diagrams" / "box_usb.yaml"
    assert tool.main([str(scenario_path), "right", "--candidates", "6", "--samples", "5"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["clearance_m"] == min(c for _, _, c in result["segments"])
    scenario = load_scenario(scenario_path)
    shipped = solve_named_poses(scenario.robots, scenario_path)
    plant = MultibodyPlant(0.0)
    instance, robot = add_robots(plant, scenario.robots)[0]
    plant.Finalize()
    context = plant.CreateDefaultContext()
    assert set(result["poses"]) == {"r_home", "r_covers", "r_wait", "r_station"}
    for name, joints in result["poses"].items():
        picked = tool_position(plant, context, instance, robot.model, "right", np.array(joints))
        wanted = tool_position(plant, context, instance, robot.model, "right", shipped[("yumi", name)])
        assert np.linalg.norm(np.subtract(picked, wanted)) < 0.01, name


@pytest.mark.parametrize("args, message", [
    (["right", "--home", "0.2,nan,0.9"], "--home: three finite numbers"),
    (["right", "--home", "0.2,0.9"], "--home: three finite numbers"),
    (["right", "--home", "a,b,c"], "--home: three finite numbers"),
    (["right", "--robot", "ur5"], "--robot: no robot 'ur5'"),
    (["elbow"], "arm 'elbow' needs a home and an action"),
    (["right", "--restarts", "0"], "--restarts: at least 1"),
    (["right", "--samples", "1"], "--samples: at least 2"),
])
def test_bad_arguments_are_refused_with_the_reason(tool, capsys, args, message):
    with pytest.raises(SystemExit) as exit_info:
        tool.main([str(REPO / "diagrams" / "box_usb.yaml"), *args])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
