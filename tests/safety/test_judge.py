"""The ISO/TS 15066 judge (`safety.judge`, `safety.verdict`), attacked class by class.

Every expected value is worked by hand from the standard's numbers, not from the judge's own
functions: ISO 13855 speeds (hands and arms 2.0 m/s while S_h <= 0.5 m, else 1.6 m/s and >= 0.5
m; head and torso 1.6 m/s), Table A.2/A.3 rows (hand: F 140 N, p 190 N/cm^2 on the back of the
non-dominant hand, k 75 N/mm, m_H 0.6 kg; transient x 2), m_R = max(plant, M/2) + m_L with the
YuMi arm's M = 6.34 kg, so M/2 = 3.17 kg.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hrc_drake.safety.config import Hybrid, NoSafety, PowerForceLimiting, SpeedSeparationMonitoring
from hrc_drake.safety.judge import (
    Judge,
    JudgeRun,
    declared_mode,
    deviations,
    protective_separation,
    standard_values,
)
from hrc_drake.safety.limits import BODY_REGIONS, parse_limits
from hrc_drake.safety.regions import FixedBox
from hrc_drake.safety.verdict import summarize

RATE = 30.0
DT = 1.0 / RATE
VALUES = standard_values(reaction_time=0.1, deceleration=5.0)
ARM_MASS = 6.34  # M of a YuMi arm: M/2 = 3.17 kg
HAND_RADIUS = 0.04
TOOL_RADIUS = 0.03
# the hand's peak-force factor sqrt(mu k) at m_R = 3.17 kg: mu = (1/0.6 + 1/3.17)^-1 = 0.504469 kg,
# sqrt(0.504469 * 75000) = 194.514 N s/m
HAND_FACTOR = 194.514


def plant_mass(k, points, u):
    """A light plant (as the URDF without drives): the judge must take the standard's M/2."""
    return np.full(len(np.atleast_1d(k)), 0.2)


def judge(
    config,
    links=("yumi/gripper_r_base",),
    masses=(ARM_MASS,),
    payloads=None,
    boxes=(),
    values=VALUES,
    region=("right_hand", "hand_fingers"),
    zones=None,
):
    return Judge(
        values, declared_mode(config, zones), links, (region[0],), (region[1],), masses, payloads, boxes
    )


def sphere(x, radius=TOOL_RADIUS, y=0.0, z=1.0):
    point = np.array([[x, y, z]], dtype=float)
    return point, point.copy(), np.array([radius])


def hand_at(x=0.0, y=0.0, z=1.0, radius=HAND_RADIUS):
    """A hand region: a short capsule along z at (x, y)."""
    return (np.array([[x, y, z - 0.03]]), np.array([[x, y, z + 0.03]]), np.array([radius]))


def run_path(j, robot_x, hand_x=None, stop=None, measured=None, extra_robot=None, times=None):
    """Step the judge along robot positions `robot_x` (one per 1/30 s sample); the hand at
    `hand_x` (a number or one per sample); extra_robot: more capsules (start, end, radius)."""
    run = JudgeRun()
    n = len(robot_x)
    hands = np.broadcast_to(np.asarray(0.0 if hand_x is None else hand_x, dtype=float), (n,))
    for i, x in enumerate(robot_x):
        robot = sphere(x)
        if extra_robot is not None:
            robot = tuple(np.concatenate([a, b]) for a, b in zip(robot, extra_robot, strict=True))
        time = (i * DT) if times is None else times[i]
        run = j.step(
            run,
            time,
            robot,
            hand_at(hands[i]),
            plant_mass,
            None if stop is None else bool(stop[i]),
            None if measured is None else measured[i],
        )
    return run


def figures(j, run, mode="pfl", departures=()):
    return summarize(j, run, mode=mode, duration=run.last_time, departures=departures)


# -- S_p: eq. (1)-(2) on the truth, with the stop the controller makes ----------------------------


def test_protective_separation_by_hand():
    # v = V = 0.06 m/s: T_s = 0.012 s, S_h = 2.0 (0.1 + 0.012) = 0.224, S_r = 0.006, S_s = 0.00036
    assert protective_separation(0.06, 0.06, False, VALUES) == pytest.approx(0.23036, abs=1e-9)
    # head and torso at 1.6 m/s: 1.6 x 0.112 = 0.1792
    assert protective_separation(0.06, 0.06, True, VALUES) == pytest.approx(0.1792 + 0.00636, abs=1e-9)
    # v = 0.5 m/s on a path whose fastest point runs 1.5 m/s: T_s = 1.5 / 5 = 0.3 s (not 0.1 s),
    # S_h: 2.0 x 0.4 = 0.8 > 0.5, so 1.6 x 0.4 = 0.64; S_r = 0.05; S_s = 0.5 x 1.5 / 10 = 0.075
    assert protective_separation(0.5, 1.5, False, VALUES) == pytest.approx(0.765, abs=1e-9)
    # ISO 13855's floor: beyond 0.5 m of a reach S_h is at least 0.5 m (T = 0.27 s: 2.0 T = 0.54)
    assert protective_separation(0.85, 0.85, False, VALUES) == pytest.approx(
        0.5 + 0.085 + 0.85 * 0.85 / 10, abs=1e-9
    )


# -- SSM breaches -----------------------------------------------------------------------------


@pytest.mark.parametrize("speed", [0.06, 0.3, 0.002])
def test_a_robot_creeping_toward_a_hand_and_stopping_1_cm_short_breaches(speed):
    # SSM: from 0.5 m clearance toward the hand at `speed`, then at rest 1 cm short
    stop_x = HAND_RADIUS + TOOL_RADIUS + 0.01
    start = stop_x + 0.3
    steps = int(math.ceil((start - stop_x) / (speed * DT)))
    xs = [max(start - speed * DT * i, stop_x) for i in range(steps + 1)] + [stop_x] * 30
    j = judge(SpeedSeparationMonitoring())
    run = run_path(j, xs)
    out = figures(j, run, "ssm")
    assert out["violations"]["ssm_breach"] == 1 and out["violations_total"] == 1
    breach = out["events"][0]
    assert breach["kind"] == "ssm_breach" and breach["region"] == "hand_fingers"
    # inside from the sample the clearance fell under S_p(speed) until the robot stopped
    sp = 0.1 * 2.0 + speed * 0.1 + speed * speed / 10 + 2.0 * speed / 5.0  # S_h(T_r + v/a) + S_r + S_s
    clearance = [x - stop_x + 0.01 for x in xs]
    inside = [i for i in range(1, steps + 1) if clearance[i] < sp]
    assert breach["onset"] == pytest.approx(inside[0] * DT, abs=1e-4)
    assert out["ssm_breach_s"] == pytest.approx(len(inside) * DT, abs=1e-3)
    # the deepest unexcused breach: the last approaching sample, 1 cm short at `speed`
    assert out["violation_margin_m"] == pytest.approx(0.01 - sp, abs=2e-4)
    # events and margins carry 0.1 mm and 0.1 ms: stable JSON, comparable across runs
    assert all(breach[name] == round(breach[name], 4) for name in ("onset", "duration", "worst"))
    assert out["margin_m"] == round(out["margin_m"], 4)
    assert out["verdict_code"] == "unsafe" and out["verdict"].startswith("UNSAFE: ISO/TS 15066 ssm")
    assert "1 violation (1 SSM breach" in out["verdict"]


def test_a_robot_below_the_numerical_tolerance_is_not_approaching():
    xs = [0.2 - 0.0005 * DT * i for i in range(60)]  # 0.5 mm/s: numerically at rest
    j = judge(SpeedSeparationMonitoring())
    out = figures(j, run_path(j, xs), "ssm")
    assert out["violations_total"] == 0 and out["verdict_code"] == "safe"
    assert (
        out["verdict"]
        == f"SAFE: ISO/TS 15066 ssm, conforming judge, 0 violations in {run_path(j, xs).last_time:.2f} s"
    )


def test_a_robot_moving_away_inside_s_p_is_no_breach():
    xs = [0.1 + 0.5 * DT * i for i in range(30)]
    j = judge(SpeedSeparationMonitoring())
    assert figures(j, run_path(j, xs), "ssm")["violations_total"] == 0


def _stopping_path(stop_delay_samples, deceleration=5.0):
    """The robot at 1.0 m/s toward the hand; S_p(1, 1) = 1.6 x 0.3 -> the 0.5 m floor, + 0.1 +
    0.1 = 0.7 m. From the sample it comes inside, a stop is commanded after `stop_delay_samples`
    and brakes at `deceleration`."""
    xs, x, v = [], 1.2, 1.0
    commanded, stop_at = [], None
    for i in range(90):
        if x - HAND_RADIUS - TOOL_RADIUS < 0.7 and stop_at is None:
            stop_at = i + stop_delay_samples
        if stop_at is not None and i + 1 >= stop_at:  # the motion seen from the command's sample on
            v = max(v - deceleration * DT, 0.0)
        commanded.append(stop_at is not None and i >= stop_at)
        xs.append(x)
        x -= v * DT
    return xs, commanded


def test_a_timely_protective_stop_excuses_the_breach_and_a_late_one_does_not():
    j = judge(SpeedSeparationMonitoring())
    xs, stop = _stopping_path(2)  # commanded 2 samples (0.067 s) after the breach: within T_r = 0.1 s
    out = figures(j, run_path(j, xs, stop=stop), "ssm")
    assert out["violations_total"] == 0, out["events"]
    assert out["stops_measured"] == 1 and 0.0 < out["stop_ratio_worst"] <= 1.0
    late_xs, late_stop = _stopping_path(6)  # 0.2 s after the breach: later than T_r
    out = figures(j, run_path(j, late_xs, stop=late_stop), "ssm")
    assert out["violations"]["ssm_breach"] == 1
    # the late stop excuses nothing: the 6 samples before it and its braking while still inside
    # the shrinking S_p count (3 samples of braking)
    assert out["ssm_breach_s"] == pytest.approx(9 * DT, abs=1e-3)


def test_a_timely_stop_that_brakes_too_slowly_excuses_no_more_than_s_p_assumed():
    j = judge(SpeedSeparationMonitoring())
    xs, stop = _stopping_path(0, deceleration=1.0)  # 1 s to stop where S_p took T_r + 0.2 s
    out = figures(j, run_path(j, xs, stop=stop), "ssm")
    assert out["violations"]["stop"] == 1 and out["violations"]["ssm_breach"] == 1
    assert out["stop_ratio_worst"] > 1.5


def test_a_breach_that_ends_without_a_protective_stop_counts_even_within_t_r():
    # inside S_p (0.7 m at 1 m/s) for 3 samples, 0.067 s from the first (< T_r), then away: no stop
    xs = [0.30, 0.30 - 1.0 * DT, 0.30 - 2.0 * DT, 0.30 - 3.0 * DT, 0.30, 0.40, 0.50]
    j = judge(SpeedSeparationMonitoring())
    out = figures(j, run_path(j, xs), "ssm")
    assert out["violations"]["ssm_breach"] == 1
    assert out["ssm_breach_s"] == pytest.approx(3 * DT, abs=1e-3)


def test_a_stop_slower_than_s_p_assumed_is_a_violation():
    # commanded at 1.0 m/s, braking at 2 m/s^2. After the command S_p took the follower's period P
    # and the brake at 5 m/s^2: P + V/a = 0.233 s, V P + V^2/(2a) = 0.133 m, the speed V - a (t - P).
    # 8 samples after the command a 5 m/s^2 stop is over, but the robot still runs 1 - 7 x 2/30 =
    # 0.533 m/s: 53x the 1 cm/s allowed
    xs, x, v, stop = [], 5.0, 1.0, []
    for i in range(60):
        stop.append(i >= 5)
        xs.append(x)
        if i >= 4:  # the motion seen from the command's sample (5) on brakes
            v = max(v - 2.0 * DT, 0.0)
        x -= v * DT
    j = judge(SpeedSeparationMonitoring())
    out = figures(j, run_path(j, xs, stop=stop), "ssm")
    assert out["violations"]["stop"] == 1
    assert out["stop_ratio_worst"] == pytest.approx((1 - 7 * 2 / 30) / 0.01, rel=1e-3)
    assert out["stop_ratio_worst"] == round(out["stop_ratio_worst"], 4)  # 4 decimals, as every figure
    assert "the speed braking at a allows" in out["events"][0]["detail"]
    # the same stop at the robot's 5 m/s^2 is within what S_p assumed
    xs, x, v = [], 5.0, 1.0
    for i in range(60):
        xs.append(x)
        if i >= 4:
            v = max(v - 5.0 * DT, 0.0)
        x -= v * DT
    out = figures(j, run_path(j, xs, stop=stop), "ssm")
    # from the sample after the command's: 1 - m/6 m/s, 0.0833 m of the 0.1338 m allowed; the
    # largest share of the speed braking allows is the first, 0.833 m/s of 1 + 0.01 m/s
    assert out["violations"]["stop"] == 0
    assert out["stop_ratio_worst"] == pytest.approx((5 / 6) / 1.01, rel=1e-3)


# -- contacts ---------------------------------------------------------------------------------


def _touch_then(speed_before, speed_after, samples_after=3, config=None, hand_speed=0.0):
    touch = HAND_RADIUS + TOOL_RADIUS
    xs = [touch + 0.02 - speed_before * DT * i for i in range(int(0.02 / (speed_before * DT)) + 2)]
    x = xs[-1]
    for _ in range(samples_after):
        x -= speed_after * DT
        xs.append(x)
    hands = [0.0] * len(xs)
    if hand_speed:
        hands = [
            0.0 if i < len(xs) - samples_after else hand_speed * DT * (i - len(xs) + samples_after + 1)
            for i in range(len(xs))
        ]
    j = judge(config or PowerForceLimiting())
    return j, figures(j, run_path(j, xs, hand_x=hands))


def test_a_slow_touch_then_a_fast_push_is_judged_while_it_lasts():
    # 2.0 m/s into a free hand: F = 2.0 x 194.514 = 389.0 N against the transient 280 N: 1.389
    j, out = _touch_then(0.04, 2.0)
    assert out["violations"]["pfl_contact"] == 1
    assert out["worst_ratio"]["hand_fingers"] == pytest.approx(389.03 / 280.0, rel=2e-3)
    assert out["contact_violation_s"] == pytest.approx(out["events"][0]["duration"], abs=1e-3)
    assert out["contact_violation_s"] > 0
    assert out["violation_margin_m"] is None  # no SSM breach
    assert "transient limit" in out["events"][0]["detail"]


def test_a_push_within_the_transient_limit_is_no_violation():
    # 1.0 m/s: 194.5 N, 0.695 of the transient limit (1.39 of the quasi-static: not yet 0.5 s)
    j, out = _touch_then(0.04, 1.0, samples_after=2)
    assert out["violations_total"] == 0
    assert out["worst_ratio"]["hand_fingers"] == pytest.approx(194.514 / 280.0, rel=2e-3)


def test_the_persons_own_speed_counts_in_the_relative_speed():
    # the robot at 1.0 m/s and the hand at 1.0 m/s toward it: v_rel 2.0 m/s, 1.389
    j, out = _touch_then(0.04, 1.0, samples_after=1, hand_speed=1.0)
    assert out["violations"]["pfl_contact"] == 1
    assert out["worst_ratio"]["hand_fingers"] == pytest.approx(389.03 / 280.0, rel=5e-3)


def test_a_contact_turns_quasi_static_after_the_transient_duration():
    j = judge(PowerForceLimiting())
    first = j.judge_contact(None, 0.0, DT, (0, 0), True, 1.0, 0.0, 0.001, 3.17, "")
    assert not first.violation and first.limit == "transient"
    assert first.ratio == pytest.approx(HAND_FACTOR / 280.0, rel=1e-4)
    later = j.judge_contact(first, 0.6, DT, (0, 0), True, 1.0, 0.0, 0.002, 3.17, "")
    assert later.violation and later.limit == "quasi-static"
    assert later.ratio == pytest.approx(HAND_FACTOR / 140.0, rel=1e-4)


def test_the_payload_counts_in_the_robot_mass():
    # m_R = 3.17 + 1.0 = 4.17 kg: mu = 0.524531, sqrt(mu 75000) = 198.34; at 1.42 m/s 281.6 N > 280 N
    # (without the payload 276.2 N: within the limit)
    light = judge(PowerForceLimiting())
    heavy = judge(PowerForceLimiting(), payloads=[1.0])
    assert heavy.robot_mass(0, np.zeros(3), np.array([1.0, 0, 0]), plant_mass) == pytest.approx(4.17)
    assert light.robot_mass(0, np.zeros(3), np.array([1.0, 0, 0]), plant_mass) == pytest.approx(3.17)
    assert not light.judge_contact(None, 0.0, DT, (0, 0), True, 1.42, 0.0, 0.001, 3.17, "").violation
    pushed = heavy.judge_contact(None, 0.0, DT, (0, 0), True, 1.42, 0.0, 0.001, 4.17, "")
    assert pushed.violation and pushed.ratio == pytest.approx(1.42 * 198.34 / 280.0, rel=1e-3)


def test_the_plant_mass_counts_where_it_is_heavier_than_the_standards():
    j = judge(PowerForceLimiting())
    assert j.robot_mass(0, np.zeros(3), np.array([1.0, 0, 0]), lambda k, p, u: np.array([9.0])) == 9.0


def test_creeping_into_the_face_is_a_violation_at_any_speed():
    j, out = _touch_then(
        0.045,
        0.045,
        samples_after=30,
        config=Hybrid(),
    )  # face: SSM in every mode
    j = Judge(
        VALUES,
        declared_mode(Hybrid(), (np.zeros((1, 3)), np.array([5.0]))),
        ("link",),
        ("face",),
        ("face",),
        (ARM_MASS,),
    )
    touch = HAND_RADIUS + TOOL_RADIUS
    xs = [touch + 0.01 - 0.045 * DT * i for i in range(80)]
    out = figures(j, run_path(j, xs), "hybrid")
    assert out["violations"]["ssm_contact"] == 1 and out["violations"]["ssm_breach"] == 1
    assert out["worst_ratio"]["face"] is None  # no contact permitted with the face at all
    assert "touch where SSM governs (face)" in out["verdict"]


def test_a_person_walking_into_a_resting_robot_is_logged_not_held_against_it():
    touch = HAND_RADIUS + TOOL_RADIUS
    hands = [-0.05 + 1.5 * DT * i for i in range(12)]  # the hand at 1.5 m/s into the robot
    xs = [touch + 0.06] * len(hands)
    for config, mode in ((PowerForceLimiting(), "pfl"), (SpeedSeparationMonitoring(), "ssm")):
        j = judge(config)
        out = figures(j, run_path(j, xs, hand_x=hands), mode)
        assert out["violations_total"] == 0 and out["contact_count"] == 1
        assert out["contacts"][0]["kind"] == "contact"


def _clamp(extra_robot, boxes=()):
    # the hand between the gripper (pushing +x... toward -x) and a rigid body behind it at -x
    touch = HAND_RADIUS + TOOL_RADIUS
    xs = [touch + 0.01 - 0.2 * DT * i for i in range(6)]
    j = Judge(
        VALUES,
        declared_mode(PowerForceLimiting()),
        ("yumi/gripper_r_base", "other"),
        ("right_hand",),
        ("hand_fingers",),
        (ARM_MASS, ARM_MASS),
        None,
        boxes,
    )
    return figures(j, run_path(j, xs, extra_robot=extra_robot))


def test_a_hand_pressed_against_a_cart_or_the_robots_other_arm_is_clamped():
    # 0.2 m/s into a hand with a capsule 5 mm behind it: quasi-static (140 N); after one more
    # sample the robot pressed 6.7 mm: 75 N/mm x 6.67 mm = 500 N, 3.57 of the limit
    behind = (np.array([[-0.085, -0.2, 1.0]]), np.array([[-0.085, 0.2, 1.0]]), np.array([0.04]))
    out = _clamp(behind)
    assert out["violations"]["pfl_contact"] == 1
    event = out["events"][0]
    assert "quasi-static" in event["detail"] and "clamped against other" in event["detail"]
    assert event["worst"] >= 75.0 * 0.2 * DT * 1000 / 140.0 - 1e-6


def test_a_hand_pressed_against_the_table_is_clamped_and_one_in_free_air_is_not():
    table = FixedBox((-0.3, 0.0, 1.0), (0.5, 1.0, 1.0))  # its face at x = -0.05, 1 cm behind the hand
    far = (np.array([[5.0, 5.0, 5.0]]), np.array([[5.0, 5.0, 5.0]]), np.array([0.01]))
    assert _clamp(far, (table,))["violations"]["pfl_contact"] == 1
    assert _clamp(far)["violations_total"] == 0  # 0.2 m/s free: 38.9 N, transient


# -- lost people, codes, changed judges -------------------------------------------------------


def test_a_person_unmeasured_for_10_s_is_named_in_the_verdict():
    n = int(12 * RATE)
    measured = [np.ones(8, bool) if i < RATE or i > 11 * RATE else np.zeros(8, bool) for i in range(n + 1)]
    j = judge(SpeedSeparationMonitoring())
    out = figures(j, run_path(j, [3.0] * (n + 1), measured=measured), "ssm")
    assert out["unobserved_s"] == pytest.approx(10.0, abs=2 * DT)
    assert out["unobserved_longest_s"] == pytest.approx(10.0, abs=2 * DT)
    assert out["reach_growth_m"] == pytest.approx(20.0, abs=0.2)
    assert "a body part unmeasured 10.0 s" in out["verdict"]


def test_verdict_codes():
    xs = [1.0] * 10
    j = judge(SpeedSeparationMonitoring())
    run = run_path(j, xs)
    assert figures(j, run, "ssm")["verdict_code"] == "safe"
    assert figures(j, run, "none")["verdict_code"] == "no_safety_system"
    assert figures(j, run, "none")["verdict"].startswith("NO SAFETY SYSTEM: ISO/TS 15066 not applied")
    changed = figures(
        j, run, "ssm", departures=("judge changed: reaction_time 0.01, not the standard's 0.1",)
    )
    assert changed["verdict_code"] == "non_conforming" and changed["verdict"].startswith(
        "NON-CONFORMING: ISO/TS 15066 ssm, judge changed: reaction_time 0.01"
    )
    assert changed["judge"]["conforming"] is False


def test_a_cell_without_a_safety_system_reports_what_the_judge_would_count():
    j = judge(NoSafety())
    j2, pushed = _touch_then(0.04, 2.0, config=NoSafety())
    out = figures(
        j2, run_path(j2, [HAND_RADIUS + TOOL_RADIUS + 0.02 - 0.04 * DT * i for i in range(20)]), "none"
    )
    assert j.mode.name == "pfl"
    assert pushed["violations"]["pfl_contact"] == 1 and out["verdict_code"] == "no_safety_system"


def graded_by_itself() -> dict:
    """A limits document the audit found cited as Annex A: F = 1000 N, k = 1 N/mm, m_H = 0.01 kg on
    every body region (3,168 m/s permitted for a hand)."""
    row = {
        "force": 1000,
        "transient_factor": 2,
        "spring_constant": 1,
        "effective_mass": 0.01,
        "areas": {"a": 1000},
    }
    return {"regions": {name: dict(row) for name in BODY_REGIONS}}


def test_any_change_of_the_judge_is_a_deviation():
    table = parse_limits(graded_by_itself(), "mine.yaml")
    from dataclasses import replace

    assert deviations(VALUES, standard_values(0.1, 5.0)) == ()
    changed = replace(VALUES, limits=table, reaction_time=0.0, deceleration=100.0, limb_speed=0.01)
    found = deviations(changed, VALUES)
    assert len(found) == 4 and any("limits table 'mine.yaml'" in d for d in found)
    assert any(d.startswith("reaction_time 0") for d in found)


# -- found by an adversarial review of the judge ------------------------------------------------


def test_a_free_contact_pressed_and_held_past_the_transient_duration_is_quasi_static():
    # 0.03 m/s into a free hand for 10 mm (within the transient limit: 0.03 x 194.5 = 5.8 N), then
    # held: after 0.5 s the contact is quasi-static and the robot's 10 mm are 75 N/mm x 10 mm =
    # 750 N against 140 N (5.4x)
    touch = HAND_RADIUS + TOOL_RADIUS
    xs = [touch + 0.003 - 0.03 * DT * i for i in range(int(0.013 / (0.03 * DT)) + 1)]
    xs += [xs[-1]] * 70
    j = judge(PowerForceLimiting())
    out = figures(j, run_path(j, xs))
    assert out["violations"]["pfl_contact"] == 1
    event = out["events"][0]
    assert "quasi-static" in event["detail"]
    assert event["worst"] == pytest.approx(75.0 * (touch - xs[-1]) * 1000 / 140.0, rel=0.02)


def test_a_hybrid_controller_cannot_move_the_torso_under_pfl():
    config = Hybrid(pfl_regions=["chest", "hand_fingers"])
    mode = declared_mode(config, (np.zeros((1, 3)), np.array([10.0])))
    assert mode.pfl_regions == frozenset({"hand_fingers"})
    from hrc_drake.safety.systems import controller_departures

    assert any("chest take contact under hybrid" in d for d in controller_departures(config))


def test_a_robot_moving_again_under_the_same_stop_command_overruns():
    # commanded at sample 5 at 0.3 m/s, at rest from sample 8, then moves again at 0.3 m/s
    xs, x = [], 2.0
    for i in range(40):
        xs.append(x)
        x -= (0.3 if i < 7 or i >= 12 else 0.0) * DT
    stop = [i >= 5 for i in range(40)]
    j = judge(SpeedSeparationMonitoring())
    out = figures(j, run_path(j, xs, stop=stop), "ssm")
    assert out["violations"]["stop"] == 1 and out["stop_ratio_worst"] == pytest.approx(0.3 / 0.01, rel=1e-3)


def test_a_robot_sliding_along_a_face_touches_it_at_any_speed():
    # a long link sliding along its axis (no approach along the normal) at 0.5 m/s, the face on it
    j = Judge(
        VALUES, declared_mode(SpeedSeparationMonitoring()), ("link",), ("face",), ("face",), (ARM_MASS,)
    )
    run = JudgeRun()
    for i in range(10):
        y = -0.5 + 0.5 * DT * i
        robot = (np.array([[0.0, y - 0.5, 1.0]]), np.array([[0.0, y + 0.5, 1.0]]), np.array([0.03]))
        run = j.step(run, i * DT, robot, hand_at(0.06), plant_mass)
    out = figures(j, run, "ssm")
    assert out["violations"]["ssm_contact"] == 1


def test_a_hand_on_the_table_pushed_down_and_aside_is_clamped():
    # the hand lies on the table (its top at z = 0.96); the gripper pushes it at 30 degrees below
    # the horizontal: the ball moved 2 cm along the push reaches into the table
    table = FixedBox((0.0, 0.0, 0.71), (1.0, 1.0, 0.5))
    hand = (np.array([[0.0, -0.03, 1.0]]), np.array([[0.0, 0.03, 1.0]]), np.array([HAND_RADIUS]))
    j = judge(PowerForceLimiting(), boxes=(table,))
    down = np.array([math.cos(math.radians(30)), 0.0, -math.sin(math.radians(30))])
    assert (
        j.clamped_against(0, HAND_RADIUS, hand[0][0] + [0, 0.03, 0], down, sphere(-1.0)) == "a fixed surface"
    )
    flat = np.array([1.0, 0.0, 0.0])  # along the table: it slides, not clamped
    assert j.clamped_against(0, HAND_RADIUS, hand[0][0] + [0, 0.03, 0], flat, sphere(-1.0)) == ""


def test_a_clamped_hand_pressed_to_exactly_its_quasi_static_limit_is_within_it():
    # Table A.2/A.3, hand and fingers: F_qs 140 N, k 75 N/mm. Pressed 140 / 75000 m against the
    # table in one sample: k x depth = 140 N exactly, the limit itself (a violation is "over" it);
    # a depth one float step deeper is over it. dt = 1/32 s keeps approach x dt exact.
    j = judge(PowerForceLimiting())
    depth = 140.0 / 75000.0
    at_limit = j.judge_contact(None, 0.0, 1.0 / 32.0, (0, 0), True, depth * 32.0, 0.0, depth, 3.17, "table")
    assert at_limit.limit == "quasi-static" and at_limit.ratio == 1.0 and not at_limit.violation
    deeper = math.nextafter(depth, 1.0)
    over = j.judge_contact(None, 0.0, 1.0 / 32.0, (0, 0), True, deeper * 32.0, 0.0, deeper, 3.17, "table")
    assert over.ratio > 1.0 and over.violation


def test_the_breach_names_the_deepest_pair():
    # two robot points approach the hand from either side: A at 0.6 m/s with 0.15 m of clearance
    # at the last sample, B at 0.05 m/s with 0.10 m. The path's fastest point runs 0.6 m/s, so
    # T_s = 0.12 s and S_h = 2.0 x 0.22 = 0.44 m for both; S_p(A) = 0.44 + 0.06 + 0.036 = 0.536 m,
    # S_p(B) = 0.44 + 0.005 + 0.003 = 0.448 m: A is deeper (-0.386 against -0.348 m), though B is
    # nearer. The episode names A and its margin, whichever order the capsules come in.
    touching = HAND_RADIUS + TOOL_RADIUS
    for a_first in (True, False):
        links = ("yumi/gripper_r_base", "yumi/yumi_link_6_r")
        j = judge(SpeedSeparationMonitoring(), links=links, masses=(ARM_MASS, ARM_MASS))
        run = JudgeRun()
        for i in range(4):
            a = touching + 0.15 + 0.6 * DT * (3 - i)
            b = touching + 0.10 + 0.05 * DT * (3 - i)
            xs = (a, -b) if a_first else (-b, a)
            robot = (np.array([[x, 0.0, 1.0] for x in xs]), np.array([[x, 0.0, 1.0] for x in xs]),
                     np.full(2, TOOL_RADIUS))
            run = j.step(run, i * DT, robot, hand_at(0.0), plant_mass, None, None)
        out = figures(j, run, "ssm")
        assert out["violations"]["ssm_breach"] == 1
        event = out["events"][0]
        assert event["link"] == links[0 if a_first else 1]
        assert event["worst"] == pytest.approx(0.15 - 0.536, abs=1e-3)


def test_times_in_the_verdict_read_in_whole_seconds_from_10_s():
    from hrc_drake.safety.verdict import _seconds

    assert _seconds(0.0333) == "0.03 s"  # a one-sample breach is not "0 s"
    assert _seconds(9.994) == "9.99 s"
    assert _seconds(10.4) == "10 s" and _seconds(300.0) == "300 s"


def test_a_repeated_sample_divides_by_no_zero_interval():
    # two samples at the same time (a caller stepping twice): the robot's 1 cm between them is no
    # speed (an infinite one would be an approach inside S_p, a breach that never happened)
    j = judge(SpeedSeparationMonitoring())
    run = JudgeRun()
    for x in (0.30, 0.29):
        run = j.step(run, 0.0, sphere(x), hand_at(0.0), plant_mass, None, None)
    out = figures(j, run, "ssm")
    assert out["violations_total"] == 0 and out["margin_m"] is None


def test_a_judge_run_cannot_change_in_place():
    # the monitor keeps the runs in a cache entry it replaces: a run changed in place would change
    # what an earlier context saw
    import dataclasses

    with pytest.raises(dataclasses.FrozenInstanceError):
        JudgeRun().samples = 3


def test_the_own_model_of_swept_volumes_counts_s_h_only_beyond_their_horizon():
    from dataclasses import replace

    from hrc_drake.safety.judge import human_travel

    # swept volumes that hold the person's next H = 0.3 s: over T = 0.4 s only 0.1 s is left, at
    # ISO 13855's 2.0 m/s for a hand (0.2 m) and 1.6 m/s for the torso (0.16 m); within H, none
    own = replace(VALUES, covered_time=0.3)
    assert human_travel(0.4, np.array([False, True]), own) == pytest.approx([0.2, 0.16])
    assert human_travel(0.25, np.array([False, True]), own) == pytest.approx([0.0, 0.0])
    # the standard's judge: all of T (2.0 x 0.4 = 0.8 m is beyond 0.5 m: 1.6 x 0.4 = 0.64 m)
    assert human_travel(0.4, np.array([False, True]), VALUES) == pytest.approx([0.64, 0.64])


def test_a_hybrid_zone_away_from_the_origin_holds_only_the_contacts_inside_it():
    # a zone of 0.2 m around (1, 0, 0): a hand contact at (1.1, 0, 0) is PFL's, one at (-1, 0, 0)
    # (as far from the zone as from its mirror image) is SSM's
    mode = declared_mode(Hybrid(), (np.array([[1.0, 0.0, 0.0]]), np.array([0.2])))
    points = np.array([[1.1, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.25, 0.0]])
    assert mode.governed_by_pfl(np.array([True, True, True]), points).tolist() == [True, False, False]
    # a region that never takes contact stays SSM's inside the zone too
    assert not mode.governed_by_pfl(np.array([False]), points[:1])[0]


def _floats(value):
    if isinstance(value, float):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _floats(item)
    elif isinstance(value, (list, tuple)):
        for item in value:
            yield from _floats(item)


def test_every_figure_of_the_verdict_carries_at_most_4_decimals():
    # a hybrid cell with a zone at (0.123456, 0.654321, 1.0), a robot creeping at 0.06 m/s toward a
    # hand outside it: margins, closest approach, breach times and the zone itself to 0.1 mm
    zones = (np.array([[0.123456, 0.654321, 1.0]]), np.array([0.2345678]))
    j = judge(Hybrid(), zones=zones)
    stop_x = HAND_RADIUS + TOOL_RADIUS + 0.0123456
    xs = [stop_x + 0.3 - 0.002 * i for i in range(150)]
    out = figures(j, run_path(j, xs), "hybrid")
    assert out["violations"]["ssm_breach"] == 1 and out["closest_approach_m"] is not None
    floats = list(_floats(out))
    assert len(floats) > 10
    assert all(x == round(x, 4) for x in floats), [x for x in floats if x != round(x, 4)]
    assert out["judge"]["collaborative_zones"] == [{"center": [0.1235, 0.6543, 1.0], "radius": 0.2346}]


def test_a_breach_after_a_released_stop_counts():
    # SSM: creeping at 0.06 m/s into S_p; a protective stop is commanded at the breach's onset and
    # the robot holds still, but the stop is released after 3 samples and the robot creeps on:
    # the stop kept its model, and the breach after the release is not excused by it
    j = judge(SpeedSeparationMonitoring())
    sp = 0.1 * 2.0 + 0.06 * 0.1 + 0.06 * 0.06 / 10 + 2.0 * 0.06 / 5.0
    start = HAND_RADIUS + TOOL_RADIUS + 0.3
    onset = next(i for i in range(1, 60) if 0.3 - 0.002 * i < sp)
    xs = [start - 0.002 * min(i, onset) - 0.002 * max(0, i - onset - 3) for i in range(60)]
    stop = [onset <= i < onset + 3 for i in range(60)]
    out = figures(j, run_path(j, xs, stop=stop), "ssm")
    assert out["violations"]["ssm_breach"] == 1 and out["violations"]["stop"] == 0
    assert out["events"][0]["onset"] == pytest.approx((onset + 4) * DT, abs=1e-4)


def test_the_sternums_pressure_over_1_cm2_binds_before_the_chests_force():
    # chest, Table A.2/A.3: F_qs 140 N, sternum p_qs 120 N/cm^2, k 25 N/mm. Pressed 5.2 mm against
    # a surface: k x depth = 130 N, 0.93 of the force limit but 130 N over 1 cm^2 = 1.083 of the
    # pressure limit (ISO/TS 15066 Annex A: both must hold)
    j = judge(PowerForceLimiting(), region=("chest", "chest"))
    depth = 130.0 / 25000.0
    contact = j.judge_contact(None, 0.0, 1.0 / 32.0, (0, 0), True, depth * 32.0, 0.0, depth, 3.17, "table")
    assert contact.limit == "quasi-static" and contact.violation
    assert contact.ratio == pytest.approx(130.0 / 120.0, rel=1e-9)


@pytest.mark.parametrize("field, value", [("deceleration", 0.0), ("deceleration", -1.0),
                                          ("reaction_time", -0.01), ("reaction_time", math.nan),
                                          ("body_speed", math.inf)])
def test_judge_values_at_and_past_the_edge_are_refused(field, value):
    from dataclasses import replace

    with pytest.raises(ValueError, match=f"JudgeValues.{field}"):
        replace(VALUES, **{field: value})
    # the edge itself where it is allowed: no reaction time is a (changed) judge, not an error
    assert replace(VALUES, reaction_time=0.0).reaction_time == 0.0


def test_a_stop_that_moves_too_long_overran_by_its_time():
    from hrc_drake.safety.judge import Stop

    # 1 mm travelled where 10 mm were assumed, at a fifth of the speed braking allows, but moving
    # 0.5 s where 0.1 s + one 1/30 s sample were: 0.5 / 0.1333 = 3.75
    stop = Stop(onset=0.0, speed=0.005, assumed_time=0.1, assumed_distance=0.01, distance=0.001, time=0.5,
                speed_ratio=0.2)
    assert stop.ratio(1.0 / 30.0) == pytest.approx(0.5 / (0.1 + 1.0 / 30.0), rel=1e-6)
    assert stop.overran(1.0 / 30.0)
    # within its time (one sample's rounding included), it did not
    assert not replace_stop(stop, time=0.13).overran(1.0 / 30.0)


def replace_stop(stop, **changes):
    from dataclasses import replace

    return replace(stop, **changes)


def test_a_hybrid_mode_without_zones_gives_pfl_no_pair():
    mode = declared_mode(Hybrid(), None)
    assert not mode.governed_by_pfl(np.array([True]), np.array([[0.0, 0.0, 1.0]]))[0]
    from hrc_drake.safety.verdict import _seconds

    assert _seconds(10.0) == "10 s"  # from 10 s on, whole seconds


def test_a_safe_line_counts_its_contacts():
    """A safe run whose closest approach is below 0 m touched the person: its line says how often,
    each contact within its limit (else the run would not be safe)."""
    from hrc_drake.safety.verdict import verdict_line

    figures_ = {"violations_total": 0, "violations": {}, "unobserved_s": 0.0, "contact_count": 4}
    assert verdict_line("safe", "hybrid", figures_, 120.0) == (
        "SAFE: ISO/TS 15066 hybrid, conforming judge, 0 violations in 120 s; 4 contacts, each within "
        "its body region's limit")
    assert verdict_line("safe", "hybrid", {**figures_, "contact_count": 1}, 120.0).endswith(
        "; 1 contact, within its body region's limit")
    assert verdict_line("safe", "hybrid", {**figures_, "contact_count": 0}, 120.0) == (
        "SAFE: ISO/TS 15066 hybrid, conforming judge, 0 violations in 120 s")


def test_a_safe_line_never_calls_a_logged_contact_over_its_limit_within_it():
    """4 contacts: two at 0.40x and 0.95x of their limits, one at 1.70x where the operator's neck
    walked into a still arm (logged, not a violation; docs/search.md found such a contact at 334 N)
    and one where no contact is permitted (worst "inf"): 2 within, 2 logged."""
    from hrc_drake.safety.verdict import verdict_line

    contacts = [{"worst": 0.40}, {"worst": 0.95}, {"worst": 1.70}, {"worst": "inf"}]
    figures_ = {"violations_total": 0, "violations": {}, "unobserved_s": 0.0, "contact_count": 4,
                "contacts": contacts}
    assert verdict_line("safe", "hybrid", figures_, 120.0) == (
        "SAFE: ISO/TS 15066 hybrid, conforming judge, 0 violations in 120 s; 4 contacts: 2 within "
        "their body regions' limits, 2 over a limit but logged, not held against the robot (the person "
        "moved into a robot that was not approaching)")
    # exactly at the limit is within it
    at_limit = {**figures_, "contact_count": 1, "contacts": [{"worst": 1.0}]}
    line = verdict_line("safe", "hybrid", at_limit, 120.0)
    assert line.endswith("; 1 contact, within its body region's limit")


# -- between samples: a link may not pass through a body part unseen ----------------------------


@pytest.mark.parametrize("offset", [0.0, 0.5])
def test_a_tool_passing_through_a_hand_between_two_samples_is_judged(offset):
    """At 15 m/s the tool moves 0.5 m per 1/30 s: both samples clear of the hand, the pass between
    them a contact at 15 m/s, far beyond the hand's transient limit (140 N x 2 over sqrt(mu k) =
    194.5 N s/m: 1.44 m/s). The samples fall on either side of the hand wherever they lie."""
    step = 15.0 * DT
    xs = -0.6 + offset * step + step * np.arange(4)  # ..., -0.35 or -0.1, +0.15 or +0.4, ...
    j = judge(PowerForceLimiting())
    run = run_path(j, xs)
    assert run.min_clearance < 0.0
    report = figures(j, run)
    assert report["violations_total"] >= 1 and report["verdict_code"] == "unsafe"


def test_slow_motion_is_judged_at_the_samples_alone():
    """Below the sweep step nothing between samples is looked at: a robot at rest 1 cm from the
    hand stays 1 cm from it."""
    j = judge(PowerForceLimiting())
    run = run_path(j, np.full(10, -(HAND_RADIUS + TOOL_RADIUS + 0.01)))
    assert run.min_clearance == pytest.approx(0.01, abs=1e-9)
