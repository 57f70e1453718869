"""Minimum-jerk point-to-point motion (Flash & Hogan), the reaching profile of the synthetic operator.

With s = clip(t / T, 0, 1):
    x(t)   = p0 + (p1 - p0) (10 s^3 - 15 s^4 + 6 s^5)
    x'(t)  = (p1 - p0) (30 s^2 - 60 s^3 + 30 s^4) / T
    x''(t) = (p1 - p0) (60 s - 180 s^2 + 120 s^3) / T^2
Velocity and acceleration are zero at both ends; outside [0, T] the point rests at p0 / p1.
"""

from __future__ import annotations

import numpy as np


def _prepare(p0, p1, duration, t):
    p0 = np.asarray(p0, dtype=float)
    p1 = np.asarray(p1, dtype=float)
    if p0.shape != p1.shape:
        raise ValueError(f"minimum_jerk: p0 and p1 must have the same shape, got {p0.shape} and {p1.shape}")
    duration = float(duration)
    if not np.isfinite(duration) or duration <= 0.0:
        raise ValueError(f"minimum_jerk: duration must be a positive number, got {duration!r}")
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(t)):
        raise ValueError("minimum_jerk: t contains NaN or inf")
    s = np.clip(t / duration, 0.0, 1.0)
    inside = (t > 0.0) & (t < duration)
    # broadcast the profile (shape of t) against the point (shape of p0)
    s = s.reshape(s.shape + (1,) * p0.ndim)
    inside = inside.reshape(s.shape)
    return p0, p1, duration, s, inside


def minimum_jerk(p0, p1, duration: float, t):
    """Minimum-jerk position and velocity from p0 to p1 in `duration` s, at times t.

    p0, p1: arrays of the same shape D (or scalars); t: any shape S. Returns
    (position, velocity), each of shape S + D.
    """
    p0, p1, duration, s, inside = _prepare(p0, p1, duration, t)
    delta = p1 - p0
    s2 = s * s
    position = p0 + delta * (s2 * s * (10.0 + s * (-15.0 + 6.0 * s)))
    velocity = delta * (s2 * (30.0 + s * (-60.0 + 30.0 * s)) / duration) * inside
    return position, velocity


def minimum_jerk_acceleration(p0, p1, duration: float, t):
    """Minimum-jerk acceleration (shape S + D), zero outside (0, duration)."""
    p0, p1, duration, s, inside = _prepare(p0, p1, duration, t)
    return (p1 - p0) * (s * (60.0 + s * (-180.0 + 120.0 * s)) / duration**2) * inside
