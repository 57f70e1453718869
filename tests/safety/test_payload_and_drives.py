"""Issue 51, item 3: the robot's effective mass holds its drives and the parts it carries.

The YuMi URDF states its drives (a 100:1 gear; rotors 2.0e-5 and 5.0e-6 kg m^2, an assumption:
ABB publishes none), so the plant's mass matrix holds N^2 I_r on each arm joint's diagonal; an arm
carries the heaviest part among the buffers its actions take from or put into, and the judge and
the controller both add it to m_R (eq. A.5)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from hrc_drake.cell.build import build_cell
from hrc_drake.cell.scenario import ScenarioError, arm_payloads, load_scenario, load_scenario_with

REPO = Path(__file__).resolve().parents[2]
PCB_IC = REPO / "diagrams" / "pcb_ic.yaml"


def _yumi_mass_matrix(text: str) -> tuple[np.ndarray, MultibodyPlant]:
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(text, "urdf")
    plant.Finalize()
    return plant.CalcMassMatrix(plant.CreateDefaultContext()), plant


def test_the_yumi_mass_matrix_holds_the_reflected_inertia_of_its_drives():
    text = (REPO / "models" / "yumi.urdf").read_text()
    without = re.sub(r"<drake:(rotor_inertia|gear_ratio) value=\"[^\"]*\"/>", "", text)
    assert without != text
    with_drives, plant = _yumi_mass_matrix(text)
    bare, _ = _yumi_mass_matrix(without)
    reflected = np.diag(with_drives - bare)
    for side in ("r", "l"):
        for axis, expected in (("1", 0.2), ("2", 0.2), ("7", 0.2), ("3", 0.2), ("4", 0.05), ("5", 0.05),
                               ("6", 0.05)):
            # hand-worked: N^2 I_r = 100^2 x 2.0e-5 = 0.2 and 100^2 x 5.0e-6 = 0.05 kg m^2
            index = plant.GetJointByName(f"yumi_joint_{axis}_{side}").velocity_start()
            assert reflected[index] == pytest.approx(expected, rel=1e-9)
    # nothing else changed: the fingers have no drive, off-diagonal terms stay the link's
    np.testing.assert_allclose(with_drives - bare - np.diag(reflected), 0.0, atol=1e-12)


def test_an_arm_carries_the_heaviest_part_it_handles():
    scenario = load_scenario(PCB_IC)
    # every buffer of pcb_ic holds 0.05 kg parts; the operator's actions are not the robot's
    assert arm_payloads(scenario)["yumi_right"] == pytest.approx(0.05)
    scenario.layout.buffers[[b.name for b in scenario.layout.buffers].index("caps")].part_mass = 0.4
    payloads = arm_payloads(scenario)
    assert payloads["yumi_right"] == pytest.approx(0.4)  # R_cap takes from caps
    assert payloads["human"] == pytest.approx(0.05)


def test_the_judge_and_the_controller_of_a_built_cell_carry_the_parts():
    cell = build_cell(load_scenario(PCB_IC), PCB_IC)
    monitor = cell.diagram.GetSubsystemByName("safety_monitor")
    judge = monitor.judges[0]
    names = list(judge.link_names)
    payload = dict(zip(names, judge.payloads, strict=True))
    assert payload["yumi/gripper_r_base"] == pytest.approx(0.05)
    assert payload["yumi/yumi_link_3_r"] == pytest.approx(0.05)
    assert payload["yumi/yumi_body"] == 0.0  # welded: no arm moves it
    # the left arm does nothing in pcb_ic's flow: it carries nothing
    assert payload["yumi/gripper_l_base"] == 0.0
    controller = cell.diagram.GetSubsystemByName("safety_controller")
    np.testing.assert_allclose(controller.rules.payloads, judge.payloads)
    # the capsules' structure for the clamping test (`SafetyRules.near_pairs`): one robot, and a
    # gripper joined to its wrist link only
    index = {name: k for k, name in enumerate(names)}
    joined = controller.rules.joined_capsules
    gripper = index["yumi/gripper_r_base"]
    assert len(set(controller.rules.capsule_robots.tolist())) == 1
    assert joined[gripper, index["yumi/yumi_link_7_r"]] and joined[gripper, gripper]
    assert not joined[gripper, index["yumi/yumi_link_6_r"]]
    assert not joined[gripper, index["yumi/gripper_l_base"]]


@pytest.mark.parametrize("mass", [-0.1, 101.0, float("nan")])
def test_a_part_mass_out_of_range_is_refused(mass):
    with pytest.raises(ScenarioError, match=r"layout\.buffers\[0\]\.part_mass"):
        load_scenario_with(PCB_IC, {"layout": {"buffers": [
            {"name": "pcbs", "kind": "raw", "part_mass": mass, "position": [0.74, 0.36, 0.76]}]}})


def test_the_standards_m_is_the_moving_arm_not_the_robot():
    from hrc_drake.safety.systems import arm_masses

    # M of eq. (A.5) for the right gripper: the links outboard of axis 1 of the right arm in
    # models/yumi.urdf, 1.5 + 1.2 + 1 + 1 + 0.8 + 0.5 + 0.1 + 0.2 + 0.02 + 0.02 + 0.001 = 6.341 kg
    # (not the welded body's 25 kg nor the other arm); the body, welded, is its own 25 kg
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString((REPO / "models" / "yumi.urdf").read_text(), "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("yumi_base_link"))  # as a cell does
    plant.Finalize()
    bodies = [plant.GetBodyByName(name).index() for name in ("gripper_r_base", "yumi_link_4_l", "yumi_body")]
    assert arm_masses(plant, bodies) == pytest.approx([6.341, 6.341, 25.0])
