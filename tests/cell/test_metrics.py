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


def test_times_between_products_are_per_type_and_the_mean_over_any_type_says_so():
    m = summarize(_log(), 40.0, ["human", "arm"], {"torch": ("torch_out",), "clock": ("clock_out",)})
    torch, clock = m["products"]["torch_out"], m["products"]["clock_out"]
    assert (torch["times_between"], torch["mean_time_between"]) == ([10.0, 10.0], 10.0)
    assert (clock["times_between"], clock["mean_time_between"]) == ([20.0], 20.0)
    # without the flow a product starts at the begin of the action that finishes it
    assert torch["cycle_times"] == [10.0, 10.0, 10.0] and clock["cycle_times"] == [10.0, 10.0]
    # any type: products at 10, 15, 20, 30, 35 -> intervals after the first: 5, 5, 10, 5
    assert m["mean_time_between_products"] == pytest.approx(6.25) and m["products_finished"] == 5
    assert m["times_between_products"] == [10.0, 5.0, 5.0, 10.0, 5.0]  # from t = 0, nothing left out
    assert m["products_per_hour"] == 450.0 and torch["per_hour"] == 270.0  # 5 and 3 in 40 s
    later = summarize(_log(), 40.0, ["human", "arm"], {"torch": ("torch_out",), "clock": ("clock_out",)},
                      warmup_products=0, warmup_time=12.0)
    assert later["products"]["torch_out"]["times_between"] == [8.0, 10.0]
    assert later["products"]["torch_out"]["cycle_times"] == [10.0, 10.0]  # only warmup_time applies
    assert later["warmup"] == {"products": 0, "time": 12.0}


def _flow_log():
    """A feeder -> `mid` (1 part at t = 0) -> `out` line (the human's A makes a part, the arm's B
    finishes it) and a shared action C (human and arm) putting a `pair` product."""
    from types import SimpleNamespace as N

    actions = [N(name="A", inputs=["feed"], outputs=["mid"]), N(name="B", inputs=["mid"], outputs=["out"]),
               N(name="C", inputs=["feed"], outputs=["pair"])]
    buffers = [N(name="feed", kind="raw", initial=0), N(name="mid", kind="intermediate", initial=1),
               N(name="out", kind="product", initial=0), N(name="pair", kind="product", initial=0)]
    human = [(0, "A", "begin"), (5, "A", "end"), (10, "A", "begin"), (14, "A", "end"), (15, "A", "begin"),
             (18, "A", "end"), (31, "C", "begin"), (38, "C", "end"), (40, "C", "begin"), (45, "C", "end")]
    arm = [(1, "B", "begin"), (4, "B", "end"), (6, "B", "begin"), (10, "B", "end"), (14, "B", "begin"),
           (20, "B", "end"), (21, "B", "begin"), (30, "B", "end"), (31, "C", "begin"), (35, "C", "end"),
           (41, "C", "begin"), (50, "C", "end")]
    events = [HumanEvent(float(t), a, k, n) for n, (t, a, k) in enumerate(human, 1)]
    events += [RobotEvent(float(t), "arm", a, k, n) for n, (t, a, k) in enumerate(arm, 1)]
    return MetricsLog(events=events), actions, buffers


def test_each_products_cycle_runs_from_its_first_action_to_its_completion():
    """By hand: `out` products start 1 (the part at t = 0 starts when B takes it), 0, 10 (A's
    part put at 14 as B begins at 14: the world puts before it takes), 15 and finish 4, 10, 20,
    30: cycles 3, 10, 10, 15; `pair` (C shared, done when its last agent ends): 38 - 31 = 7 and
    50 - 40 = 10. Median and p90 by numpy's linear rule: [3, 10, 10, 15] -> 10 and
    10 + 0.7 x 5 = 13.5; [7, 10] -> 8.5 and 9.7."""
    log, actions, buffers = _flow_log()
    kwargs = dict(flow_actions=actions, buffers=buffers, shared_actions={"C": ("human", "arm")})
    m = summarize(log, 60.0, ["human", "arm"], {"B": ("out",), "C": ("pair",)}, **kwargs)
    out, pair = m["products"]["out"], m["products"]["pair"]
    assert out["cycle_times"] == [3.0, 10.0, 10.0, 15.0] and pair["cycle_times"] == [7.0, 10.0]
    assert (out["cycle_time_median"], out["cycle_time_p90"]) == (10.0, 13.5)
    assert (pair["cycle_time_median"], pair["cycle_time_p90"]) == (8.5, 9.7)
    assert m["products_per_hour"] == 360.0 and out["per_hour"] == 240.0  # 6 and 4 products in 60 s
    # the warm-up time leaves out the products finished before it (4 and 10)
    later = summarize(log, 60.0, ["human", "arm"], {"B": ("out",), "C": ("pair",)}, warmup_time=12.0,
                      **kwargs)
    assert later["products"]["out"]["cycle_times"] == [10.0, 15.0]
    assert (later["products"]["out"]["cycle_time_median"], later["products"]["out"]["cycle_time_p90"]) == (
        12.5, 14.5)
    assert summarize(MetricsLog(), 60.0, [], {"B": ("out",)}, flow_actions=actions, buffers=buffers)[
        "products"]["out"]["cycle_time_median"] is None


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


# --- the report's figures, read back from their matplotlib artists ---------------------------

def _work_log(spans, decisions=()) -> MetricsLog:
    """A log of (agent, action, start, end) work spans (robot events) and scheduler decisions."""
    events = []
    for k, (agent, action, start, end) in enumerate(spans):
        events += [RobotEvent(start, agent, action, "begin", 2 * k + 1),
                   RobotEvent(end, agent, action, "end", 2 * k + 2)]
    return MetricsLog(events=events, decisions=list(decisions))


def _bar_colors(ax) -> dict:
    """Action -> the face colour of its bars (the figure labels each action's collection)."""
    return {c.get_label().removeprefix("_bars "): tuple(c.get_facecolor()[0]) for c in ax.collections
            if c.get_label().startswith("_bars ")}


def _close(fig):
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_an_action_has_one_colour_in_every_run_of_a_scenario():
    from matplotlib.colors import to_rgba

    from hrc_drake.cell.metrics import action_colors, gantt_figure

    names = ["R_pick_board", "R_place_board", "fill", "tape"]
    one = gantt_figure(_work_log([("arm", "R_place_board", 0, 5), ("arm", "tape", 5, 9)]), 10.0, ["arm"],
                       action_names=names)
    # another run: other actions happened, in another order
    two = gantt_figure(_work_log([("arm", "fill", 0, 3), ("arm", "R_pick_board", 3, 6),
                                  ("arm", "R_place_board", 6, 9)]), 10.0, ["arm"], action_names=names)
    first, second = _bar_colors(one.axes[0]), _bar_colors(two.axes[0])
    assert first["R_place_board"] == second["R_place_board"] == to_rgba(action_colors(names)["R_place_board"])
    assert len(set(first.values()) | set(second.values())) == 4  # four names, four colours
    assert action_colors(reversed(names)) == action_colors(names)  # the set of names decides
    _close(one), _close(two)


def test_bar_labels_fit_their_bars_and_never_run_into_each_other():
    from hrc_drake.cell.metrics import gantt_figure

    # short picks and places back to back (the "R_place_boardR_pick_board"), one long fill
    spans = [("arm", "R_pick_board" if k % 2 else "R_place_board", 0.6 * k, 0.6 * (k + 1))
             for k in range(100)]
    spans += [("human", "fill", 0.0, 40.0), ("human", "tape", 40.0, 41.5)]
    fig = gantt_figure(_work_log(spans), 120.0, ["human", "arm"],
                       action_names=["R_pick_board", "R_place_board", "fill", "tape"])
    ax = fig.axes[0]
    renderer = fig.canvas.get_renderer()
    labels = [t for t in ax.texts if t.get_gid() == "bar_label"]
    boxes = [t.get_window_extent(renderer) for t in labels]
    for k, a in enumerate(boxes):
        for b in boxes[k + 1:]:
            assert not a.overlaps(b), "two labels overlap"
    # each label lies inside its bar (in display x)
    for text, box in zip(labels, boxes, strict=True):
        x, row = text.get_position()
        agent = ["human", "arm"][round(row)]
        start, end = next((s, e) for who, _, s, e in spans if who == agent and s <= x <= e)
        left, right = ax.transData.transform([(start, 0), (end, 0)])[:, 0]
        assert left <= box.x0 and box.x1 <= right, text.get_text()
    shown = [t.get_text() for t in labels]
    assert "fill" in shown  # a long bar shows its name
    assert "R_place_board" not in shown and "R_pick_board" not in shown  # 0.6 s bars: too short
    keyed = {t for t in shown if t.isdigit()}
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    for key in keyed:  # a bar's key names its action in the legend
        assert any(entry.startswith(f"{key}: ") for entry in legend)
    assert {"1: R_pick_board", "2: R_place_board", "3: fill", "4: tape"} <= set(legend)
    _close(fig)


def test_the_distance_panel_draws_the_safety_distance_and_the_title_states_the_verdict():
    from hrc_drake.cell.metrics import gantt_figure

    log = _work_log([("arm", "pick", 0.0, 2.0)])
    log.safety_distance = 0.1
    for k, d in enumerate([0.4, 0.08, 0.3]):
        log.record(0.5 * k, d, 1.0, {}, 0)
    safety = {"safety_distance": 0.1, "time_below_s": 0.5, "below": True,
              "verdict": "SAFE: ISO/TS 15066 ssm, conforming judge, 0 violations in 2 s"}
    fig = gantt_figure(log, 2.0, ["arm"], title="cell", safety=safety)
    top, distance = fig.axes[0], fig.axes[1]
    lines = [line for line in distance.get_lines() if line.get_label().startswith("safety distance")]
    assert len(lines) == 1 and set(lines[0].get_ydata()) == {0.1}
    assert lines[0].get_label() == "safety distance 0.1 m"
    legend = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    assert "safety distance 0.1 m" in legend and "min human-robot distance" in legend
    verdict = f"below the safety distance 0.1 m for 0.5 s; {safety['verdict']}"
    assert top.get_title() == f"cell\n{verdict}"
    _close(fig)
    fig = gantt_figure(_work_log([("arm", "pick", 0.0, 2.0)]), 2.0, ["arm"], title="cell")
    assert "no safety distance or safety system" in fig.axes[0].get_title()
    _close(fig)


def test_the_legend_draws_the_decision_marks_as_the_plot_does():
    from matplotlib.colors import to_rgba
    from matplotlib.lines import Line2D

    from hrc_drake.cell.metrics import gantt_figure
    from hrc_drake.messages import RobotCommand

    decisions = [RobotCommand(0.0, "arm", "pick", 1), RobotCommand(2.0, "arm", None, 2, wait=1.0),
                 RobotCommand(3.0, "arm", "place", 3)]
    fig = gantt_figure(_work_log([("arm", "pick", 0.0, 2.0), ("arm", "place", 3.0, 5.0)], decisions), 6.0,
                       ["arm"], action_names=["pick", "place"])
    ax = fig.axes[0]
    starts = next(c for c in ax.collections if c.get_label() == "_decision starts")
    plotted = {tuple(c) for c in starts.get_facecolor()}
    assert plotted == {to_rgba(c) for c in _bar_colors(ax).values()}  # the actions' colours
    legend = ax.get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert "decision: start (the action's colour)" in labels and "decision: wait t_w" in labels
    # the marks the legend draws (a start's entry draws a triangle per colour)
    marks = [line for line in legend.findobj(Line2D) if line.get_marker() == "v"]
    filled = {to_rgba(m.get_markerfacecolor()) for m in marks if m.get_markerfacecolor() != "none"}
    assert filled == plotted  # coloured as in the plot, not black
    assert all(to_rgba(m.get_markeredgecolor()) == to_rgba("black") for m in marks
               if m.get_markerfacecolor() != "none")
    hollow = [m for m in marks if m.get_markerfacecolor() == "none"]
    assert len(hollow) == 1 and to_rgba(hollow[0].get_markeredgecolor()) == to_rgba("grey")
    waits = next(c for c in ax.collections if c.get_label() == "_decision waits")
    assert to_rgba(waits.get_edgecolor()[0]) == to_rgba("grey") and waits.get_facecolor().size == 0
    _close(fig)


def test_the_collaboration_figure_names_its_colours():
    from matplotlib.colors import to_rgba

    from hrc_drake.cell.metrics import collaboration_figure

    log = MetricsLog(events=[
        HumanEvent(0.0, "insert", "begin", 1), HumanEvent(4.0, "insert", "end", 2),
        HumanEvent(4.0, "enclosure", "begin", 3), HumanEvent(6.0, "enclosure", "end", 4),
        RobotEvent(0.0, "arm", "check", "begin", 1), RobotEvent(4.0, "arm", "check", "end", 2),
        RobotEvent(4.0, "arm", "place", "begin", 3), RobotEvent(6.0, "arm", "place", "end", 4)])
    fig = collaboration_figure(log, 8.0, "human", "arm", "enclosure", ["place"])
    top = fig.axes[0]
    legend = top.get_legend()
    assert legend is not None
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[:3] == ["human: autonomous actions", "arm: autonomous actions",
                          "collaboration: 'enclosure' and the actions that assist it"]
    plotted = {tuple(c.get_facecolor()[0][:3]) for c in top.collections}
    for handle in legend.legend_handles[:3]:
        assert tuple(to_rgba(handle.get_facecolor())[:3]) in plotted
    _close(fig)


def test_events_csv_holds_the_judges_violations_in_time_order(tmp_path):
    import csv

    from hrc_drake.cell.metrics import write_events_csv

    events = [HumanEvent(1.0, "torch", "begin", 1), RobotEvent(2.0, "arm", "clock", "begin", 1)]
    violation = {"kind": "ssm_breach", "onset": 1.5, "duration": 0.0333, "link": "yumi/gripper_r_base",
                 "body_part": "left_hand", "region": "hand_fingers", "worst": -0.02, "violation": True,
                 "detail": "0.020 m inside S_p, \"quoted\""}
    path = tmp_path / "events.csv"
    write_events_csv(path, events, (), [violation])
    rows = list(csv.DictReader(path.open()))
    assert [r["source"] for r in rows] == ["truth", "judge", "truth"]
    judged = rows[1]
    assert (judged["time"], judged["agent"], judged["action"], judged["kind"]) == (
        "1.500", "yumi/gripper_r_base", "left_hand", "ssm_breach")
    assert judged["duration"] == "0.0333" and judged["detail"] == 'hand_fingers: 0.020 m inside S_p, "quoted"'
    assert [int(r["seq"]) for r in rows] == [1, 2, 3] and rows[0]["duration"] == ""
