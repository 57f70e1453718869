"""A trapezoid's membership stays finite and warning-free for edges of any width (issue 40: the
suite printed "overflow encountered in divide" for a subnormal rising edge)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hrc_drake.scheduling.fuzzy import FuzzyNumber


@pytest.mark.parametrize("corners, x, expected", [
    # a rising edge of one subnormal step: far points were (x - a) / (b - a) = inf before the clip
    ((-5e-324, 0.0, 0.0, 1.0), [-1e300, -5e-324, 0.0, 0.5, 1.0, 1e300], [0.0, 0.0, 1.0, 0.5, 0.0, 0.0]),
    # a falling edge 1e-310 wide
    ((-1.0, 0.0, 0.0, 1e-310), [-1e300, -0.5, 0.0, 5e-311, 1e-310, 1.0, 1e300],
     [0.0, 0.5, 1.0, 0.5, 0.0, 0.0, 0.0]),
])
def test_membership_of_a_subnormal_edge_is_exact_and_does_not_overflow(corners, x, expected):
    number = FuzzyNumber(*corners)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow would raise here
        mu = number.membership(np.array(x))
    np.testing.assert_allclose(mu, expected, atol=1e-12)


def test_membership_is_the_trapezoid_of_eq_d5():
    x = FuzzyNumber(1.0, 2.0, 4.0, 8.0)
    np.testing.assert_allclose(x.membership([0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 9.0]),
                               [0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 0.5, 0.0, 0.0])
