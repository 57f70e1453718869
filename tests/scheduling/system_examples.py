"""Contract examples of the scheduling systems (see tests/contract.py)."""

from __future__ import annotations

from hrc_drake.messages import EventLog, RobotEvent
from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.config import MonteCarloScheduler
from hrc_drake.scheduling.systems import Scheduler
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


EXAMPLES = {Scheduler: scheduler}
