"""Fuzzy numbers of thesis App. D, as the fuzzy scheduler of 7.4 uses them.

- `FuzzyNumber`: a trapezoidal fuzzy number <a, b, c, d> (support [a, d], core [b, c]), immutable.
  The triangular number <a_1, a_M, a_2> of eq. (D.5) is b = c; a crisp number is a = b = c = d
  (App. D: all its alpha-cuts are singletons).
- `SampledFuzzySet`: a convex fuzzy set given by its membership on a time grid, piecewise linear
  between the grid points: the arrival times of eq. (7.4)-(7.9), which are not triangular.

Rankings (eq. D.9, D.10): L(mu, r) is the degree of truth of "mu <= r", G(mu, r) of "mu >= r".
A crisp number has no area, so D.9-D.10 are read as their limits: L(r0, r) = [r >= r0] and
G(r0, r) = [r <= r0] (both 1 at r = r0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FuzzyNumber:
    """Trapezoidal fuzzy number <a, b, c, d>: membership 0 outside [a, d], rising linearly on
    [a, b], 1 on [b, c], falling linearly on [c, d] (eq. D.5 for b = c). Needs finite
    a <= b <= c <= d."""

    a: float
    b: float
    c: float
    d: float

    def __post_init__(self):
        values = (self.a, self.b, self.c, self.d)
        for name, v in zip("abcd", values, strict=True):
            if not isinstance(v, (int, float, np.floating, np.integer)) or not math.isfinite(v):
                raise ValueError(f"FuzzyNumber: {name} = {v!r} is not a finite number")
        if not self.a <= self.b <= self.c <= self.d:
            raise ValueError(f"FuzzyNumber: needs a <= b <= c <= d, got {values}")
        for name, v in zip("abcd", values, strict=True):
            object.__setattr__(self, name, float(v))

    @classmethod
    def triangular(cls, low: float, peak: float, high: float) -> FuzzyNumber:
        """<a_1, a_M, a_2> of eq. (D.5)."""
        return cls(low, peak, peak, high)

    @classmethod
    def crisp(cls, value: float) -> FuzzyNumber:
        """A crisp number (App. D: a Dirac delta, every alpha-cut the singleton {value})."""
        return cls(value, value, value, value)

    def __deepcopy__(self, memo):
        return self

    @property
    def is_crisp(self) -> bool:
        return self.a == self.d

    @property
    def is_triangular(self) -> bool:
        return self.b == self.c

    @property
    def support(self) -> tuple[float, float]:
        """Extremals of alpha_0 (the closure of {mu > 0}, as eq. (7.10) uses alpha_0)."""
        return self.a, self.d

    @property
    def core(self) -> tuple[float, float]:
        """alpha_1, the values of possibility 1."""
        return self.b, self.c

    def membership(self, x):
        """mu(x), eq. (D.5) (trapezoid: 1 on [b, c]); a float for a scalar x, else an array."""
        x = np.asarray(x, dtype=float)
        # x clipped to the edge first: the ratio stays in [0, 1] (a far x over a subnormal edge
        # width, e.g. <-5e-324, 0, 0, 1> at x = 0.5, overflowed to inf before the clip)
        a, b, c, d = self.a, self.b, self.c, self.d
        rise = np.ones_like(x) if b == a else (np.clip(x, a, b) - a) / (b - a)
        fall = np.ones_like(x) if d == c else (d - np.clip(x, c, d)) / (d - c)
        mu = np.clip(np.minimum(rise, fall), 0.0, 1.0)
        mu = np.where((x < self.a) | (x > self.d), 0.0, mu)
        return float(mu) if mu.ndim == 0 else mu

    def alpha_cut(self, level: float) -> tuple[float, float]:
        """alpha_eps = {x: mu(x) >= eps}, eq. (D.2), as (low, high); level 0 gives the support."""
        if not 0.0 <= level <= 1.0:
            raise ValueError(f"FuzzyNumber.alpha_cut: level must be in [0, 1], got {level}")
        return self.a + level * (self.b - self.a), self.d - level * (self.d - self.c)

    @classmethod
    def _unchecked(cls, a: float, b: float, c: float, d: float) -> FuzzyNumber:
        """Build from corners already known finite and ordered (sums and shifts of valid numbers)."""
        x = object.__new__(cls)
        object.__setattr__(x, "a", a)
        object.__setattr__(x, "b", b)
        object.__setattr__(x, "c", c)
        object.__setattr__(x, "d", d)
        return x

    def __add__(self, other) -> FuzzyNumber:
        """Sum (+) of eq. (7.3): the extension principle (D.6) with g(x, y) = x + y, which for
        trapezoids adds the four corners; a real number shifts."""
        if isinstance(other, FuzzyNumber):
            out = (self.a + other.a, self.b + other.b, self.c + other.c, self.d + other.d)
        else:
            k = float(other)
            out = (self.a + k, self.b + k, self.c + k, self.d + k)
        if not (math.isfinite(out[0]) and math.isfinite(out[3])):
            raise ValueError(f"FuzzyNumber: the sum {out} is not finite")
        return FuzzyNumber._unchecked(*out)

    __radd__ = __add__

    def __mul__(self, k) -> FuzzyNumber:
        """k x by the extension principle (D.6) with g(x) = k x (k real)."""
        k = float(k)
        corners = (k * self.a, k * self.b, k * self.c, k * self.d)
        return FuzzyNumber(*(corners if k >= 0 else corners[::-1]))

    __rmul__ = __mul__

    @property
    def area(self) -> float:
        """Integral of mu over the real line (the denominator of eq. D.9, D.10)."""
        return 0.5 * ((self.d - self.a) + (self.c - self.b))

    def _integral_below(self, r: np.ndarray) -> np.ndarray:
        """Integral of mu from -inf to r (closed form of the numerator of eq. D.9)."""
        a, b, c, d = self.a, self.b, self.c, self.d
        left = 0.5 * (b - a)
        rise = np.where(b > a, (np.clip(r, a, b) - a) ** 2 / (2.0 * (b - a) if b > a else 1.0), 0.0)
        flat = np.clip(r, b, c) - b
        u = d - np.clip(r, c, d)
        fall = np.where(d > c, 0.5 * (d - c) - u * u / (2.0 * (d - c) if d > c else 1.0), 0.0)
        return np.where(r <= b, rise, left + flat + np.where(r > c, fall, 0.0))

    def _integral_below_scalar(self, r: float) -> float:
        a, b, c, d = self.a, self.b, self.c, self.d
        if r <= a:
            return 0.0
        if r <= b:
            return (r - a) ** 2 / (2.0 * (b - a))
        if r <= c:
            return 0.5 * (b - a) + (r - b)
        if r < d:
            return 0.5 * (b - a) + (c - b) + 0.5 * (d - c) - (d - r) ** 2 / (2.0 * (d - c))
        return self.area

    def L(self, r):  # noqa: N802 - the thesis's name
        """L(mu, r) of eq. (D.9): the degree of truth of mu <= r."""
        if isinstance(r, float):
            if self.is_crisp:
                return 1.0 if r >= self.a else 0.0
            return min(1.0, max(0.0, self._integral_below_scalar(r) / self.area))
        r = np.asarray(r, dtype=float)
        if self.is_crisp:
            out = (r >= self.a).astype(float)
        else:
            out = np.clip(self._integral_below(r) / self.area, 0.0, 1.0)
        return float(out) if out.ndim == 0 else out

    def G(self, r):  # noqa: N802 - the thesis's name
        """G(mu, r) of eq. (D.10): the degree of truth of mu >= r."""
        if isinstance(r, float):
            if self.is_crisp:
                return 1.0 if r <= self.a else 0.0
            return min(1.0, max(0.0, 1.0 - self._integral_below_scalar(r) / self.area))
        r = np.asarray(r, dtype=float)
        if self.is_crisp:
            out = (r <= self.a).astype(float)
        else:
            out = np.clip(1.0 - self._integral_below(r) / self.area, 0.0, 1.0)
        return float(out) if out.ndim == 0 else out

    def breakpoints(self) -> tuple[float, float, float, float]:
        return self.a, self.b, self.c, self.d

    def __repr__(self) -> str:
        if self.is_triangular:
            return f"<{self.a:g}, {self.b:g}, {self.d:g}>"
        return f"<{self.a:g}, {self.b:g}, {self.c:g}, {self.d:g}>"


def intersection_height(x: FuzzyNumber, y: FuzzyNumber) -> float:
    """max_t min(x(t), y(t)): the height of the intersection x n y of eq. (D.3)-(D.4), used by
    eq. (7.13). Closed form: 1 when the cores meet, else the crossing of the falling edge of
    the earlier number with the rising edge of the later."""
    if max(x.b, y.b) <= min(x.c, y.c):
        return 1.0
    if x.c > y.b:  # make x the one whose core is to the left
        x, y = y, x
    if x.d < y.a:
        return 0.0
    width = (x.d - x.c) + (y.b - y.a)
    if width <= 0:
        return 0.0
    return float(min(1.0, max(0.0, (x.d - y.a) / width)))


@dataclass(frozen=True, eq=False)
class SampledFuzzySet:
    """A fuzzy set by its membership mu (K,) on an increasing time grid t (K,), piecewise linear
    in between and 0 outside [t_0, t_K-1]: the convex sets of eq. (7.4)-(7.9)."""

    t: np.ndarray
    mu: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        mu = np.asarray(self.mu, dtype=float)
        if t.ndim != 1 or t.shape != mu.shape or t.size < 2:
            raise ValueError(f"SampledFuzzySet: t and mu must be (K,) with K >= 2, got {t.shape}, {mu.shape}")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise ValueError("SampledFuzzySet: t must be finite and non-decreasing")
        if not np.all(np.isfinite(mu)) or np.any(mu < 0) or np.any(mu > 1 + 1e-12):
            raise ValueError("SampledFuzzySet: mu must be in [0, 1]")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "mu", np.minimum(mu, 1.0))
        steps = np.diff(t)
        cum = np.concatenate([[0.0], np.cumsum(0.5 * steps * (mu[1:] + mu[:-1]))])
        object.__setattr__(self, "_cum", cum)

    @classmethod
    def from_number(cls, x: FuzzyNumber, t) -> SampledFuzzySet:
        return cls(np.asarray(t, dtype=float), x.membership(np.asarray(t, dtype=float)))

    def __deepcopy__(self, memo):
        return self

    is_crisp = False

    @property
    def support(self) -> tuple[float, float]:
        """The grid's extent (the set is built on its support's closure)."""
        return float(self.t[0]), float(self.t[-1])

    def membership(self, x):
        x = np.asarray(x, dtype=float)
        out = np.interp(x, self.t, self.mu, left=0.0, right=0.0)
        return float(out) if out.ndim == 0 else out

    def height(self) -> float:
        """max_t mu(t), as p of eq. (7.6) and P_fi of eq. (7.8)."""
        return float(self.mu.max())

    def normalized(self) -> SampledFuzzySet:
        """(1/p) mu, eq. (7.5) and (7.9)."""
        p = self.height()
        if p <= 0:
            raise ValueError("SampledFuzzySet.normalized: the set is empty (height 0)")
        return SampledFuzzySet(self.t, self.mu / p)

    @property
    def area(self) -> float:
        return float(self._cum[-1])

    def alpha_cut(self, level: float) -> tuple[float, float]:
        """alpha_eps of eq. (D.2) on the grid (the convex hull of the grid points with mu >= eps;
        level 0: the grid's extent). Raises ValueError when no point reaches `level`."""
        if not 0.0 <= level <= 1.0:
            raise ValueError(f"SampledFuzzySet.alpha_cut: level must be in [0, 1], got {level}")
        if level == 0.0:
            return self.support
        k = np.flatnonzero(self.mu >= level)
        if k.size == 0:
            raise ValueError(f"SampledFuzzySet.alpha_cut: no point has membership >= {level}")
        return float(self.t[k[0]]), float(self.t[k[-1]])

    def L(self, r):  # noqa: N802 - the thesis's name
        """L(mu, r) of eq. (D.9), the integrals by the trapezoid rule on the grid."""
        if self.area <= 0:
            raise ValueError("SampledFuzzySet.L: the set has no area")
        r = np.asarray(r, dtype=float)
        out = np.interp(r, self.t, self._cum, left=0.0, right=self.area) / self.area
        return float(out) if out.ndim == 0 else out

    def G(self, r):  # noqa: N802 - the thesis's name
        """G(mu, r) of eq. (D.10): 1 - L(mu, r) (mu has no atom)."""
        out = 1.0 - np.asarray(self.L(r))
        return float(out) if out.ndim == 0 else out

    def breakpoints(self) -> tuple[float, float]:
        return self.support

    def to_triangular(self) -> FuzzyNumber:
        """The triangular approximation of eq. (7.10): <A_1, A_M, A_2>, A_M = alpha_1 (the middle
        of the points of maximal membership, should there be several), A_1, A_2 the extremals of
        alpha_0."""
        lo, hi = self.support
        top = np.flatnonzero(self.mu >= self.mu.max() * (1.0 - 1e-12))
        peak = 0.5 * (self.t[top[0]] + self.t[top[-1]])
        return FuzzyNumber.triangular(lo, min(max(peak, lo), hi), hi)

    def to_trapezoidal(self, eps: float) -> FuzzyNumber:
        """The trapezoid of eq. (7.22): alpha_0 the extremals of this set's alpha_0, alpha_1 that
        interval shrunk by eps on both sides (to its middle when narrower than 2 eps)."""
        return trapezoid_from_support(*self.support, eps)


def trapezoid_from_support(low: float, high: float, eps: float) -> FuzzyNumber:
    """<low, low + eps, high - eps, high>, the trapezoid of eq. (7.21)-(7.22); the core shrinks
    to the middle point when high - low < 2 eps."""
    if not eps > 0:
        raise ValueError(f"trapezoid_from_support: eps must be > 0, got {eps}")
    mid = 0.5 * (low + high)
    return FuzzyNumber(low, min(low + eps, mid), max(high - eps, mid), high)


def intersection(*sets: SampledFuzzySet) -> SampledFuzzySet:
    """mu = mu_1 n ... n mu_n, eq. (D.3)-(D.4): the pointwise min, on the union of the grids."""
    if not sets:
        raise ValueError("intersection: needs at least one set")
    t = np.unique(np.concatenate([s.t for s in sets]))
    mu = np.min([s.membership(t) for s in sets], axis=0)
    return SampledFuzzySet(t, mu)
