"""Contract examples of the scheduling systems (see tests/contract.py)."""

from __future__ import annotations

import numpy as np

from hrc_drake.messages import EventLog, Forecast, HumanEvent, RobotEvent
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.config import MonteCarloScheduler, PredictiveRobotScheduler
from hrc_drake.scheduling.systems import CollaborationScheduler, Scheduler
from tests.contract import SystemExample


def scheduler() -> SystemExample:
    """Monte Carlo scheduler on the two-robot cell of Fig. 7.11 (random generator and learned
    durations in the state). A: robot r1 reports ready; B: robot r2 does (fixed logs, so every
    event is read at the first update)."""
    flow, buffers, pattern, robots = tc.fig_7_11()
    config = MonteCarloScheduler(n_trials=20, horizon=10.0, rate=10.0, wait_quantum=3.0)
    system = Scheduler.from_flow(flow, buffers, "human", pattern, robots, config, seed=3)
    human = EventLog()
    return SystemExample(
        system,
        inputs_a={"human_events": human, "robot_events": EventLog((RobotEvent(0.0, "r1", "", "ready", 1),))},
        inputs_b={"human_events": human, "robot_events": EventLog((RobotEvent(0.0, "r2", "", "ready", 1),))},
        duration=1.0,
    )


def use_case_a_forecast(enclosure_wait: float) -> Forecast:
    """A forecast whose 80th percentile of the waiting time until "enclosure" is `enclosure_wait`."""
    return Forecast(time=0.0, actions=("ic_insert", "enclosure", "cable"),
                    next_probabilities=np.array([0.2, 0.6, 0.2]), percentile_levels=np.array([0.5, 0.8]),
                    waiting_percentiles=np.array([[5.0, 8.0], [0.6 * enclosure_wait, enclosure_wait],
                                                  [20.0, 25.0]]))


def use_case_a_scheduler(**overrides) -> CollaborationScheduler:
    fields = dict(agent="yumi_right", autonomous_action="R_check", assist_actions=["R_place", "R_close"],
                  request_action="enclosure", autonomous_duration=11.5, supplied_by="ic_insert",
                  autonomous_stock=2)
    config = PredictiveRobotScheduler(**dict(fields, **overrides))
    return CollaborationScheduler(config, {"yumi_right": ["R_check", "R_place", "R_close"], "yumi_left": []})


def collaboration_scheduler() -> SystemExample:
    """The predictive robot with a PCB to check and two checked in stock, ready at t = 0: A, the
    forecast puts the collaboration 3 s away (it waits to assist: R_place); B, 40 s away (it
    checks: R_check)."""
    supplied = EventLog((HumanEvent(0.0, "ic_insert", "begin", 1), HumanEvent(0.0, "ic_insert", "end", 2)))
    ready = EventLog((RobotEvent(0.0, "yumi_right", "", "ready", 1),))
    common = {"human_events": supplied, "robot_events": ready}
    return SystemExample(use_case_a_scheduler(), dict(common, forecast=use_case_a_forecast(3.0)),
                         dict(common, forecast=use_case_a_forecast(40.0)), duration=0.5)


EXAMPLES = {Scheduler: scheduler, CollaborationScheduler: collaboration_scheduler}
