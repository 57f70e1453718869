"""Named poses of the robots of a cell as joint vectors (joint values checked, Cartesian targets by IK).

Reads only the robots' configs (`hrc_drake.robots.config.Robot`), so the scenario loader and the
cell builder both use it without importing each other.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hrc_drake.errors import ConfigError, ScenarioError
from hrc_drake.robots.config import Robot
from hrc_drake.robots.description import DescriptionError, robot_record
from hrc_drake.robots.ik import InfeasibleTarget, solve_tool_position
from hrc_drake.robots.models import add_robots, arm_joint_limits, arm_position_indices
from hrc_drake.robots.registry import get_robot_model


def _error(file, field: str, reason: str) -> ScenarioError:
    return ConfigError(field, reason) if file is None else ScenarioError(file, field, reason)


def _approach(pose, file, field_path: str):
    """The pose's approach direction (3,), or None; raises naming the field for a bad one."""
    if not pose.approach:
        return None
    numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in pose.approach)
    u = np.asarray(pose.approach, dtype=float).reshape(-1) if numbers else np.full(1, np.nan)
    if u.shape != (3,) or not np.all(np.isfinite(u)) or not np.any(u):
        raise _error(file, f"{field_path}.approach",
                     f"must be 3 finite numbers, not all zero (a direction), got {list(pose.approach)!r}")
    if pose.joints:
        raise _error(file, f"{field_path}.approach",
                     "chooses among the IK postures of a target: a pose given by joints has none to choose")
    return u


def solve_named_poses(
    robots: Sequence[Robot], file: str | Path | None = None, field: str = "robots"
) -> dict[tuple[str, str], np.ndarray]:
    """Joint vectors {(robot name, pose name): q (n,)} of every named pose of `robots`.

    Joint poses must lie within the arm's joint limits; Cartesian targets are solved by Drake
    InverseKinematics (`solve_tool_position`), each seeded by the arm's previous pose. Raises
    `ScenarioError(file, "<field>[i].poses[j]...", reason)` naming the pose at fault (an unknown
    model or arm, a joint outside its limits, a target out of reach); `ConfigError` (no file)
    when `file` is None.
    """
    records = {}
    for i, robot in enumerate(robots):
        try:
            record = records[robot.name] = robot_record(robot, file)
        except DescriptionError as err:
            raise _error(file, f"{field}[{i}].{err.field}", err.reason) from None
        except ValueError as err:
            raise _error(file, f"{field}[{i}].model", str(err)) from None
        for j, pose in enumerate(robot.poses):
            if pose.arm not in record.arm_names:
                raise _error(
                    file, f"{field}[{i}].poses[{j}].arm",
                    f"unknown arm '{pose.arm}' of {record.name} {record.arm_names}",
                )
    plant = MultibodyPlant(0.0)
    instances = add_robots(plant, robots, file)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    solved: dict[tuple[str, str], np.ndarray] = {}
    for i, (instance, robot) in enumerate(instances):
        limits = {}
        for j, pose in enumerate(robot.poses):
            field_path = f"{field}[{i}].poses[{j}]"
            if pose.arm not in limits:
                limits[pose.arm] = arm_joint_limits(plant, instance, records[robot.name], pose.arm)
            lower, upper, _ = limits[pose.arm]
            approach = _approach(pose, file, field_path)
            if pose.joints:
                q = np.asarray(pose.joints, float)
                if q.shape != lower.shape:
                    raise _error(
                        file, f"{field_path}.joints", f"expected {lower.size} joint values, got {q.size}"
                    )
                bad = np.flatnonzero((q < lower - 1e-9) | (q > upper + 1e-9))
                if len(bad):
                    k = int(bad[0])
                    raise _error(
                        file,
                        f"{field_path}.joints[{k}]",
                        f"{q[k]:.4f} rad is outside the joint's limits [{lower[k]:.4f}, {upper[k]:.4f}]",
                    )
            else:
                seed_q = next(
                    (
                        solved[(robot.name, p.name)]
                        for p in reversed(robot.poses[:j])
                        if p.arm == pose.arm and (robot.name, p.name) in solved
                    ),
                    None,
                )
                try:
                    q = solve_tool_position(
                        plant,
                        context,
                        instance,
                        records[robot.name],
                        pose.arm,
                        pose.target.xyz,
                        target_rpy=pose.target.rpy if pose.orient else None,
                        q_seed=seed_q,
                        tolerance=pose.tolerance,
                        tool_z_down=not pose.orient,
                        approach=approach,
                    )
                except InfeasibleTarget as err:
                    raise _error(file, f"{field_path}.target", f"out of reach: {err}") from err
            solved[(robot.name, pose.name)] = np.asarray(q, float)
    return solved


def tool_positions(robots: Sequence[Robot],
                   file: str | Path | None = None) -> dict[tuple[str, str], np.ndarray]:
    """World position (3,) of the tool frame at every named pose {(robot name, pose name): xyz}:
    a Cartesian target's IK solution or a joint pose, each arm's other joints at zero."""
    solved = solve_named_poses(robots, file)
    plant = MultibodyPlant(0.0)
    instances = add_robots(plant, robots, file)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    return {(robot.name, pose.name): tool_position(plant, context, instance, robot_record(robot, file),
                                                   pose.arm, solved[(robot.name, pose.name)])
            for instance, robot in instances for pose in robot.poses}


def tool_position(plant, context, instance, model, arm: str, arm_joints) -> np.ndarray:
    """World position (3,) of `arm`'s tool frame at `arm_joints`, every other joint at zero."""
    q = np.zeros(plant.num_positions())
    q[arm_position_indices(plant, instance, model, arm)] = arm_joints
    plant.SetPositions(context, q)
    frame = plant.GetFrameByName(get_robot_model(model).arm(arm).tool_frame, instance)
    return frame.CalcPoseInWorld(context).translation().copy()
