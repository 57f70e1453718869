"""Inverse kinematics of one arm's tool frame (Drake `InverseKinematics` + `Solve`).

Used to turn the Cartesian named poses of a scenario into joint vectors.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.math import RollPitchYaw
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.solvers import Solve
from pydrake.systems.framework import Context

from hrc_drake.robots.models import arm_joint_limits, arm_position_indices, effective_mass
from hrc_drake.robots.registry import get_robot_model

#: maximum angle (rad) between the tool z axis and the world's -z when `tool_z_down` is set
TOOL_DOWN_ANGLE = 0.05


def lowest_mass_posture(plant: MultibodyPlant, frame, candidates, direction) -> tuple[int, np.ndarray]:
    """(index, m_R (n,)) of the candidate position vectors (n, nq) of `plant` whose effective mass at
    the origin of `frame` along the unit `direction` u (world) is lowest: m_R = (u^T J M^-1 J^T u)^-1
    (ISO/TS 15066 Annex A, eq. A.6: the permissible PFL speed grows as m_R falls; the first of
    equal ones)."""
    u = _vector3(direction, "direction")
    norm = float(np.linalg.norm(u))
    if norm <= 0.0:
        raise ValueError("lowest_mass_posture: the direction must not be zero")
    context = plant.CreateDefaultContext()
    point = frame.GetFixedPoseInBodyFrame().translation()
    masses = []
    for q in np.atleast_2d(np.asarray(candidates, dtype=float)):
        plant.SetPositions(context, q)
        masses.append(effective_mass(plant, context, frame.body(), point, u / norm))
    masses = np.asarray(masses)
    return int(np.argmin(masses)), masses


class InfeasibleTarget(ValueError):
    """No joint vector within the arm's limits puts the tool within tolerance of the target."""


def _vector3(value, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"solve_tool_position: {what} must be 3 finite numbers, got {value!r}")
    return arr


def solve_tool_position(
    plant: MultibodyPlant,
    plant_context: Context,
    instance: ModelInstanceIndex,
    model,
    arm: str,
    target_xyz: Sequence[float],
    target_rpy: Sequence[float] | None = None,
    q_seed: Sequence[float] | None = None,
    tolerance: float = 0.005,
    tool_z_down: bool = False,
    angle_tolerance: float = 0.02,
    attempts: int = 6,
    seed: int = 0,
    approach: Sequence[float] | None = None,
) -> np.ndarray:
    """Joint values (chain order) of `arm` that put its tool frame at `target_xyz` (world, m).

    Every joint other than the arm's stays at its value in `plant_context`. target_rpy (rad) also
    constrains the tool orientation (within angle_tolerance); tool_z_down only asks the tool z axis
    to point down (within TOOL_DOWN_ANGLE). The first attempt starts from q_seed (or the context's
    arm joints), the others from joint vectors drawn uniformly inside the limits with
    `numpy.random.default_rng(seed)`; the first solution within tolerance is returned (a quadratic
    cost keeps it near the first seed). Raises InfeasibleTarget (target, best distance reached) otherwise.
    approach: a direction (world) the tool moves toward a person at this pose (a hand-over): every
    seed is solved (at least 12), each kept near its own start, and of the solutions within
    tolerance the posture of the lowest effective mass along it is returned (`lowest_mass_posture`,
    issue 52: the permissible PFL speed of the approach is then the highest).
    """
    if not plant.is_finalized():
        raise ValueError("solve_tool_position needs a finalized plant")
    target = _vector3(target_xyz, "target_xyz")
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"solve_tool_position: tolerance must be > 0, got {tolerance!r}")
    if attempts < 1:
        raise ValueError(f"solve_tool_position: attempts must be >= 1, got {attempts!r}")
    arm_idx = arm_position_indices(plant, instance, model, arm)  # validates model and arm
    lower, upper, _ = arm_joint_limits(plant, instance, model, arm)
    tool_frame = get_robot_model(model).arm(arm).tool_frame
    tool = plant.GetFrameByName(tool_frame, instance)

    q_context = plant.GetPositions(plant_context).copy()
    if q_seed is None:
        first_seed = np.clip(q_context[arm_idx], lower, upper)
    else:
        first_seed = np.asarray(q_seed, dtype=float).reshape(-1)
        if first_seed.shape != arm_idx.shape or not np.all(np.isfinite(first_seed)):
            raise ValueError(
                f"solve_tool_position: q_seed must hold {arm_idx.size} finite joint values for "
                f"{model}/{arm}, got {q_seed!r}"
            )
    if approach is not None:
        attempts = max(attempts, 12)
    rng = np.random.default_rng(seed)
    seeds = [first_seed] + [rng.uniform(lower, upper) for _ in range(attempts - 1)]

    others = np.setdiff1d(np.arange(plant.num_positions()), arm_idx)
    box = np.full(3, tolerance / (2.0 * np.sqrt(3.0)))  # a box whose corners stay within tolerance / 2

    # InverseKinematics writes its iterates into the context it is given: keep the caller's intact.
    ik_context = plant.CreateDefaultContext()
    plant.SetPositions(ik_context, q_context)

    def build(with_position_constraint: bool):
        ik = InverseKinematics(plant, ik_context, with_joint_limits=True)
        q = ik.q()
        prog = ik.get_mutable_prog()
        if others.size:
            prog.AddBoundingBoxConstraint(q_context[others], q_context[others], q[others])
        if with_position_constraint:
            ik.AddPositionConstraint(tool, np.zeros(3), plant.world_frame(), target - box, target + box)
        else:
            ik.AddPositionCost(plant.world_frame(), target, tool, np.zeros(3), np.eye(3))
        if target_rpy is not None:
            R_target = RollPitchYaw(_vector3(target_rpy, "target_rpy")).ToRotationMatrix()
            ik.AddOrientationConstraint(
                plant.world_frame(),
                R_target,
                tool,
                RollPitchYaw(0.0, 0.0, 0.0).ToRotationMatrix(),
                angle_tolerance,
            )
        elif tool_z_down:
            ik.AddAngleBetweenVectorsConstraint(
                plant.world_frame(),
                np.array([0.0, 0.0, -1.0]),
                tool,
                np.array([0.0, 0.0, 1.0]),
                0.0,
                TOOL_DOWN_ANGLE,
            )
        return ik, q, prog

    eval_context = plant.CreateDefaultContext()

    def tool_distance(q_arm: np.ndarray) -> float:
        q_full = q_context.copy()
        q_full[arm_idx] = q_arm
        plant.SetPositions(eval_context, q_full)
        return float(np.linalg.norm(tool.CalcPoseInWorld(eval_context).translation() - target))

    best = np.inf
    solutions = []
    for start in seeds:
        ik, q, prog = build(True)
        # with an approach each solution stays near its own start: the postures differ
        near = first_seed if approach is None else start
        prog.AddQuadraticErrorCost(np.eye(arm_idx.size), near, q[arm_idx])
        q_init = q_context.copy()
        q_init[arm_idx] = start
        result = Solve(prog, q_init)
        q_arm = np.clip(result.GetSolution(q)[arm_idx], lower, upper)
        dist = tool_distance(q_arm)
        best = min(best, dist)
        if result.is_success() and dist <= tolerance:
            if approach is None:
                return q_arm
            solutions.append(q_arm)
    if solutions:
        full = np.tile(q_context, (len(solutions), 1))
        full[:, arm_idx] = solutions
        return solutions[lowest_mass_posture(plant, tool, full, approach)[0]]

    # Report how close the arm can get: minimise the distance without the position constraint.
    for start in seeds[:2]:
        ik, q, prog = build(False)
        q_init = q_context.copy()
        q_init[arm_idx] = start
        result = Solve(prog, q_init)
        best = min(best, tool_distance(np.clip(result.GetSolution(q)[arm_idx], lower, upper)))
    raise InfeasibleTarget(
        f"{model}/{arm}: no IK solution puts {tool_frame} within {tolerance:.4f} m of "
        f"target {np.round(target, 4).tolist()}"
        + (f" with rpy {list(target_rpy)}" if target_rpy is not None else "")
        + (" with the tool pointing down" if tool_z_down and target_rpy is None else "")
        + f" after {len(seeds)} seeds; best distance reached {best:.4f} m"
    )
