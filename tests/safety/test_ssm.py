"""S_p of ISO/TS 15066 eq. (1)-(2) and its closed-form permissible speed, on hand-worked numbers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hrc_drake.safety.ssm import (
    SeparationParameters,
    human_approach,
    path_stop,
    permissible_speed,
    protective_separation,
)

PARAMS = SeparationParameters(reaction_time=0.1, deceleration=5.0, intrusion=0.05, robot_uncertainty=0.01)


def test_iso13855_human_speed():
    assert human_approach(0.2) == pytest.approx(0.4)  # 2.0 m/s while <= 0.5 m
    assert human_approach(0.3) == pytest.approx(0.5)  # 1.6 x 0.3 = 0.48 < 0.5: at least 0.5 m
    assert human_approach(0.5) == pytest.approx(0.8)  # 1.6 m/s beyond
    assert human_approach(0.3, human_speed=1.0) == pytest.approx(0.3)


def test_separation_on_hand_worked_numbers():
    # v_r = 1 m/s: T_s = 0.2 s, S_s = 0.1 m, S_r = 0.1 m, S_h = max(1.6 x 0.3, 0.5) = 0.5 m
    assert protective_separation(1.0, PARAMS, z_d=0.03) == pytest.approx(0.5 + 0.1 + 0.1 + 0.05 + 0.03 + 0.01)
    # v_r = 0.5 m/s: T_s = 0.1 s, S_s = 0.025 m, S_r = 0.05 m, S_h = 2.0 x 0.2 = 0.4 m
    assert protective_separation(0.5, PARAMS, z_d=0.03) == pytest.approx(0.4 + 0.05 + 0.025 + 0.09)
    # a fixed v_h = 1.6 m/s
    fixed = SeparationParameters(human_speed=1.6)
    assert protective_separation(1.0, fixed, z_d=0.03) == pytest.approx(0.48 + 0.1 + 0.1 + 0.09)
    # swept volumes over 0.3 s cover S_h while T_r + T_s <= 0.3 s
    assert protective_separation(1.0, PARAMS, 0.03, covered_time=0.3) == pytest.approx(0.1 + 0.1 + 0.09)


def test_permissible_speed_inverts_the_separation():
    assert permissible_speed(0.565, PARAMS, 0.03) == pytest.approx(0.5)
    assert permissible_speed(0.79, PARAMS, 0.03) == pytest.approx(1.0)
    # a stopped robot needs S_p(0) = 2.0 x 0.1 + 0.09 = 0.29 m: nearer, a protective stop
    assert permissible_speed(0.289, PARAMS, 0.03) == 0.0
    assert permissible_speed(0.291, PARAMS, 0.03) > 0.0


@given(st.floats(0.0, 3.0), st.floats(0.0, 0.3), st.floats(0.02, 0.4), st.floats(0.5, 20.0),
       st.sampled_from([0.0, 1.0, 1.6, 2.5]), st.sampled_from([0.0, 0.2, 0.5]))
def test_permissible_speed_is_the_root_of_the_separation(speed, z_d, t_r, a, v_h, covered):
    params = SeparationParameters(reaction_time=t_r, deceleration=a, human_speed=v_h)
    d = protective_separation(speed, params, z_d, covered)
    assert permissible_speed(d, params, z_d, covered) == pytest.approx(speed, abs=1e-6)
    assert permissible_speed(d - 1e-3, params, z_d, covered) < speed + 1e-9


def test_vectorised():
    d = np.array([0.1, 0.565, 0.79])
    assert np.allclose(permissible_speed(d, PARAMS, 0.03), [0.0, 0.5, 1.0])


def test_the_controllers_s_p_takes_the_stop_it_makes_on_the_paths_fastest_point():
    # a face pair approaching at 0.2 m/s on a path whose fastest point runs 1.5 m/s: the controller
    # brakes the path at 5 m/s^2 on that point, so T_s = 1.5 / 5 = 0.3 s (not 0.2 / 5 = 0.04 s) and
    # the pair's point travels 0.2 x 1.5 / 10 = 0.03 m. S_h = 1.6 x 0.4 = 0.64 (2.0 x 0.4 > 0.5),
    # S_r = 0.02, C + Z_d + Z_r = 0.05 + 0.03 + 0.01: S_p = 0.78 m (the per-pair stop gave 0.338 m)
    face = SeparationParameters(reaction_time=0.1, deceleration=5.0, intrusion=0.05, robot_uncertainty=0.01,
                                human_speed=1.6)  # head and torso: the whole body's 1.6 m/s
    stop = path_stop(face, 0.2, 1.5)
    assert stop.deceleration == pytest.approx(5.0 * 0.2 / 1.5)
    assert protective_separation(0.2, stop, z_d=0.03) == pytest.approx(0.78, abs=1e-12)
    # per pair (T_s = 0.04 s): 1.6 x 0.14 + 0.02 + 0.004 + 0.09 = 0.338 m
    assert protective_separation(0.2, face, z_d=0.03) == pytest.approx(0.338, abs=1e-12)
    # the permissible speed at that separation is the pair's 0.2 m/s, and so the override is
    assert permissible_speed(0.78, stop, 0.03) == pytest.approx(0.2, abs=1e-9)
    # the path's fastest point itself stops at a: no change
    assert path_stop(PARAMS, 1.5, 1.5) is PARAMS and path_stop(PARAMS, 0.0, 1.5) is PARAMS


def test_separation_parameters_cannot_change_under_the_rules_that_share_them():
    # SafetyRules hands one SeparationParameters to the compiled kernels and derives the body's
    # from it with dataclasses.replace: a change in place would move both
    import dataclasses

    params = SeparationParameters()
    with pytest.raises(dataclasses.FrozenInstanceError):
        params.reaction_time = 0.0


@pytest.mark.parametrize("field, value", [("deceleration", 0.0), ("deceleration", np.inf),
                                          ("deceleration", -5.0), ("reaction_time", -0.1),
                                          ("human_speed", np.inf), ("intrusion", np.nan)])
def test_separation_parameters_at_and_past_the_edge_are_refused(field, value):
    with pytest.raises(ValueError, match=f"SeparationParameters.{field}"):
        SeparationParameters(**{field: value})
    assert SeparationParameters(reaction_time=0.0, human_speed=0.0).reaction_time == 0.0
