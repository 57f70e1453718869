"""The report's figures as metrics.json defines them: cycle times per product type after a
stated warm-up, busy / wait / idle, and the definitions written into the file."""

from __future__ import annotations

import numpy as np
import pytest

from hrc_drake.cell.metrics import DEFINITIONS, MetricsLog, cycle_times_after_warmup, summarize
from hrc_drake.messages import HumanEvent, RobotEvent


def test_the_warm_up_rule_leaves_out_what_it_says():
    times = [5.0, 12.0, 20.0, 27.0, 35.0]
    np.testing.assert_allclose(cycle_times_after_warmup(times), [7.0, 8.0, 7.0, 8.0])
    np.testing.assert_allclose(cycle_times_after_warmup(times, 0), [5.0, 7.0, 8.0, 7.0, 8.0])
    np.testing.assert_allclose(cycle_times_after_warmup(times, 2), [8.0, 7.0, 8.0])
    np.testing.assert_allclose(cycle_times_after_warmup(times, 1, warmup_time=15.0), [7.0, 8.0])
    np.testing.assert_allclose(cycle_times_after_warmup(times, 0, warmup_time=15.0), [5.0, 7.0, 8.0])
    assert cycle_times_after_warmup([5.0], 1).size == 0 and cycle_times_after_warmup([], 3).size == 0


def _log() -> MetricsLog:
    """A human making torches every 10 s (ends at 10, 20, 30) and a robot a clock at 15 and 35;
    the robot waits 5 s for parts from 20 to 25."""
    events, seq = [], 0
    for start in (0.0, 10.0, 20.0):
        seq += 2
        events += [HumanEvent(start, "torch", "begin", seq - 1),
                   HumanEvent(start + 10.0, "torch", "end", seq)]
    events += [RobotEvent(5.0, "arm", "clock", "begin", 1), RobotEvent(15.0, "arm", "clock", "end", 2),
               RobotEvent(20.0, "arm", "clock", "wait_begin", 3),
               RobotEvent(25.0, "arm", "clock", "wait_end", 4),
               RobotEvent(25.0, "arm", "clock", "begin", 5), RobotEvent(35.0, "arm", "clock", "end", 6)]
    return MetricsLog(events=events)


def test_cycle_times_are_per_product_type_and_the_mean_over_any_type_says_so():
    m = summarize(_log(), 40.0, ["human", "arm"], {"torch": ("torch_out",), "clock": ("clock_out",)})
    assert m["products"]["torch_out"] == {"finished": 3, "cycle_times": [10.0, 10.0], "mean_cycle_time": 10.0}
    assert m["products"]["clock_out"] == {"finished": 2, "cycle_times": [20.0], "mean_cycle_time": 20.0}
    # any type: products at 10, 15, 20, 30, 35 -> intervals after the first: 5, 5, 10, 5
    assert m["mean_cycle_time"] == pytest.approx(6.25) and m["products_finished"] == 5
    assert m["cycle_times"] == [10.0, 5.0, 5.0, 10.0, 5.0]  # from t = 0, nothing left out
    later = summarize(_log(), 40.0, ["human", "arm"], {"torch": ("torch_out",), "clock": ("clock_out",)},
                      warmup_products=0, warmup_time=12.0)
    assert later["products"]["torch_out"]["cycle_times"] == [8.0, 10.0]
    assert later["warmup"] == {"products": 0, "time": 12.0}


def test_idle_is_everything_but_work_and_wait_is_the_blocked_part_of_it():
    arm = summarize(_log(), 40.0, ["human", "arm"], {})["agents"]["arm"]
    assert arm["busy_time"] == 20.0 and arm["wait_time"] == 5.0 and arm["idle_time"] == 20.0
    assert arm["actions_finished"] == 2 and arm["utilisation"] == 0.5


def test_metrics_json_defines_every_figure_it_holds():
    m = summarize(_log(), 40.0, ["human", "arm"], {"torch": ("torch_out",)}, wall_time=2.0)
    figures = set(m) - {"definitions", "agents", "simulated_time", "wall_time"}
    assert figures <= set(m["definitions"]), figures - set(m["definitions"])
    assert set(m["agents"]["arm"]) <= set(m["definitions"])
    assert m["definitions"]["idle_time"] == DEFINITIONS["idle_time"]
    assert "wait_time" in DEFINITIONS["idle_time"]


def test_time_below_the_safety_distance_is_counted_over_every_sample():
    from hrc_drake.cell.metrics import SampleStats, summarize

    log = MetricsLog(safety_distance=0.1, sample_period=0.1)
    overrides = [1.0, 0.0, 0.5, 0.005, 1.0, 1.0, 1.0, 1.0]
    for k, d in enumerate([0.5, 0.09, 0.05, -0.02, 0.1, 0.3, float("inf"), 0.2]):
        log.record(0.1 * k, d, overrides[k], {}, 0)
    safety = summarize(log, 0.8, [], {})["safety"]
    # 0.09, 0.05 and -0.02 are under 0.1 (0.1 itself is not; no distance, inf, is not); of them
    # only 0.05 had the robot moving (override 0.5 > 1 %)
    assert safety == {"safety_distance": 0.1, "time_below_s": 0.3, "fraction_below": 0.375,
                      "time_below_not_stopped_s": 0.1, "below": True}
    # the recorder's running figures give the same count as the samples
    stats = SampleStats()
    for d, override in zip(log.distances, log.overrides, strict=True):
        stats = stats.add(d, override, 0.1)
    log.stats = stats
    assert summarize(log, 0.8, [], {})["safety"] == safety
    clear = MetricsLog(safety_distance=0.1)
    clear.record(0.0, 0.4, 1.0, {}, 0)
    assert summarize(clear, 0.1, [], {})["safety"]["below"] is False
    assert summarize(MetricsLog(), 0.1, [], {})["safety"] is None  # no threshold given


def test_robot_cycles_are_the_intervals_between_begins_of_the_first_program_action():
    """robot_cycles (Fig. 9.7): only the first arm's agent and its program's first action count."""
    from types import SimpleNamespace

    from hrc_drake.cell.metrics import robot_cycles
    from hrc_drake.messages import RobotEvent

    arm = SimpleNamespace(agent="yumi_left", program=["L_carry", "L_unload"])
    scenario = SimpleNamespace(robots=[SimpleNamespace(arms=[arm])])
    events = [RobotEvent(time=t, agent=agent, action=action, kind=kind, seq=0) for t, agent, action, kind in [
        (1.0, "yumi_left", "L_carry", "begin"), (5.0, "yumi_left", "L_carry", "end"),
        (6.0, "yumi_left", "L_unload", "begin"), (9.0, "yumi_right", "L_carry", "begin"),
        (31.0, "yumi_left", "L_carry", "begin"), (71.0, "yumi_left", "L_carry", "begin")]]
    out = robot_cycles(SimpleNamespace(log=SimpleNamespace(events=events)), scenario)
    assert out == {"times": [30.0, 40.0], "mean": 35.0, "count": 2}
    one = robot_cycles(SimpleNamespace(log=SimpleNamespace(events=events[:1])), scenario)
    assert one["count"] == 0 and one["times"] == [] and one["mean"] != one["mean"]  # NaN
