"""numpy SerialChain against Drake's MultibodyPlant built by `add_robot` (poses, capsules, points)."""

import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant

from hrc_drake.robots.chain import SerialChain, pose_matrix
from hrc_drake.robots.models import RobotCapsuleKinematics, add_robot, arm_position_indices

BASE_XYZ, BASE_RPY = (0.4, -0.3, 0.75), (0.1, -0.2, 0.6)
CASES = [("yumi", "left"), ("yumi", "right"), ("irb140", "arm"), ("cart", "rail")]


@pytest.fixture(scope="module", params=CASES, ids=[f"{m}-{a}" for m, a in CASES])
def case(request):
    model, arm = request.param
    plant = MultibodyPlant(0.0)
    instance = add_robot(plant, model, "robot", BASE_XYZ, BASE_RPY)
    plant.Finalize()
    chain = SerialChain.from_model(model, arm, base_pose=(BASE_XYZ, BASE_RPY), include_static=True)
    return plant, instance, chain


def random_q(chain, rng, size):
    return rng.uniform(chain.lower, chain.upper, size=(size, chain.num_joints))


def drake_poses(plant, instance, chain, q):
    context = plant.CreateDefaultContext()
    positions = plant.GetPositions(context)
    positions[arm_position_indices(plant, instance, chain.model, chain.arm)] = q
    plant.SetPositions(context, positions)
    return context, np.array(
        [plant.GetFrameByName(b, instance).CalcPoseInWorld(context).GetAsMatrix4() for b in chain.bodies]
    )


def test_body_poses_match_drake(case):
    plant, instance, chain = case
    qs = random_q(chain, np.random.default_rng(1), 6)
    ours = chain.link_poses(qs.reshape(2, 3, -1)).reshape(6, len(chain.bodies), 4, 4)  # batched
    for q, X in zip(qs, ours, strict=True):
        _, expected = drake_poses(plant, instance, chain, q)
        np.testing.assert_allclose(X, expected, atol=1e-9)
        np.testing.assert_allclose(chain.link_poses(q), expected, atol=1e-9)  # unbatched


def test_joint_limits_match_drake(case):
    plant, instance, chain = case
    joints = [plant.GetJointByName(j, instance) for j in chain.joints]
    np.testing.assert_array_equal(chain.lower, [j.position_lower_limits()[0] for j in joints])
    np.testing.assert_array_equal(chain.upper, [j.position_upper_limits()[0] for j in joints])


def test_capsules_match_robot_capsule_kinematics(case):
    plant, instance, chain = case
    kin = RobotCapsuleKinematics(plant, [(instance, chain.model)], include_static=True)
    rows = [kin.names.index(f"robot/{b}") for b in chain.capsule_bodies]
    qs = random_q(chain, np.random.default_rng(2), 4)
    starts, ends, radii = chain.capsules(qs)
    assert starts.shape == ends.shape == (4, len(rows), 3) and radii.shape == (len(rows),)
    for k, q in enumerate(qs):
        context, _ = drake_poses(plant, instance, chain, q)
        s, e, r = kin.capsules(context)
        np.testing.assert_allclose(starts[k], s[rows], atol=1e-9)
        np.testing.assert_allclose(ends[k], e[rows], atol=1e-9)
        np.testing.assert_array_equal(radii, r[rows])


def test_arm_capsules_exclude_the_other_arm_and_static_bodies():
    left = SerialChain.from_model("yumi", "left")
    assert left.capsule_bodies == tuple(f"yumi_link_{i}_l" for i in range(1, 8)) + ("gripper_l_base",)
    with_body = SerialChain.from_model("yumi", "left", include_static=True)
    assert with_body.capsule_bodies == ("yumi_body", *left.capsule_bodies)
    assert SerialChain.from_model("irb140", "arm").capsule_bodies[0] == "irb140_link_1"


def test_points_are_body_origins_and_offsets(case):
    plant, instance, chain = case
    q = random_q(chain, np.random.default_rng(3), 1)[0]
    context, _ = drake_poses(plant, instance, chain, q)
    tool = plant.GetFrameByName(chain.tool_frame, instance).CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(chain.points(q, ["tool"])[0], tool, atol=1e-9)
    if chain.num_joints >= 3:
        elbow_link = plant.GetJointByName(chain.joints[(chain.num_joints - 1) // 2], instance).child_body()
        np.testing.assert_allclose(
            chain.points(q, ["elbow"])[0], elbow_link.EvalPoseInWorld(context).translation(), atol=1e-9
        )
    offset = np.array([0.01, -0.02, 0.03])
    extra = SerialChain.from_model(chain.model, chain.arm, (BASE_XYZ, BASE_RPY),
                                   extra_points={"probe": (chain.tool_frame, offset)})
    X = plant.GetFrameByName(chain.tool_frame, instance).CalcPoseInWorld(context)
    np.testing.assert_allclose(extra.points(q, ["probe"])[0], X.multiply(offset), atol=1e-9)


def test_yumi_named_points_and_base_matrix():
    chain = SerialChain.from_model("yumi", "left", base_pose=pose_matrix(BASE_XYZ, BASE_RPY))
    same = SerialChain.from_model("yumi", "left", base_pose=(BASE_XYZ, BASE_RPY))
    q = np.zeros((2, 5, 7))
    np.testing.assert_array_equal(chain.points(q, ["elbow", "wrist", "tool"]),
                                  same.points(q, ["elbow", "wrist", "tool"]))
    assert chain.control_points["elbow"][0] == chain.bodies.index("yumi_link_4_l")
    assert chain.points(q).shape == (2, 5, 2, 3)
    with pytest.raises(ValueError, match="unknown control points"):
        chain.points(q, ["knee"])
    with pytest.raises(ValueError, match=r"\(\.\.\., 7\)"):
        chain.link_poses(np.zeros(6))
