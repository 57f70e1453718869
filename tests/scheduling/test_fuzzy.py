"""Fuzzy numbers of thesis App. D (`hrc_drake.scheduling.fuzzy`): membership (D.5), alpha-cuts
(D.2), the sum by the extension principle (D.6), intersection (D.3-D.4) and the rankings L, G
(D.9-D.10), on hand-worked numbers and against sampling approximations."""

import copy
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hrc_drake.scheduling.fuzzy import (
    FuzzyNumber,
    SampledFuzzySet,
    intersection,
    intersection_height,
    trapezoid_from_support,
)

T = FuzzyNumber.triangular


def test_construction_is_validated_and_immutable():
    x = FuzzyNumber(1, 2, 4, 7)
    assert (x.a, x.b, x.c, x.d) == (1.0, 2.0, 4.0, 7.0)
    assert x.support == (1.0, 7.0) and x.core == (2.0, 4.0)
    assert T(0, 2, 4).is_triangular and not x.is_triangular
    assert FuzzyNumber.crisp(3.0).is_crisp and not x.is_crisp
    with pytest.raises(ValueError, match="a <= b <= c <= d"):
        FuzzyNumber(2, 1, 3, 4)
    with pytest.raises(ValueError, match="a <= b <= c <= d"):
        T(0, 5, 4)
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError, match="finite"):
            FuzzyNumber(0, 1, 2, bad)
    with pytest.raises(AttributeError):
        x.a = 0.0
    assert copy.deepcopy(x) is x


def test_membership_eq_d5_hand_worked():
    x = T(0, 2, 4)  # rises as x/2, falls as (4 - x)/2
    assert x.membership(1.0) == 0.5 and x.membership(2.0) == 1.0 and x.membership(3.5) == 0.25
    assert x.membership(-0.1) == 0.0 and x.membership(4.1) == 0.0
    y = FuzzyNumber(1, 2, 4, 7)
    assert np.allclose(y.membership([1.5, 3.0, 5.5, 7.0]), [0.5, 1.0, 0.5, 0.0])
    c = FuzzyNumber.crisp(3.0)
    assert c.membership(3.0) == 1.0 and c.membership(3.0001) == 0.0
    left_vertical = FuzzyNumber(2, 2, 3, 5)
    assert left_vertical.membership(2.0) == 1.0 and left_vertical.membership(1.99) == 0.0


def test_alpha_cuts_eq_d2_hand_worked():
    y = FuzzyNumber(1, 2, 4, 7)
    assert y.alpha_cut(0.0) == (1.0, 7.0)
    assert y.alpha_cut(0.5) == (1.5, 5.5)
    assert y.alpha_cut(1.0) == (2.0, 4.0)
    assert FuzzyNumber.crisp(3.0).alpha_cut(0.3) == (3.0, 3.0)
    with pytest.raises(ValueError, match="level"):
        y.alpha_cut(1.5)


def test_sum_shift_and_scaling_hand_worked():
    # <1, 2, 3> + <2, 4, 7> = <3, 6, 10> (D.6 with g = x + y adds the corners)
    s = T(1, 2, 3) + T(2, 4, 7)
    assert (s.a, s.b, s.c, s.d) == (3.0, 6.0, 6.0, 10.0)
    t = FuzzyNumber(1, 2, 4, 7) + T(0, 1, 1)
    assert (t.a, t.b, t.c, t.d) == (1.0, 3.0, 5.0, 8.0)
    shifted = 2.5 + T(1, 2, 3)
    assert (shifted.a, shifted.b, shifted.d) == (3.5, 4.5, 5.5)
    assert T(1, 2, 3) + FuzzyNumber.crisp(-1.0) == T(0, 1, 2)
    assert 2 * T(1, 2, 4) == T(2, 4, 8)
    assert T(1, 2, 4) * -1 == T(-4, -2, -1)  # a negative factor reverses the corners
    with pytest.raises(ValueError, match="finite"):
        T(0, 1, 1e308) + T(0, 1, 1e308)


def test_sum_matches_the_extension_principle_by_sampling():
    """mu_{x+y}(z) = sup{min(mu_x(u), mu_y(v)) : u + v = z} (eq. D.6) estimated from random pairs:
    the binned sup approaches the closed-form sum from below, and every pair whose min
    membership is >= alpha has u + v inside the alpha-cut of the sum."""
    rng = np.random.default_rng(0)
    x, y = T(1, 2, 5), FuzzyNumber(0, 3, 4, 6)
    u = rng.uniform(x.a, x.d, 400_000)
    v = rng.uniform(y.a, y.d, 400_000)
    level = np.minimum(x.membership(u), y.membership(v))
    z = u + v
    s = x + y
    edges = np.linspace(s.a, s.d, 61)
    k = np.clip(np.digitize(z, edges) - 1, 0, 59)
    sup = np.zeros(60)
    np.maximum.at(sup, k, level)
    centers = 0.5 * (edges[1:] + edges[:-1])
    # the sup in a bin is at least the membership somewhere in the bin, never above its max
    half = 0.5 * (edges[1] - edges[0])
    upper = np.maximum(s.membership(centers - half), s.membership(centers + half))
    upper = np.maximum(upper, np.where((centers - half <= s.b) & (centers + half >= s.c), 1.0, 0.0))
    assert np.all(sup <= upper + 1e-9)
    assert np.max(np.abs(sup - s.membership(centers))) < 0.08
    for alpha in (0.2, 0.5, 0.8):
        lo, hi = s.alpha_cut(alpha)
        inside = z[level >= alpha]
        assert inside.min() >= lo - 1e-9 and inside.max() <= hi + 1e-9
        assert inside.min() < lo + 0.05 and inside.max() > hi - 0.05  # the ends are reached


def test_rankings_eq_d9_d10_hand_worked():
    x = T(0, 2, 4)  # area 2; int_0^1 x/2 = 1/4; int_0^3 mu = 1 + 3/4
    assert x.L(1.0) == pytest.approx(0.125) and x.G(1.0) == pytest.approx(0.875)
    assert x.L(2.0) == pytest.approx(0.5)
    assert x.L(3.0) == pytest.approx(0.875) and x.G(3.0) == pytest.approx(0.125)
    assert x.L(-1.0) == 0.0 and x.L(5.0) == 1.0 and x.G(5.0) == 0.0
    y = FuzzyNumber(1, 2, 4, 7)  # area 4: L(3) = (1/2 + 1)/4, L(5) = (1/2 + 2 + 5/6)/4
    assert y.L(3.0) == pytest.approx(0.375)
    assert y.L(5.0) == pytest.approx((0.5 + 2.0 + 5.0 / 6.0) / 4.0)
    # the array form agrees with the scalar one
    r = np.array([0.5, 1.5, 2.5, 3.9, 6.0])
    assert np.allclose(y.L(r), [y.L(float(v)) for v in r])
    assert np.allclose(y.G(r), [y.G(float(v)) for v in r])
    # crisp numbers: the limits of D.9-D.10
    c = FuzzyNumber.crisp(3.0)
    assert (c.L(2.9), c.L(3.0), c.G(3.0), c.G(3.1)) == (0.0, 1.0, 1.0, 0.0)
    assert np.array_equal(c.L(np.array([2.0, 3.0, 4.0])), [0.0, 1.0, 1.0])


def test_rankings_order_hand_made_pairs():
    early, late = T(0, 2, 4), T(1, 3, 5)
    # "early <= 3" is truer than "late <= 3", "late >= 3" truer than "early >= 3"
    assert early.L(3.0) == pytest.approx(0.875) and late.L(3.0) == pytest.approx(0.5)
    assert late.G(3.0) > early.G(3.0)
    # a wide and a narrow number with the same peak: L at the peak is 1/2 for both (symmetry),
    # a second later the narrow one is surer to be done
    wide, narrow = T(0, 5, 10), T(4, 5, 6)
    assert wide.L(5.0) == pytest.approx(0.5) and narrow.L(5.0) == pytest.approx(0.5)
    assert narrow.L(6.0) == 1.0 and wide.L(6.0) == pytest.approx(1 - 0.5 * 16 / 25)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-50, 50, allow_nan=False), min_size=4, max_size=4).map(sorted),
    st.floats(-60, 60, allow_nan=False),
)
def test_rankings_match_numerical_integration(corners, r):
    x = FuzzyNumber(*corners)
    if x.area < 1e-3:
        return
    # the corners and points 1e-9 s either side of them: a vertical edge (a == b or c == d) then
    # costs the trapezoid rule 1e-9 s of error, not a grid step
    near = np.concatenate([np.asarray(corners) + offset for offset in (-1e-9, 0.0, 1e-9)])
    grid = np.unique(np.concatenate([np.linspace(x.a - 1, x.d + 1, 20001), near]))
    mu = x.membership(grid)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(grid) * (mu[1:] + mu[:-1]))])
    assert x.L(r) == pytest.approx(np.interp(r, grid, cum) / cum[-1], abs=2e-3)
    assert x.L(r) + x.G(r) == pytest.approx(1.0)


def test_intersection_height_hand_worked_and_against_a_grid():
    assert intersection_height(T(0, 2, 4), T(2, 4, 6)) == pytest.approx(0.5)  # edges cross at 3
    assert intersection_height(T(0, 2, 4), T(0, 2, 4)) == 1.0
    assert intersection_height(T(0, 1, 2), T(3, 4, 5)) == 0.0
    # cores [1, 3] and {5} apart: 4 - t = (t - 2) / 3 at t = 3.5, height 1/2
    assert intersection_height(FuzzyNumber(0, 1, 3, 4), T(2, 5, 6)) == pytest.approx(0.5)
    assert intersection_height(FuzzyNumber(0, 1, 3, 4), T(2, 3, 6)) == 1.0  # the cores meet at 3
    assert intersection_height(FuzzyNumber.crisp(1.0), T(0, 2, 4)) == pytest.approx(0.5)
    assert intersection_height(T(0, 2, 4), FuzzyNumber.crisp(3.0)) == pytest.approx(0.5)
    assert intersection_height(FuzzyNumber.crisp(1.0), FuzzyNumber.crisp(1.0)) == 1.0
    assert intersection_height(FuzzyNumber.crisp(1.0), FuzzyNumber.crisp(2.0)) == 0.0
    rng = np.random.default_rng(1)
    grid = np.linspace(-1, 12, 130001)
    for _ in range(50):
        xs = [FuzzyNumber(*np.sort(rng.uniform(0, 10, 4))) for _ in range(2)]
        numeric = np.max(np.minimum(xs[0].membership(grid), xs[1].membership(grid)))
        assert intersection_height(*xs) == pytest.approx(numeric, abs=1e-3)


def test_sampled_sets_height_normalization_rankings_and_triangular_approximation():
    x = T(0, 2, 4)
    grid = np.linspace(0, 4, 401)
    s = SampledFuzzySet.from_number(x, grid)
    assert s.height() == pytest.approx(1.0) and s.area == pytest.approx(2.0, abs=1e-4)
    assert s.L(1.0) == pytest.approx(0.125, abs=1e-4) and s.G(3.0) == pytest.approx(0.125, abs=1e-4)
    assert s.alpha_cut(0.5) == pytest.approx((1.0, 3.0), abs=0.01)
    # eq. (7.4)-(7.6) by hand: x cut by L(crisp 3, t) keeps [3, 4], height mu(3) = 1/2
    tilde = SampledFuzzySet(grid, np.where(grid >= 3, x.membership(grid), 0.0))
    assert tilde.height() == pytest.approx(0.5)
    bar = tilde.normalized()
    assert bar.height() == pytest.approx(1.0) and bar.membership(3.5) == pytest.approx(0.5)
    # eq. (7.10) on the set of [3, 4] falling from 1 to 0: <3, 3, 4> (A_M where membership is 1)
    tri = SampledFuzzySet(np.linspace(3, 4, 11), np.linspace(1, 0, 11)).to_triangular()
    assert (tri.a, tri.b, tri.d) == pytest.approx((3.0, 3.0, 4.0))
    # a plateau: A_M is the middle of the points of maximal membership
    plateau = SampledFuzzySet(np.array([0.0, 1.0, 3.0, 4.0]), np.array([0.0, 0.6, 0.6, 0.0]))
    assert plateau.to_triangular() == T(0, 2, 4)
    with pytest.raises(ValueError, match="empty"):
        SampledFuzzySet(grid, np.zeros_like(grid)).normalized()
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        SampledFuzzySet(grid, np.full_like(grid, 1.5))


def test_intersection_eq_d3_d4_is_the_pointwise_min():
    a = SampledFuzzySet.from_number(T(0, 2, 4), np.linspace(0, 4, 41))
    b = SampledFuzzySet.from_number(T(2, 4, 6), np.linspace(2, 6, 41))
    both = intersection(a, b)
    assert both.height() == pytest.approx(0.5, abs=1e-9)  # at t = 3
    assert both.membership(2.5) == pytest.approx(0.25) and both.membership(1.0) == 0.0
    with pytest.raises(ValueError):
        intersection()


def test_trapezoid_from_support_eq_7_21_7_22():
    assert trapezoid_from_support(2.0, 4.0, 0.01) == FuzzyNumber(2.0, 2.01, 3.99, 4.0)
    assert trapezoid_from_support(2.0, 2.01, 0.01) == FuzzyNumber(2.0, 2.005, 2.005, 2.01)
    assert trapezoid_from_support(3.0, 3.0, 0.01).is_crisp
    with pytest.raises(ValueError, match="eps"):
        trapezoid_from_support(0.0, 1.0, 0.0)
