"""The replay explains its run (issue 54, item 6): its card holds the safety verdict and the
products, its legend names the depth camera and the buffers, its first view frames the cell."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hrc_drake.cell.replay import MESHCAT_FOV_DEG, ReplayMarkers, add_overlay, initial_view
from hrc_drake.cell.scenario import load_scenario
from tests.conftest import DIAGRAMS

PAGE = "<html><head><title>Drake MeshCat</title></head><body><div id='meshcat'></div></body></html>"


def _card(html: str) -> str:
    return html[html.index('id="hrc-overlay"'):html.index('id="hrc-legend"')]


def test_the_card_holds_the_verdict_and_the_products():
    verdict = "UNSAFE: ISO/TS 15066 ssm, conforming judge: 2 violations (2 SSM breaches 0.4 s) in 300 s"
    html = add_overlay(PAGE, "torch_clock", "a cell", 7, 300.0, verdict=verdict,
                       products={"products_finished": 8, "products_per_hour": 96.0})
    card = _card(html)
    assert verdict in card and "8 products finished (96.0 per hour)" in card
    assert "color:#c01818" in card  # an unsafe run's verdict in red
    safe = _card(add_overlay(PAGE, "c", "", 1, 10.0, verdict="SAFE: <all> fine",
                             products={"products_finished": 1, "products_per_hour": 360.0}))
    assert "SAFE: &lt;all&gt; fine" in safe and "color:#1a7f1a" in safe and "1 product finished" in safe
    assert "<all>" not in safe  # the verdict's words are text, never markup


def test_the_legend_names_the_depth_camera_and_the_buffers():
    scenario = load_scenario(DIAGRAMS / "torch_clock.yaml")
    labels = [label for label, _ in ReplayMarkers(scenario, None, 10.0, False, False).legend()]
    assert any(label.startswith("depth camera") for label in labels), labels
    assert any(label.startswith("buffers") for label in labels), labels


@pytest.mark.parametrize("name", sorted(p.name for p in DIAGRAMS.glob("*.yaml")))
def test_the_first_view_sees_every_robot_the_table_the_operator_and_the_camera(name):
    """Every robot's base and 0.6 m above it, the operator's feet and head (1.8 m), the table's
    corners and the camera lie inside the view cone (half the vertical field of view: the
    horizontal one of a landscape window is wider)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scenario = load_scenario(DIAGRAMS / name)
    position, target = initial_view(scenario)
    t = scenario.layout.table
    points = [[t.center[0] + sx * t.size[0] / 2, t.center[1] + sy * t.size[1] / 2, t.height]
              for sx in (-1, 1) for sy in (-1, 1)]
    for robot in scenario.robots:
        points += [robot.base.xyz, np.add(robot.base.xyz, [0.0, 0.0, 0.6])]
    base = scenario.operator.base.xyz
    points += [base, np.add(base, [0.0, 0.0, 1.8]), scenario.layout.camera.position]
    axis = (target - position) / np.linalg.norm(target - position)
    rays = np.asarray(points, float) - position
    angles = np.degrees(np.arccos(rays @ axis / np.linalg.norm(rays, axis=1)))
    assert angles.max() < MESHCAT_FOV_DEG / 2, (name, angles.round(1))
