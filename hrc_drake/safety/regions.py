"""The simulated operator's body as ISO/TS 15066 body regions, and clamping against the scene.

The body model has six capsules (torso, head, upper arms, forearms with the hand, thesis
Fig. 8.2). Each is cut along its axis into the body regions of Table A.2 it covers, so every
region is a capsule of its own:

    torso      hip -> thorax: abdomen (lower `ABDOMEN_FRACTION`), chest (the rest)
    head       thorax -> beyond the head point: neck (lower `NECK_FRACTION`), face (the rest;
               the stricter of face and skull/forehead: transient contact is not permitted
               with either, and the face's 65 N is the lower force)
    upper arm  upper_arm_elbow
    forearm    elbow -> wrist: lower_arm_wrist; wrist -> fingertips: hand_fingers

Back and shoulders and the pelvis, whose limits are higher than chest and abdomen, are not
told apart from them: a contact with the torso is judged by the front's stricter limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hrc_drake.kernels import capsule_clearances

#: m: a rigid body this far behind a part (beyond its radius) along the push clamps it (the judge's
#: `judge.CLAMP_MARGIN`; the controller's margin is never below it).
CLAMP_MARGIN = 0.02
#: points along a capsule's axis at which `surface_clearances` measures the distance to a box
SURFACE_SAMPLES = 17
#: lower fraction of the torso capsule (hip -> thorax) that is abdomen
ABDOMEN_FRACTION = 0.45
#: lower fraction of the head capsule (thorax -> head) that is neck
NECK_FRACTION = 0.35
#: skeleton point indices (thesis Fig. 9.1 order) of the thorax and the head
THORAX, HEAD = 0, 1
#: the body capsules in `human.body.CAPSULE_NAMES` order
BODY_CAPSULES = ("torso", "head", "left_upper_arm", "right_upper_arm", "left_forearm", "right_forearm")
#: skeleton points (thesis Fig. 9.1 order) that place each body capsule: its uncertainty is theirs
CAPSULE_POINTS = {"torso": (0,), "head": (0, 1), "left_upper_arm": (2, 4), "right_upper_arm": (3, 5),
                  "left_forearm": (4, 6), "right_forearm": (5, 7)}


@dataclass(frozen=True)
class RegionCut:
    """One region capsule: the body capsule it is cut from and the axis fractions [t0, t1]."""

    name: str
    region: str
    capsule: int
    t0: float
    t1: float


def region_cuts(hand_fraction: float = 0.37) -> tuple[RegionCut, ...]:
    """The region capsules of the body model; hand_fraction: the hand's length beyond the wrist
    as a fraction of the forearm (`human.body.HAND_FRACTION`)."""
    wrist = 1.0 / (1.0 + hand_fraction)
    cuts = [RegionCut("abdomen", "abdomen", 0, 0.0, ABDOMEN_FRACTION),
            RegionCut("chest", "chest", 0, ABDOMEN_FRACTION, 1.0),
            RegionCut("neck", "neck", 1, 0.0, NECK_FRACTION),
            RegionCut("face", "face", 1, NECK_FRACTION, 1.0)]
    for side, upper, fore in (("left", 2, 4), ("right", 3, 5)):
        cuts += [RegionCut(f"{side}_upper_arm", "upper_arm_elbow", upper, 0.0, 1.0),
                 RegionCut(f"{side}_lower_arm", "lower_arm_wrist", fore, 0.0, wrist),
                 RegionCut(f"{side}_hand", "hand_fingers", fore, wrist, 1.0)]
    return tuple(cuts)


class RegionCapsules:
    """Cuts body capsules into region capsules, all at once (one gather, one product)."""

    def __init__(self, hand_fraction: float = 0.37):
        self.cuts = region_cuts(hand_fraction)
        self.names = tuple(c.name for c in self.cuts)
        self.regions = tuple(c.region for c in self.cuts)
        self._capsule = np.array([c.capsule for c in self.cuts])
        self._t0 = np.array([c.t0 for c in self.cuts])[:, None]
        self._t1 = np.array([c.t1 for c in self.cuts])[:, None]

    def __len__(self) -> int:
        return len(self.cuts)

    def cut(self, start, end, radius) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Region capsules (R, 3), (R, 3), (R,) of body capsules (6, 3), (6, 3), (6,)."""
        start = np.asarray(start, dtype=float)[self._capsule]
        axis = np.asarray(end, dtype=float)[self._capsule] - start
        radius = np.asarray(radius, dtype=float)[self._capsule]
        return start + self._t0 * axis, start + self._t1 * axis, radius

    def region_uncertainty(self, per_capsule) -> np.ndarray:
        """Z_d (R,) of every region from its body capsule's uncertainty (6,)."""
        return np.asarray(per_capsule, dtype=float)[self._capsule]


#: the arms' kinematic chains: (shoulder, elbow, wrist) skeleton points, (upper arm, forearm) capsules
ARM_CHAINS = (((2, 4, 6), (2, 4)), ((3, 5, 7), (3, 5)))


def reach_bounded(start, end, radius, point_uncertainty, cap: float, upper_arm: float, forearm_reach: float):
    """Body capsules (6, 3), (6, 3), (6,) and their uncertainty (6,) as reachable sets (issue 51,
    item 5): a part not measured for t s may be anywhere within its last position plus v_h t, with
    no cap, bounded by the body's reach where that is tighter.

    An arm point whose uncertainty (m, (8,), inf when lost) exceeds `cap` may be anywhere its
    parent joint lets it reach: a lost wrist within `forearm_reach` (forearm + hand) of its elbow,
    a lost elbow within `upper_arm` of its shoulder (and its hand within upper_arm +
    forearm_reach). The capsules they place become spheres of that reach around the parent, with
    the parent's own uncertainty, uncapped (a lost shoulder's grows too): a reachable set, as
    sara-shield bounds a human it cannot see (a Kalman filter's prediction of a hidden hand drifts
    away from it). Other capsules take the largest uncertainty of their points, uncapped."""
    start, end = np.array(start, dtype=float), np.array(end, dtype=float)
    radius = np.array(radius, dtype=float)
    u = np.asarray(point_uncertainty, dtype=float)
    per_capsule = np.array([max(u[list(CAPSULE_POINTS[name])]) for name in BODY_CAPSULES])
    for (shoulder, elbow, wrist), (upper, fore) in ARM_CHAINS:
        if u[elbow] > cap:
            end[upper] = start[upper]
            start[fore] = end[fore] = start[upper]
            radius[fore] += upper_arm + forearm_reach
            radius[upper] += upper_arm
            per_capsule[upper] = per_capsule[fore] = u[shoulder]
        elif u[wrist] > cap:
            end[fore] = start[fore]
            radius[fore] += forearm_reach
            per_capsule[fore] = u[elbow]
    return start, end, radius, per_capsule


def lost_capsules(point_uncertainty, cap: float) -> np.ndarray:
    """(6,) whether each body capsule is a reachable set in `reach_bounded` (a lost arm point)."""
    u = np.asarray(point_uncertainty, dtype=float)
    lost = np.zeros(len(BODY_CAPSULES), dtype=bool)
    for (_, elbow, wrist), (upper, fore) in ARM_CHAINS:
        if u[elbow] > cap:
            lost[upper] = lost[fore] = True
        elif u[wrist] > cap:
            lost[fore] = True
    return lost


@dataclass(frozen=True)
class FixedBox:
    """An axis-aligned fixed surface of the cell (the table, a fixture, an occluder): centre, size."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]


def clamped(points, directions, radius, boxes, margin: float = CLAMP_MARGIN) -> np.ndarray:
    """(N,) whether a body part, a ball of `radius` (N,) at `points` (N, 3), pushed along `directions`
    (N, 3) (unit, from the robot toward the body), is clamped (ISO/TS 15066 quasi-static contact):
    the ball moved `margin` on along the push comes nearer a fixed box and lies within its radius
    of it, or the part is in a box already. The judge's test (`Judge.clamped_against`), so that
    the controller holds clamped every part the judge would find clamped on the same estimate."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    if not boxes:
        return np.zeros(len(points), dtype=bool)
    lower = np.array([np.subtract(b.center, np.multiply(b.size, 0.5)) for b in boxes])[None]  # (1, B, 3)
    upper = np.array([np.add(b.center, np.multiply(b.size, 0.5)) for b in boxes])[None]
    moved = points + margin * np.atleast_2d(np.asarray(directions, dtype=float))
    # (N, B): each point's distance to each box
    now, then = (np.linalg.norm(np.maximum(lower - p[:, None], 0.0) + np.maximum(p[:, None] - upper, 0.0),
                                axis=2) for p in (points, moved))
    within = then < np.asarray(radius, dtype=float)[:, None]
    return np.any(within & ((then < now - 1e-9) | (now <= 0.0)), axis=1)


def clamped_by_capsules(points, directions, radius, pushed_by, capsules,
                        margin: float = CLAMP_MARGIN) -> np.ndarray:
    """(N,) whether a body part, a ball of `radius` (N,) at `points` (N, 3) pushed along
    `directions` (N, 3) by robot capsule `pushed_by` (N,), is clamped against another robot capsule
    of `capsules` (start, end, radius) (another robot, a cart, the robot's own other links): the
    ball moved `margin` on reaches into it and comes nearer it (the judge's `Judge.clamped_against`)."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    start, end, capsule_radius = (np.asarray(x, dtype=float) for x in capsules)
    moved = points + margin * np.atleast_2d(np.asarray(directions, dtype=float))
    # (N, K): each ball's centre to each capsule's surface
    now, then = (capsule_clearances(p, p, np.zeros(len(p)), start, end, capsule_radius)
                 for p in (points, moved))
    behind = (then < np.asarray(radius, dtype=float)[:, None]) & (then < now - 1e-9)
    behind[np.arange(len(points)), np.asarray(pushed_by, dtype=int)] = False
    return behind.any(axis=1)


def near_surfaces(start, end, radius, z_d, boxes, margin: float = CLAMP_MARGIN) -> np.ndarray:
    """(R,) whether each region (capsules start, end (R, 3), radius (R,)) may be clamped whatever
    the push, as its estimate is uncertain by Z_d (R,) > 0: its axis comes within radius + Z_d +
    margin of a fixed box. A superset of the judge's test on the true body: the judge's ball, moved
    `margin` along the true push, lies within its radius of a box, so its axis point lies within
    radius + margin, and the estimated axis, each point within Z_d of the true one, within radius
    + margin + Z_d (`surface_clearances`, a lower bound, keeps it a superset). Direction is left
    out because the true push may tilt any way from the estimate's: near a surface the estimate's
    direction to it turns by up to asin(Z_d / distance), which for a hand on a table is 90 degrees."""
    z_d = np.asarray(z_d, dtype=float)
    if not boxes:
        return np.zeros(len(z_d), dtype=bool)
    axis_gap = surface_clearances(start, end, np.zeros(len(z_d)), boxes)
    return (z_d > 0.0) & (axis_gap < np.asarray(radius, dtype=float) + z_d + margin)


def surface_clearances(start, end, radius, boxes, samples: int = SURFACE_SAMPLES) -> np.ndarray:
    """(K,) a lower bound on the clearance between each capsule (start, end (K, 3), radius (K,))
    and the nearest fixed box: the distance of `samples` points along the axis, less half their
    spacing (distance to a box is 1-Lipschitz along the axis), less the radius; inf without boxes."""
    start, end = np.atleast_2d(np.asarray(start, dtype=float)), np.atleast_2d(np.asarray(end, dtype=float))
    if not boxes:
        return np.full(len(start), np.inf)
    lower = np.array([np.subtract(b.center, np.multiply(b.size, 0.5)) for b in boxes])
    upper = np.array([np.add(b.center, np.multiply(b.size, 0.5)) for b in boxes])
    t = np.linspace(0.0, 1.0, samples)
    points = start[:, None, :] + t[None, :, None] * (end - start)[:, None, :]  # (K, S, 3)
    outside = (np.maximum(lower[None, None] - points[:, :, None], 0.0)
               + np.maximum(points[:, :, None] - upper[None, None], 0.0))  # (K, S, B, 3)
    nearest = np.linalg.norm(outside, axis=3).min(axis=(1, 2))
    spacing = np.linalg.norm(end - start, axis=1) / (samples - 1)
    return nearest - 0.5 * spacing - np.asarray(radius, dtype=float)
