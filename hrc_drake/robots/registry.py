"""The robot models a cell can hold: one `RobotModel` record per model, in `ROBOT_MODELS`.

Adding a robot is one URDF and one description `<name>.yaml` in `models/` (installed as
`hrc_drake.models` package data), read by `hrc_drake.robots.description`; a scenario's own robot
(`robots[i].urdf`) becomes the same record. Nothing else in the package names a model: the
cell's scenario checks, the plant builder, IK and the capsule kinematics all read these records.

Numbers follow docs/KINEMATICS.md (joint names and chain order of the public ROS
descriptions; capsule radii after the median mesh distances of 1.4 / 2.6; PD gains chosen so
that gravity sag stays below ~0.01 rad on a 1-10 ms discrete plant). Plain data: no pydrake.
"""

from __future__ import annotations

from hrc_drake.robots.description import get_robot_model, shipped_robot_models
from hrc_drake.robots.records import MODELS_PACKAGE, ArmModel, Capsule, RobotModel, capsule_arrays

__all__ = ["MODELS_PACKAGE", "ArmModel", "Capsule", "RobotModel", "capsule_arrays", "get_robot_model",
           "shipped_robot_models"]


def __getattr__(name: str):
    # ROBOT_MODELS is read on first use (the descriptions' files are read once)
    if name == "ROBOT_MODELS":
        return shipped_robot_models()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
