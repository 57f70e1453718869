"""A two-link planar arm plant for the safety tests (point masses at the links' ends)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, RevoluteJoint, RotationalInertia, SpatialInertia


def point_mass(mass: float, length: float) -> SpatialInertia:
    """A point mass at (length, 0, 0) of its body frame."""
    return SpatialInertia.MakeFromCentralInertia(mass, [length, 0.0, 0.0], RotationalInertia(0.0, 0.0, 0.0))


def two_link_arm(l1: float = 1.0, l2: float = 0.8, m1: float = 2.0, m2: float = 1.5, height: float = 0.0,
                 rotor_inertia: float = 0.0, gear_ratio: float = 1.0):
    """A planar arm in the plane z = height: joints about z at (0, 0, height) and at the end of
    link 1, a point mass at the end of each link; with `rotor_inertia` (kg m^2) each joint has a
    drive of that rotor and `gear_ratio`, reflected into the mass matrix as N^2 I_r. Returns
    (plant, link2)."""
    plant = MultibodyPlant(0.0)
    link1 = plant.AddRigidBody("link1", point_mass(m1, l1))
    link2 = plant.AddRigidBody("link2", point_mass(m2, l2))
    base = plant.AddFrame(FixedOffsetFrame("base", plant.world_frame(), RigidTransform([0.0, 0.0, height])))
    shoulder = plant.AddJoint(RevoluteJoint("shoulder", base, link1.body_frame(), [0.0, 0.0, 1.0]))
    elbow = plant.AddFrame(FixedOffsetFrame("elbow", link1.body_frame(), RigidTransform([l1, 0.0, 0.0])))
    elbow_joint = plant.AddJoint(RevoluteJoint("elbow", elbow, link2.body_frame(), [0.0, 0.0, 1.0]))
    plant.AddFrame(FixedOffsetFrame("tip", link2.body_frame(), RigidTransform([l2, 0.0, 0.0])))
    if rotor_inertia > 0.0:
        for joint in (shoulder, elbow_joint):
            drive = plant.AddJointActuator(f"{joint.name()}_drive", joint)
            drive.set_default_rotor_inertia(rotor_inertia)
            drive.set_default_gear_ratio(gear_ratio)
    plant.Finalize()
    return plant, link2


def two_link_kinematics(plant, l2: float = 0.8, radius: float = 0.05):
    """The capsule kinematics (`RobotCapsuleKinematics`' interface) of link 2 of `two_link_arm`."""
    link2 = plant.GetBodyByName("link2")
    return SimpleNamespace(names=("arm/link2",), capsule_bodies=np.array([int(link2.index())]),
                           local_ends=(np.zeros((1, 3)), np.array([[l2, 0.0, 0.0]])),
                           radius=np.array([radius]))
