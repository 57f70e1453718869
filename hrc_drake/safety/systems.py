"""Drake systems of ISO/TS 15066 safety: the `SafetyController` between the speed rules and the
path follower, the `SafetyMonitor` that accounts contacts on the truth, and `apply_safety_config`.

Both read the robot from the `MultibodyPlant` (`RobotPointDynamics`): the capsules of its links,
the velocities of their end points from the bodies' spatial velocities (V = J v), and the
effective mass along a direction u at a point, m_R = (u^T J M^-1 J^T u)^-1, from the point's
translational Jacobian J and the mass matrix M.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.linalg
from pydrake.common.value import AbstractValue
from pydrake.multibody.tree import BodyIndex, JacobianWrtVariable
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem, ValueProducer
from pydrake.systems.primitives import MatrixGain

from hrc_drake.kernels import capsule_clearances
from hrc_drake.messages import SkeletonEstimate, SkeletonFrame, SweptVolumes, no_capsules
from hrc_drake.safety.config import LIMB_REGIONS, Hybrid, NoSafety, mode_name
from hrc_drake.safety.judge import (
    LIMB_FAST_SPEED,
    WALKING_SPEED,
    Judge,
    JudgeRun,
    JudgeValues,
    declared_mode,
    deviations,
)
from hrc_drake.safety.regions import (
    BODY_CAPSULES,
    CAPSULE_POINTS,
    HEAD,
    THORAX,
    RegionCapsules,
    lost_capsules,
    reach_bounded,
)
from hrc_drake.safety.rules import SafetyRules, decelerated_override, fastest_speed
from hrc_drake.safety.verdict import summarize
from hrc_drake.systems import declare_periodic_discrete_update


def capsule_structure(plant, bodies) -> tuple[np.ndarray, np.ndarray]:
    """(robot (K,), joined (K, K)) of the capsules on `bodies`: each one's model instance, and
    whether two lie on one body or on two bodies a joint (welds too) joins (`SafetyRules.near_pairs`)."""
    bodies = [int(b) for b in bodies]
    robots = np.array([int(plant.get_body(BodyIndex(b)).model_instance()) for b in bodies])
    links = set()
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        parent, child = int(joint.parent_body().index()), int(joint.child_body().index())
        links |= {(parent, child), (child, parent)}
    joined = np.array([[a == b or (a, b) in links for b in bodies] for a in bodies], dtype=bool)
    return robots, joined


def arm_masses(plant, bodies) -> np.ndarray:
    """M per body (kg): the mass of the moving subtree it belongs to (the bodies outboard of the
    innermost movable joint above it), for the standard's m_R = M/2 + m_L."""
    context = plant.CreateDefaultContext()
    joints = [plant.get_joint(j) for j in plant.GetJointIndices() if plant.get_joint(j).num_velocities() > 0]
    outboard = [set(int(b) for b in plant.GetBodiesKinematicallyAffectedBy([j.index()])) for j in joints]
    out = []
    for body in bodies:
        subtrees = [s for s in outboard if int(body) in s]
        largest = max(subtrees, key=len) if subtrees else {int(body)}
        out.append(sum(plant.get_body(BodyIndex(b)).get_mass(context) for b in largest))
    return np.array(out)


class RobotPointDynamics:
    """Capsules, end-point velocities and effective masses of the robot links of a plant.

    kinematics: `robots.models.RobotCapsuleKinematics` of the plant. Holds a scratch plant context,
    fully overwritten by `set_state` before each use (as `cell.systems.RobotCapsules`); what it
    derives from the positions (capsules, each body's operational-space inverse inertia) is kept
    until `set_state` is given other positions, what it derives from the velocities until other
    velocities: the safety controller and the contact monitor share one, and read the same
    positions at most of their samples.
    """

    def __init__(self, plant, kinematics):
        self.plant = plant
        self.kinematics = kinematics
        self.names = tuple(kinematics.names)
        self._context = plant.CreateDefaultContext()
        self._nq, self._nv = plant.num_positions(), plant.num_velocities()
        bodies = np.asarray(kinematics.capsule_bodies, dtype=int)
        self.bodies = bodies
        self._unique, self._inverse = np.unique(bodies, return_inverse=True)
        self._unique_list = [int(i) for i in self._unique]
        # one body per capsule in the capsules' order needs no gather
        self._gather = None if np.array_equal(self._unique, bodies) else self._inverse
        self._start_B, self._end_B = kinematics.local_ends
        self._local = np.stack([self._start_B, self._end_B])
        self.radius = np.array(kinematics.radius, dtype=float)
        self._body = [plant.get_body(BodyIndex(int(b))) for b in bodies]
        self._poses_port = plant.get_body_poses_output_port()
        self._velocities_port = plant.get_body_spatial_velocities_output_port()
        self._origins = None
        self._inverse_inertia: dict = {}
        self._mass_factor = None
        self._q = self._v = None
        self._robot = self._ends = self._moved = None

    @property
    def num_positions(self) -> int:
        return self._nq

    @property
    def num_velocities(self) -> int:
        return self._nv

    def set_state(self, q, v=None) -> None:
        """Positions (the first nq entries of `q`) and velocities (nv; None: as they were) of the plant."""
        q = np.asarray(q, dtype=float)[: self._nq]
        if self._q is None or not np.array_equal(q, self._q):
            self.plant.SetPositions(self._context, q)
            self._q = q.copy()
            self._origins = self._robot = self._ends = self._moved = None
            self._inverse_inertia = {}
            self._mass_factor = None
        if v is None:
            return
        v = np.asarray(v, dtype=float)[: self._nv]
        if self._v is None or not np.array_equal(v, self._v):
            self.plant.SetVelocities(self._context, v)
            self._v = v.copy()
            self._moved = None

    def capsules(self, velocities: bool = True):
        """((start, end, radius), (v_start, v_end)): world capsules (K) and their end points'
        velocities (K, 3), v = v_B + w_B x (p - p_B) from each body's spatial velocity (with
        `velocities` False, only the capsules and None: the velocity kinematics is not run)."""
        if self._robot is None:
            poses = self._poses_port.Eval(self._context)
            X = np.array([poses[i].GetAsMatrix4() for i in self._unique_list])
            if self._gather is not None:
                X = X[self._gather]
            R, p = X[:, :3, :3], X[:, :3, 3]
            self._origins = p
            self._ends = np.einsum("kij,skj->ski", R, self._local) + p  # (2, K, 3): starts and ends
            self._robot = (self._ends[0], self._ends[1], self.radius)
        robot = (*self._robot[:2], self.radius.copy())
        if not velocities:
            return robot, None
        if self._moved is None:
            spatial = self._velocities_port.Eval(self._context)
            V = np.array([spatial[i].get_coeffs() for i in self._unique_list])
            if self._gather is not None:
                V = V[self._gather]
            self._moved = V[:, 3:] + _cross(V[:, :3], self._ends - self._origins)  # (2, K, 3)
        return robot, (self._moved[0], self._moved[1])

    def _body_inverse_inertia(self, k: int) -> np.ndarray:
        """J M^-1 J^T (6, 6) at the origin of capsule k's body, J its spatial Jacobian ([w; v])."""
        body = int(self.bodies[k])
        cached = self._inverse_inertia.get(body)
        if cached is not None:
            return cached
        plant, world = self.plant, self.plant.world_frame()
        jacobian = plant.CalcJacobianSpatialVelocity(self._context, JacobianWrtVariable.kV,
                                                     self._body[k].body_frame(), np.zeros(3), world, world)
        if self._mass_factor is None:
            self._mass_factor = scipy.linalg.cho_factor(plant.CalcMassMatrix(self._context))
        value = jacobian @ scipy.linalg.cho_solve(self._mass_factor, jacobian.T)
        self._inverse_inertia[body] = value
        return value

    def effective_mass(self, k, points, directions) -> np.ndarray:
        """m_R = (a^T J M^-1 J^T a)^-1 (N,) at world `points` (N, 3) of capsules `k` (N,) along the
        unit `directions` u (N, 3), a = [r x u; u] with r the point's offset from its body's origin:
        the same as (u^T J_p M^-1 J_p^T u)^-1 with the point's translational Jacobian J_p (the last
        `set_state`)."""
        if self._origins is None:
            self.capsules()
        k = np.atleast_1d(np.asarray(k, dtype=int))
        u = np.asarray(directions, dtype=float).reshape(-1, 3)
        r = np.asarray(points, dtype=float).reshape(-1, 3) - self._origins[k]
        a = np.concatenate([_cross(r, u), u], axis=1)
        inertia = np.array([self._body_inverse_inertia(int(i)) for i in k])
        inverse_mass = np.einsum("ni,nij,nj->n", a, inertia, a)
        return np.where(inverse_mass > 1e-12, 1.0 / np.maximum(inverse_mass, 1e-12), np.inf)


def _cross(a, b):
    """a x b of (..., 3) arrays (numpy's cross costs ~20 us of argument handling per call)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


class HumanRegions:
    """Body-region capsules (ISO/TS 15066) from a skeleton estimate, with their Z_d."""

    def __init__(self, body_model, config, camera_noise: float = 0.0):
        self.body = body_model
        self.cutter = RegionCapsules()
        self.config = config
        self.camera_noise = float(camera_noise)
        # the skeleton points some region's capsule is placed by: all must be finite
        self._needed_points = np.unique([p for name in BODY_CAPSULES for p in CAPSULE_POINTS[name]])
        # each body capsule's first and last skeleton point: its uncertainty is their larger one
        self._capsule_first = np.array([CAPSULE_POINTS[name][0] for name in BODY_CAPSULES])
        self._capsule_last = np.array([CAPSULE_POINTS[name][-1] for name in BODY_CAPSULES])
        # a lost point may have moved at the human's speed since it was last seen (the limbs' v_h)
        self.lost_speed = config.human_speed if config.human_speed > 0 else 2.0

    def __call__(self, estimate: SkeletonEstimate, unseen_for=None, head_offset=None, age=0.0):
        """(region capsules, z_d (R,), lost_radius (R,)), or None while some region's points were
        never seen; lost_radius: a region's own radius where its capsule is a reachable set (a lost
        arm point), NaN elsewhere (`SafetyRules.clamped`).

        unseen_for: (8,) s since each point was last measured (camera source: a point the camera
        lost is held where it was last seen, and may have moved v_h x that time since).
        head_offset: head - thorax when both were last measured: a lost head (the robot's arm
        between camera and face) is carried with the measured thorax, its Z_d growing at v_h up to
        `lost_head_uncertainty` (the neck's own motion), and a lost thorax with the measured head
        likewise (the robot's arm between camera and chest: pcb_occlusion held its robot for good,
        the thorax's uncapped Z_d growing while the robot it waited for hid it). A lost arm point
        is bounded by its parent's reach (`regions.reach_bounded`); every other point's Z_d grows
        at v_h with no cap (issue 51, item 5: a person the camera lost for 10 s may be 20 m away).
        age: s (scalar or (8,)) since the measurement each point's position comes from: the person
        moves v_h x age after it, which the judge, on the truth now, holds against the robot (a
        hand at 2 m/s moved 3.3 cm during half a camera period); it grows a point's Z_d unless the
        point's v_h x time unseen, which runs to now, is larger."""
        points = np.asarray(estimate.points, dtype=float)
        if points.shape != (8, 3):
            return None
        unseen = None if unseen_for is None else np.array(unseen_for, dtype=float)
        offset_known = (unseen is not None and head_offset is not None
                        and bool(np.isfinite(head_offset).all()))
        head_carried = (offset_known and unseen[HEAD] > 0.0 and unseen[THORAX] == 0.0
                        and np.isfinite(points[THORAX]).all())
        thorax_carried = (offset_known and unseen[THORAX] > 0.0 and unseen[HEAD] == 0.0
                          and np.isfinite(points[HEAD]).all())
        if head_carried:
            points = points.copy()
            points[HEAD] = points[THORAX] + head_offset
        elif thorax_carried:
            points = points.copy()
            points[THORAX] = points[HEAD] - head_offset
        if not np.isfinite(points[self._needed_points]).all():
            return None
        start, end, radius = self.body.capsules_from_points(points)
        config = self.config
        if config.position_uncertainty == "fixed":
            z_d = np.full(len(self.cutter), config.fixed_uncertainty)
            return self.cutter.cut(start, end, radius), z_d, np.full(len(self.cutter), np.nan)
        # a point the camera has not measured for t s may be v_h t away (a lost head rides on the
        # measured thorax, within the neck's reach)
        moved = np.zeros(8) if unseen is None else self.lost_speed * unseen
        if head_carried:
            moved[HEAD] = min(moved[HEAD], config.lost_head_uncertainty)
        elif thorax_carried:
            moved[THORAX] = min(moved[THORAX], config.lost_head_uncertainty)
        since_measured = self.lost_speed * np.maximum(np.asarray(age, dtype=float), 0.0)
        if config.position_uncertainty == "tracker":
            # whatever the tracker's model predicts (its spread of a hidden point grows at its own
            # rate); without the times a point with no spread stays lost (NaN, below: anywhere)
            # (the spread is the estimate's at its time, which the person has moved on from; a lost
            # point's v_h t already runs to now)
            spread = config.uncertainty_sigmas * np.asarray(estimate.spread, dtype=float) + since_measured
            uncertainty = spread if unseen is None else np.fmax(spread, moved)
        else:  # camera
            uncertainty = config.uncertainty_sigmas * self.camera_noise + np.maximum(moved, since_measured)
        uncertainty = np.where(np.isnan(uncertainty), np.inf, uncertainty)
        if (uncertainty <= config.max_uncertainty).all():  # nothing lost: `reach_bounded` keeps the capsules
            per_capsule = np.maximum(uncertainty[self._capsule_first], uncertainty[self._capsule_last])
            return (self.cutter.cut(start, end, radius), self.cutter.region_uncertainty(per_capsule),
                    np.full(len(self.cutter), np.nan))
        own_radius = self.cutter.cut(start, end, radius)[2]
        lost = self.cutter.region_uncertainty(lost_capsules(uncertainty, config.max_uncertainty)) > 0.5
        start, end, radius, per_capsule = reach_bounded(
            start, end, radius, uncertainty, config.max_uncertainty, self.body.upper_arm,
            self.body.forearm + self.body.hand_length)
        regions = self.cutter.cut(start, end, radius)
        # a point never measured or without a spread may be anywhere: a finite stand-in beyond
        # any cell keeps the separation arithmetic free of inf - inf
        z_d = self.cutter.region_uncertainty(np.minimum(per_capsule, ANYWHERE))
        return regions, z_d, np.where(lost, own_radius, np.nan)


def swept_regions(swept: SweptVolumes, cutter: RegionCapsules):
    """Each region's swept capsule: the swept volume of its body capsule (by name), or None."""
    names = {name: k for k, name in enumerate(swept.names)}
    if not len(swept.radius) or any(name not in names for name in BODY_CAPSULES):
        return None
    index = np.array([names[BODY_CAPSULES[c.capsule]] for c in cutter.cuts])
    return (np.asarray(swept.start)[index], np.asarray(swept.end)[index], np.asarray(swept.radius)[index])


def _union(present, grown):
    """Each region's capsule covering both: the grown (swept) one where it holds the present one,
    else one capsule around both (ends and radius of the larger reach), so the present body is
    never left out."""
    start, end, radius = (np.asarray(x, dtype=float) for x in present)
    g_start, g_end, g_radius = (np.asarray(x, dtype=float) for x in grown)
    # a swept capsule holds the present one when both present ends lie within g_radius - radius of
    # its segment
    inside = (_point_segment_distance(start, g_start, g_end) <= g_radius - radius + 1e-9) & (
        _point_segment_distance(end, g_start, g_end) <= g_radius - radius + 1e-9)
    grow = np.maximum(_point_segment_distance(start, g_start, g_end),
                      _point_segment_distance(end, g_start, g_end)) + radius
    return (g_start, g_end, np.where(inside, g_radius, np.maximum(g_radius, grow)))


def _point_segment_distance(points, a, b):
    """(R,) distance of each point to its segment [a, b]."""
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    along = np.einsum("ij,ij->i", points - a, ab)
    t = np.where(length2 > 0, along / np.where(length2 > 0, length2, 1.0), 0.0)
    closest = a + np.clip(t, 0.0, 1.0)[:, None] * ab
    return np.linalg.norm(points - closest, axis=1)


#: Z_d (m) of a body point that may be anywhere (never measured, no spread): beyond any cell
ANYWHERE = 1000.0

#: the controller's discrete state: [override applied, safety command, protective stops, stopped
#: flag, binding clearance, S_p of the binding pair], then the time each skeleton point was last
#: measured (8), the head's offset from the thorax when both were last measured (3), until when
#: the robot backs off after a contact and until when PFL parts keep the compression budget (2),
#: and the time until which each (robot capsule, region) pair counts as clamped (K x R)
_STATE = ("override", "command", "stops", "stopped", "distance", "separation")


#: a robot link pressing a body part deeper than this (m) is a contact the robot senses (an
#: assumption for its joint-torque contact detection: 0.5 mm is 37 N on a hand, k 75 N/mm, a
#: quarter of its quasi-static limit)
CONTACT_DETECTION = 0.0005


class ContactSensing(LeafSystem):
    """The robot's contact detection: each period the deepest overlap (m) of a robot link with the
    person's true body, output "contact_depth" (1,), held until the next period (a sampled sensor).
    Inputs "positions" (the plant's first) and "human_capsules" (`Capsules`, the true body). What
    a PFL robot's joint-torque sensing feels; the controller reacts to it (`contact_reaction`)."""

    def __init__(self, dynamics: RobotPointDynamics, input_size: int, period: float):
        super().__init__()
        self.dynamics = dynamics
        self._state = self.DeclareDiscreteState(1)
        self._positions = self.DeclareVectorInputPort("positions", input_size)
        self._human = self.DeclareAbstractInputPort("human_capsules", AbstractValue.Make(no_capsules()))
        self.DeclareStateOutputPort("contact_depth", self._state)
        declare_periodic_discrete_update(self, period, 0.0, self._update)

    def _update(self, context, discrete_state):
        start, end, radius = self._human.Eval(context)
        depth = 0.0
        if len(radius):
            self.dynamics.set_state(self._positions.Eval(context))
            robot, _ = self.dynamics.capsules(velocities=False)
            gaps = capsule_clearances(*robot, np.asarray(start, float), np.asarray(end, float),
                                      np.asarray(radius, float))
            depth = max(-float(gaps.min(initial=np.inf)), 0.0)
        discrete_state.get_mutable_vector(self._state).SetAtIndex(0, depth)
        return EventStatus.Succeeded()


class SafetyController(LeafSystem):
    """The ISO/TS 15066 safety controller: the speed override of the path follower (`safety.rules`).

    Inputs "positions" (the plant's positions first), "velocities_full" (nv: the path's joint
    velocities at override 1), "skeleton_estimate" (`SkeletonEstimate`), "requested_override"
    (1: the thesis's own speed rules, layered under; unconnected: 1), "swept_volumes" (with
    `human_motion: swept_volumes`), the next tick's "positions_full_next" and
    "velocities_full_next", "contact_depth" (1: `ContactSensing`; PFL's `contact_reaction`:
    after a sensed contact the robot brakes and backs off along its path, override < 0), and
    "path_preview" (the follower's, with `speed_profile: predictive`: `_planned_profile`), and
    "skeleton_frame" (the camera's measurement, `SkeletonFrame`; unconnected: the estimate only).
    The person's points are the camera's where it measured them, the estimate's elsewhere (a
    tracker's estimate lags a hand moving at 2 m/s by several cm, more than its spread: the
    safety function reads the sensor), each with Z_d grown by v_h x the age of its measurement.
    Output "speed_override" (1, in [-1, 1]) and "status" (6: `_STATE`).
    Each period it takes the smallest of the requested override and the rules' override, and
    lets it fall no faster than the stopping model's deceleration; a command of 0 is a
    protective stop (counted once per stop), and so is a command below what that deceleration
    reaches within the period (the robot is inside S_p at its speed): it then brakes toward 0.
    Until every body region has been seen once the robot is held (0).
    """

    def __init__(self, rules: SafetyRules, dynamics: RobotPointDynamics, regions: HumanRegions,
                 input_size: int):
        super().__init__()
        config = rules.config
        self.rules = rules
        self.dynamics = dynamics
        self.regions = regions
        self.period = 1.0 / config.rate
        self.swept = config.human_motion == "swept_volumes"
        self._preview_swept = config.speed_profile == "predictive" and config.preview_human == "swept_volumes"
        # then the time until which each (robot capsule, region) pair counts as clamped (`clamp_hold`)
        self._pairs = (len(dynamics.names), len(regions.cutter))
        initial = [[1.0, 1.0, 0.0, 0.0, np.inf, np.nan], np.full(8, -np.inf), np.full(3, np.nan),
                   [-np.inf, -np.inf], np.full(self._pairs[0] * self._pairs[1], -np.inf)]
        self._state = self.DeclareDiscreteState(np.concatenate(initial))
        self._positions = self.DeclareVectorInputPort("positions", input_size)
        self._velocities = self.DeclareVectorInputPort("velocities_full", dynamics.num_velocities)
        self._velocities_ahead = self.DeclareVectorInputPort("velocities_full_ahead", dynamics.num_velocities)
        self._positions_next = self.DeclareVectorInputPort("positions_full_next", dynamics.num_positions)
        self._velocities_next = self.DeclareVectorInputPort("velocities_full_next", dynamics.num_velocities)
        self._contact_depth = self.DeclareVectorInputPort("contact_depth", 1)
        self._preview_steps = config.preview_steps()
        self._preview = self.DeclareVectorInputPort(
            "path_preview", 2 * dynamics.num_positions * self._preview_steps)
        self._estimate = self.DeclareAbstractInputPort("skeleton_estimate",
                                                       AbstractValue.Make(SkeletonEstimate()))
        self._frame = self.DeclareAbstractInputPort("skeleton_frame", AbstractValue.Make(SkeletonFrame()))
        self._requested = self.DeclareVectorInputPort("requested_override", 1)
        self._swept_volumes = self.DeclareAbstractInputPort("swept_volumes",
                                                            AbstractValue.Make(SweptVolumes()))
        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareVectorOutputPort("speed_override", 1, self._calc_override, ticket)
        self.DeclareVectorOutputPort("status", len(_STATE), self._calc_status, ticket)
        self._seen = slice(len(_STATE), len(_STATE) + 8)
        self._head = slice(len(_STATE) + 8, len(_STATE) + 11)
        self._contact = slice(len(_STATE) + 11, len(_STATE) + 13)
        self._clamped = slice(len(_STATE) + 13, None)
        declare_periodic_discrete_update(self, self.period, 0.0, self._update)

    def _command(self, context, measurement, seen, head_offset, clamped_until, budget: bool = False,
                 backing: bool = False):
        """(rules' override, binding clearance, its S_p, the fastest robot point's speed at full
        path speed now and the most it reaches within `lookahead` of path time, the largest
        override of backing off along the path (0 unless `backing`), the predictive profile's
        override (1 when reactive)) for the inputs of `context`; measurement: `_measurement`'s
        (estimate, measurement times), or None without an estimate; `seen` (8,): the time each point
        was last measured; head_offset: head - thorax when last both seen; clamped_until (K, R): updated
        in place (`SafetyRules.override`); budget: as `SafetyRules.override` (after a contact)."""
        human = None
        if measurement is not None:
            estimate, measured_at = measurement
            human = self.regions(estimate, context.get_time() - seen, head_offset,
                                 age=context.get_time() - measured_at)
        if human is None:
            return 0.0, math.nan, math.nan, 0.0, 0.0, 0.0, 0.0
        regions, z_d, lost_radius = human
        covered = 0.0
        preview_regions = regions
        if (self.swept or self._preview_swept) and self._swept_volumes.HasValue(context):
            swept = self._swept_volumes.Eval(context)
            grown = swept_regions(swept, self.regions.cutter)
            if grown is not None and self.swept:
                regions, covered = grown, float(swept.horizon)
            if grown is not None and self._preview_swept:
                # the regions where the person may be within the horizon (present included), with
                # the standard's full S_h on top: the profile slows earlier, never later
                preview_regions = _union(human[0], grown)
        positions = self._positions.Eval(context)
        self.dynamics.set_state(positions, self._velocities.Eval(context))
        robot, velocity = self.dynamics.capsules()
        now = context.get_time()
        mass = self.dynamics.effective_mass
        command, binding = self.rules.override(robot, velocity, regions, z_d, mass, covered, clamped_until,
                                               now, lost_radius, budget)
        fastest = next_fastest = fastest_speed(velocity)
        # backing off is a motion too: toward whatever is behind the robot it keeps the rules (a short
        # slow motion: the transient PFL speeds, not the compression budget, which the estimate's
        # Z_d turns into a stop beside a part the robot is wedged against)
        back = 0.0 if not backing else self.rules.override(
            robot, tuple(-v for v in velocity), regions, z_d, mass, covered, clamped_until.copy(), now,
            lost_radius)[0]
        if self._velocities_ahead.HasValue(context):
            # a path accelerating within T_r (from rest, say): the speed it reaches counts, not only
            # the speed it has (S_r = v T_r holds v over T_r); the smaller override of the two
            self.dynamics.set_state(positions, self._velocities_ahead.Eval(context))
            _, velocity_ahead = self.dynamics.capsules()
            fastest_ahead = fastest_speed(velocity_ahead)
            if fastest_ahead > fastest:
                ahead, ahead_binding = self.rules.override(
                    robot, velocity_ahead, regions, z_d, mass, covered, clamped_until, now, lost_radius,
                    budget)
                if ahead < command:
                    command, binding = ahead, ahead_binding
                next_fastest = fastest_ahead
        if self._positions_next.HasValue(context) and self._velocities_next.HasValue(context):
            next_command, next_binding, next_speed = self._next_tick(
                context, regions, z_d, covered, clamped_until, now, lost_radius, budget)
            if next_command < command:
                command, binding = next_command, next_binding
            next_fastest = max(next_fastest, next_speed)
        planned = 1.0
        if self._preview_steps and not backing and self._preview.HasValue(context):
            planned = self._planned_profile(self._preview.Eval(context), fastest, preview_regions, z_d,
                                            0.0 if preview_regions is not regions else covered,
                                            clamped_until, now, lost_radius, budget)
        if binding is None:
            return command, math.inf, math.nan, fastest, next_fastest, back, planned
        pairs, n, _, separation = binding
        return command, float(pairs.distance[n]), separation, fastest, next_fastest, back, planned

    def _measurement(self, context) -> tuple[SkeletonEstimate, np.ndarray]:
        """(the estimate with the camera's measured points in place of its own, (8,) the time of the
        measurement each point comes from): a point the camera measured has the camera's noise as
        its spread and is tracked."""
        estimate = self._estimate.Eval(context)
        measured_at = np.full(8, float(estimate.time))
        if not self._frame.HasValue(context):
            return estimate, measured_at
        frame = self._frame.Eval(context)
        frame_points = np.asarray(frame.points, dtype=float)
        points = np.asarray(estimate.points, dtype=float)
        if frame_points.shape != (8, 3) or points.shape != (8, 3):
            return estimate, measured_at
        fresh = (np.asarray(frame.tracked, dtype=bool) & np.isfinite(frame_points).all(axis=1)
                 & (float(frame.time) >= measured_at))
        if not fresh.any():
            return estimate, measured_at
        merged = replace(
            estimate,
            points=np.where(fresh[:, None], frame_points, points),
            spread=np.where(fresh, self.regions.camera_noise, np.asarray(estimate.spread, dtype=float)),
            tracked=np.asarray(estimate.tracked, dtype=bool) | fresh,
        )
        return merged, np.where(fresh, float(frame.time), measured_at)

    def _planned_profile(self, preview, fastest, regions, z_d, covered, clamped_until, now, lost_radius,
                         budget=False) -> float:
        """The predictive speed profile's override now: the largest from which braking at the
        planning deceleration a_p reaches the override o_k the rules allow at each preview sample k
        (k steps of full-speed path time ahead) by the sample before it, tau_{k-1} = (k - 1) step
        ahead (the rules hold at the samples only: a lower speed may be needed anywhere after the
        last sample checked): o <= sqrt(o_k^2 + 2 a_p tau_{k-1} / V), V the fastest point's speed
        at full path speed up to sample k (the path time runs at o, the fastest point slows by at
        most a_p). So the robot reaches a place it may not pass at rest, a planned wait, instead of
        a stop; it leaves rest only where the next sample is free. The human at each sample: the
        present estimate (a person standing still; S_p's S_h covers their motion during a stop)."""
        config = self.rules.config
        nq = self.dynamics.num_positions
        samples = np.asarray(preview, dtype=float).reshape(self._preview_steps, 2, nq)
        highest = fastest
        planned = 1.0
        for k, (positions, velocities) in enumerate(samples, start=1):
            if not np.any(velocities):
                continue  # the path rests there: no motion to keep S_p for
            self.dynamics.set_state(positions, velocities)
            robot, velocity = self.dynamics.capsules()
            allowed, _ = self.rules.override(robot, velocity, regions, z_d, self.dynamics.effective_mass,
                                             covered, clamped_until.copy(), now, lost_radius, budget)
            highest = max(highest, fastest_speed(velocity))
            if highest <= 1e-9:
                continue  # joints move that move no link's surface (a wrist turning in place)
            tau = (k - 1) * config.preview_step
            planned = min(planned, math.sqrt(allowed**2 + 2.0 * config.planning_deceleration * tau / highest))
        return planned

    def _next_tick(self, context, regions, z_d, covered, clamped_until, now, lost_radius, budget=False):
        """(rules' override, binding pair, fastest point's speed) at the robot's state one period of
        full-speed path ahead: the judge samples S_p again there, and a path turning toward a body
        part within the period (a corner of a blended polyline, the nearest point moving along a
        link) raises that pair's approach before the next tick could answer it. The human's regions
        are today's (their own motion is the S_h of the next tick's S_p, which stops in time); a
        clamp the robot would meet there holds the override but is not remembered."""
        positions = self._positions_next.Eval(context)
        velocities = self._velocities_next.Eval(context)
        if not np.any(velocities):
            return 1.0, None, 0.0
        self.dynamics.set_state(positions, velocities)
        robot, velocity = self.dynamics.capsules()
        command, binding = self.rules.override(robot, velocity, regions, z_d, self.dynamics.effective_mass,
                                               covered, clamped_until.copy(), now, lost_radius, budget)
        return command, binding, fastest_speed(velocity)

    def _update(self, context, discrete_state):
        x = np.array(context.get_discrete_state(self._state).get_value())
        seen, head_offset = x[self._seen], x[self._head]
        measurement = self._measurement(context) if self._estimate.HasValue(context) else None
        if measurement is not None:
            estimate = measurement[0]
            measured = (np.isfinite(np.asarray(estimate.spread, dtype=float))
                        & np.asarray(estimate.tracked, bool))
            if measured.shape == (8,):
                seen = np.where(measured, context.get_time(), seen)
                if measured[HEAD] and measured[THORAX]:
                    points = np.asarray(estimate.points, dtype=float)
                    head_offset = points[HEAD] - points[THORAX]
        clamped_until = x[self._clamped].reshape(self._pairs)
        now = context.get_time()
        backing_until, hold_until, touched = self._contact_step(context, float(x[0]), *x[self._contact])
        backing = now < backing_until
        command, distance, separation, fastest, next_fastest, back, planned = self._command(
            context, measurement, seen, head_offset, clamped_until, budget=now < hold_until, backing=backing)
        deceleration = self.rules.config.deceleration
        if touched:
            applied, command, stopped = 0.0, 0.0, True
        elif backing:
            applied, command, stopped = self._back_off(float(x[0]), back, fastest, next_fastest)
        else:
            requested = float(self._requested.Eval(context)[0]) if self._requested.HasValue(context) else 1.0
            requested = min(max(requested, 0.0), 1.0) if math.isfinite(requested) else 0.0
            # the planned profile only slows the robot earlier: a stop is the present's command only
            target = min(requested, command, planned)
            applied = decelerated_override(float(x[0]), target, self.period, fastest, deceleration,
                                           next_fastest)
            # braking cannot bring the robot down to the speed its separation allows within this
            # period: at the speed it has it is inside S_p, which ISO/TS 15066 5.5.4 answers with a
            # protective stop (a speed reduction is only allowed while S_p holds)
            braking_limited = applied > command + 1e-9
            if braking_limited:
                applied = decelerated_override(float(x[0]), 0.0, self.period, fastest, deceleration,
                                               next_fastest)
            stopped = command <= 0.0 or braking_limited
        # a stop stops a robot in motion: a command of 0 to a robot at rest (waiting where its
        # planned profile brought it, the estimate's noise flipping the command) is none
        stops = x[2] + (1.0 if stopped and not x[3] and self._moving(context, float(x[0])) else 0.0)
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            np.concatenate([[applied, command, stops, float(stopped), distance, separation], seen,
                            head_offset, [backing_until, hold_until], clamped_until.ravel()]))
        return EventStatus.Succeeded()

    def _contact_step(self, context, previous: float, backing_until: float, hold_until: float):
        """(until when the robot backs off, until when PFL parts keep the compression budget, whether
        it is touched at rest) after this period's reading of its contact sensing
        (`contact_reaction`). A robot moving (faster than the judge's 1 mm/s) when a contact comes
        made it and backs off; a robot at rest did not: it stays at rest while touched (a person
        who walks into a stopped robot is not held against it, one it moves under is)."""
        config = self.rules.config
        if not (self.rules.pfl and config.contact_reaction and self._contact_depth.HasValue(context)):
            return backing_until, hold_until, False
        if float(self._contact_depth.Eval(context)[0]) <= CONTACT_DETECTION:
            return backing_until, hold_until, False
        now = context.get_time()
        hold_until = max(hold_until, now + config.retreat_time + config.contact_hold)
        if now < backing_until or self._moving(context, previous):
            return now + config.retreat_time, hold_until, False
        return backing_until, hold_until, True

    def _moving(self, context, override: float) -> bool:
        """Whether the robot's fastest point moves faster than 1 mm/s at `override` of its path."""
        self.dynamics.set_state(self._positions.Eval(context), self._velocities.Eval(context))
        return abs(override) * fastest_speed(self.dynamics.capsules()[1]) > 1e-3

    def _back_off(self, previous: float, back: float, fastest: float, next_fastest: float):
        """(applied override, command, stopped) of a period backing off after a contact: braking at
        a first (a protective stop while the robot still moves on), then back along the path at up
        to `retreat_speed` on its fastest point, within the rules of that motion (`back`); a robot
        whose path is at rest here did not make the contact and holds (0)."""
        config = self.rules.config
        if fastest <= 1e-9:
            return 0.0, 0.0, True
        command = -min(config.retreat_speed / fastest, back, 1.0)
        applied = decelerated_override(previous, command, self.period, fastest, config.deceleration,
                                       next_fastest, lowest=-1.0)
        return applied, command, applied > 1e-12 or command == 0.0

    def _calc_override(self, context, output: BasicVector):
        output.SetAtIndex(0, context.get_discrete_state(self._state).get_value()[0])

    def _calc_status(self, context, output: BasicVector):
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[: len(_STATE)])

    def protective_stops(self, context) -> int:
        """Protective stops so far in this system's `context`."""
        return int(context.get_discrete_state(self._state).get_value()[2])


class _MonitorRecording:
    """The monitor's cache value: the judges' runs so far (replaced, never changed in place)."""

    __slots__ = ("runs",)

    def __init__(self, runs: tuple[JudgeRun, ...] = ()):
        self.runs = runs

    def __deepcopy__(self, memo):
        return _MonitorRecording(self.runs)


class SafetyMonitor(LeafSystem):
    """The ISO/TS 15066 judge as a system: judges the run on the truth every `period` s
    (`safety.judge`), independent of the controller (it reads only the controller's protective-stop
    command, to measure the stops).

    Inputs "human_capsules" (`Capsules`, the true body), "positions" (the plant's first),
    "protective_stop" (1: the controller's stop command, > 0.5 a stop; unconnected: no controller)
    and "skeleton_estimate" (what the cell measured of the person; unconnected: not judged). The
    robot's and the body's velocities are their capsules' motion since the last sample. A recorder
    like `MetricsRecorder`: its runs are a cache entry its periodic publish replaces, cleared at
    initialization, so it costs the simulation no state copies. `judges[0]` is the standard judge;
    a second one, where given, is the scenario's changed judge or the controller's own model.
    `summary(context, stops)` gives metrics.json's `safety`.
    """

    def __init__(self, judges: tuple[Judge, ...], dynamics: RobotPointDynamics, input_size: int,
                 period: float,
                 mode: str, departures: tuple[str, ...] = ()):
        super().__init__()
        self.judges = tuple(judges)
        self.dynamics = dynamics
        self.cutter = RegionCapsules()
        self.mode = mode
        self.departures = tuple(departures)
        self._human = self.DeclareAbstractInputPort("human_capsules", AbstractValue.Make(no_capsules()))
        self._positions = self.DeclareVectorInputPort("positions", input_size)
        self._stop = self.DeclareVectorInputPort("protective_stop", 1)
        self._estimate = self.DeclareAbstractInputPort("skeleton_estimate",
                                                       AbstractValue.Make(SkeletonEstimate()))
        self._entry = self.DeclareCacheEntry(
            "judged runs", ValueProducer(allocate=lambda: AbstractValue.Make(_MonitorRecording()),
                                         calc=lambda *_: None), {self.nothing_ticket()})
        self.DeclareInitializationPublishEvent(self._clear)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._record)

    def _recording(self, context) -> _MonitorRecording:
        return self._entry.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()

    def _clear(self, context):
        self._recording(context).runs = tuple(JudgeRun() for _ in self.judges)
        return EventStatus.Succeeded()

    def _measured(self, context):
        """(8,) which skeleton points the cell measured at this sample, or None (not connected)."""
        if not self._estimate.HasValue(context):
            return None
        estimate = self._estimate.Eval(context)
        measured = (np.asarray(estimate.tracked, dtype=bool)
                    & np.isfinite(np.asarray(estimate.spread, dtype=float)))
        points = np.asarray(estimate.points, dtype=float)
        if measured.shape != (8,) or points.shape != (8, 3):
            return np.zeros(8, dtype=bool)
        return measured & np.isfinite(points).all(axis=1)

    def _record(self, context):
        recording = self._recording(context)
        time = context.get_time()
        if not recording.runs:
            recording.runs = tuple(JudgeRun() for _ in self.judges)
        if time <= recording.runs[0].last_time:
            return EventStatus.DidNothing()
        start, end, radius = self._human.Eval(context)
        if len(radius) != len(BODY_CAPSULES):
            return EventStatus.DidNothing()
        regions = self.cutter.cut(start, end, radius)
        self.dynamics.set_state(self._positions.Eval(context))
        robot, _ = self.dynamics.capsules(velocities=False)
        stop = bool(self._stop.Eval(context)[0] > 0.5) if self._stop.HasValue(context) else None
        measured = self._measured(context)
        mass = self.dynamics.effective_mass
        recording.runs = tuple(judge.step(run, time, robot, regions, mass, stop, measured)
                               for judge, run in zip(self.judges, recording.runs, strict=True))
        return EventStatus.Succeeded()

    def run(self, context, which: int = 0) -> JudgeRun:
        """The standard judge's run (`which` 1: the changed judge's) in this system's `context`."""
        runs = self._recording(context).runs
        return runs[which] if runs else JudgeRun()

    def episodes(self, context):
        """Every episode of the standard judge's run (violations and logged contacts), by onset."""
        return self.judges[0].finish(self.run(context))[0]

    def summary(self, context, protective_stops: int = 0) -> dict:
        """metrics.json's ISO/TS 15066 figures and verdict (`safety.verdict.summarize`)."""
        run = self.run(context)
        duration = max(run.last_time, 0.0) if run.samples else 0.0
        own = (self.judges[1], self.run(context, 1)) if len(self.judges) > 1 else None
        return summarize(self.judges[0], run, mode=self.mode, duration=duration,
                         protective_stops=protective_stops,
                         departures=self.departures, own=own)


def controller_departures(config) -> tuple[str, ...]:
    """How a safety controller's S_h departs from ISO 13855's speeds (a declared departure, e.g. the
    thesis's 8.1 swept volumes): its verdict is NON-CONFORMING, its own model judged beside."""
    if isinstance(config, NoSafety):
        return ()
    out = []
    if config.human_motion == "swept_volumes":
        out.append("the controller's S_h comes from the motion model's swept volumes (thesis 8.1), not ISO "
                   "13855's speeds")
    if 0 < config.human_speed < LIMB_FAST_SPEED:
        out.append(f"the controller's v_h of hands and arms is {config.human_speed:g} m/s, below ISO 13855's "
                   f"{LIMB_FAST_SPEED:g} m/s")
    if isinstance(config, Hybrid):
        torso = sorted(set(config.pfl_regions) - set(LIMB_REGIONS))
        if torso:
            out.append(f"the controller lets {', '.join(torso)} take contact under hybrid, where the judge "
                       "holds head and torso to SSM")
    body = config.body_speed or config.human_speed
    if 0 < body < WALKING_SPEED:
        out.append(f"the controller's v_h of head and torso is {body:g} m/s, below ISO 13855's "
                   f"{WALKING_SPEED:g} m/s")
    return tuple(out)


def own_model_values(config, standard: JudgeValues, covered_time: float = 0.0) -> JudgeValues:
    """The judge's values with the controller's own S_h (its v_h, or its swept volumes' horizon H)."""
    limb = config.human_speed if config.human_speed > 0 else 0.0
    body = config.body_speed or config.human_speed or WALKING_SPEED
    covered = covered_time if config.human_motion == "swept_volumes" else 0.0
    return replace(standard, limb_speed=limb, body_speed=body, covered_time=covered)


def apply_safety_config(config, builder, *, plant, kinematics, body_model, limits, zones, fixed_boxes,
                        positions, velocities_full, skeleton_estimate, human_capsules, skeleton_frame=None,
                        velocities_full_ahead=None, positions_full_next=None, velocities_full_next=None,
                        path_preview=None, requested_override, judge_values: JudgeValues,
                        judge_changes: JudgeValues | None = None,
                        payloads=None, swept_volumes=None, swept_horizon: float = 0.0,
                        camera_noise: float = 0.0, monitor_period: float = 1.0 / 30.0,
                        robot_claims: tuple[str, ...] = ()):
    """Add the safety controller of `config` ("safety_controller"; none for `NoSafety`) and the
    judge ("safety_monitor", always) to `builder` and connect them.

    positions: the plant's positions port (kinematic: the follower's; dynamic: the plant state);
    velocities_full: the follower's joint velocities at full speed (the controller's approach speeds);
    velocities_full_ahead: the same a reaction time of path ahead (None: not used);
    positions_full_next, velocities_full_next: the plant's positions and the velocities at full speed
    one tick of path ahead (None: not used; the controller then checks the present only);
    path_preview: the follower's "path_preview" of `config.preview_steps()` samples (the predictive
    speed profile; None: not planned);
    requested_override: the smallest of the thesis's own speed rules (a port giving (1,)), or None
    to connect later; limits: the controller's limits table; judge_values: the standard judge's
    values of this cell (`judge.standard_values`); judge_changes: the scenario's changed judge, or
    None; payloads (K,): m_L of each robot capsule's arm; swept_horizon: H of the motion model;
    skeleton_frame: the camera's "skeleton_frame" (the controller's measured points), or None.
    Returns (controller or None, monitor); the follower reads the controller's "speed_override".
    """
    config.validate("safety")
    region_names = RegionCapsules().regions
    masses = arm_masses(plant, kinematics.capsule_bodies)
    robots, joined = capsule_structure(plant, kinematics.capsule_bodies)
    rules = SafetyRules(config, limits, region_names, zones, fixed_boxes, masses, payloads=payloads,
                        capsule_robots=robots, joined_capsules=joined)
    input_size = positions.size()
    controller = None
    # one for both systems: they read the same positions at most samples (`RobotPointDynamics`)
    dynamics = RobotPointDynamics(plant, kinematics)
    if not isinstance(config, NoSafety):
        controller = builder.AddSystem(SafetyController(
            rules, dynamics, HumanRegions(body_model, config, camera_noise), input_size))
        controller.set_name("safety_controller")
        builder.Connect(positions, controller.GetInputPort("positions"))
        builder.Connect(velocities_full, controller.GetInputPort("velocities_full"))
        if velocities_full_ahead is not None:
            builder.Connect(velocities_full_ahead, controller.GetInputPort("velocities_full_ahead"))
        if positions_full_next is not None and velocities_full_next is not None:
            builder.Connect(positions_full_next, controller.GetInputPort("positions_full_next"))
            builder.Connect(velocities_full_next, controller.GetInputPort("velocities_full_next"))
        builder.Connect(skeleton_estimate, controller.GetInputPort("skeleton_estimate"))
        if skeleton_frame is not None:
            builder.Connect(skeleton_frame, controller.GetInputPort("skeleton_frame"))
        if path_preview is not None and config.preview_steps():
            builder.Connect(path_preview, controller.GetInputPort("path_preview"))
        if requested_override is not None:
            builder.Connect(requested_override, controller.GetInputPort("requested_override"))
        if swept_volumes is not None:
            builder.Connect(swept_volumes, controller.GetInputPort("swept_volumes"))
        if rules.pfl and config.contact_reaction:
            sensing = builder.AddSystem(ContactSensing(dynamics, input_size, 1.0 / config.rate))
            sensing.set_name("contact_sensing")
            builder.Connect(positions, sensing.GetInputPort("positions"))
            builder.Connect(human_capsules, sensing.GetInputPort("human_capsules"))
            builder.Connect(sensing.GetOutputPort("contact_depth"), controller.GetInputPort("contact_depth"))
    mode = declared_mode(config, zones)
    cutter = RegionCapsules()

    def judge(values):
        return Judge(values, mode, kinematics.names, cutter.names, cutter.regions, masses, payloads,
                     fixed_boxes)

    judges = [judge(judge_values)]
    departures = list(controller_departures(config))
    if judge_changes is not None:
        departures = [f"judge changed: {d}" for d in deviations(judge_changes, judge_values)] + departures
        judges.append(judge(judge_changes))
    elif departures:
        judges.append(judge(own_model_values(config, judge_values, swept_horizon)))
    # what the judge takes from a scenario's own robot unchecked: named, the verdict NON-CONFORMING
    departures += list(robot_claims)
    monitor = builder.AddSystem(SafetyMonitor(tuple(judges), dynamics, input_size, monitor_period,
                                              mode_name(config), tuple(departures)))
    monitor.set_name("safety_monitor")
    builder.Connect(human_capsules, monitor.GetInputPort("human_capsules"))
    builder.Connect(positions, monitor.GetInputPort("positions"))
    if skeleton_estimate is not None:  # a cell without sensing (a recorded skeleton) measures nothing
        builder.Connect(skeleton_estimate, monitor.GetInputPort("skeleton_estimate"))
    if controller is not None:
        # the status's "stopped" entry, picked by a gain row (Drake's C++ system, no Python per read)
        pick = np.zeros((1, len(_STATE)))
        pick[0, _STATE.index("stopped")] = 1.0
        stop = builder.AddSystem(MatrixGain(pick))
        stop.set_name("protective_stop")
        builder.Connect(controller.GetOutputPort("status"), stop.get_input_port())
        builder.Connect(stop.get_output_port(), monitor.GetInputPort("protective_stop"))
    return controller, monitor

