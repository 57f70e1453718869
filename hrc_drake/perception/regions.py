"""Belief regions of the skeleton trackers, and whether a true point lies inside one (thesis
9.1.3, Fig. 9.7; issue 15 item 3).

The particle filter's mean is the centroid of a set (the admissible region of 9.1.2, a crown
around the parent point), not a point estimate, so the error of a hidden point is judged here by
whether the truth lies inside the region each tracker reports, next to the region's volume
(coverage alone rewards a huge region):
- particle filter: the particle positions inflated by `PARTICLE_RADIUS` (the union of balls
  around every particle; all particles, their mass is 1);
- Kalman filter: its `REGION_MASS` (95 %) covariance ellipsoid,
  (x - m)^T P^-1 (x - m) <= chi2_3^-1(0.95), volume 4/3 pi chi^3 sqrt(det P);
- hold last seen: a ball of `PARTICLE_RADIUS` around the held point (a point estimate given
  the same inflation as one particle).
Arrays: M points, N particles per point, 3 coordinates (m). No pydrake here.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: Probability mass of the Kalman filter's ellipsoid region.
REGION_MASS = 0.95
#: Radius (m) by which particles (and a held point) are inflated: 2 x the camera's 0.01 m noise.
PARTICLE_RADIUS = 0.02
#: Monte Carlo samples of `ball_union_volume` (relative error ~2 % for a region filling half
#: of its bounding box).
VOLUME_SAMPLES = 4000


def ellipsoid_threshold(mass: float = REGION_MASS, dim: int = 3) -> float:
    """Squared Mahalanobis radius of the Gaussian region holding `mass`: chi2_dim^-1(mass)."""
    from scipy.stats import chi2  # here: scipy.stats takes 0.6 s to import, and most cells never call this

    if not 0.0 < mass < 1.0:
        raise ValueError(f"ellipsoid_threshold: mass must be in (0, 1), got {mass!r}")
    return float(chi2.ppf(mass, dim))


def in_ellipsoid(means, covariances, points, mass: float = REGION_MASS) -> np.ndarray:
    """(M,) bool: point m inside the `mass` ellipsoid of N(means[m], covariances[m]).

    means, points (M, 3); covariances (M, 3, 3) positive definite."""
    means, points = np.atleast_2d(means).astype(float), np.atleast_2d(points).astype(float)
    covariances = np.asarray(covariances, float).reshape(-1, 3, 3)
    offset = points - means
    d2 = np.einsum("mi,mi->m", offset, np.linalg.solve(covariances, offset[..., None])[..., 0])
    return d2 <= ellipsoid_threshold(mass)


def ellipsoid_volume(covariances, mass: float = REGION_MASS) -> np.ndarray:
    """(M,) volumes (m^3) of the `mass` ellipsoids of covariances (M, 3, 3)."""
    covariances = np.asarray(covariances, float).reshape(-1, 3, 3)
    det = np.clip(np.linalg.det(covariances), 0.0, None)
    return 4.0 / 3.0 * np.pi * ellipsoid_threshold(mass) ** 1.5 * np.sqrt(det)


def ball_volume(radius) -> np.ndarray:
    """Volume (m^3) of a ball of `radius` (m)."""
    return 4.0 / 3.0 * np.pi * np.asarray(radius, float) ** 3


def in_ball_union(centers, points, radius: float = PARTICLE_RADIUS) -> np.ndarray:
    """(M,) bool: point m within `radius` of some of centers[m] (M, N, 3) (or (N, 3), M = 1)."""
    centers = np.asarray(centers, float)
    if centers.ndim == 2:
        centers = centers[None]
    points = np.atleast_2d(points).astype(float)
    d2 = np.sum((centers - points[:, None, :]) ** 2, axis=2)
    return d2.min(axis=1) <= radius**2


def ball_union_volume(centers, radius: float = PARTICLE_RADIUS, samples: int = VOLUME_SAMPLES,
                      seed: int = 0) -> float:
    """Volume (m^3) of the union of balls of `radius` around centers (N, 3): Monte Carlo with
    `samples` uniform points in the union's bounding box (seeded: the same set, the same value);
    exact for one center."""
    centers = np.unique(np.asarray(centers, float).reshape(-1, 3), axis=0)
    if len(centers) == 1:
        return float(ball_volume(radius))
    lo, hi = centers.min(axis=0) - radius, centers.max(axis=0) + radius
    box = float(np.prod(hi - lo))
    sample = np.random.default_rng(seed).uniform(lo, hi, (samples, 3))
    distance, _ = cKDTree(centers).query(sample, k=1, distance_upper_bound=radius * (1 + 1e-12))
    share = float(np.mean(distance <= radius))
    return min(box * share, len(centers) * float(ball_volume(radius)))
