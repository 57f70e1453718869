"""The pure helpers of tools/real_intention.py (intention, thesis 3.1, on real seated reaches)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.conftest import load_tool


@pytest.fixture(scope="module")
def ri():
    module = load_tool("real_intention")
    return module


def test_reach_span_takes_the_run_around_the_peak(ri):
    # still, a small twitch (0.04 m/s, below the 0.05 floor), then a reach peaking at 0.6 m/s
    speed = np.array([0.0, 0.04, 0.0, 0.01, 0.03, 0.07, 0.2, 0.6, 0.4, 0.1, 0.059, 0.02, 0.0])
    # level = max(0.05, 0.1 * 0.6) = 0.06: samples 5..9 are >= 0.06, sample 10 (0.059) is not
    assert ri.reach_span(speed) == (5, 9)
    # a second, slower motion after a pause is not part of the reach
    two = np.array([0.0, 0.3, 0.5, 0.3, 0.0, 0.0, 0.2, 0.0])
    assert ri.reach_span(two) == (1, 3)
    assert ri.reach_span(np.full(10, 0.01)) is None  # never faster than the floor


def test_wrist_speed_of_a_straight_line(ri):
    times = np.arange(10) / 30.0
    positions = np.stack([0.3 * times, np.zeros(10), np.ones(10)], axis=1)
    assert np.allclose(ri.wrist_speed(times, positions), 0.3)


def test_segmentation_of_a_minimum_jerk_reach(ri):
    times = np.arange(0, 3.0, 1 / 30.0)
    s = np.clip((times - 1.0) / 1.0, 0.0, 1.0)  # a 1 s minimum-jerk reach starting at t = 1 s
    x = 0.3 * (10 * s**3 - 15 * s**4 + 6 * s**5)
    positions = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    start, end = ri.reach_span(ri.wrist_speed(times, positions))
    assert 1.0 <= times[start] <= 1.2 and 1.8 <= times[end] <= 2.0


def trace(rows):
    return np.array(rows, dtype=float)


def test_commit_fraction_and_no_wrong_commitment(ri):
    times = np.arange(11) * 0.1
    p = np.full((11, 3), 1 / 3)
    p[6:] = [0.1, 0.85, 0.05]  # goal 1 reaches 0.8 at sample 6
    out = ri.reach_outcome(times, p, 1, start=2, end=10)
    assert out["committed"] and not out["wrong"] and not out["wrong_first"]
    assert out["commit_fraction"] == pytest.approx((0.6 - 0.2) / (1.0 - 0.2))


def test_wrong_before_and_after_the_right_one(ri):
    times = np.arange(8) * 0.1
    first_wrong = trace([[0.3, 0.4, 0.3], [0.9, 0.05, 0.05], [0.5, 0.4, 0.1], [0.1, 0.85, 0.05],
                         [0.1, 0.85, 0.05], [0.1, 0.85, 0.05], [0.1, 0.85, 0.05], [0.1, 0.85, 0.05]])
    out = ri.reach_outcome(times, first_wrong, 1, 0, 7)
    assert out["wrong"] and out["wrong_first"] and out["committed"]
    assert out["commit_fraction"] == pytest.approx(3 / 7)
    wrong_late = first_wrong[[0, 3, 4, 5, 1, 1, 1, 1]]  # right at 1, then goal 0 rises at 4
    out = ri.reach_outcome(times, wrong_late, 1, 0, 7)
    assert out["wrong"] and not out["wrong_first"]
    assert out["commit_fraction"] == pytest.approx(1 / 7)


def test_a_belief_held_from_before_the_reach_is_no_new_commitment(ri):
    times = np.arange(6) * 0.1
    p = trace([[0.9, 0.05, 0.05]] * 3 + [[0.5, 0.4, 0.1], [0.2, 0.7, 0.1], [0.1, 0.75, 0.15]])
    out = ri.reach_outcome(times, p, 1, start=2, end=5)  # goal 0 above 0.8 since sample 0
    assert not out["wrong"] and not out["committed"] and math.isnan(out["commit_fraction"])
    again = p.copy()
    again[4] = [0.85, 0.1, 0.05]  # ... but it falls and rises again during the reach
    assert ri.reach_outcome(times, again, 1, 2, 5)["wrong"]


def test_summarise_counts_missed_apart(ri):
    committed = {"committed": True, "commit_fraction": 0.4, "wrong": False, "wrong_first": False}
    late = {"committed": True, "commit_fraction": 0.6, "wrong": True, "wrong_first": False}
    missed = {"committed": False, "commit_fraction": math.nan, "wrong": True, "wrong_first": True}
    s = ri.summarise([committed, late, missed, committed])
    assert s["reaches"] == 4
    assert s["commit_fraction_median"] == pytest.approx(0.4)  # over the committed reaches only
    assert s["missed_pct"] == 25.0 and s["wrong_commit_pct"] == 50.0 and s["wrong_first_pct"] == 25.0


def test_leave_one_trial_out_goal_centres(ri):
    def reach(participant, kind, start_xyz, end_xyz):
        points = np.zeros((2, 8, 3))
        points[0, 7], points[1, 7] = start_xyz, end_xyz
        return {"participant": participant, "kind": kind, "points": points, "start": 0, "end": 1}

    reaches = [reach("A", "forward", [1, 0, 0], [0, 0, 0]), reach("A", "forward", [1, 0, 0], [0, 0, 0.2]),
               reach("A", "across", [1, 0, 0], [0, 1, 0]), reach("A", "across", [1, 0, 0], [0, 1, 0.2]),
               reach("B", "forward", [9, 9, 9], [9, 9, 9]), reach("B", "across", [9, 9, 9], [9, 9, 9])]
    names, centres = ri.real_goal_centres(reaches, 0)
    assert names == ("forward", "across", "rest")
    assert np.allclose(centres, [[0, 0, 0.2], [0, 1, 0.1], [1, 0, 0]])  # reach 0 and B left out
    names, centres = ri.real_goal_centres(reaches, 0, with_rest=False)
    assert names == ("forward", "across") and centres.shape == (2, 3)


def test_synthetic_reaches_are_seeded(ri):
    names = ("forward", "across", "rest")
    centres = np.array([[0.55, 0.2, 0.86], [0.59, 0.03, 0.86], [0.81, 0.24, 0.82]])
    a = ri.synthetic_reaches(list(names), centres, 3, seed=5)
    b = ri.synthetic_reaches(list(names), centres, 3, seed=5)
    assert np.array_equal(a["recording"].points, b["recording"].points, equal_nan=True)
    assert a["reaches"] == b["reaches"] and len(a["reaches"]) >= 2
    assert all(r["goal"] in (0, 1) and r["from"] <= r["start"] < r["end"] for r in a["reaches"])
    c = ri.synthetic_reaches(list(names), centres, 3, seed=6)
    assert not np.array_equal(a["recording"].points, c["recording"].points, equal_nan=True)


def test_same_seed_same_figures_and_m3_falls_back_to_m2(ri, capsys):
    try:
        ri.dataset_dir("ue_adl", None)
    except FileNotFoundError:
        pytest.skip("no ue_adl recordings")
    a = ri.intention_figures(None, seed=3, quick=True, two_goal_variant=False)
    b = ri.intention_figures(None, seed=3, quick=True, two_goal_variant=False)
    assert a == b
    assert a["reaches"] == 20 and a["real"]["M1"]["reaches"] == 20

    def real_only(row):  # the minus-synthetic figures differ: the synthetic operators have gaze
        return {k: v for k, v in row.items() if "minus_synthetic" not in k}

    # no gaze recorded: M3 is M2 on real reaches
    assert a["m3_equals_m2_on_real"] and real_only(a["real"]["M3"]) == real_only(a["real"]["M2"])
    assert a["real"]["M2"]["wrong_commit_pct.ci95"] is not None  # two people: an interval over them
    keys = ri.bench_keys(a)
    assert "intention.M2.wrong_commit_pct_minus_synthetic.ci95" in keys
    assert keys["intention.M2.commit_fraction_median"] == a["real"]["M2"]["commit_fraction_median"]
    assert "intention_synthetic.M3.wrong_commit_pct" in keys
