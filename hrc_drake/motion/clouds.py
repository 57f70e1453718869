"""Proactive-planning cores of thesis Section 8.2 (no Drake).

- `InteractionModel`: P_RH(t), the probability of each human action of A_S given each robot
  action of R over a sliding window, eqs. (8.20)-(8.23), computed exactly from interval overlaps.
- `probability_cloud`: the occupancy cloud C of a regressed arm trajectory Phi, eqs. (8.27)-(8.28).
- `cloud_error`: E_cloud of Fig. 8.16.
- `weighted_union`: the cloud varsigma_j of a robot action, eqs. (8.29)-(8.30).
- `repulsive_potential`: the field of the J_Rep term of eq. (8.32).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hrc_drake.motion.geometry import point_segment_distance

#: vertex pairs (edges) and triples (triangles) of a 4-point hull
_EDGES_I = [0, 0, 0, 1, 1, 2]
_EDGES_J = [1, 2, 3, 2, 3, 3]
_FACES = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
#: relative tolerance below which a triangle is flat (zero area) or a tetrahedron is flat
_FLAT = 1e-12
#: pairs (node, swept volume) tested in one vectorised batch (memory bound, ~100 MB)
_BATCH = 200_000


def _points(name: str, array, shape_tail=(3,)) -> np.ndarray:
    array = np.asarray(array, dtype=float)
    tail = len(shape_tail)
    if array.ndim < tail or array.shape[array.ndim - tail:] != tuple(shape_tail):
        tail_text = ", ".join(map(str, shape_tail))
        raise ValueError(f"{name}: expected shape (..., {tail_text}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or inf")
    return array


def _readonly(array) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


# --------------------------------------------------------------------------------------------
# P_RH, eqs. (8.20)-(8.23)
# --------------------------------------------------------------------------------------------


class InteractionModel:
    """P_RH(t) = M * integral_{t-T}^{t} I_r I_h^T dtau, eqs. (8.20)-(8.23).

    R(t) in {None, 0..m-1} and A(t) in {None, 0..n-1} are piecewise constant; None is the
    thesis's value 0 (no action of R, resp. A_S). Both signals are None before their first
    change. `set_robot(t, j)` / `set_human(t, i)` make the signal take the value from time t on;
    all calls and queries share one clock and must not go back in time. History older than the
    window is dropped, so the state stays small. The model is mutable; `copy()` gives an
    independent one.
    """

    def __init__(self, n_robot_actions: int, n_human_actions: int, window: float):
        for name, value in (("n_robot_actions", n_robot_actions), ("n_human_actions", n_human_actions)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be an int >= 1, got {value!r}")
        window = float(window)
        if not (math.isfinite(window) and window > 0.0):
            raise ValueError(f"window must be a finite time > 0, got {window!r}")
        self.n_robot_actions = int(n_robot_actions)
        self.n_human_actions = int(n_human_actions)
        self.window = window
        # per signal: change times and values (-1 = None), value[k] holds on [time[k], time[k+1])
        self._times: dict[str, list[float]] = {"robot": [], "human": []}
        self._values: dict[str, list[int]] = {"robot": [], "human": []}
        self._now = -math.inf

    def copy(self) -> InteractionModel:
        other = InteractionModel(self.n_robot_actions, self.n_human_actions, self.window)
        other._times = {k: list(v) for k, v in self._times.items()}
        other._values = {k: list(v) for k, v in self._values.items()}
        other._now = self._now
        return other

    def set_robot(self, t: float, action: int | None) -> None:
        """R(tau) = action for tau >= t (None: no action of R)."""
        self._set("robot", t, action, self.n_robot_actions)

    def set_human(self, t: float, action: int | None) -> None:
        """A(tau) = action for tau >= t (None: no action of A_S)."""
        self._set("human", t, action, self.n_human_actions)

    def _check_time(self, t) -> float:
        t = float(t)
        if not math.isfinite(t):
            raise ValueError(f"time must be finite, got {t!r}")
        if t < self._now:
            raise ValueError(f"time {t} is before the last recorded time {self._now}: "
                             "times must not decrease")
        return t

    def _set(self, signal: str, t, action, size: int) -> None:
        t = self._check_time(t)
        if action is None:
            code = -1
        elif isinstance(action, bool) or not isinstance(action, int | np.integer) or not 0 <= action < size:
            raise ValueError(f"{signal} action must be None or an int in [0, {size}), got {action!r}")
        else:
            code = int(action)
        times, values = self._times[signal], self._values[signal]
        if times and times[-1] == t:
            values[-1] = code
        elif (values[-1] if values else -1) != code:
            times.append(t)
            values.append(code)
        self._now = t
        for name in ("robot", "human"):  # keep the change in force at t - T, drop the older ones
            first = bisect.bisect_right(self._times[name], t - self.window) - 1
            if first > 0:
                del self._times[name][:first], self._values[name][:first]

    def _value_at(self, signal: str, when: np.ndarray) -> np.ndarray:
        times = np.asarray(self._times[signal], dtype=float)
        values = np.asarray(self._values[signal] + [-1], dtype=int)  # index -1 -> None
        return values[np.searchsorted(times, when, side="right") - 1]

    def integrals(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(integral of I_r I_h^T (m, n), integral of I_r (m,)) over [t - T, t], exact."""
        t = self._check_time(t)
        low = t - self.window
        changes = np.asarray(self._times["robot"] + self._times["human"], dtype=float)
        edges = np.unique(np.concatenate([[low, t], changes[(changes > low) & (changes < t)]]))
        middle = 0.5 * (edges[:-1] + edges[1:])
        duration = np.diff(edges)
        robot, human = self._value_at("robot", middle), self._value_at("human", middle)
        joint = np.zeros((self.n_robot_actions, self.n_human_actions))
        both = (robot >= 0) & (human >= 0)
        np.add.at(joint, (robot[both], human[both]), duration[both])
        active = robot >= 0
        robot_time = np.bincount(robot[active], weights=duration[active], minlength=self.n_robot_actions)
        return joint, robot_time

    def defined_rows(self, t: float) -> np.ndarray:
        """(m,) bool: robot action j occurred in [t - T, t], so row j of P_RH(t) is defined."""
        return self.integrals(t)[1] > 0.0

    def matrix(self, t: float) -> np.ndarray:
        """P_RH(t) (m, n), eqs. (8.22)-(8.23).

        Row j is P(A = i | R = j) over the window. A row whose robot action did not occur in
        the window (1 / 0 in M, undefined in the thesis) is NaN; see `defined_rows`. Rows sum
        to <= 1: the rest is the time the human did no action of A_S.
        """
        joint, robot_time = self.integrals(t)
        defined = robot_time > 0.0
        out = np.full_like(joint, np.nan)
        out[defined] = joint[defined] / robot_time[defined, None]
        return out

    def __repr__(self) -> str:
        return (f"InteractionModel(m={self.n_robot_actions}, n={self.n_human_actions}, T={self.window}, "
                f"now={self._now}, changes={len(self._times['robot'])}+{len(self._times['human'])})")


# --------------------------------------------------------------------------------------------
# Grid and clouds, eqs. (8.27)-(8.30)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GridBox:
    """An oriented box split into `grid` equal bins per side; the nodes are the bin centres.

    centre (3,) world position; axes (3, 3) rows are the box axes (orthonormal, right-handed);
    extents (3,) full side lengths. Node (i, j, k) has box coordinates (idx + 0.5) * cell - extents / 2
    and flat index (i * grid + j) * grid + k. Immutable (`deepcopy` returns itself).
    """

    centre: np.ndarray
    axes: np.ndarray
    extents: np.ndarray
    grid: int

    def __post_init__(self):
        centre = _readonly(_points("centre", self.centre))
        axes = _readonly(_points("axes", self.axes))
        extents = _readonly(_points("extents", self.extents))
        if centre.shape != (3,) or axes.shape != (3, 3) or extents.shape != (3,):
            raise ValueError(f"GridBox: centre (3,), axes (3, 3), extents (3,); got "
                             f"{centre.shape}, {axes.shape}, {extents.shape}")
        if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-9) or np.linalg.det(axes) < 0:
            raise ValueError("GridBox: axes must be orthonormal and right-handed")
        if np.any(extents <= 0):
            raise ValueError(f"GridBox: extents must be > 0, got {extents}")
        if isinstance(self.grid, bool) or not isinstance(self.grid, int | np.integer) or self.grid < 1:
            raise ValueError(f"GridBox: grid must be an int >= 1, got {self.grid!r}")
        fields = {"centre": centre, "axes": axes, "extents": extents, "grid": int(self.grid)}
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    def __deepcopy__(self, memo):
        return self

    @property
    def cell_size(self) -> np.ndarray:
        """(3,) bin side lengths, extents / grid."""
        return self.extents / self.grid

    @property
    def cell_volume(self) -> float:
        return float(np.prod(self.cell_size))

    def to_box(self, points) -> np.ndarray:
        """World points (..., 3) in box coordinates (origin at the centre)."""
        return (_points("points", points) - self.centre) @ self.axes.T

    def local_nodes(self, index) -> np.ndarray:
        """Box coordinates (..., 3) of integer node indices (..., 3)."""
        return (np.asarray(index) + 0.5) * self.cell_size - 0.5 * self.extents

    def nodes(self) -> np.ndarray:
        """(grid**3, 3) world positions of all nodes, in flat-index order."""
        ticks = np.arange(self.grid)
        index = np.stack(np.meshgrid(ticks, ticks, ticks, indexing="ij"), axis=-1).reshape(-1, 3)
        return self.centre + self.local_nodes(index) @ self.axes

    def nearest_node_distance(self, points) -> np.ndarray:
        """(...) distance of points (..., 3) to the nearest grid node (closed form)."""
        local = self.to_box(points)
        index = np.clip(np.rint((local + 0.5 * self.extents) / self.cell_size - 0.5), 0, self.grid - 1)
        return np.linalg.norm(local - self.local_nodes(index), axis=-1)


@dataclass(frozen=True, eq=False)
class ProbabilityCloud:
    """Cloud C = {(p_Cl, gamma_l)}, eq. (8.27): points (g, 3), occupancy gamma (g,) >= 0.

    box is the grid the points were taken from (None for a union of clouds on different grids).
    Immutable (`deepcopy` returns itself).
    """

    points: np.ndarray
    gamma: np.ndarray
    box: GridBox | None = None

    def __post_init__(self):
        points = _readonly(_points("points", self.points).reshape(-1, 3))
        gamma = _readonly(np.asarray(self.gamma, dtype=float).reshape(-1))
        if gamma.shape[0] != points.shape[0]:
            raise ValueError(f"ProbabilityCloud: {points.shape[0]} points but {gamma.shape[0]} gamma values")
        if not np.all(np.isfinite(gamma)) or np.any(gamma < 0):
            raise ValueError("ProbabilityCloud: gamma must be finite and >= 0")
        if self.box is not None and not isinstance(self.box, GridBox):
            raise ValueError(f"ProbabilityCloud: box must be a GridBox or None, "
                             f"got {type(self.box).__name__}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "gamma", gamma)

    def __deepcopy__(self, memo):
        return self

    def __len__(self) -> int:
        return len(self.gamma)

    def occupied_volume(self) -> float:
        """sum gamma * cell volume: the expected volume occupied per step (needs the grid box)."""
        if self.box is None:
            raise ValueError("occupied_volume needs the cloud's grid box (this cloud has none)")
        return float(self.gamma.sum() * self.box.cell_volume)


def hull_distance(points, vertices) -> np.ndarray:
    """Distance of points (..., 3) to the convex hull of 4 points vertices (..., 4, 3), broadcast.

    Exact for every hull, degenerate ones included (coplanar, collinear, coincident points): the
    minimum over the 6 edges and the interiors of the 4 vertex triangles, and 0 inside a solid
    tetrahedron. A solid hull is bounded by those triangles; a flat one is their union
    (Caratheodory), and a flat triangle is the union of its edges.
    """
    p = _points("points", points)[..., None, :]
    v = _points("vertices", vertices, (4, 3))
    d = point_segment_distance(p, v[..., _EDGES_I, :], v[..., _EDGES_J, :]).min(axis=-1)
    a, b, c = (v[..., _FACES[:, i], :] for i in range(3))
    normal = np.cross(b - a, c - a)
    area2 = np.linalg.norm(normal, axis=-1)
    scale2 = np.maximum.reduce([np.einsum("...i,...i->...", e, e) for e in (b - a, c - b, a - c)])
    solid_face = area2 > _FLAT * scale2
    over = np.logical_and.reduce([np.einsum("...i,...i->...", np.cross(q1 - q0, p - q0), normal) >= 0
                                  for q0, q1 in ((a, b), (b, c), (c, a))])
    plane = np.abs(np.einsum("...i,...i->...", p - a, normal)) / np.where(solid_face, area2, 1.0)
    d = np.minimum(d, np.where(over & solid_face, plane, np.inf).min(axis=-1))
    e1, e2, e3 = (v[..., i, :] - v[..., 0, :] for i in (1, 2, 3))
    det = np.einsum("...i,...i->...", e1, np.cross(e2, e3))
    solid = np.abs(det) > _FLAT * scale2.max(axis=-1) ** 1.5
    w = p[..., 0, :] - v[..., 0, :]
    safe = np.where(solid, det, 1.0)
    lam = [np.einsum("...i,...i->...", w, np.cross(f, g)) / safe for f, g in ((e2, e3), (e3, e1), (e1, e2))]
    inside = solid & (lam[0] >= 0) & (lam[1] >= 0) & (lam[2] >= 0) & (lam[0] + lam[1] + lam[2] <= 1)
    return np.where(inside, 0.0, d)


def _check_trajectory(trajectory) -> np.ndarray:
    trajectory = _points("trajectory", trajectory, (3, 3))
    if trajectory.ndim != 3 or trajectory.shape[0] < 2:
        raise ValueError(f"trajectory must be (L >= 2, 3, 3) (shoulder, elbow, wrist per pose), "
                         f"got {trajectory.shape}")
    return trajectory


def swept_hulls(trajectory) -> np.ndarray:
    """(L-1, 2, 4, 3) hull vertices of the arm (shoulder-elbow) and forearm (elbow-wrist) from k to k+1."""
    trajectory = _check_trajectory(trajectory)
    starts, ends = trajectory[:, :2], trajectory[:, 1:]
    return np.stack([starts[:-1], ends[:-1], starts[1:], ends[1:]], axis=2)


def pca_box(trajectory, radius: float, grid: int) -> GridBox:
    """Box holding every swept volume: PCA axes of all skeletal points, inflated by radius.

    The thesis asks for the smallest oriented bounding box; this one is PCA-oriented (not the
    minimal one), which is cheap and tight for the elongated sets of an arm motion.
    """
    points = _check_trajectory(trajectory).reshape(-1, 3)
    mean = points.mean(axis=0)
    _, vectors = np.linalg.eigh(np.cov((points - mean).T, bias=True))
    axes = vectors.T[::-1].copy()  # major axis first
    if np.linalg.det(axes) < 0:
        axes[2] = -axes[2]
    local = (points - mean) @ axes.T
    low, high = local.min(axis=0) - radius, local.max(axis=0) + radius
    return GridBox(mean + 0.5 * (low + high) @ axes, axes, high - low, grid)


def _block_pairs(first: np.ndarray, count: np.ndarray, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """All (volume, node) pairs of the index blocks [first, first + count) per volume, flat."""
    sizes = count.prod(axis=1)
    volume = np.repeat(np.arange(len(sizes)), sizes)
    local = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    ny, nz = count[volume, 1], count[volume, 2]
    index = np.stack([local // (ny * nz), (local // nz) % ny, local % nz], axis=1) + first[volume]
    return volume, index


def _screen_segments(hulls: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Screening segments of hulls (V, 4, 3) [s0, e0, s1, e1], as (segment, coordinate, V) arrays.

    Segment 0 is the mid-line [(s0+s1)/2, (e0+e1)/2], segments 1, 2 the link at k and k+1. The
    hull lies within `slack` (V,) = max(|s0-s1|, |e0-e1|) / 2 of the mid-line (the distance to a
    segment is convex, so its maximum over the hull is at a vertex) and holds both links.
    Returns start (3, 3, V), direction (3, 3, V), 1 / squared length (3, V) (0 for a point), slack.
    """
    start = np.stack([0.5 * (hulls[:, 0] + hulls[:, 2]), hulls[:, 0], hulls[:, 2]])
    end = np.stack([0.5 * (hulls[:, 1] + hulls[:, 3]), hulls[:, 1], hulls[:, 3]])
    direction = end - start
    length2 = np.einsum("svi,svi->sv", direction, direction)
    inverse = np.where(length2 > 0, 1.0 / np.where(length2 > 0, length2, 1.0), 0.0)
    slack = 0.5 * np.maximum(np.linalg.norm(hulls[:, 0] - hulls[:, 2], axis=-1),
                             np.linalg.norm(hulls[:, 1] - hulls[:, 3], axis=-1))
    return start.transpose(0, 2, 1).copy(), direction.transpose(0, 2, 1).copy(), inverse, slack


def _volume_contains(x, volume, hulls, screen, radius) -> np.ndarray:
    """Node x (N, 3) within radius of the hull hulls[volume] (N,): cheap screens, then exact."""
    start, direction, inverse, slack = screen
    coordinates = [x[:, i] for i in range(3)]
    distance2 = []
    for s in range(3):  # component-wise point-segment distances: ~3x faster than (N, 3) arrays
        w = [coordinates[i] - start[s, i][volume] for i in range(3)]
        d = [direction[s, i][volume] for i in range(3)]
        u = np.clip((w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) * inverse[s][volume], 0.0, 1.0)
        distance2.append((w[0] - u * d[0]) ** 2 + (w[1] - u * d[1]) ** 2 + (w[2] - u * d[2]) ** 2)
    inside = np.minimum(distance2[1], distance2[2]) <= radius**2  # within radius of a link: inside
    maybe = ~inside & (distance2[0] <= (radius + slack[volume]) ** 2)  # else outside the capsule
    inside[maybe] = hull_distance(x[maybe], hulls[volume[maybe]]) <= radius
    return inside


def occupancy(trajectory, radius: float, box: GridBox) -> np.ndarray:
    """(L-1, grid**3) bool c_k of eq. (8.28): node inside a volume swept from pose k to k+1.

    Exact test: `hull_distance` of the node to the 4-point hull <= radius (the thesis's OctTree
    is only a speed-up of this test). Each volume is tested on the block of nodes inside its
    bounds in box coordinates only, all pairs in vectorised batches; nodes near a link (inside)
    or far from the hull's bounding capsule (outside) skip the exact test.
    """
    hulls = box.to_box(swept_hulls(trajectory).reshape(-1, 4, 3))  # (2(L-1), 4, 3)
    screen = _screen_segments(hulls)
    g, cell, half = box.grid, box.cell_size, 0.5 * box.extents
    first = np.clip(np.ceil((hulls.min(axis=1) - radius + half) / cell - 0.5), 0, g).astype(int)
    stop = np.clip(np.floor((hulls.max(axis=1) + radius + half) / cell - 0.5) + 1, 0, g).astype(int)
    count = np.maximum(stop - first, 0)
    occupied = np.zeros((len(hulls) // 2, g**3), dtype=bool)
    bounds = np.concatenate([[0], np.cumsum(count.prod(axis=1))])
    start = 0
    while start < len(hulls):
        end = max(start + 1, int(np.searchsorted(bounds, bounds[start] + _BATCH, side="right")) - 1)
        volume, index = _block_pairs(first[start:end], count[start:end], g)
        volume += start
        inside = _volume_contains(box.local_nodes(index), volume, hulls, screen, radius)
        flat = (index[:, 0] * g + index[:, 1]) * g + index[:, 2]
        occupied[volume[inside] // 2, flat[inside]] = True
        start = end
    return occupied


def probability_cloud(trajectory, radius: float, grid: int = 25, threshold: float = 0.0) -> ProbabilityCloud:
    """Probability cloud C of a regressed arm trajectory Phi, eqs. (8.27)-(8.28).

    trajectory (L, 3, 3): shoulder, elbow, wrist of the moving arm per pose. From pose k to k+1
    each link sweeps the Minkowski sum of a sphere of `radius` and the hull of its 4 end points.
    The grid is the grid**3 bin centres of `pca_box` (G = 25 gives the thesis's 15625 points);
    gamma = mean over k of c_k (`occupancy`). Nodes with gamma <= threshold are dropped (a
    negative threshold keeps them all, in flat-index order).
    """
    trajectory = _check_trajectory(trajectory)
    radius = float(radius)
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be a finite length > 0, got {radius!r}")
    box = pca_box(trajectory, radius, grid)
    gamma = occupancy(trajectory, radius, box).mean(axis=0)
    keep = gamma > float(threshold)
    return ProbabilityCloud(box.nodes()[keep], gamma[keep], box)


def cloud_error(trajectory, cloud_box: GridBox | ProbabilityCloud) -> np.ndarray:
    """E_cloud of Fig. 8.16: distance of each skeletal point (..., 3) to the nearest grid node.

    For a trajectory (L, 3, 3) the result is (L, 3), per frame and shoulder/elbow/wrist. For
    points inside the box it is at most half the cell diagonal.
    """
    box = cloud_box.box if isinstance(cloud_box, ProbabilityCloud) else cloud_box
    if not isinstance(box, GridBox):
        raise ValueError("cloud_error needs a GridBox or a ProbabilityCloud with a box")
    return box.nearest_node_distance(trajectory)


def weighted_union(clouds: Sequence[ProbabilityCloud], weights) -> ProbabilityCloud:
    """varsigma_j = union of P_ji (.) C_i, eqs. (8.29)-(8.30): gamma * w, points concatenated.

    weights (n,) are typically row j of P_RH; zero and NaN (undefined row) weights drop their
    cloud. The box is kept when every kept cloud has the same one, else None.
    """
    clouds = list(clouds)
    weights = np.asarray(weights, dtype=float).reshape(-1)
    if len(clouds) != weights.size:
        raise ValueError(f"{len(clouds)} clouds but {weights.size} weights")
    if not all(isinstance(c, ProbabilityCloud) for c in clouds):
        raise ValueError("weighted_union: every cloud must be a ProbabilityCloud")
    if np.any(np.isinf(weights)) or np.any(weights < 0):
        raise ValueError(f"weights must be finite and >= 0 (NaN drops a cloud), got {weights}")
    kept = [(c, w) for c, w in zip(clouds, weights, strict=True) if w > 0]
    if not kept:
        return ProbabilityCloud(np.zeros((0, 3)), np.zeros(0))
    boxes = {id(c.box) for c, _ in kept}
    box = kept[0][0].box if len(boxes) == 1 else None
    return ProbabilityCloud(np.concatenate([c.points for c, _ in kept]),
                            np.concatenate([c.gamma * w for c, w in kept]), box)


def repulsive_potential(cloud: ProbabilityCloud, query_points, alpha: float) -> np.ndarray:
    """Field of the J_Rep term of eq. (8.32): sum_l gamma_l exp(-alpha ||p_Cl - t||) per point t.

    query_points (..., 3) -> (...). The thesis sums this over the points T along the robot's
    kinematic chain; that sum (`.sum(axis=-1)` over the point axis) is left to the caller.
    """
    if not isinstance(cloud, ProbabilityCloud):
        raise ValueError("repulsive_potential: cloud must be a ProbabilityCloud")
    alpha = float(alpha)
    if not (math.isfinite(alpha) and alpha >= 0):
        raise ValueError(f"alpha must be finite and >= 0, got {alpha!r}")
    query = _points("query_points", query_points)
    flat = query.reshape(-1, 3)
    out = np.zeros(len(flat))
    chunk = max(1, 2**20 // max(1, len(cloud)))
    for start in range(0, len(flat), chunk):
        distance = np.linalg.norm(flat[start:start + chunk, None] - cloud.points[None], axis=-1)
        out[start:start + chunk] = np.exp(-alpha * distance) @ cloud.gamma
    return out.reshape(query.shape[:-1])
