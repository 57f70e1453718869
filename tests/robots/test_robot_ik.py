"""Tool-position IK of the YuMi and IRB 140 arms."""

import numpy as np
import pytest
from pydrake.math import RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant

from hrc_drake.robots.ik import InfeasibleTarget, solve_tool_position
from hrc_drake.robots.models import add_robot, arm_joint_limits, arm_position_indices
from hrc_drake.robots.registry import ROBOT_MODELS

YUMI_BASE = np.array([0.0, 0.0, 0.75])


@pytest.fixture(scope="module")
def cell():
    plant = MultibodyPlant(0.0)
    yumi = add_robot(plant, "yumi", "yumi", YUMI_BASE)
    irb = add_robot(plant, "irb140", "irb", (1.5, 0.0, 0.0), (0.0, 0.0, np.pi))
    plant.Finalize()
    return plant, yumi, irb


def _tool_after(plant, context, instance, model, arm, q_arm):
    ctx = plant.CreateDefaultContext()
    q = plant.GetPositions(context).copy()
    q[arm_position_indices(plant, instance, model, arm)] = q_arm
    plant.SetPositions(ctx, q)
    return plant.GetFrameByName(ROBOT_MODELS[model].arm(arm).tool_frame, instance).CalcPoseInWorld(ctx)


@pytest.mark.parametrize(("arm", "target"), [("right", (0.40, -0.20, 0.90)), ("left", (0.35, 0.25, 0.85))])
def test_yumi_reaches_target_in_front(cell, arm, target):
    plant, yumi, _ = cell
    context = plant.CreateDefaultContext()
    q_arm = solve_tool_position(plant, context, yumi, "yumi", arm, target, tool_z_down=True, tolerance=0.005)
    lower, upper, _ = arm_joint_limits(plant, yumi, "yumi", arm)
    assert q_arm.shape == (7,) and np.all(q_arm >= lower - 1e-9) and np.all(q_arm <= upper + 1e-9)
    X = _tool_after(plant, context, yumi, "yumi", arm, q_arm)
    assert np.linalg.norm(X.translation() - target) <= 0.005
    assert X.rotation().matrix()[:, 2] @ [0, 0, -1] > np.cos(0.06)  # tool pointing down


def test_yumi_orientation_target_and_other_joints_fixed(cell):
    plant, yumi, _ = cell
    context = plant.CreateDefaultContext()
    q0 = np.zeros(plant.num_positions())
    left = arm_position_indices(plant, yumi, "yumi", "left")
    q0[left] = [-0.4, -0.5, 0.2, 0.3, 0.1, 0.4, 0.0]
    plant.SetPositions(context, q0)
    target, rpy = np.array([0.45, -0.15, 0.95]), (np.pi, 0.0, np.pi / 2)
    q_arm = solve_tool_position(plant, context, yumi, "yumi", "right", target, target_rpy=rpy)
    X = _tool_after(plant, context, yumi, "yumi", "right", q_arm)
    assert np.linalg.norm(X.translation() - target) <= 0.005
    R_err = X.rotation().inverse().multiply(RollPitchYaw(rpy).ToRotationMatrix())
    assert R_err.ToAngleAxis().angle() < 0.021
    np.testing.assert_array_equal(plant.GetPositions(context), q0)  # the caller's context untouched


def test_same_seed_same_solution(cell):
    plant, yumi, _ = cell
    context = plant.CreateDefaultContext()
    kwargs = dict(target_xyz=(0.3, -0.3, 1.0), q_seed=np.full(7, 0.1), seed=3)
    q1 = solve_tool_position(plant, context, yumi, "yumi", "right", **kwargs)
    q2 = solve_tool_position(plant, context, yumi, "yumi", "right", **kwargs)
    np.testing.assert_array_equal(q1, q2)


def test_far_target_raises_infeasible(cell):
    plant, yumi, _ = cell
    context = plant.CreateDefaultContext()
    target = YUMI_BASE + [2.0, 0.0, 0.3]
    with pytest.raises(InfeasibleTarget, match="best distance reached") as info:
        solve_tool_position(plant, context, yumi, "yumi", "right", target)
    assert isinstance(info.value, ValueError)
    best = float(str(info.value).split("best distance reached ")[1].split(" m")[0])
    # j1 is 1.959 m from the target and j1 -> tool is at most 0.104 + 0.709 m (KINEMATICS.md 1.2)
    assert 1.959 - 0.813 - 0.005 < best < 1.25


def test_irb140_reaches_floor_target(cell):
    plant, _, irb = cell
    context = plant.CreateDefaultContext()
    target = np.array([0.9, 0.1, 0.3])  # 0.6 m in front of the IRB 140 (its base faces -x)
    q_arm = solve_tool_position(plant, context, irb, "irb140", "arm", target, tool_z_down=True)
    assert (
        np.linalg.norm(_tool_after(plant, context, irb, "irb140", "arm", q_arm).translation() - target)
        <= 0.005
    )


def test_bad_inputs(cell):
    plant, yumi, _ = cell
    context = plant.CreateDefaultContext()
    with pytest.raises(ValueError, match="target_xyz"):
        solve_tool_position(plant, context, yumi, "yumi", "right", (0.4, np.nan, 0.9))
    with pytest.raises(ValueError, match="q_seed"):
        solve_tool_position(plant, context, yumi, "yumi", "right", (0.4, 0.0, 0.9), q_seed=[0.0] * 6)
    with pytest.raises(ValueError, match="no arm"):
        solve_tool_position(plant, context, yumi, "yumi", "middle", (0.4, 0.0, 0.9))
