"""Robot models of the cell (ABB YuMi IRB 14000, ABB IRB 140, ...), built from primitives.

Which robots exist, their arms, tools, grippers, PD gains and capsules is the registry
`hrc_drake.robots.registry.ROBOT_MODELS` (read from `models/<name>.yaml`); their URDFs are the
`hrc_drake.models` package data
(the top-level `models/` folder, mapped into the package by pyproject.toml), read with
`importlib.resources`. The URDFs follow docs/KINEMATICS.md (joint origins, axes,
limits and velocities of the public ROS descriptions); masses, inertias and capsule radii are
approximations. This module loads them into a `MultibodyPlant` and gives the capsule set used for
human-robot distance computations (thesis Fig. 8.18 draws the robot links as capsules).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from importlib.resources import as_file, files
from importlib.resources.abc import Traversable
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, ModelInstanceIndex, PdControllerGains
from pydrake.systems.framework import Context

from hrc_drake.robots.config import Robot
from hrc_drake.robots.description import robot_record
from hrc_drake.robots.registry import (
    ArmModel,
    RobotModel,
    capsule_arrays,
    get_robot_model,
    shipped_robot_models,
)
from hrc_drake.robots.urdf import file_parser

#: the package holding the URDF / SDF model files (package data)
MODELS_PACKAGE = "hrc_drake.models"


def model_resource(name: str) -> Traversable:
    """A model file of the `hrc_drake.models` package data (e.g. 'yumi.urdf', 'table.sdf')."""
    resource = files(MODELS_PACKAGE) / name
    if not resource.is_file():
        raise FileNotFoundError(f"no model file {name!r} in the {MODELS_PACKAGE} package data")
    return resource


@contextlib.contextmanager
def model_file(name: str) -> Iterator[Path]:
    """A file-system path of a model file for the duration of the `with` block (parsers that need one)."""
    with as_file(model_resource(name)) as path:
        yield path


def _arm(model: str | RobotModel, arm: str) -> ArmModel:
    return get_robot_model(model).arm(arm)


def robot_model(model: str | RobotModel) -> RobotModel:
    """The registry record of `model` (ValueError listing the known models)."""
    return get_robot_model(model)


def add_robot(
    plant: MultibodyPlant,
    model: str | RobotModel,
    name: str,
    base_xyz: Sequence[float] = (0.0, 0.0, 0.0),
    base_rpy: Sequence[float] = (0.0, 0.0, 0.0),
) -> ModelInstanceIndex:
    """Parse `model`'s URDF (a shipped name or a record) as a model instance called `name` and weld
    its root link to the world.

    base_xyz (m) and base_rpy (rad, roll-pitch-yaw) place the root link: for the YuMi the root is
    its foot plane, so welding it at the table top gives the true geometry. Call before Finalize.
    """
    record = get_robot_model(model)
    if not name:
        raise ValueError("add_robot: the model instance name must not be empty")
    if plant.is_finalized():
        raise ValueError(f"add_robot({record.name!r}, {name!r}): the plant is already finalized")
    if plant.HasModelInstanceNamed(name):
        raise ValueError(f"add_robot: a model instance named {name!r} already exists in the plant")
    xyz = np.asarray(base_xyz, dtype=float).reshape(-1)
    rpy = np.asarray(base_rpy, dtype=float).reshape(-1)
    if xyz.shape != (3,) or rpy.shape != (3,) or not (np.all(np.isfinite(xyz)) and np.all(np.isfinite(rpy))):
        raise ValueError(
            f"add_robot({record.name!r}, {name!r}): base_xyz and base_rpy must be 3 finite numbers, "
            f"got {list(base_xyz)} and {list(base_rpy)}"
        )
    instance = _parse_urdf(plant, record, name)
    plant.WeldFrames(
        plant.world_frame(),
        plant.GetFrameByName(record.root_link, instance),
        RigidTransform(RollPitchYaw(rpy), xyz),
    )
    return instance


def _parse_urdf(plant: MultibodyPlant, record: RobotModel, name: str) -> ModelInstanceIndex:
    """The record's URDF as one model instance called `name`."""
    if record.urdf_path:
        # a robot of the user's: parsed from its file so that its meshes' relative paths resolve
        instances = file_parser(plant, record.urdf_path).AddModels(record.urdf_path)
        if len(instances) != 1:
            raise ValueError(f"{record.urdf_path}: expected one robot, the file holds {len(instances)} "
                             "models")
        plant.RenameModelInstance(instances[0], name)
        return instances[0]
    text = record.urdf_text()
    marker = f'<robot name="{record.name}"'
    if marker not in text:
        raise ValueError(f"{MODELS_PACKAGE}/{record.urdf} does not declare {marker}")
    (instance,) = Parser(plant).AddModelsFromString(text.replace(marker, f'<robot name="{name}"', 1), "urdf")
    return instance


def arm_joint_limits(plant: MultibodyPlant, instance: ModelInstanceIndex, model: str | RobotModel, arm: str):
    """(lower, upper, velocity) limits of the arm's joints in chain order, each shape (n,)."""
    joints = [plant.GetJointByName(j, instance) for j in _arm(model, arm).joints]
    lower = np.array([j.position_lower_limits()[0] for j in joints])
    upper = np.array([j.position_upper_limits()[0] for j in joints])
    velocity = np.array([j.velocity_upper_limits()[0] for j in joints])
    return lower, upper, velocity


def _joint_starts(plant: MultibodyPlant, instance: ModelInstanceIndex, joints, start: str) -> np.ndarray:
    """`position_start` or `velocity_start` of each named joint of `instance`, in the given order."""
    return np.array([getattr(plant.GetJointByName(j, instance), start)() for j in joints], dtype=int)


def arm_position_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, model: str | RobotModel, arm: str
) -> np.ndarray:
    """Indices of the arm's joints (chain order) into the plant's full position vector q."""
    return _joint_starts(plant, instance, _arm(model, arm).joints, "position_start")


def arm_velocity_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, model: str | RobotModel, arm: str
) -> np.ndarray:
    """Indices of the arm's joints (chain order) into the plant's full velocity vector v."""
    return _joint_starts(plant, instance, _arm(model, arm).joints, "velocity_start")


def gripper_position_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, model: str | RobotModel, arm: str
) -> np.ndarray:
    """Indices of the arm's finger joints into the plant's full position vector (empty if none)."""
    return _joint_starts(plant, instance, _arm(model, arm).gripper_joints, "position_start")


def _default_gains(joint: str, model: str | RobotModel | None) -> tuple[float, float]:
    """(kp, kd) of `joint` from the registry (of `model`, or of the one model naming the joint)."""
    records = [get_robot_model(model)] if model is not None else list(shipped_robot_models().values())
    found = [r.pd_gains[joint] for r in records if joint in r.pd_gains]
    if not found:
        where = f"robot model {model!r}" if model is not None else "any robot model of the registry"
        raise ValueError(f"set_pd_gains: no PD gains for joint {joint!r} in {where}; pass kp and kd")
    return found[0]


def set_pd_gains(
    plant: MultibodyPlant,
    instance: ModelInstanceIndex,
    kp: float | Sequence[float] | None = None,
    kd: float | Sequence[float] | None = None,
    model: str | RobotModel | None = None,
) -> None:
    """Give every actuator of `instance` an implicit PD controller (discrete plants; before Finalize).

    Afterwards `plant.get_desired_state_input_port(instance)` must be connected with the desired
    [q_d, v_d] of the instance's actuated joints (actuator order) and the actuation input port is
    added as a feed-forward torque. kp (N m/rad or N/m) and kd may be scalars or one per actuator;
    None takes each joint's gains from the registry record of `model` (`RobotModel.pd_gains`;
    model=None: the record whose gains name the joint).
    """
    if plant.is_finalized():
        raise ValueError("set_pd_gains must be called before the plant is finalized")
    # GetJointActuatorIndices(instance) is empty before Finalize: filter all actuators instead.
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices()]
    actuators = [a for a in actuators if a.model_instance() == instance]
    defaults = [_default_gains(a.joint().name(), model) for a in actuators]
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


def link_capsules(model: str | RobotModel,
                  include_static: bool = True) -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    """Capsules (body name, p_start (3,), p_end (3,), radius) in body frames (thesis Fig. 8.18).

    include_static=False drops the capsules of the bodies welded to the base (`RobotModel.static_bodies`).
    """
    return capsule_arrays(get_robot_model(model), include_static)


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

    @property
    def capsule_bodies(self) -> np.ndarray:
        """(K,) the plant's body index of each capsule."""
        return self._unique_bodies[self._capsule_body]

    @property
    def local_ends(self) -> tuple[np.ndarray, np.ndarray]:
        """Capsule end points (K, 3) each, in their bodies' frames."""
        return self._start_B, self._end_B

    def capsules(self, plant_context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start (K,3), end (K,3), radius (K,)) in the world frame for the context's positions."""
        poses = self._poses_port.Eval(plant_context)
        X = np.array([poses[i].GetAsMatrix4() for i in self._unique_bodies])[self._capsule_body]
        R, p = X[:, :3, :3], X[:, :3, 3]
        start = np.einsum("kij,kj->ki", R, self._start_B) + p
        end = np.einsum("kij,kj->ki", R, self._end_B) + p
        return start, end, self.radius.copy()


def add_robots(plant: MultibodyPlant, robots: Sequence[Robot],
               scenario_file=None) -> list[tuple[ModelInstanceIndex, Robot]]:
    """`add_robot` for every robot config (its record, name, base pose; a `urdf` relative to
    `scenario_file`); [(instance, config)] in order."""
    return [(add_robot(plant, robot_record(r, scenario_file), r.name, r.base.xyz, r.base.rpy), r)
            for r in robots]


def effective_mass(plant, context, body, point_in_body, direction) -> float:
    """m_R = (u^T J M^-1 J^T u)^-1 (kg): the robot's effective mass at a point of `body` (its frame's
    coordinates) along the unit `direction` u (world), J the point's translational Jacobian (3, nv)
    and M the mass matrix of the plant at `context`."""
    world = plant.world_frame()
    jacobian = plant.CalcJacobianTranslationalVelocity(context, JacobianWrtVariable.kV, body.body_frame(),
                                                       np.asarray(point_in_body, float), world, world)
    mass_matrix = plant.CalcMassMatrix(context)
    ju = jacobian.T @ np.asarray(direction, dtype=float)
    inverse_mass = float(ju @ np.linalg.solve(mass_matrix, ju))
    return 1.0 / inverse_mass if inverse_mass > 1e-12 else math.inf
