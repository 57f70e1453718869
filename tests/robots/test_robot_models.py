"""YuMi / IRB 140 models against docs/KINEMATICS.md (tables 1.2, 1.3, 2.2, 2.5)."""

import numpy as np
import pytest
from pydrake.geometry import SceneGraph
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from hrc_drake.robots.models import (
    RobotCapsuleKinematics,
    add_robot,
    arm_position_indices,
    gripper_position_indices,
    link_capsules,
    model_file,
)
from hrc_drake.robots.registry import ROBOT_MODELS


def arm_joints(model):  # arm name -> joints in chain order, from the registry
    return {a.name: list(a.joints) for a in ROBOT_MODELS[model].arms}


def tool_frame(model, arm):
    return ROBOT_MODELS[model].arm(arm).tool_frame


def gripper_joints(model, arm):
    return list(ROBOT_MODELS[model].arm(arm).gripper_joints)

YUMI_BASE = (0.3, -0.2, 0.75)
IRB_BASE = (2.0, 1.0, 0.0)


@pytest.fixture(scope="module")
def kinematic_plant():
    """A continuous plant with one YuMi (on a table top, no yaw) and one IRB 140 (on the floor)."""
    plant = MultibodyPlant(0.0)
    yumi = add_robot(plant, "yumi", "yumi", YUMI_BASE, (0.0, 0.0, 0.0))
    irb = add_robot(plant, "irb140", "irb", IRB_BASE, (0.0, 0.0, 0.0))
    plant.Finalize()
    return plant, yumi, irb


@pytest.fixture()
def zero_context(kinematic_plant):
    plant, _, _ = kinematic_plant
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, np.zeros(plant.num_positions()))
    return context


# KINEMATICS.md 1.2: zero-configuration joint origins in the YuMi body frame (computed there).
YUMI_ORIGINS = {
    "r": {
        "1": (0.0536, -0.0725, 0.4149),
        "2": (0.1178, -0.1253, 0.4780),
        "7": (0.2756, -0.1658, 0.5431),
        "3": (0.3636, -0.1668, 0.5576),
        "4": (0.4905, -0.0787, 0.4880),
        "5": (0.5259, -0.0072, 0.4213),
        "6": (0.5645, 0.0015, 0.4184),
        "gripper": (0.5685, 0.0059, 0.4146),
        "tip": (0.6461, 0.0901, 0.3415),
    },
    "l": {
        "1": (0.0536, 0.0725, 0.4149),
        "2": (0.1178, 0.1252, 0.4781),
        "7": (0.2756, 0.1658, 0.5431),
        "3": (0.3636, 0.1669, 0.5574),
        "4": (0.4906, 0.0792, 0.4874),
        "5": (0.5260, 0.0080, 0.4204),
        "6": (0.5646, -0.0006, 0.4174),
        "gripper": (0.5686, -0.0050, 0.4136),
        "tip": (0.6463, -0.0888, 0.3401),
    },
}
BODY_IN_BASE = np.array([0.0, 0.0, 0.1])  # yumi_body is 0.1 m above the foot plane (yumi_base_link)

# KINEMATICS.md 1.2 limits (deg) and velocities (deg/s) per ABB axis; 2.2 for the IRB 140.
YUMI_LIMITS = {
    "1": (-168.5, 168.5, 180),
    "2": (-143.5, 43.5, 180),
    "7": (-168.5, 168.5, 180),
    "3": (-123.5, 80, 180),
    "4": (-290, 290, 400),
    "5": (-88, 138, 400),
    "6": (-229, 229, 400),
}
IRB_LIMITS = [
    (-180, 180, 200),
    (-90, 110, 200),
    (-230, 50, 260),
    (-200, 200, 360),
    (-115, 115, 360),
    (-400, 400, 450),
]


def _world(point_in_base, base_xyz):
    return np.asarray(base_xyz) + BODY_IN_BASE + np.asarray(point_in_base)


@pytest.mark.parametrize("side", ["r", "l"])
def test_yumi_zero_configuration_joint_origins(kinematic_plant, zero_context, side):
    plant, yumi, _ = kinematic_plant
    for axis in ("1", "2", "7", "3", "4", "5", "6"):
        joint = plant.GetJointByName(f"yumi_joint_{axis}_{side}", yumi)
        p = joint.frame_on_child().CalcPoseInWorld(zero_context).translation()
        expected = _world(YUMI_ORIGINS[side][axis], YUMI_BASE)
        assert np.linalg.norm(p - expected) < 0.002, (axis, side, p, expected)
    gripper = plant.GetBodyByName(f"gripper_{side}_base", yumi).EvalPoseInWorld(zero_context).translation()
    assert np.linalg.norm(gripper - _world(YUMI_ORIGINS[side]["gripper"], YUMI_BASE)) < 0.002
    arm = "right" if side == "r" else "left"
    tool = plant.GetFrameByName(tool_frame("yumi", arm), yumi).CalcPoseInWorld(zero_context).translation()
    assert np.linalg.norm(tool - _world(YUMI_ORIGINS[side]["tip"], YUMI_BASE)) < 0.002
    assert abs(np.linalg.norm(tool - gripper) - 0.136) < 1e-9


def test_yumi_joint_1_axis_direction(kinematic_plant, zero_context):
    """Joint-1 axes of KINEMATICS.md 1.1 (computed: 28 deg above horizontal, +-22.8 deg azimuth)."""
    plant, yumi, _ = kinematic_plant
    for side, sign in (("r", -1), ("l", 1)):
        R = plant.GetJointByName(f"yumi_joint_1_{side}", yumi).frame_on_child().CalcPoseInWorld(zero_context)
        axis = R.rotation().matrix()[:, 2]
        np.testing.assert_allclose(axis, [0.8138, sign * 0.3421, 0.4698], atol=5e-4)


def test_yumi_limits_and_velocities(kinematic_plant):
    plant, yumi, _ = kinematic_plant
    for side in ("r", "l"):
        for axis, (lo, hi, vel) in YUMI_LIMITS.items():
            joint = plant.GetJointByName(f"yumi_joint_{axis}_{side}", yumi)
            assert joint.position_lower_limits()[0] == pytest.approx(np.deg2rad(lo), abs=1e-6)
            assert joint.position_upper_limits()[0] == pytest.approx(np.deg2rad(hi), abs=1e-6)
            assert joint.velocity_upper_limits()[0] == pytest.approx(np.deg2rad(vel), abs=1e-6)
            assert joint.velocity_lower_limits()[0] == pytest.approx(-np.deg2rad(vel), abs=1e-6)
        for name in gripper_joints("yumi", "right" if side == "r" else "left"):
            joint = plant.GetJointByName(name, yumi)
            assert joint.position_lower_limits()[0] == 0.0
            assert joint.position_upper_limits()[0] == pytest.approx(0.025)


def test_irb140_limits_and_velocities(kinematic_plant):
    plant, _, irb = kinematic_plant
    for name, (lo, hi, vel) in zip(arm_joints("irb140")["arm"], IRB_LIMITS, strict=True):
        joint = plant.GetJointByName(name, irb)
        assert joint.position_lower_limits()[0] == pytest.approx(np.deg2rad(lo), abs=1e-6)
        assert joint.position_upper_limits()[0] == pytest.approx(np.deg2rad(hi), abs=1e-6)
        assert joint.velocity_upper_limits()[0] == pytest.approx(np.deg2rad(vel), abs=1e-6)


def test_irb140_zero_configuration(kinematic_plant, zero_context):
    plant, _, irb = kinematic_plant
    base = np.asarray(IRB_BASE)
    expected = {
        "irb140_joint_2": (0.070, 0, 0.352),
        "irb140_joint_3": (0.070, 0, 0.712),
        "irb140_joint_5": (0.450, 0, 0.712),
        "irb140_joint_6": (0.515, 0, 0.712),
    }
    for name, p in expected.items():
        got = plant.GetJointByName(name, irb).frame_on_child().CalcPoseInWorld(zero_context).translation()
        np.testing.assert_allclose(got, base + p, atol=1e-6)
    X_tool = plant.GetFrameByName("irb140_tool", irb).CalcPoseInWorld(zero_context)
    np.testing.assert_allclose(X_tool.translation(), base + (0.515, 0, 0.712), atol=1e-6)
    # tool0 convention: the tool z axis points out of the flange (world +x at zero configuration)
    np.testing.assert_allclose(X_tool.rotation().matrix()[:, 2], [1, 0, 0], atol=1e-6)


def test_actuators_cover_arm_and_finger_joints(kinematic_plant):
    plant, yumi, irb = kinematic_plant
    for instance, model in ((yumi, "yumi"), (irb, "irb140")):
        actuated = {
            plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(instance)
        }
        for arm, joints in arm_joints(model).items():
            assert set(joints) <= actuated
            assert set(gripper_joints(model, arm)) <= actuated
        for i in plant.GetJointActuatorIndices(instance):
            actuator = plant.get_joint_actuator(i)
            if actuator.joint().name().startswith("yumi_joint"):
                assert actuator.effort_limit() == 300.0
    assert plant.num_actuators() == 7 * 2 + 2 * 2 + 6


def test_inertias_are_physical():
    plant = MultibodyPlant(0.001)
    add_robot(plant, "yumi", "yumi")
    add_robot(plant, "irb140", "irb")
    plant.Finalize()
    context = plant.CreateDefaultContext()
    for name in ("yumi", "irb"):
        for index in plant.GetBodyIndices(plant.GetModelInstanceByName(name)):
            body = plant.get_body(index)
            spatial = body.CalcSpatialInertiaInBodyFrame(context)
            assert spatial.get_mass() > 0, body.name()
            assert spatial.IsPhysicallyValid(), body.name()
            eig = np.linalg.eigvalsh(spatial.CalcRotationalInertia().CopyToFullMatrix3())
            assert np.all(eig > 0), body.name()
    total = plant.CalcTotalMass(context, [plant.GetModelInstanceByName("yumi")])
    assert 30.0 < total < 45.0  # the IRB 14000 weighs 38 kg


def test_position_indices(kinematic_plant, zero_context):
    plant, yumi, irb = kinematic_plant
    context = plant.CreateDefaultContext()
    idx = arm_position_indices(plant, yumi, "yumi", "left")
    q = np.zeros(plant.num_positions())
    q[idx] = np.linspace(0.1, 0.7, 7)
    plant.SetPositions(context, q)
    for k, name in enumerate(arm_joints("yumi")["left"]):
        assert plant.GetJointByName(name, yumi).get_angle(context) == pytest.approx(0.1 * (k + 1))
    assert len(set(arm_position_indices(plant, irb, "irb140", "arm")) | set(idx)) == 13
    assert gripper_position_indices(plant, irb, "irb140", "arm").size == 0
    assert gripper_position_indices(plant, yumi, "yumi", "right").size == 2
    with pytest.raises(ValueError, match="no arm"):
        arm_position_indices(plant, yumi, "yumi", "arm")


def test_add_robot_pose_and_errors():
    plant = MultibodyPlant(0.0)
    rpy = (0.0, 0.0, np.pi / 2)
    yumi = add_robot(plant, "yumi", "cell_yumi", (1.0, 2.0, 0.8), rpy)
    with pytest.raises(ValueError, match="already exists"):
        add_robot(plant, "yumi", "cell_yumi")
    with pytest.raises(ValueError, match="unknown robot model"):
        add_robot(plant, "ur5", "x")
    with pytest.raises(ValueError, match="3 finite"):
        add_robot(plant, "yumi", "y2", (0.0, 0.0))
    second = add_robot(plant, "yumi", "y3")  # two YuMis in one plant: names are per instance
    plant.Finalize()
    assert plant.GetModelInstanceName(yumi) == "cell_yumi" and second != yumi
    context = plant.CreateDefaultContext()
    X_WB = RigidTransform(RollPitchYaw(rpy), [1.0, 2.0, 0.8])
    j2 = plant.GetJointByName("yumi_joint_2_r", yumi).frame_on_child().CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(j2, X_WB @ (BODY_IN_BASE + YUMI_ORIGINS["r"]["2"]), atol=0.002)
    with pytest.raises(ValueError, match="finalized"):
        add_robot(plant, "irb140", "late")


@pytest.mark.parametrize("model", ["yumi", "irb140"])
def test_capsules_follow_joint_origins_at_zero(kinematic_plant, zero_context, model):
    """Each arm capsule runs from its link's joint origin to the next joint origin."""
    plant, yumi, irb = kinematic_plant
    instance = yumi if model == "yumi" else irb
    kin = RobotCapsuleKinematics(plant, [(instance, model)], include_static=False)
    start, end, radius = kin.capsules(zero_context)
    assert start.shape == end.shape == (kin.num_capsules, 3) and radius.shape == (kin.num_capsules,)
    assert np.all((radius > 0.02) & (radius < 0.2))
    by_name = {name.split("/")[1]: k for k, name in enumerate(kin.names)}

    def origin(joint):
        return (
            plant.GetJointByName(joint, instance).frame_on_child().CalcPoseInWorld(zero_context).translation()
        )

    for arm, joints in arm_joints(model).items():
        links = [plant.GetJointByName(j, instance).child_body().name() for j in joints]
        for k, link in enumerate(links):
            np.testing.assert_allclose(start[by_name[link]], origin(joints[k]), atol=1e-9)
            if k + 1 < len(links):
                np.testing.assert_allclose(end[by_name[link]], origin(joints[k + 1]), atol=1e-9)
        if model == "yumi":
            side = arm[0]
            gripper = plant.GetBodyByName(f"gripper_{side}_base", instance).EvalPoseInWorld(zero_context)
            np.testing.assert_allclose(end[by_name[links[-1]]], gripper.translation(), atol=1e-9)
            tool = plant.GetFrameByName(tool_frame(model, arm), instance).CalcPoseInWorld(zero_context)
            np.testing.assert_allclose(end[by_name[f"gripper_{side}_base"]], tool.translation(), atol=1e-9)


def test_capsules_move_with_the_joints(kinematic_plant):
    """Rotating joint 1 rotates every downstream capsule rigidly about the joint-1 axis."""
    plant, yumi, _ = kinematic_plant
    kin = RobotCapsuleKinematics(plant, [(yumi, "yumi")])
    assert kin.num_capsules == len(link_capsules("yumi")) == 17
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, np.zeros(plant.num_positions()))
    s0, e0, _ = kin.capsules(context)
    X_J1 = plant.GetJointByName("yumi_joint_1_r", yumi).frame_on_child().CalcPoseInWorld(context)
    q = np.zeros(plant.num_positions())
    q[arm_position_indices(plant, yumi, "yumi", "right")[0]] = 0.7
    plant.SetPositions(context, q)
    s1, e1, _ = kin.capsules(context)
    right = np.array([("_r" in n or "gripper_r" in n) for n in kin.names])
    assert right.sum() == 8
    R = (
        X_J1.rotation().matrix()
        @ RollPitchYaw(0, 0, 0.7).ToRotationMatrix().matrix()
        @ X_J1.rotation().matrix().T
    )
    expected = (s0[right] - X_J1.translation()) @ R.T + X_J1.translation()
    np.testing.assert_allclose(s1[right], expected, atol=1e-9)
    np.testing.assert_allclose(s1[~right], s0[~right], atol=1e-12)
    np.testing.assert_allclose(e1[~right], e0[~right], atol=1e-12)


@pytest.mark.parametrize("model", ["yumi", "irb140"])
def test_link_capsules_match_urdf_collision_capsules(model):
    """The distance capsules are the URDF collision capsules of the arm links (same frame, size)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    instance = add_robot(plant, model, "robot")
    plant.Finalize()
    inspector = scene_graph.model_inspector()
    checked = 0
    for body_name, start, end, radius in link_capsules(model, include_static=False):
        body = plant.GetBodyByName(body_name, instance)
        geometries = plant.GetCollisionGeometriesForBody(body)
        shapes = [(inspector.GetShape(g), inspector.GetPoseInFrame(g)) for g in geometries]
        capsules = [(s, X) for s, X in shapes if type(s).__name__ in ("Capsule", "Sphere")]
        if not capsules:
            assert body_name.startswith("gripper"), body_name  # grippers collide as boxes
            continue
        ((shape, X_BG),) = capsules
        assert shape.radius() == pytest.approx(radius)
        length = np.linalg.norm(end - start)
        if type(shape).__name__ == "Capsule":
            half = X_BG.rotation().matrix()[:, 2] * shape.length() / 2
            ends = sorted([tuple(X_BG.translation() - half), tuple(X_BG.translation() + half)])
            np.testing.assert_allclose(
                np.array(ends), np.array(sorted([tuple(start), tuple(end)])), atol=1e-6
            )
        else:
            assert length < 1e-9
            np.testing.assert_allclose(X_BG.translation(), start, atol=1e-9)
        checked += 1
    assert checked == (14 if model == "yumi" else 6)


def test_furniture_models_parse():
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    with model_file("table.sdf") as table_sdf, model_file("part_bin.sdf") as bin_sdf:
        (table,) = parser.AddModels(str(table_sdf))
        (bin_,) = parser.AddModels(str(bin_sdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("table_link", table))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    top = plant.GetFrameByName("table_top", table).CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(top, [0.0, 0.0, 0.75], atol=1e-9)
    assert plant.CalcTotalMass(context, [bin_]) > 0


def test_scene_graph_roles():
    """Every robot link with collision geometry also has a visual (for meshcat replays)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    assert isinstance(scene_graph, SceneGraph)
    yumi = add_robot(plant, "yumi", "yumi")
    plant.Finalize()
    for index in plant.GetBodyIndices(yumi):
        body = plant.get_body(index)
        if plant.GetCollisionGeometriesForBody(body):
            assert plant.GetVisualGeometriesForBody(body), body.name()
