"""Both robots on a discrete plant with the implicit PD actuators hold their pose under gravity."""

import numpy as np
import pytest
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from hrc_drake.robots.models import add_robot, arm_position_indices, set_pd_gains


def _build(time_step):
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step)
    yumi = add_robot(plant, "yumi", "yumi", (0.0, 0.0, 0.75))
    irb = add_robot(plant, "irb140", "irb", (1.5, 0.0, 0.0))
    set_pd_gains(plant, yumi, model="yumi")  # the registry's gains, as the cell builder uses them
    set_pd_gains(plant, irb)  # model=None: the record whose gains name the joints
    plant.Finalize()
    # the pose held: YuMi arms bent in front of the body, IRB 140 elbow up
    q_desired = np.zeros(plant.num_positions())
    for arm, sign in (("right", 1.0), ("left", -1.0)):
        q_desired[arm_position_indices(plant, yumi, "yumi", arm)] = [
            sign * 0.5,
            -0.6,
            0.0,
            0.3,
            0.0,
            0.6,
            0.0,
        ]
    q_desired[arm_position_indices(plant, irb, "irb140", "arm")] = [0.2, 0.3, -0.4, 0.0, 0.5, 0.0]
    for instance in (yumi, irb):
        actuated = [plant.get_joint_actuator(i).joint() for i in plant.GetJointActuatorIndices(instance)]
        x_d = np.concatenate([[q_desired[j.position_start()] for j in actuated], np.zeros(len(actuated))])
        source = builder.AddSystem(ConstantVectorSource(x_d))
        builder.Connect(source.get_output_port(), plant.get_desired_state_input_port(instance))
        builder.Connect(
            builder.AddSystem(ConstantVectorSource(np.zeros(len(actuated)))).get_output_port(),
            plant.get_actuation_input_port(instance),
        )
    diagram = builder.Build()
    return diagram, plant, q_desired


@pytest.mark.parametrize("time_step", [0.001, 0.01])
def test_pd_hold_under_gravity(time_step):
    diagram, plant, q_desired = _build(time_step)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, q_desired)
    simulator.AdvanceTo(0.2)
    q = plant.GetPositions(plant_context)
    v = plant.GetVelocities(plant_context)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(v))
    assert np.max(np.abs(v)) < 0.2  # settled, nothing is flying away
    revolute = np.ones(plant.num_positions(), dtype=bool)
    for name in ("gripper_r_joint", "gripper_r_joint_m", "gripper_l_joint", "gripper_l_joint_m"):
        revolute[plant.GetJointByName(name).position_start()] = False
    # gravity sag of a PD joint is torque / kp: a few hundredths of a radian here
    assert np.max(np.abs(q - q_desired)[revolute]) < 0.03
    assert np.max(np.abs(q - q_desired)[revolute]) > 1e-5  # gravity really acts
    assert np.all(np.abs(q[~revolute]) < 2e-3)  # fingers held closed


def test_without_control_the_arms_fall():
    """The same plant with zero gains: gravity pulls the YuMi shoulder joints away (sanity of the test)."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, 0.01)
    yumi = add_robot(plant, "yumi", "yumi", (0.0, 0.0, 0.75))
    plant.Finalize()
    diagram = builder.Build()
    simulator = Simulator(diagram)
    plant_context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.get_actuation_input_port(yumi).FixValue(plant_context, np.zeros(plant.num_actuators()))
    simulator.AdvanceTo(0.2)
    q = plant.GetPositions(plant_context)
    assert np.all(np.isfinite(q))
    assert np.max(np.abs(q[arm_position_indices(plant, yumi, "yumi", "right")])) > 0.05


def test_pd_gain_errors():
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, 0.01)
    irb = add_robot(plant, "irb140", "irb")
    with pytest.raises(ValueError, match="needs 1 or 6 values"):
        set_pd_gains(plant, irb, kp=[1.0, 2.0])
    with pytest.raises(ValueError, match=">= 0"):
        set_pd_gains(plant, irb, kp=-1.0)
    set_pd_gains(plant, irb, kp=[1, 2, 3, 4, 5, 6], kd=0.5)
    plant.Finalize()
    gains = [plant.get_joint_actuator(i).get_controller_gains() for i in plant.GetJointActuatorIndices(irb)]
    assert [g.p for g in gains] == [1, 2, 3, 4, 5, 6] and all(g.d == 0.5 for g in gains)
    with pytest.raises(ValueError, match="finalized"):
        set_pd_gains(plant, irb)
