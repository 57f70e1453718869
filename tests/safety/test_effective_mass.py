"""The robot's effective mass from a plant, m_R = (u^T J M^-1 J^T u)^-1, on a two-link arm."""

from __future__ import annotations

import numpy as np
import pytest

from hrc_drake.robots.models import effective_mass
from hrc_drake.safety.systems import RobotPointDynamics
from tests.safety.arms import two_link_arm, two_link_kinematics

L1, L2, M1, M2 = 1.0, 0.8, 2.0, 1.5


def hand_computed(q, u):
    """m_R at the tip (the second point mass) by the textbook formulas of a two-link arm."""
    q1, q2 = q
    s1, c1, s12, c12 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2)
    j1 = np.array([[-L1 * s1, 0.0], [L1 * c1, 0.0]])
    j2 = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12]])
    mass = M1 * j1.T @ j1 + M2 * j2.T @ j2
    ju = j2.T @ np.asarray(u)[:2]
    return 1.0 / (ju @ np.linalg.solve(mass, ju))


@pytest.mark.parametrize("q", [(0.0, 0.5), (0.3, 1.2), (-1.0, 2.0)])
@pytest.mark.parametrize("angle", [0.0, 0.7, 2.0])
def test_effective_mass_of_a_two_link_arm_matches_the_hand_computation(q, angle):
    plant, link2 = two_link_arm(L1, L2, M1, M2)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, np.array(q))
    u = np.array([np.cos(angle), np.sin(angle), 0.0])
    assert (effective_mass(plant, context, link2, [L2, 0.0, 0.0], u)
            == pytest.approx(hand_computed(q, u), rel=1e-9))


def test_stretched_arm_tangential_mass_worked_by_hand():
    # q2 = 0, unit lengths and masses: M = [[5, 2], [2, 1]], J^T u = [2, 1] along y, so
    # u^T J M^-1 J^T u = [2, 1] . [0, 1] = 1 and m_R = 1 kg
    global L1, L2, M1, M2
    saved = L1, L2, M1, M2
    L1, L2, M1, M2 = 1.0, 1.0, 1.0, 1.0
    try:
        plant, link2 = two_link_arm(L1, L2, M1, M2)
        context = plant.CreateDefaultContext()
        assert effective_mass(plant, context, link2, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) == pytest.approx(1.0)
    finally:
        L1, L2, M1, M2 = saved


def test_the_drives_reflected_inertia_counts_in_the_effective_mass():
    # unit links and masses, stretched (q2 = 0), along y at the tip: M = [[5, 2], [2, 1]] without
    # drives (m_R = 1 kg, above). Each joint's drive: rotor 5e-5 kg m^2 behind a 100:1 gear
    # reflects N^2 I_r = 0.5 kg m^2 onto its diagonal: M = [[5.5, 2], [2, 1.5]], det 4.25,
    # J^T u = [2, 1], M^-1 J^T u = [1.0, 1.5] / 4.25, u^T J M^-1 J^T u = 3.5 / 4.25: m_R = 17/14 kg
    plant, link2 = two_link_arm(1.0, 1.0, 1.0, 1.0, rotor_inertia=5e-5, gear_ratio=100.0)
    context = plant.CreateDefaultContext()
    assert effective_mass(plant, context, link2, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) == pytest.approx(17 / 14)
    kinematics = two_link_kinematics(plant, 1.0)
    dynamics = RobotPointDynamics(plant, kinematics)
    dynamics.set_state(np.zeros(2), np.zeros(2))
    dynamics.capsules()
    assert dynamics.effective_mass([0], [[2.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])[0] == pytest.approx(17 / 14)


def test_the_cached_body_form_equals_the_point_jacobian_form():
    plant, link2 = two_link_arm(L1, L2, M1, M2)
    kinematics = two_link_kinematics(plant, L2)
    dynamics = RobotPointDynamics(plant, kinematics)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-2, 2, 2)
        dynamics.set_state(q, rng.normal(size=2))
        (start, end, _), (v_start, v_end) = dynamics.capsules()
        assert np.allclose(end[0][:2], [L1 * np.cos(q[0]) + L2 * np.cos(q.sum()),
                                        L1 * np.sin(q[0]) + L2 * np.sin(q.sum())])
        u = rng.normal(size=3)
        u[2] = 0.0
        u /= np.linalg.norm(u)
        assert dynamics.effective_mass([0], end[:1], u)[0] == pytest.approx(hand_computed(q, u), rel=1e-9)
    # end-point velocities: the tip's Jacobian times v
    v = np.array([0.4, -0.9])
    dynamics.set_state(q, v)
    (_, end, _), (_, v_end) = dynamics.capsules()
    s1, c1, s12, c12 = np.sin(q[0]), np.cos(q[0]), np.sin(q.sum()), np.cos(q.sum())
    j2 = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12]])
    assert np.allclose(v_end[0][:2], j2 @ v)


def test_shared_dynamics_keep_only_what_the_state_leaves_unchanged():
    """The controller and the monitor share one `RobotPointDynamics`: what it keeps between
    `set_state` calls (capsules for the same positions, velocities for the same velocities, masses)
    equals a fresh one's, through repeated, changed and velocity-less (`v` None) states."""
    plant, _ = two_link_arm(L1, L2, M1, M2)
    kinematics = two_link_kinematics(plant, L2)
    shared = RobotPointDynamics(plant, kinematics)
    rng = np.random.default_rng(8)
    q, v = rng.uniform(-2, 2, 2), rng.normal(size=2)
    u = np.array([[0.6, 0.8, 0.0]])
    for _ in range(40):
        if rng.random() < 0.4:
            q = rng.uniform(-2, 2, 2)
        if rng.random() < 0.4:
            v = rng.normal(size=2)
        positions_only = rng.random() < 0.3
        shared.set_state(q, None if positions_only else v)
        fresh = RobotPointDynamics(plant, kinematics)
        fresh.set_state(q, v)
        got = shared.capsules(velocities=not positions_only)
        want = fresh.capsules(velocities=not positions_only)
        for x, y in zip(got[0], want[0], strict=True):
            np.testing.assert_array_equal(x, y)
        if not positions_only:
            for x, y in zip(got[1], want[1], strict=True):
                np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(shared.effective_mass([0], got[0][1][:1], u),
                                      fresh.effective_mass([0], want[0][1][:1], u))
