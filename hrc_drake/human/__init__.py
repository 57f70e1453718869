"""The human: 12-dof body model, synthetic operator, depth camera, recorded skeletons.

Cores (no pydrake): `body`, `trajectories`, `operator`, `camera`, `recorded`.
Drake adapters: `hrc_drake.human.systems`.
"""

from hrc_drake.human.body import ARM_DOFS, CAPSULE_NAMES, JOINT_NAMES, N_DOF, BodyModel
from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.human.operator import (
    OperatorTask,
    SyntheticOperator,
    sampler_from_distribution,
    tasks_from_schema,
)
from hrc_drake.human.recorded import load_skeleton_csv, save_skeleton_csv
from hrc_drake.human.trajectories import minimum_jerk

__all__ = [
    "ARM_DOFS",
    "CAPSULE_NAMES",
    "JOINT_NAMES",
    "N_DOF",
    "BodyModel",
    "DepthCameraModel",
    "OperatorTask",
    "SyntheticOperator",
    "load_skeleton_csv",
    "minimum_jerk",
    "sampler_from_distribution",
    "save_skeleton_csv",
    "tasks_from_schema",
]
