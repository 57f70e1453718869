"""Value types that travel on the ports of hrc_drake systems.

Every type is a frozen dataclass. Arrays are numpy arrays; their axes are stated in the
field comments. Times are seconds of simulated time, positions metres in the world frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

#: The 8 skeletal points, in port order (thesis Fig. 9.1).
SKELETON_POINTS: tuple[str, ...] = (
    "thorax",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
)
THORAX, HEAD, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_WRIST, R_WRIST = range(8)
#: Parent of every skeletal point in the kinematic hierarchy (-1: root).
SKELETON_PARENTS: tuple[int, ...] = (-1, THORAX, THORAX, THORAX, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW)
HANDS: tuple[str, ...] = ("left", "right")
WRIST_OF_HAND = {"left": L_WRIST, "right": R_WRIST}

HUMAN_AGENT = "human"


class Immutable:
    """A value that is never changed after it is built: copies return the value itself.

    Drake copies abstract-state and port values (twice per unrestricted update, once per port
    read); for an immutable value a copy is the value, so those copies cost nothing
    (DESIGN.md, performance rules). Arrays inside such a value are never written to.
    """

    __slots__ = ()

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self


def shallow_copy(obj):
    """A new object of obj's class sharing obj's attributes (a fast `copy.copy` for cores'
    `clone` methods, which then replace what an update writes)."""
    other = object.__new__(type(obj))
    other.__dict__.update(obj.__dict__)
    return other


def _empty_points() -> np.ndarray:
    return np.zeros((8, 3))


@dataclass(frozen=True)
class SkeletonFrame(Immutable):
    """One camera measurement of the skeleton.

    points: (8, 3) measured positions; rows of untracked points hold NaN.
    tracked: (8,) bool, False where the camera lost the point (occluded or out of view).
    gaze: (3,) unit gaze direction (head z axis), world frame.
    gaze_valid: the gaze flag F of thesis 3.1.2 (False when the face is turned away).
    """

    time: float = 0.0
    points: np.ndarray = field(default_factory=_empty_points)
    tracked: np.ndarray = field(default_factory=lambda: np.ones(8, dtype=bool))
    gaze: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    gaze_valid: bool = True


def _no_depth() -> np.ndarray:
    return np.zeros((0, 0), dtype=np.float32)


@dataclass(frozen=True)
class DepthFrame(Immutable):
    """One depth image of the rendered camera, how to project into it, and what it hid of the
    skeleton (thesis Ch. 9: the depth map behind L_c1 of eq. (9.10)).

    depth: (H, W) float32 depth along the optical axis (m); inf where nothing is within
        max_depth, 0 where a surface is nearer than min_depth (no measure: it hides what is
        behind it).
    X_CW: (4, 4) world -> camera transform; camera frame x right, y down, z forward (Drake's).
    intrinsics: (fx, fy, cx, cy) in pixels; pixel (row v, column u) is centred on (u, v).
    tolerance: a position is hidden where the image is in front of it by more than this (m).
    hidden: (8,) the skeletal points this image hides (before the tracker's failure modes);
    wrong_surface: (8,) hidden points the camera reported as tracked, on the surface in front;
    true_points: (8, 3) where the skeletal points were (for the replay).
    An empty image (before the first frame) hides everything.
    """

    time: float = -math.inf
    depth: np.ndarray = field(default_factory=_no_depth)
    X_CW: np.ndarray = field(default_factory=lambda: np.eye(4))
    intrinsics: tuple[float, float, float, float] = (1.0, 1.0, 0.0, 0.0)
    min_depth: float = 0.5
    max_depth: float = 4.5
    tolerance: float = 0.03
    hidden: np.ndarray = field(default_factory=lambda: np.ones(8, dtype=bool))
    wrong_surface: np.ndarray = field(default_factory=lambda: np.zeros(8, dtype=bool))
    true_points: np.ndarray = field(default_factory=lambda: np.full((8, 3), np.nan))

    def project(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Pinhole projection of points (..., 3): column u, row v (int pixel indices), depth z
        along the optical axis, and whether the pixel lies in the image."""
        pts = np.asarray(points, dtype=float)
        p_c = pts @ self.X_CW[:3, :3].T + self.X_CW[:3, 3]
        z = p_c[..., 2]
        fx, fy, cx, cy = self.intrinsics
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.floor(fx * p_c[..., 0] / z + cx + 0.5)
            v = np.floor(fy * p_c[..., 1] / z + cy + 0.5)
        height, width = self.depth.shape
        inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u < width) & (v >= 0) & (v < height) & (z > 0)
        u = np.where(inside, u, 0).astype(int)
        v = np.where(inside, v, 0).astype(int)
        return u, v, z, inside

    def is_hidden(self, points, tolerance=None) -> np.ndarray:
        """(...,) True where the image cannot show the point: outside the image or the depth
        range, or a surface in front of it by more than `tolerance` (default self.tolerance;
        an array broadcasts against the points' leading axes)."""
        tol = self.tolerance if tolerance is None else np.asarray(tolerance, dtype=float)
        u, v, z, inside = self.project(points)
        if not self.depth.size:
            return np.ones(np.shape(z), dtype=bool)
        image = self.depth[v, u]
        in_range = (z >= self.min_depth) & (z <= self.max_depth)
        return ~(inside & in_range & ~(image < z - tol))


@dataclass(frozen=True)
class SkeletonEstimate(Immutable):
    """The tracker's belief about the skeleton.

    points: (8, 3) mean positions.
    spread: (8,) standard deviation of each point's position (m, isotropic summary).
    tracked: (8,) bool, whether the point was measured in the last frame.
    workspace_fraction: (8,) fraction of each point's belief mass inside the robot workspace box.
    gaze, gaze_valid: as in `SkeletonFrame`.
    particles: optional (8, N, 3) samples of the belief, for display.
    """

    time: float = 0.0
    points: np.ndarray = field(default_factory=_empty_points)
    spread: np.ndarray = field(default_factory=lambda: np.zeros(8))
    tracked: np.ndarray = field(default_factory=lambda: np.ones(8, dtype=bool))
    workspace_fraction: np.ndarray = field(default_factory=lambda: np.zeros(8))
    gaze: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    gaze_valid: bool = True
    particles: np.ndarray | None = None


@dataclass(frozen=True)
class GoalBelief(Immutable):
    """Probability of each goal for each hand (thesis 3.1, recursive Bayes eq. 3.2).

    goals: goal names, in column order.
    probabilities: (2, G), row 0 the left hand, row 1 the right hand; rows sum to 1.
    understood: (hand, goal) pairs whose probability crossed the feedback threshold
        (Fig. 3.6) at this update.
    """

    time: float = 0.0
    goals: tuple[str, ...] = ()
    probabilities: np.ndarray = field(default_factory=lambda: np.zeros((2, 0)))
    understood: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class HumanEvent(Immutable):
    """The operator began or ended an action, or began/ended waiting for parts.

    kind: "begin", "end", "wait_begin" or "wait_end".
    seq: strictly increasing number per source, so readers can skip what they have seen.
    hand, goal: for a perceived event (`intention.detector`), the hand ("left"/"right") whose
        entry or exit made it and the goal region G_a; "" for the operator's own events.
    """

    time: float
    action: str
    kind: str
    seq: int
    agent: str = HUMAN_AGENT
    hand: str = ""
    goal: str = ""


@dataclass(frozen=True)
class RobotEvent(Immutable):
    """A robot agent (an arm) began or ended an action, or began/ended waiting.

    agent: the robot agent name, e.g. "yumi_right".
    kind: "begin", "end", "wait_begin" or "wait_end".
    """

    time: float
    agent: str
    action: str
    kind: str
    seq: int


@dataclass(frozen=True)
class EventLog(Immutable):
    """The events a source has emitted so far, oldest first (a port value).

    Readers remember the last `seq` they processed and read `since(seq)`.
    """

    events: tuple = ()

    def appended(self, new, keep: int) -> EventLog:
        """This log with the events `new` appended, keeping the last `keep` (itself if none)."""
        if not new:
            return self
        return EventLog((self.events + tuple(new))[-keep:])

    def since(self, seq: int) -> tuple:
        """Events with a sequence number greater than `seq`."""
        out = []
        for event in reversed(self.events):
            if event.seq <= seq:
                break
            out.append(event)
        return tuple(reversed(out))


@dataclass(frozen=True)
class RobotCommand(Immutable):
    """What the scheduler asks a robot agent to do next.

    action: the action to start, or None to wait `wait` seconds (thesis 6.3.1 wait quantum).
    seq: strictly increasing per scheduler; the executor acts on each command once.
    give_up_after: how long the agent waits for the action's other agents (a collaboration
        with the human) before the command is revoked and it is ready again (T_wait, the t_W
        of Fig. 7.3); inf waits for good.
    """

    time: float
    agent: str
    action: str | None
    seq: int
    wait: float = 0.0
    give_up_after: float = math.inf


@dataclass(frozen=True)
class Forecast(Immutable):
    """Predicted next human actions and their waiting times (thesis Ch. 5).

    actions: action names, in column order.
    next_probabilities: (A,) probability that each action is the next one.
    percentile_levels: (P,) levels in (0, 1), e.g. (0.2, 0.5, 0.8).
    waiting_percentiles: (A, P) time from now until each action starts, per level; inf if
        it does not start within the horizon.
    """

    time: float = 0.0
    actions: tuple[str, ...] = ()
    next_probabilities: np.ndarray = field(default_factory=lambda: np.zeros(0))
    percentile_levels: np.ndarray = field(default_factory=lambda: np.zeros(0))
    waiting_percentiles: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


@dataclass(frozen=True)
class SweptVolumes(Immutable):
    """Capsules bounding where the human body can be within the horizon (thesis 8.1).

    start, end: (K, 3) capsule segment end points; radius: (K,); names: K labels
    (torso, upper arms, forearms, ...); horizon: seconds covered.
    """

    time: float = 0.0
    names: tuple[str, ...] = ()
    start: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    end: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    horizon: float = 0.0


@dataclass(frozen=True)
class WorldSnapshot(Immutable):
    """Ground truth of the cell: parts in each buffer, what each agent is doing.

    buffers: buffer name -> number of parts.
    activity: agent name -> current action name, "wait:<action>" or "idle".
    finished_products: products that left the cell so far.
    granted, refused: agent name -> seq of its last start `WorldRequest` that was granted /
        found impossible at least once (the agent waits until it is granted).
    withdrawn: agent name -> seq of its last start request dropped after its `patience`.
    joint: action shared by several agents -> the agents still at work on it (its outputs
        are put when the last one finishes).
    """

    time: float = 0.0
    buffers: dict = field(default_factory=dict)
    activity: dict = field(default_factory=dict)
    finished_products: int = 0
    granted: dict = field(default_factory=dict)
    refused: dict = field(default_factory=dict)
    withdrawn: dict = field(default_factory=dict)
    joint: dict = field(default_factory=dict)


class Capsules(NamedTuple):
    """Capsules in the world: segment end points start, end (K, 3) and radius (K,).

    Unpacks as (start, end, radius). Immutable: copies return the value itself.
    """

    start: np.ndarray
    end: np.ndarray
    radius: np.ndarray

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self

    @property
    def count(self) -> int:
        return int(len(self.radius))


def no_capsules() -> Capsules:
    """Zero capsules: the value of an unconnected capsules input."""
    return Capsules(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


@dataclass(frozen=True)
class PathRequest(Immutable):
    """A motion one arm (its follower channel) should start: joint waypoints (n, dof) and the
    dwell (s) at each; seq increases per channel so that the follower starts each request once.
    blended: one move along the whole polyline (a dense path), not a stop at every waypoint."""

    channel: int
    seq: int
    waypoints: np.ndarray
    dwells: np.ndarray
    blended: bool = False


@dataclass(frozen=True)
class ProactivePaths(Immutable):
    """Robot paths planned around the human (thesis 8.2.3): (agent, action, waypoints (n, dof))
    triples, the waypoints after the start pose; seq increases with every replanning."""

    seq: int = 0
    paths: tuple = ()

    def by_action(self) -> dict:
        """(agent, action) -> waypoints."""
        return {(agent, action): waypoints for agent, action, waypoints in self.paths}


@dataclass(frozen=True)
class PathStatus(Immutable):
    """The last completed request seq of every follower channel."""

    done_seq: tuple[int, ...] = ()


@dataclass(frozen=True)
class WorldRequest(Immutable):
    """An agent asks the cell's truth to start an action (take its inputs, reserve its output
    room, hold its resources) or reports that it finished one (put its outputs).

    kind: "start" or "finish". seq: strictly increasing per source (the system emitting it).
    patience: a start not granted within this many seconds is withdrawn (inf: never).
    """

    time: float
    agent: str
    action: str
    kind: str
    seq: int
    patience: float = math.inf


@dataclass(frozen=True)
class AgentActivity(Immutable):
    """What each agent of a source is doing: agent name -> action, "wait:<action>" or "idle"."""

    activity: tuple[tuple[str, str], ...] = ()

    def as_dict(self) -> dict[str, str]:
        return dict(self.activity)
