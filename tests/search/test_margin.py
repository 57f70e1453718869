"""metrics.json's single safety margins (`safety.margin_m`, `safety.contact_margin`): exact on a
scripted robot link driven toward the hand (the set-up of tests/safety/test_contacts.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hrc_drake.safety.config import NoSafety, PowerForceLimiting, SpeedSeparationMonitoring
from hrc_drake.safety.contacts import ContactAccountant, MonitorRun, summarize_safety
from hrc_drake.safety.rules import SafetyRules
from hrc_drake.safety.ssm import protective_separation
from tests.safety.test_contacts import CUTTER, LIMITS, ROBOT_MASS, body, robot_at


def run_down(config, speed: float, steps: int, gap: float = 0.05, hand_height: float = 1.0):
    """The robot capsule `gap` above the hand's surface moving down at `speed` for `steps` 30 Hz samples."""
    rules = SafetyRules(config, LIMITS, CUTTER.regions, (np.array([[0.0, 0.5, 1.0]]), np.array([0.5])))
    accountant = ContactAccountant(rules, LIMITS, ["link"], CUTTER.names, moving_speed=0.01)
    run = MonitorRun()
    z = hand_height + 0.05 + 0.03 + gap
    velocity = np.array([[0.0, 0.0, -speed]])
    for step in range(steps):
        run = accountant.step(
            run, step / 30.0, robot_at(z), (velocity, velocity), body(hand_height),
            lambda k, p, u: np.full(len(k), ROBOT_MASS),
        )
        z -= speed / 30.0
    return rules, summarize_safety(run, rules.mode, 0, LIMITS, LIMITS.source)


@pytest.mark.parametrize("speed", [0.1, 0.5])
def test_one_sample_margin_is_the_clearance_minus_s_p(speed):
    rules, summary = run_down(SpeedSeparationMonitoring(), speed, steps=1)
    # the hand is the nearest region, 5 cm below, the link approaching it at `speed`
    expected = 0.05 - float(protective_separation(speed, rules.separation))
    assert summary["margin_m"] == pytest.approx(expected, abs=1e-9)
    assert summary["margin_m"] < 0  # S_p at 0.1 m/s is 0.31 m
    assert summary["contact_margin"] == 1.0  # no contact yet


def test_the_margin_is_the_smallest_over_the_run_and_agrees_with_the_time_below_s_p():
    rules, early = run_down(SpeedSeparationMonitoring(), 0.3, steps=2, gap=0.8)
    first = 0.8 - float(protective_separation(0.3, rules.separation))
    second = first - 0.3 / 30.0
    assert early["margin_m"] == pytest.approx(second, abs=1e-9)  # the later, nearer sample
    assert early["margin_m"] > 0 and early["time_below_sp_moving_s"] == 0
    _, late = run_down(SpeedSeparationMonitoring(), 0.3, steps=40, gap=0.8)
    assert late["margin_m"] < 0 and late["time_below_sp_moving_s"] > 0


def test_no_margin_without_an_approach_or_a_safety_system():
    _, still = run_down(SpeedSeparationMonitoring(), 0.0, steps=5)
    assert still["margin_m"] is None
    _, none = run_down(NoSafety(), 0.5, steps=5)
    assert none["margin_m"] is None


def test_the_contact_margin_is_one_minus_the_worst_ratio():
    _, summary = run_down(PowerForceLimiting(), 1.5, steps=20)
    finite = [v for v in summary["worst_ratio"].values() if v is not None]
    assert summary["contact_count"] >= 1 and max(finite) > 0
    assert summary["contact_margin"] == pytest.approx(1.0 - max(finite), abs=1e-4)  # worst_ratio is rounded
    assert (summary["contact_margin"] < 0) == any(c["ratio"] > 1 for c in summary["contacts"])
    assert math.isfinite(summary["contact_margin"])
