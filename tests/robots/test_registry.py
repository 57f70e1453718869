"""The robot registry: one record per model, read by everything that needs a model's facts."""

import pytest

from hrc_drake.robots.models import model_resource
from hrc_drake.robots.registry import ROBOT_MODELS, ArmModel, RobotModel, get_robot_model


def test_every_record_is_consistent_and_has_its_urdf():
    assert set(ROBOT_MODELS) == {"yumi", "irb140", "cart", "ur5e", "panda"}
    for name, record in ROBOT_MODELS.items():
        assert record.name == name
        text = model_resource(record.urdf).read_text()
        assert f'<robot name="{name}"' in text
        assert f'name="{record.root_link}"' in text
        for arm in record.arms:
            assert arm.num_joints == record.num_joints(arm.name) == len(arm.joints) > 0
            for joint in (*arm.joints, *arm.gripper_joints):
                assert f'name="{joint}"' in text and joint in record.pd_gains
            assert f'name="{arm.tool_frame}"' in text
        for capsule in record.capsules:
            assert f'name="{capsule.body}"' in text and capsule.radius > 0
        assert record.static_bodies <= {c.body for c in record.capsules}


def test_joints_per_arm():
    assert get_robot_model("yumi").arm_names == ("right", "left")
    assert [get_robot_model("yumi").num_joints(a) for a in ("left", "right")] == [7, 7]
    assert get_robot_model("irb140").arm_names == ("arm",)
    assert get_robot_model("irb140").num_joints("arm") == 6
    assert get_robot_model("cart").arm_names == ("rail",) and get_robot_model("cart").num_joints("rail") == 1


def test_unknown_model_and_arm_name_the_known_ones():
    known = "cart, irb140, panda, ur5e, yumi"
    with pytest.raises(ValueError, match=rf"unknown robot model 'ur5'; known models: {known}"):
        get_robot_model("ur5")
    with pytest.raises(ValueError, match=r"has no arm 'left'; arms: \['arm'\]"):
        get_robot_model("irb140").arm("left")


def test_a_record_checks_itself():
    arm = ArmModel("arm", ("j1", "j2"), "tool")
    with pytest.raises(ValueError, match="no PD gains"):
        RobotModel("bot", "bot.urdf", "base", (arm,), pd_gains={"j1": (1.0, 0.1)})
    with pytest.raises(ValueError, match="at least one arm"):
        RobotModel("bot", "bot.urdf", "base", ())
    gains = {"j1": (1.0, 0.1), "j2": (1.0, 0.1)}
    with pytest.raises(ValueError, match="stopping_deceleration must be > 0"):
        RobotModel("bot", "bot.urdf", "base", (arm,), pd_gains=gains)  # the judge needs its stop
    record = RobotModel("bot", "bot.urdf", "base", (arm,), pd_gains=gains, stopping_deceleration=5.0)
    with pytest.raises(TypeError):
        record.pd_gains["j3"] = (0.0, 0.0)  # read-only
