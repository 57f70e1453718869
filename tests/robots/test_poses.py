"""solve_named_poses: the robots' named poses as joint vectors, errors naming the field."""

import numpy as np
import pytest

from hrc_drake.config_common import Pose
from hrc_drake.errors import ConfigError, ScenarioError
from hrc_drake.robots.config import NamedPose, Robot
from hrc_drake.robots.poses import solve_named_poses


def _irb(*poses, name="irb"):
    return Robot(name=name, model="irb140", base=Pose(xyz=[0.0, 0.0, 0.0]), poses=list(poses))


def test_joint_and_cartesian_poses():
    robot = _irb(
        NamedPose(name="home", arm="arm", joints=[0.0, 0.2, -0.3, 0.0, 0.5, 0.0]),
        NamedPose(name="reach", arm="arm", target=Pose(xyz=[0.5, 0.1, 0.4])),
    )
    solved = solve_named_poses([robot])
    np.testing.assert_allclose(solved[("irb", "home")], [0.0, 0.2, -0.3, 0.0, 0.5, 0.0])
    assert solved[("irb", "reach")].shape == (6,)


def test_errors_name_the_field():
    bad_joint = _irb(NamedPose(name="home", arm="arm", joints=[0.0, 0.2, -0.3, 0.0, 3.0, 0.0]))
    with pytest.raises(ConfigError) as info:
        solve_named_poses([bad_joint])
    assert info.value.field == "robots[0].poses[0].joints[4]"
    assert "outside the joint's limits" in str(info.value)
    with pytest.raises(ScenarioError) as info:
        solve_named_poses([_irb(name="other"), bad_joint], "cell.yaml", field="cell.robots")
    assert info.value.file == "cell.yaml" and info.value.field == "cell.robots[1].poses[0].joints[4]"
    far = _irb(NamedPose(name="far", arm="arm", target=Pose(xyz=[3.0, 0.0, 0.5])))
    with pytest.raises(ScenarioError, match="out of reach") as info:
        solve_named_poses([far], "cell.yaml")
    assert info.value.field == "robots[0].poses[0].target"
    with pytest.raises(ConfigError, match="known models: cart, irb140, panda, ur5e, yumi") as info:
        solve_named_poses([Robot(name="x", model="ur5")])
    assert info.value.field == "robots[0].model"
    with pytest.raises(ConfigError, match="unknown arm 'left' of irb140") as info:
        solve_named_poses([_irb(NamedPose(name="p", arm="left", joints=[0.0] * 6))])
    assert info.value.field == "robots[0].poses[0].arm"


def test_an_approach_picks_the_reaching_posture_of_lowest_effective_mass():
    """The YuMi's right arm (7 joints: many postures reach a point) placing down onto a hand: with an
    approach along -z the chosen posture's m_R along it is the lowest of the reaching postures the
    IK found, lower than the first one found (measured 3.35 against 4.73 kg)."""
    from pydrake.multibody.plant import MultibodyPlant

    from hrc_drake.robots.ik import lowest_mass_posture
    from hrc_drake.robots.models import add_robots, arm_position_indices
    from hrc_drake.robots.registry import get_robot_model

    def yumi(*poses):
        return Robot(name="yumi", model="yumi", base=Pose(xyz=[0.0, 0.0, 0.0]), poses=list(poses))

    target = Pose(xyz=[0.45, -0.15, 0.25])
    first = solve_named_poses([yumi(NamedPose(name="give", arm="right", target=target))])
    light = solve_named_poses([yumi(NamedPose(name="give", arm="right", target=target,
                                              approach=[0.0, 0.0, -2.0]))])
    plant = MultibodyPlant(0.0)
    (instance, _), = add_robots(plant, [yumi()])
    plant.Finalize()
    tool = plant.GetFrameByName(get_robot_model("yumi").arm("right").tool_frame, instance)
    index = arm_position_indices(plant, instance, "yumi", "right")
    postures = np.zeros((2, plant.num_positions()))
    postures[0, index], postures[1, index] = first[("yumi", "give")], light[("yumi", "give")]
    _, masses = lowest_mass_posture(plant, tool, postures, (0.0, 0.0, -1.0))
    assert masses[1] < masses[0]
    # bad approaches name the field
    for bad in ([0.0, 0.0, 0.0], [1.0, 0.0], [float("nan"), 0.0, 1.0]):
        with pytest.raises(ConfigError, match="approach") as info:
            solve_named_poses([yumi(NamedPose(name="give", arm="right", target=target, approach=bad))])
        assert info.value.field == "robots[0].poses[0].approach"
    with pytest.raises(ConfigError, match="joints has none to choose"):
        solve_named_poses([yumi(NamedPose(name="p", arm="right", joints=[0.0] * 7,
                                          approach=[0.0, 1.0, 0.0]))])
