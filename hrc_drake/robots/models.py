"""Robot models of the cell: ABB YuMi (IRB 14000) and ABB IRB 140, built from primitives.

The URDFs in `models/` follow /work/shared/robots/KINEMATICS.md (joint origins, axes, limits and
velocities of the public ROS descriptions); masses, inertias and capsule radii are approximations.
This module loads them into a `MultibodyPlant`, names their arms, tools and grippers, and gives the
capsule set used for human-robot distance computations (thesis Fig. 8.18 draws the robot links as
capsules).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex, PdControllerGains
from pydrake.systems.framework import Context

MODELS_DIR: Path = Path(__file__).resolve().parents[2] / "models"

MODEL_FILES: dict[str, str] = {"yumi": "yumi.urdf", "irb140": "irb140.urdf"}

#: the link welded to the world by `add_robot` (YuMi: the foot plane, 0.1 m below the body frame)
ROOT_LINKS: dict[str, str] = {"yumi": "yumi_base_link", "irb140": "irb140_base_link"}

_YUMI_ABB_ORDER = ("1", "2", "7", "3", "4", "5", "6")  # physical order from the body (ABB axes)

#: arm joints in chain order (base to flange) for every robot model and arm
ROBOT_ARMS: dict[str, dict[str, list[str]]] = {
    "yumi": {
        "right": [f"yumi_joint_{k}_r" for k in _YUMI_ABB_ORDER],
        "left": [f"yumi_joint_{k}_l" for k in _YUMI_ABB_ORDER],
    },
    "irb140": {"arm": [f"irb140_joint_{k}" for k in range(1, 7)]},
}

#: tool centre point frame of every arm (YuMi: finger tips, 0.136 m from the gripper base along z)
TOOL_FRAMES: dict[tuple[str, str], str] = {
    ("yumi", "right"): "yumi_tool_r",
    ("yumi", "left"): "yumi_tool_l",
    ("irb140", "arm"): "irb140_tool",
}

#: prismatic finger joints of every arm's gripper (0 = closed, 0.025 m = open, per finger)
GRIPPER_JOINTS: dict[tuple[str, str], list[str]] = {
    ("yumi", "right"): ["gripper_r_joint", "gripper_r_joint_m"],
    ("yumi", "left"): ["gripper_l_joint", "gripper_l_joint_m"],
    ("irb140", "arm"): [],
}
GRIPPER_STROKE = 0.025

# Capsules in body frames: (body, start, end, radius). Arm link capsules run from the link's joint
# origin to the next joint origin (so the chain of capsules passes through every joint centre);
# radii follow the median mesh distances of KINEMATICS.md 1.4 / 2.6. The URDF collision geometry
# is the same capsule on every arm link; the YuMi body and the grippers collide as boxes.
_YUMI_SEGMENTS = (
    (1, (0.03, 0.0, 0.1), 0.060),
    (2, (-0.03, 0.17283, 0.0), 0.055),
    (3, (-0.04188, 0.0, 0.07873), 0.055),
    (4, (0.0405, 0.16461, 0.0), 0.055),
    (5, (-0.027, 0.0, 0.10039), 0.050),
    (6, (0.027, 0.029, 0.0), 0.050),
    (7, (0.0, 0.0, 0.007), 0.035),
)
YUMI_TOOL_OFFSET = 0.136


def _yumi_capsules() -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    caps = [("yumi_body", np.array([-0.12, 0.0, 0.10]), np.array([-0.12, 0.0, 0.27]), 0.20)]
    for side in ("r", "l"):
        for index, end, radius in _YUMI_SEGMENTS:
            caps.append((f"yumi_link_{index}_{side}", np.zeros(3), np.array(end, float), radius))
        caps.append((f"gripper_{side}_base", np.zeros(3), np.array([0.0, 0.0, YUMI_TOOL_OFFSET]), 0.045))
    return caps


def _irb140_capsules() -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    segments = (
        ("irb140_base_link", (0.0, 0.0, 0.104), 0.16),
        ("irb140_link_1", (0.07, 0.0, 0.248), 0.12),
        ("irb140_link_2", (0.0, 0.0, 0.360), 0.11),
        ("irb140_link_3", (0.239, 0.0, 0.0), 0.085),
        ("irb140_link_4", (0.141, 0.0, 0.0), 0.065),
        ("irb140_link_5", (0.065, 0.0, 0.0), 0.045),
        ("irb140_link_6", (0.0, 0.0, 0.0), 0.035),
    )
    return [(body, np.zeros(3), np.array(end, float), radius) for body, end, radius in segments]


_STATIC_BODIES = {"yumi": {"yumi_body"}, "irb140": {"irb140_base_link"}}


def _check_model(model: str) -> None:
    if model not in MODEL_FILES:
        raise ValueError(f"unknown robot model {model!r}; expected one of {sorted(MODEL_FILES)}")


def _check_arm(model: str, arm: str) -> None:
    _check_model(model)
    if arm not in ROBOT_ARMS[model]:
        raise ValueError(f"robot model {model!r} has no arm {arm!r}; arms: {sorted(ROBOT_ARMS[model])}")


def model_path(model: str) -> Path:
    """Path of the URDF of `model` ('yumi' or 'irb140')."""
    _check_model(model)
    return MODELS_DIR / MODEL_FILES[model]


def add_robot(
    plant: MultibodyPlant,
    model: str,
    name: str,
    base_xyz: Sequence[float] = (0.0, 0.0, 0.0),
    base_rpy: Sequence[float] = (0.0, 0.0, 0.0),
) -> ModelInstanceIndex:
    """Parse `model`'s URDF as a model instance called `name` and weld its root link to the world.

    base_xyz (m) and base_rpy (rad, roll-pitch-yaw) place the root link: for the YuMi the root is
    its foot plane, so welding it at the table top gives the true geometry. Call before Finalize.
    """
    _check_model(model)
    if not name:
        raise ValueError("add_robot: the model instance name must not be empty")
    if plant.is_finalized():
        raise ValueError(f"add_robot({model!r}, {name!r}): the plant is already finalized")
    if plant.HasModelInstanceNamed(name):
        raise ValueError(f"add_robot: a model instance named {name!r} already exists in the plant")
    xyz = np.asarray(base_xyz, dtype=float).reshape(-1)
    rpy = np.asarray(base_rpy, dtype=float).reshape(-1)
    if xyz.shape != (3,) or rpy.shape != (3,) or not (np.all(np.isfinite(xyz)) and np.all(np.isfinite(rpy))):
        raise ValueError(
            f"add_robot({model!r}, {name!r}): base_xyz and base_rpy must be 3 finite numbers, "
            f"got {list(base_xyz)} and {list(base_rpy)}"
        )
    text = model_path(model).read_text()
    marker = f'<robot name="{model}"'
    if marker not in text:
        raise ValueError(f"{model_path(model)} does not declare {marker}")
    text = text.replace(marker, f'<robot name="{name}"', 1)
    (instance,) = Parser(plant).AddModelsFromString(text, "urdf")
    plant.WeldFrames(
        plant.world_frame(),
        plant.GetFrameByName(ROOT_LINKS[model], instance),
        RigidTransform(RollPitchYaw(rpy), xyz),
    )
    return instance


def arm_joint_limits(plant: MultibodyPlant, instance: ModelInstanceIndex, model: str, arm: str):
    """(lower, upper, velocity) limits of the arm's joints in chain order, each shape (n,)."""
    _check_arm(model, arm)
    joints = [plant.GetJointByName(j, instance) for j in ROBOT_ARMS[model][arm]]
    lower = np.array([j.position_lower_limits()[0] for j in joints])
    upper = np.array([j.position_upper_limits()[0] for j in joints])
    velocity = np.array([j.velocity_upper_limits()[0] for j in joints])
    return lower, upper, velocity


def _joint_starts(plant: MultibodyPlant, instance: ModelInstanceIndex, joints, start: str) -> np.ndarray:
    """`position_start` or `velocity_start` of each named joint of `instance`, in the given order."""
    return np.array([getattr(plant.GetJointByName(j, instance), start)() for j in joints], dtype=int)


def arm_position_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, model: str, arm: str
) -> np.ndarray:
    """Indices of the arm's joints (chain order) into the plant's full position vector q."""
    _check_arm(model, arm)
    return _joint_starts(plant, instance, ROBOT_ARMS[model][arm], "position_start")


def arm_velocity_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, model: str, arm: str
) -> np.ndarray:
    """Indices of the arm's joints (chain order) into the plant's full velocity vector v."""
    _check_arm(model, arm)
    return _joint_starts(plant, instance, ROBOT_ARMS[model][arm], "velocity_start")


def gripper_position_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, model: str, arm: str
) -> np.ndarray:
    """Indices of the arm's finger joints into the plant's full position vector (empty if none)."""
    _check_arm(model, arm)
    return _joint_starts(plant, instance, GRIPPER_JOINTS[(model, arm)], "position_start")


#: default implicit-PD gains (kp, kd) per URDF joint name: stiff enough that gravity sag stays
#: below ~0.01 rad on a 1-10 ms discrete plant (the IRB 140 links are heavier, hence its gains)
DEFAULT_PD_GAINS: dict[str, tuple[float, float]] = {
    **{f"yumi_joint_{k}_{s}": (400.0, 40.0) for k in _YUMI_ABB_ORDER for s in "rl"},
    **{j: (400.0, 10.0) for joints in GRIPPER_JOINTS.values() for j in joints},
    "irb140_joint_1": (8000.0, 400.0),
    "irb140_joint_2": (8000.0, 400.0),
    "irb140_joint_3": (4000.0, 200.0),
    "irb140_joint_4": (500.0, 25.0),
    "irb140_joint_5": (500.0, 25.0),
    "irb140_joint_6": (100.0, 5.0),
}


def set_pd_gains(
    plant: MultibodyPlant,
    instance: ModelInstanceIndex,
    kp: float | Sequence[float] | None = None,
    kd: float | Sequence[float] | None = None,
) -> None:
    """Give every actuator of `instance` an implicit PD controller (discrete plants; before Finalize).

    Afterwards `plant.get_desired_state_input_port(instance)` must be connected with the desired
    [q_d, v_d] of the instance's actuated joints (actuator order) and the actuation input port is
    added as a feed-forward torque. kp (N m/rad or N/m) and kd may be scalars or one per actuator;
    None takes `DEFAULT_PD_GAINS` of each joint.
    """
    if plant.is_finalized():
        raise ValueError("set_pd_gains must be called before the plant is finalized")
    # GetJointActuatorIndices(instance) is empty before Finalize: filter all actuators instead.
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices()]
    actuators = [a for a in actuators if a.model_instance() == instance]
    defaults = [DEFAULT_PD_GAINS.get(a.joint().name(), (400.0, 40.0)) for a in actuators]
    gains = []
    for value, what, column in ((kp, "kp", 0), (kd, "kd", 1)):
        if value is None:
            value = [d[column] for d in defaults]
        arr = np.asarray(value, dtype=float).reshape(-1)
        if arr.size not in (1, len(actuators)):
            raise ValueError(
                f"set_pd_gains: {what} needs 1 or {len(actuators)} values (one per actuator of "
                f"{plant.GetModelInstanceName(instance)!r}), got {arr.size}"
            )
        gains.append(np.broadcast_to(arr, (len(actuators),)))
    kp_all, kd_all = gains
    if np.any(kp_all < 0) or np.any(kd_all < 0) or not np.all(np.isfinite(kp_all + kd_all)):
        raise ValueError(f"set_pd_gains: gains must be finite and >= 0, got kp={kp!r}, kd={kd!r}")
    for actuator, p, d in zip(actuators, kp_all, kd_all, strict=True):
        actuator.set_controller_gains(PdControllerGains(p=float(p), d=float(d)))


def link_capsules(model: str, include_static: bool = True) -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    """Capsules (body name, p_start (3,), p_end (3,), radius) in body frames (thesis Fig. 8.18).

    include_static=False drops the capsule of the body welded to the base (YuMi torso, IRB 140 base).
    """
    _check_model(model)
    caps = _yumi_capsules() if model == "yumi" else _irb140_capsules()
    if not include_static:
        caps = [c for c in caps if c[0] not in _STATIC_BODIES[model]]
    return [(body, start.copy(), end.copy(), radius) for body, start, end, radius in caps]


class RobotCapsuleKinematics:
    """World-frame capsules of several robots of one plant, from a plant context.

    `capsules(context)` evaluates the plant's body poses once (a cached output port) and maps all
    capsule end points with one batched product: start_W = R_WB p_start_B + p_WB.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        instances_and_models: Sequence[tuple[ModelInstanceIndex, str]],
        include_static: bool = True,
    ):
        if not plant.is_finalized():
            raise ValueError("RobotCapsuleKinematics needs a finalized plant")
        self._plant = plant
        body_indices, starts, ends, radii, names = [], [], [], [], []
        for instance, model in instances_and_models:
            prefix = plant.GetModelInstanceName(instance)
            for body_name, start, end, radius in link_capsules(model, include_static):
                body_indices.append(int(plant.GetBodyByName(body_name, instance).index()))
                starts.append(start)
                ends.append(end)
                radii.append(radius)
                names.append(f"{prefix}/{body_name}")
        # Several capsules may share a body: fetch each body pose once.
        self._unique_bodies, self._capsule_body = np.unique(
            np.array(body_indices, dtype=int), return_inverse=True
        )
        self._start_B = np.array(starts, dtype=float).reshape(-1, 3)
        self._end_B = np.array(ends, dtype=float).reshape(-1, 3)
        self.radius = np.array(radii, dtype=float)
        self.names: tuple[str, ...] = tuple(names)
        self._poses_port = plant.get_body_poses_output_port()

    @property
    def num_capsules(self) -> int:
        return len(self.names)

    def capsules(self, plant_context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start (K,3), end (K,3), radius (K,)) in the world frame for the context's positions."""
        poses = self._poses_port.Eval(plant_context)
        X = np.array([poses[i].GetAsMatrix4() for i in self._unique_bodies])[self._capsule_body]
        R, p = X[:, :3, :3], X[:, :3, 3]
        start = np.einsum("kij,kj->ki", R, self._start_B) + p
        end = np.einsum("kij,kj->ki", R, self._end_B) + p
        return start, end, self.radius.copy()
