"""The posture of lowest effective mass (issue 52, ISO/TS 15066 Annex A), by hand on a two-link arm."""

from __future__ import annotations

import numpy as np
import pytest

from hrc_drake.robots.ik import lowest_mass_posture
from tests.safety.arms import two_link_arm

L1, L2, M1, M2 = 1.0, 0.8, 2.0, 1.5


def hand_mass(q1: float, q2: float, u) -> float:
    """m_R = (u^T J M^-1 J^T u)^-1 at the tip of the planar arm with point masses m1 at the elbow and
    m2 at the tip, written out: J the tip's Jacobian, M = m1 J_e^T J_e + m2 J^T J (J_e the elbow's)."""
    s1, c1, s12, c12 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2)
    tip = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12]])
    elbow = np.array([[-L1 * s1, 0.0], [L1 * c1, 0.0]])
    mass = M1 * elbow.T @ elbow + M2 * tip.T @ tip
    u = np.asarray(u, dtype=float)[:2]
    return 1.0 / float(u @ tip @ np.linalg.inv(mass) @ tip.T @ u)


def elbow_postures(x: float, y: float):
    """The elbow-down and elbow-up joint angles that put the tip at (x, y)."""
    c2 = (x * x + y * y - L1 * L1 - L2 * L2) / (2 * L1 * L2)
    out = []
    for q2 in (np.arccos(c2), -np.arccos(c2)):
        q1 = np.arctan2(y, x) - np.arctan2(L2 * np.sin(q2), L1 + L2 * np.cos(q2))
        out.append((q1, q2))
    return out


def test_the_posture_of_lowest_effective_mass_along_the_approach_matches_the_hand_computation():
    """The tip at (1.2, 0.9) or (1.5, 0.3) in its two postures (elbow down, up): approached along +x,
    +y or (0.6, -0.8) they differ in m_R (the inertia the contact meets: 1.56 against 3.84 kg along
    +x at (1.2, 0.9)), and the lighter one is chosen. (Along the normal to the line from the
    shoulder to the tip the two mirror postures weigh the same.)"""
    plant, _ = two_link_arm(L1, L2, M1, M2)
    tip = plant.GetFrameByName("tip")
    for target, u in (((1.2, 0.9), (1.0, 0.0, 0.0)), ((1.2, 0.9), (0.0, 1.0, 0.0)),
                      ((1.5, 0.3), (0.6, -0.8, 0.0))):
        postures = elbow_postures(*target)
        expected = np.array([hand_mass(q1, q2, u) for q1, q2 in postures])
        assert abs(expected[0] - expected[1]) > 0.05 * expected.min()  # the choice matters
        index, masses = lowest_mass_posture(plant, tip, np.array(postures), u)
        np.testing.assert_allclose(masses, expected, rtol=1e-9)
        assert index == int(np.argmin(expected))
    # the direction's length does not matter; a zero one is refused
    postures = elbow_postures(1.2, 0.9)
    index, masses = lowest_mass_posture(plant, tip, np.array(postures), (3.0, 0.0, 0.0))
    np.testing.assert_allclose(masses, [hand_mass(q1, q2, (1, 0)) for q1, q2 in postures], rtol=1e-9)
    with pytest.raises(ValueError, match="zero"):
        lowest_mass_posture(plant, tip, np.array(postures), (0.0, 0.0, 0.0))
