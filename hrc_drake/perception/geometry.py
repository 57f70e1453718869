"""Small box geometry used by the trackers, their tests and benchmarks.

`BoxOcclusion` is a stand-in depth-map query (L_c1 of eq. 9.12) for axis-aligned occluder
boxes seen from a point camera; the cell uses `hrc_drake.human.camera.DepthCameraModel.is_hidden`,
which also handles capsules. Both have the same call signature: (..., 3) points -> (...) bool.
"""

from __future__ import annotations

import numpy as np


def points_in_box(points, center, size) -> np.ndarray:
    """(...) bool: whether each point of (..., 3) lies in the axis-aligned box (center, size)."""
    half = 0.5 * np.asarray(size, dtype=float)
    return np.all(np.abs(np.asarray(points, dtype=float) - np.asarray(center, dtype=float)) <= half, axis=-1)


class BoxOcclusion:
    """Depth-map query for axis-aligned boxes: a point is hidden when the segment from the
    camera to it crosses a box (slab test, all points x all boxes in one expression).

    camera_position: (3,). boxes: list of (center (3,), size (3,)). Points inside a box count
    as hidden.
    """

    def __init__(self, camera_position, boxes):
        self.camera_position = np.asarray(camera_position, dtype=float)
        if self.camera_position.shape != (3,):
            raise ValueError(
                f"BoxOcclusion: camera_position must have shape (3,), got {self.camera_position.shape}")
        self.set_boxes(boxes)

    def set_boxes(self, boxes) -> None:
        """Replace the occluders (a changing depth map, e.g. a box that enters the scene)."""
        centers = np.array([np.asarray(c, dtype=float) for c, _ in boxes]).reshape(-1, 3)
        sizes = np.array([np.asarray(s, dtype=float) for _, s in boxes]).reshape(-1, 3)
        if np.any(sizes < 0) or not (np.all(np.isfinite(centers)) and np.all(np.isfinite(sizes))):
            raise ValueError("BoxOcclusion: box centers and sizes must be finite, sizes >= 0")
        self.lower = centers - 0.5 * sizes
        self.upper = centers + 0.5 * sizes

    def __call__(self, points) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        if points.shape[-1] != 3:
            raise ValueError(f"BoxOcclusion: points must have shape (..., 3), got {points.shape}")
        shape = points.shape[:-1]
        if len(self.lower) == 0:
            return np.zeros(shape, dtype=bool)
        flat = points.reshape(-1, 3)
        origin = self.camera_position
        direction = flat - origin  # segment parameter t in [0, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / direction[:, None, :]  # (M, 1, 3)
            t1 = (self.lower[None] - origin) * inv  # (M, B, 3)
            t2 = (self.upper[None] - origin) * inv
        t_near = np.minimum(t1, t2)
        t_far = np.maximum(t1, t2)
        # A zero direction component: inside the slab for every t, or never.
        parallel = direction[:, None, :] == 0
        inside_slab = (origin >= self.lower[None]) & (origin <= self.upper[None])
        t_near = np.where(parallel, np.where(inside_slab, -np.inf, np.inf), t_near)
        t_far = np.where(parallel, np.where(inside_slab, np.inf, -np.inf), t_far)
        enter = np.maximum(t_near.max(axis=2), 0.0)
        leave = np.minimum(t_far.min(axis=2), 1.0)
        hit = np.any(enter <= leave, axis=1)
        hit &= np.all(np.isfinite(flat), axis=1)
        return hit.reshape(shape)
