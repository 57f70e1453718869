"""The human: 12-dof body model, synthetic operator, depth cameras, recorded skeletons.

Cores (no pydrake): `body`, `trajectories`, `operator`, `camera`, `recorded`.
Drake adapters: `hrc_drake.human.systems`.
"""

from importlib import import_module

#: public name -> core module defining it; imported on first use (PEP 562), so importing a
#: submodule (e.g. `hrc_drake.human.config` for the scenario schema) does not load scipy
_EXPORTS = {
    "ARM_DOFS": "body",
    "CAPSULE_NAMES": "body",
    "JOINT_NAMES": "body",
    "N_DOF": "body",
    "BodyModel": "body",
    "DepthCameraModel": "camera",
    "RenderedCameraModel": "camera",
    "OperatorTask": "operator",
    "SyntheticOperator": "operator",
    "sampler_from_distribution": "operator",
    "tasks_from_schema": "operator",
    "load_skeleton_csv": "recorded",
    "save_skeleton_csv": "recorded",
    "minimum_jerk": "trajectories",
}


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(import_module(f"hrc_drake.human.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'hrc_drake.human' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))


__all__ = [
    "ARM_DOFS",
    "CAPSULE_NAMES",
    "JOINT_NAMES",
    "N_DOF",
    "BodyModel",
    "DepthCameraModel",
    "RenderedCameraModel",
    "OperatorTask",
    "SyntheticOperator",
    "load_skeleton_csv",
    "minimum_jerk",
    "sampler_from_distribution",
    "save_skeleton_csv",
    "tasks_from_schema",
]
