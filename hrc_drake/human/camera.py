"""A depth camera that measures the 8 skeletal points and loses the ones it cannot see (thesis Ch. 9).

Two models: `DepthCameraModel`, the analytic one (below), and `RenderedCameraModel`, which
reads a depth image rendered from the scene (the Drake system `RenderedSkeletonCamera`).

A point is lost (tracked False, NaN row) when the line of sight from the camera to it crosses
an occluder box (slab test) or passes closer than a capsule's radius to one of the given
capsules (segment-segment distance), or when it lies outside the view cone (FOV_HALF_ANGLE
from the camera axis). Visible points get isotropic Gaussian noise. The gaze flag F of thesis
3.1.2 is False when the face is hidden or turned away from the camera by more than
`gaze_valid_angle`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hrc_drake.human._kernels import hidden_points
from hrc_drake.messages import HEAD, DepthFrame, SkeletonFrame

#: half-angle of the view cone around the camera axis (rad)
FOV_HALF_ANGLE = np.deg2rad(60.0)
_EPS = 1e-12


def _vec3(value, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"DepthCameraModel: {what} must be 3 finite numbers, got {value!r}")
    return arr


def segments_hit_boxes(origin: np.ndarray, points: np.ndarray, lower: np.ndarray,
                       upper: np.ndarray) -> np.ndarray:
    """Slab test: does the segment origin -> points[n] cross box b?  Returns (N, B) bool.

    origin (3,), points (N, 3), lower/upper (B, 3) box corners. The point itself lying on
    the box surface does not count as crossing.
    """
    d = points - origin  # (N, 3)
    # a direction parallel to a slab gets a tiny component: its slab interval becomes
    # (-huge, huge) when the origin is inside the slab and empty otherwise
    d = np.where(d == 0.0, 1e-300, d)
    inv = (1.0 / d)[:, None, :]
    t1 = (lower - origin) * inv  # (N, B, 3)
    t2 = (upper - origin) * inv
    t_enter = np.minimum(t1, t2).max(axis=-1)
    t_exit = np.maximum(t1, t2).min(axis=-1)
    return (t_exit > np.maximum(t_enter, 0.0)) & (t_enter < 1.0 - 1e-9)


def _closest_parameters(a, b, c, e, f):
    """Closest-point parameters (s, t) of two segments from their dot products (Ericson 5.1.9).

    Segment 1 is p1 + s d1, segment 2 is p2 + t d2, r = p1 - p2; a = d1.d1, b = d1.d2,
    c = d1.r, e = d2.d2, f = d2.r, all broadcast together.
    """
    a_safe = np.maximum(a, _EPS)
    e_safe = np.maximum(e, _EPS)
    denom = a * e - b * b
    general = denom > _EPS * np.maximum(a * e, _EPS)
    s = np.where(general, np.clip((b * f - c * e) / np.maximum(denom, _EPS), 0.0, 1.0), 0.0)
    t = (b * s + f) / e_safe
    s_at_t1 = np.clip((b - c) / a_safe, 0.0, 1.0)
    s = np.where(t < 0.0, np.clip(-c / a_safe, 0.0, 1.0), np.where(t > 1.0, s_at_t1, s))
    t = np.clip(t, 0.0, 1.0)
    # degenerate second segment (a sphere): closest point on the first segment to p2
    point = e <= _EPS
    s = np.where(point, np.clip(-c / a_safe, 0.0, 1.0), s)
    t = np.where(point, 0.0, t)
    return s, t


def segment_segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Distance between segments p1-q1 and p2-q2, broadcast over leading axes (closest points)."""
    p1, q1, p2, q2 = (np.asarray(x, dtype=float) for x in (p1, q1, p2, q2))
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    dot = lambda x, y: np.einsum("...i,...i->...", x, y)  # noqa: E731
    s, t = _closest_parameters(dot(d1, d1), dot(d1, d2), dot(d1, r), dot(d2, d2), dot(d2, r))
    gap = (p1 + d1 * s[..., None]) - (p2 + d2 * t[..., None])
    return np.sqrt(dot(gap, gap))


def sight_capsule_distance(origin, points, start, end) -> np.ndarray:
    """Distances (N, K) from the sight segments origin -> points[n] to the segments start[k] -> end[k].

    Same result as `segment_segment_distance`, but every dot product is one matrix product,
    which matters for the particle filter's 8 x 500 points per frame.
    """
    d1 = points - origin  # (N, 3)
    d2 = end - start  # (K, 3)
    r = origin - start  # (K, 3)
    a = np.einsum("ni,ni->n", d1, d1)[:, None]
    b = d1 @ d2.T
    c = d1 @ r.T
    e = np.einsum("ki,ki->k", d2, d2)
    f = np.einsum("ki,ki->k", d2, r)
    s, t = _closest_parameters(a, b, c, e, f)
    rr = np.einsum("ki,ki->k", r, r)
    squared = rr + s * (s * a + 2.0 * c) + t * (t * e - 2.0 * f) - 2.0 * s * t * b
    return np.sqrt(np.maximum(squared, 0.0))


_NO_SEGMENTS = np.zeros((0, 3))
_NO_RADII = np.zeros(0)

#: largest (point, capsule) pair count `_sight_blocked_by_capsules` computes in full
_ALL_PAIRS = 256


def _check_capsules(capsules):
    start, end, radius = capsules
    start = np.asarray(start, dtype=float).reshape(-1, 3)
    end = np.asarray(end, dtype=float).reshape(-1, 3)
    radius = np.asarray(radius, dtype=float).reshape(-1)
    if radius.shape[0] != start.shape[0]:  # one radius for all (broadcast_to costs ~10 us a call)
        radius = np.broadcast_to(radius, (start.shape[0],))
    if end.shape != start.shape:
        raise ValueError(f"capsules: start {start.shape} and end {end.shape} must have the same shape (K, 3)")
    return start, end, radius


class DepthCameraModel:
    """Depth camera with occluder boxes, view cone and Gaussian noise (thesis Ch. 9, Fig. 9.2).

    position, target: camera centre and a point on its optical axis (world, m).
    occluders: list of (center (3,), size (3,)) axis-aligned boxes, or objects with
    `center`/`size` attributes (schema `Occluder`). margin: boxes are grown by this much
    on every side. noise_std: measurement noise per coordinate (m). rate: frames per second.
    gaze_valid_angle: largest angle (rad) between gaze and the head-to-camera direction
    for which the face is seen (flag F of Sec. 3.1.2).
    """

    def __init__(self, position, target, occluders=(), noise_std: float = 0.01, rate: float = 30.0,
                 margin: float = 0.0, gaze_valid_angle: float = 1.2, fov_half_angle: float = FOV_HALF_ANGLE):
        self.position = _vec3(position, "position")
        self.target = _vec3(target, "target")
        axis = self.target - self.position
        if np.linalg.norm(axis) < 1e-9:
            raise ValueError("DepthCameraModel: target must differ from position")
        self.axis = axis / np.linalg.norm(axis)
        for name, value in (("noise_std", noise_std), ("margin", margin)):
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"DepthCameraModel: {name} must be >= 0, got {value!r}")
        if not np.isfinite(rate) or rate <= 0:
            raise ValueError(f"DepthCameraModel: rate must be > 0, got {rate!r}")
        self.noise_std = float(noise_std)
        self.rate = float(rate)
        self.margin = float(margin)
        self.gaze_valid_angle = float(gaze_valid_angle)
        self.fov_half_angle = float(fov_half_angle)
        centers, sizes = [], []
        for i, box in enumerate(occluders):
            if hasattr(box, "center"):
                center, size = box.center, box.size
            else:
                center, size = box
            center = _vec3(center, f"occluders[{i}].center")
            size = _vec3(size, f"occluders[{i}].size")
            if np.any(size < 0):
                raise ValueError(f"DepthCameraModel: occluders[{i}].size must be >= 0, got {size}")
            centers.append(center)
            sizes.append(size)
        centers = np.reshape(centers, (-1, 3))
        half = 0.5 * np.reshape(sizes, (-1, 3)) + self.margin
        self.box_lower = centers - half
        self.box_upper = centers + half
        self._cos_limit = float(np.cos(self.fov_half_angle))

    def in_view(self, points) -> np.ndarray:
        """(...,) True where the point lies inside the view cone."""
        pts = np.asarray(points, dtype=float)
        rel = pts - self.position
        dist = np.linalg.norm(rel, axis=-1)
        cos = np.einsum("...i,i->...", rel, self.axis) / np.maximum(dist, _EPS)
        return cos >= np.cos(self.fov_half_angle)

    def is_occluded(self, points, capsules=None) -> np.ndarray:
        """(...,) True where the line of sight crosses an occluder box or a capsule."""
        pts = np.asarray(points, dtype=float)
        if pts.shape[-1] != 3:
            raise ValueError(f"DepthCameraModel: points must end with size 3, got {pts.shape}")
        flat = pts.reshape(-1, 3)
        hidden = np.zeros(flat.shape[0], dtype=bool)
        if self.box_lower.shape[0]:
            hidden |= segments_hit_boxes(self.position, flat, self.box_lower, self.box_upper).any(axis=1)
        if capsules is not None:
            start, end, radius = _check_capsules(capsules)
            if start.shape[0]:
                hidden |= self._sight_blocked_by_capsules(flat, start, end, radius)
        hidden |= ~np.all(np.isfinite(flat), axis=1)
        return hidden.reshape(pts.shape[:-1])

    def _sight_blocked_by_capsules(self, flat, start, end, radius) -> np.ndarray:
        """(N,) True where the sight segment camera -> point passes within a capsule's radius.

        A bounding-sphere test on all (point, capsule) pairs first; the exact segment-segment
        distance only for the pairs it cannot rule out (usually few: each costs ~25 numpy calls).
        A frame's few points (up to `_ALL_PAIRS` pairs) skip the test: every distance at once by
        `sight_capsule_distance` takes fewer numpy calls than the test (equal to 1e-15 m).
        """
        if flat.shape[0] * start.shape[0] <= _ALL_PAIRS:
            return np.any(sight_capsule_distance(self.position, flat, start, end) < radius, axis=1)
        sight = flat - self.position  # (N, 3)
        centre = 0.5 * (start + end) - self.position  # (K, 3)
        bound = 0.5 * np.linalg.norm(end - start, axis=1) + radius  # (K,)
        along = sight @ centre.T  # (N, K)
        length2 = np.maximum(np.einsum("ni,ni->n", sight, sight), _EPS)[:, None]
        t = np.clip(along / length2, 0.0, 1.0)
        gap2 = np.einsum("ki,ki->k", centre, centre)[None, :] - 2.0 * t * along + t * t * length2
        rows, cols = np.nonzero(gap2 < bound[None, :] ** 2)
        blocked = np.zeros(flat.shape[0], dtype=bool)
        if rows.size:
            dist = segment_segment_distance(
                np.broadcast_to(self.position, (rows.size, 3)), flat[rows], start[cols], end[cols]
            )
            blocked[rows[dist < radius[cols]]] = True
        return blocked

    def is_hidden(self, points, capsules=None) -> np.ndarray:
        """(...,) True where the camera cannot measure the point: occluded or outside the view cone.

        capsules: optional (start (K, 3), end (K, 3), radius (K,)), e.g. the robot links.
        The same as `is_occluded(points, capsules) | ~in_view(points)`, one compiled loop
        (`_kernels.hidden_points`: per point the view cone, then the boxes, then the capsules).
        """
        pts = np.asarray(points, dtype=float)
        if pts.shape[-1] != 3:
            raise ValueError(f"DepthCameraModel: points must end with size 3, got {pts.shape}")
        if capsules is None:
            start, end, radius = _NO_SEGMENTS, _NO_SEGMENTS, _NO_RADII
        else:
            start, end, radius = _check_capsules(capsules)
        hidden = hidden_points(self.position, self.axis, self._cos_limit, pts.reshape(-1, 3), self.box_lower,
                               self.box_upper, start, end, radius)
        return hidden.reshape(pts.shape[:-1])

    def gaze_visible(self, head, gaze) -> bool:
        """Flag F: the face is turned towards the camera within gaze_valid_angle."""
        # scalar arithmetic: the numpy calls on these 3-vectors cost ~40 us a frame
        hx, hy, hz = (float(v) for v in np.asarray(head, dtype=float).reshape(3))
        gx, gy, gz = (float(v) for v in np.asarray(gaze, dtype=float).reshape(3))
        px, py, pz = self.position.tolist()
        tx, ty, tz = px - hx, py - hy, pz - hz
        norm = math.sqrt(tx * tx + ty * ty + tz * tz) * math.sqrt(gx * gx + gy * gy + gz * gz)
        if not math.isfinite(norm) or norm < _EPS:
            return False
        cos = (tx * gx + ty * gy + tz * gz) / norm
        return math.acos(min(max(cos, -1.0), 1.0)) <= self.gaze_valid_angle

    def measure(self, time: float, true_points, gaze, rng: np.random.Generator,
                capsules=None) -> SkeletonFrame:
        """One frame: noisy visible points, NaN rows and tracked False for hidden ones."""
        pts = np.asarray(true_points, dtype=float)
        if pts.shape != (8, 3):
            raise ValueError(f"DepthCameraModel.measure: true_points must be (8, 3), got {pts.shape}")
        gaze = np.asarray(gaze, dtype=float).reshape(-1)
        if gaze.shape != (3,):
            raise ValueError(f"DepthCameraModel.measure: gaze must be (3,), got {gaze.shape}")
        hidden = self.is_hidden(pts, capsules)
        noisy = pts + rng.normal(0.0, self.noise_std, size=pts.shape) if self.noise_std > 0 else pts.copy()
        noisy[hidden] = np.nan
        gnorm = math.sqrt(float(gaze @ gaze))
        unit_gaze = gaze / gnorm if gnorm > _EPS else np.array([1.0, 0.0, 0.0])
        valid = bool(not hidden[HEAD] and gnorm > _EPS and self.gaze_visible(pts[HEAD], unit_gaze))
        return SkeletonFrame(time=float(time), points=noisy, tracked=~hidden, gaze=unit_gaze,
                             gaze_valid=valid)


def look_at_rotation(position, target) -> np.ndarray:
    """R_WC (3, 3) of a camera at `position` looking at `target` with no roll: columns x right,
    y down, z forward (Drake's camera frame), x horizontal (along the camera's world x when it
    looks straight up or down)."""
    forward = _vec3(target, "target") - _vec3(position, "position")
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise ValueError("look_at_rotation: target must differ from position")
    z = forward / norm
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-9:
        x = np.array([0.0, -1.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


#: per skeletal point, the body capsules (CAPSULE_NAMES indices) it lies inside: the depth
#: image shows their surface in front of the point, up to their radius
POINT_CAPSULES: tuple[tuple[int, ...], ...] = ((0,), (1,), (2,), (3,), (2, 4), (3, 5), (4,), (5,))


def point_surface_radius(capsule_radius) -> np.ndarray:
    """(8,) how far in front of each skeletal point its own body surface may be: the largest
    radius of the capsules it lies in (`POINT_CAPSULES`, radii in CAPSULE_NAMES order)."""
    radius = np.asarray(capsule_radius, dtype=float).reshape(-1)
    return np.array([max(radius[k] for k in caps) for caps in POINT_CAPSULES])


class RenderedCameraModel:
    """A skeleton tracker on a rendered depth image (thesis Ch. 9; issue 15 item 1).

    Geometry: a pinhole camera at `position` looking at `target` (`look_at_rotation`), width x
    height pixels over fov_x x fov_y (deg), depths min_depth..max_depth (m). Points are
    measured from the true pose; point k is untracked where the image is in front of it by
    more than depth_tolerance + point_radius[k] (its own body surface; self-occlusion
    included), outside the image or outside the depth range. The failure modes of a
    skeleton tracker: with probability wrong_surface_probability a hidden point with a surface
    in front of it stays tracked at the back-projected depth of a pixel within
    wrong_surface_pixels of its own (the occluder's surface), and every tracked point jitters
    with the isotropic standard deviation noise_std * (z / 1 m) ** jitter_exponent, z its depth.
    The gaze flag F (Sec. 3.1.2) as in `DepthCameraModel`.
    """

    def __init__(self, position, target, width: int = 256, height: int = 212, fov_x: float = 70.6,
                 fov_y: float = 60.0, min_depth: float = 0.5, max_depth: float = 4.5,
                 depth_tolerance: float = 0.03, point_radius=0.0, noise_std: float = 0.01,
                 jitter_exponent: float = 2.0, wrong_surface_probability: float = 0.05,
                 wrong_surface_pixels: int = 3, rate: float = 30.0, gaze_valid_angle: float = 1.2):
        self.position = _vec3(position, "position")
        self.target = _vec3(target, "target")
        self.R_WC = look_at_rotation(self.position, self.target)
        if int(width) != width or int(height) != height or width < 1 or height < 1:
            raise ValueError(f"RenderedCameraModel: width and height must be positive integers, got "
                             f"{width!r}, {height!r}")
        self.width, self.height = int(width), int(height)
        for name, value in (("fov_x", fov_x), ("fov_y", fov_y)):
            if not (np.isfinite(value) and 0 < value < 180):
                raise ValueError(f"RenderedCameraModel: {name} must be in (0, 180) deg, got {value!r}")
        if not (0 < min_depth < max_depth and np.isfinite(max_depth)):
            raise ValueError(f"RenderedCameraModel: need 0 < min_depth < max_depth, got {min_depth!r}, "
                             f"{max_depth!r}")
        for name, value in (("depth_tolerance", depth_tolerance), ("noise_std", noise_std),
                            ("jitter_exponent", jitter_exponent)):
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"RenderedCameraModel: {name} must be >= 0, got {value!r}")
        if not 0.0 <= wrong_surface_probability <= 1.0:
            raise ValueError(f"RenderedCameraModel: wrong_surface_probability must be in [0, 1], got "
                             f"{wrong_surface_probability!r}")
        if not (np.isfinite(rate) and rate > 0):
            raise ValueError(f"RenderedCameraModel: rate must be > 0, got {rate!r}")
        #: (8,) how far in front of each point its own body surface may be (`point_surface_radius`)
        self.point_radius = np.broadcast_to(np.asarray(point_radius, dtype=float), (8,)).copy()
        # square pixels are not assumed: each axis spans its own field of view
        self.fx = 0.5 * self.width / np.tan(0.5 * np.deg2rad(fov_x))
        self.fy = 0.5 * self.height / np.tan(0.5 * np.deg2rad(fov_y))
        self.cx, self.cy = 0.5 * self.width - 0.5, 0.5 * self.height - 0.5
        self.min_depth, self.max_depth = float(min_depth), float(max_depth)
        self.depth_tolerance = float(depth_tolerance)
        self.noise_std = float(noise_std)
        self.jitter_exponent = float(jitter_exponent)
        self.wrong_surface_probability = float(wrong_surface_probability)
        self.wrong_surface_pixels = int(wrong_surface_pixels)
        self.rate = float(rate)
        self._gaze = DepthCameraModel(self.position, self.target, gaze_valid_angle=gaze_valid_angle)
        X_CW = np.eye(4)
        X_CW[:3, :3] = self.R_WC.T
        X_CW[:3, 3] = -self.R_WC.T @ self.position
        self.X_CW = X_CW
        self.X_CW.setflags(write=False)

    @classmethod
    def from_config(cls, camera, sensor, capsule_radius) -> RenderedCameraModel:
        """From the typed configs `human.config.Camera` and its `RenderedDepthCamera` sensor and
        the body capsules' radii (CAPSULE_NAMES order)."""
        return cls(camera.position, camera.target, width=sensor.width, height=sensor.height,
                   fov_x=sensor.fov_x, fov_y=sensor.fov_y, min_depth=sensor.min_depth,
                   max_depth=sensor.max_depth, depth_tolerance=sensor.depth_tolerance,
                   point_radius=point_surface_radius(capsule_radius), noise_std=camera.noise_std,
                   jitter_exponent=sensor.jitter_exponent,
                   wrong_surface_probability=sensor.wrong_surface_probability,
                   wrong_surface_pixels=sensor.wrong_surface_pixels, rate=camera.rate,
                   gaze_valid_angle=camera.gaze_valid_angle)

    def depth_frame(self, time: float, depth) -> DepthFrame:
        """The image (H, W) as a `DepthFrame` (no skeleton seen in it yet)."""
        depth = np.array(depth, dtype=np.float32).reshape(self.height, self.width)
        depth.setflags(write=False)
        return DepthFrame(time=float(time), depth=depth, X_CW=self.X_CW,
                          intrinsics=(self.fx, self.fy, self.cx, self.cy), min_depth=self.min_depth,
                          max_depth=self.max_depth, tolerance=self.depth_tolerance)

    def jitter_std(self, z) -> np.ndarray:
        """Jitter standard deviation (m) at depth z (m): noise_std * z ** jitter_exponent."""
        return self.noise_std * np.maximum(np.asarray(z, dtype=float), 0.0) ** self.jitter_exponent

    def back_project(self, u, v, z) -> np.ndarray:
        """World points (..., 3) of pixels (u, v) at depths z."""
        p_c = np.stack([(u - self.cx) / self.fx * z, (v - self.cy) / self.fy * z, z], axis=-1)
        return p_c @ self.R_WC.T + self.position

    def measure(self, time: float, true_points, gaze, depth,
                rng: np.random.Generator) -> tuple[SkeletonFrame, DepthFrame]:
        """One frame from the depth image (H, W): the measured skeleton and the image with
        what it hid (`DepthFrame.hidden`, `wrong_surface`)."""
        pts = np.asarray(true_points, dtype=float)
        if pts.shape != (8, 3):
            raise ValueError(f"RenderedCameraModel.measure: true_points must be (8, 3), got {pts.shape}")
        gaze = np.asarray(gaze, dtype=float).reshape(-1)
        if gaze.shape != (3,):
            raise ValueError(f"RenderedCameraModel.measure: gaze must be (3,), got {gaze.shape}")
        image = self.depth_frame(time, depth)
        hidden = image.is_hidden(pts, self.depth_tolerance + self.point_radius) | ~np.all(np.isfinite(pts), 1)
        measured = pts.copy()
        # The wrong surface: the depth of a pixel near the hidden point's own, where it is a surface.
        u, v, _, inside = image.project(np.where(np.isfinite(pts), pts, 0.0))
        r = self.wrong_surface_pixels
        jump = rng.random(8) < self.wrong_surface_probability
        du, dv = rng.integers(-r, r + 1, size=(2, 8))
        u2 = np.clip(u + du, 0, self.width - 1)
        v2 = np.clip(v + dv, 0, self.height - 1)
        surface = image.depth[v2, u2].astype(float)
        valid = (surface >= self.min_depth) & (surface <= self.max_depth)
        wrong = hidden & inside & jump & valid
        measured[wrong] = self.back_project(u2[wrong], v2[wrong], surface[wrong])
        tracked = ~hidden | wrong
        z = (measured - self.position) @ self.R_WC[:, 2]
        noise = rng.standard_normal((8, 3)) * self.jitter_std(z)[:, None]
        measured = np.where(tracked[:, None], measured + noise, np.nan)
        gnorm = np.linalg.norm(gaze)
        unit_gaze = gaze / gnorm if gnorm > _EPS else np.array([1.0, 0.0, 0.0])
        valid_gaze = bool(not hidden[HEAD] and gnorm > _EPS and self._gaze.gaze_visible(pts[HEAD], unit_gaze))
        frame = SkeletonFrame(time=float(time), points=measured, tracked=tracked, gaze=unit_gaze,
                              gaze_valid=valid_gaze)
        return frame, dataclasses.replace(image, hidden=hidden, wrong_surface=wrong, true_points=pts.copy())
