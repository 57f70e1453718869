"""Batched forward kinematics of one robot arm as a serial chain, in plain numpy (no Drake).

`SerialChain.from_model(model, arm)` reads the arm's joints (chain order) from the registry
record and the joint origins (xyz, rpy), axes and limits from the model's URDF (package data
`hrc_drake.models`). Poses follow the URDF convention Drake's parser uses: X_P_C(q) =
X_P_J(origin) * X_J(q), rpy as R = Rz(yaw) Ry(pitch) Rx(roll), revolute joints rotate and
prismatic joints slide along the unit axis of the joint frame. Everything is batched over
leading axes of q (a planner's rollouts x waypoints), so the world poses of thousands of
configurations are a handful of stacked 4x4 products, one per body of the chain.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from hrc_drake.robots.registry import RobotModel, get_robot_model
from hrc_drake.robots.urdf import UrdfJoint, pose_matrix, read_urdf_joints, rpy_matrix  # noqa: F401 (re-exported)


def _base_matrix(base_pose) -> np.ndarray:
    """World pose (4, 4) of the root link from None, a (4, 4) matrix or an (xyz, rpy) pair."""
    if base_pose is None:
        return np.eye(4)
    array = np.asarray(base_pose, dtype=float) if not isinstance(base_pose, tuple) else None
    if array is not None and array.shape == (4, 4):
        return array.copy()
    xyz, rpy = base_pose
    return pose_matrix(xyz, rpy)


def _joint_terms(moving: Sequence[UrdfJoint]) -> tuple[np.ndarray, ...]:
    """(U, V, W, D) (n, 3, 3), (n, 3, 3), (n, 3, 3), (n, 3): X_PJ X_J(q) = [cos q U + V + sin q W, p + q D].

    Revolute (Rodrigues): R_PJ R(a, q) = cos q R_PJ (I - a a^T) + R_PJ a a^T + sin q R_PJ [a]x, D = 0;
    prismatic: U = W = 0, V = R_PJ, D = R_PJ a.
    """
    U, V, W, D = (np.zeros((len(moving), *shape)) for shape in ((3, 3), (3, 3), (3, 3), (3,)))
    for i, joint in enumerate(moving):
        R, a = joint.origin[:3, :3], joint.axis
        if joint.kind == "prismatic":
            V[i], D[i] = R, R @ a
            continue
        skew = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
        U[i], V[i], W[i] = R @ (np.eye(3) - np.outer(a, a)), R @ np.outer(a, a), R @ skew
    return U, V, W, D


class SerialChain:
    """The serial chain root link -> tool frame of one arm of a registry robot model.

    bodies: the chain's links, root first, tool frame last (fixed links included);
    joints: the arm's actuated joints in chain order (= registry `ArmModel.joints`);
    lower, upper: (n,) joint limits from the URDF; capsule_bodies / capsule radii: the arm's
    capsules (registry order), optionally with the static base capsules; control_points:
    name -> (body index, offset (3,) in the body frame) for `points`.
    """

    def __init__(self, model: str | RobotModel, arm: str, urdf_text: str, base_pose=None,
                 include_static: bool = False,
                 extra_points: Mapping[str, tuple[str, Sequence[float]]] | None = None):
        record = get_robot_model(model)
        arm_record = record.arm(arm)
        by_child = read_urdf_joints(urdf_text)
        chain, link = [], arm_record.tool_frame
        while link != record.root_link:
            if link not in by_child:
                raise ValueError(f"{record.name}: link {link!r} is not connected to root "
                                 f"{record.root_link!r}")
            chain.append(by_child[link])
            link = by_child[link].parent
        chain.reverse()
        actuated = tuple(j.name for j in chain if j.kind != "fixed")
        if actuated != arm_record.joints:
            raise ValueError(f"{record.name}/{arm}: URDF chain joints {actuated} != the record's "
                             f"{arm_record.joints}")
        self.model, self.arm, self.tool_frame = record.name, arm, arm_record.tool_frame
        self.bodies: tuple[str, ...] = (record.root_link, *(j.child for j in chain))
        self.joints: tuple[str, ...] = actuated
        self.base = _base_matrix(base_pose)
        self._origins = np.array([j.origin for j in chain])  # (B-1, 4, 4) X_P_J per chain joint
        self._moving = np.array([j.kind != "fixed" for j in chain])
        moving = [j for j in chain if j.kind != "fixed"]
        self._U, self._V, self._W, self._D = _joint_terms(moving)
        self.lower = np.array([j.lower for j in moving])
        self.upper = np.array([j.upper for j in moving])
        self._init_capsules(record, include_static)
        self._init_points(moving, extra_points or {})

    @classmethod
    def from_model(cls, model: str | RobotModel = "yumi", arm: str = "left", base_pose=None,
                   include_static: bool = False,
                   extra_points: Mapping[str, tuple[str, Sequence[float]]] | None = None) -> SerialChain:
        """The chain of `arm` of robot `model` (a shipped name or a record), its URDF read from the record.

        base_pose: world pose of the root link, None (identity), a (4, 4) matrix or (xyz, rpy) as
        `add_robot` takes it; include_static: `capsules` also returns the capsules of the static
        bodies on the chain (e.g. the YuMi body); extra_points: more named control points,
        name -> (chain body, offset (3,) in its frame).
        """
        text = get_robot_model(model).urdf_text()
        return cls(model, arm, text, base_pose, include_static, extra_points)

    def _init_capsules(self, record, include_static: bool) -> None:
        index = {b: i for i, b in enumerate(self.bodies)}
        caps = [c for c in record.capsules if c.body in index
                and (include_static or c.body not in record.static_bodies)]
        self.capsule_bodies: tuple[str, ...] = tuple(c.body for c in caps)
        self._capsule_index = np.array([index[c.body] for c in caps], dtype=int)
        self._capsule_start = np.array([c.start for c in caps], dtype=float).reshape(-1, 3)
        self._capsule_end = np.array([c.end for c in caps], dtype=float).reshape(-1, 3)
        self.radii = np.array([c.radius for c in caps], dtype=float)

    def _init_points(self, moving, extra) -> None:
        """Body origins by name, plus 'tool', 'elbow' and 'wrist' aliases and `extra` points."""
        index = {b: i for i, b in enumerate(self.bodies)}
        n = len(moving)
        points = {b: (i, np.zeros(3)) for i, b in enumerate(self.bodies)}
        points["tool"] = points[self.tool_frame]
        # elbow / wrist: origins of the child links of joints (n-1)//2 and n-2 (chain order), i.e.
        # ABB axes 3 and 5 of the 7-axis YuMi and of the 6-axis IRB 140
        if n >= 3:
            points["elbow"] = points[moving[(n - 1) // 2].child]
            points["wrist"] = points[moving[n - 2].child]
        for name, (body, offset) in extra.items():
            if body not in index:
                raise ValueError(f"control point {name!r}: {body!r} is not a body of the chain {self.bodies}")
            points[name] = (index[body], np.asarray(offset, dtype=float).reshape(3))
        self.control_points: Mapping[str, tuple[int, np.ndarray]] = points

    @property
    def num_joints(self) -> int:
        return len(self.joints)

    @property
    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower (n,), upper (n,)) joint limits from the URDF."""
        return self.lower.copy(), self.upper.copy()

    def link_poses(self, q) -> np.ndarray:
        """World poses X_WB (..., n_bodies, 4, 4) of `bodies` for joint positions q (..., n_joints)."""
        q = np.asarray(q, dtype=float)
        if q.shape[-1:] != (self.num_joints,):
            raise ValueError(f"q must be (..., {self.num_joints}), got {q.shape}")
        c, s = np.cos(q)[..., None, None], np.sin(q)[..., None, None]
        local = np.broadcast_to(self._origins, (*q.shape[:-1], *self._origins.shape)).copy()
        moving = local[..., self._moving, :, :]  # (..., n, 4, 4), X_P_J X_J(q) of the actuated joints
        moving[..., :3, :3] = c * self._U + self._V + s * self._W
        moving[..., :3, 3] += q[..., None] * self._D
        local[..., self._moving, :, :] = moving
        poses = np.empty((*q.shape[:-1], len(self.bodies), 4, 4))
        poses[..., 0, :, :] = self.base
        for b in range(1, len(self.bodies)):  # along the chain (a few bodies), batched over q
            poses[..., b, :, :] = poses[..., b - 1, :, :] @ local[..., b - 1, :, :]
        return poses

    def capsules(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World capsules of the arm: (starts (..., K, 3), ends (..., K, 3), radii (K,)) for q (..., n)."""
        X = self.link_poses(q)[..., self._capsule_index, :, :]
        R, p = X[..., :3, :3], X[..., :3, 3]
        starts = np.einsum("...kij,kj->...ki", R, self._capsule_start) + p
        ends = np.einsum("...kij,kj->...ki", R, self._capsule_end) + p
        return starts, ends, self.radii.copy()

    def points(self, q, names: Sequence[str] = ("elbow", "tool")) -> np.ndarray:
        """World positions (..., len(names), 3) of named control points (see `control_points`)."""
        unknown = [n for n in names if n not in self.control_points]
        if unknown:
            raise ValueError(f"unknown control points {unknown}; known: {sorted(self.control_points)}")
        index = np.array([self.control_points[n][0] for n in names], dtype=int)
        offset = np.array([self.control_points[n][1] for n in names]).reshape(-1, 3)
        X = self.link_poses(q)[..., index, :, :]
        return np.einsum("...kij,kj->...ki", X[..., :3, :3], offset) + X[..., :3, 3]
