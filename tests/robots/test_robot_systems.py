"""The robot systems in their Contexts (the contract examples are in system_examples.py)."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator

from hrc_drake.messages import PathRequest
from hrc_drake.robots.path import JointPathFollower
from hrc_drake.robots.systems import PathFollower


def _follower() -> PathFollower:
    return PathFollower(JointPathFollower(np.zeros(2), [np.array([0, 1])], [np.ones(2)]), period=0.02)


def _run(system, contexts_and_requests, until: float) -> list[np.ndarray]:
    sims = []
    for request in contexts_and_requests:
        context = system.CreateDefaultContext()
        system.GetInputPort("path_requests").FixValue(context, AbstractValue.Make((request,)))
        sims.append(Simulator(system, context))
        sims[-1].Initialize()
    for k in range(1, 11):
        for sim in sims:
            sim.AdvanceTo(until * k / 10)
    return [system.GetOutputPort("positions").Eval(sim.get_context()).copy() for sim in sims]


def test_path_follower_contexts_with_same_waypoints_and_other_dwells_stay_independent():
    """Regression: the paths memoised on the system were keyed without the dwells, so a context
    asking the same waypoints (same channel and seq) with other dwells followed the first
    context's path."""
    waypoints = np.array([[0.3, 0.0], [0.0, 0.0]])
    short = PathRequest(channel=0, seq=1, waypoints=waypoints, dwells=np.array([0.0, 0.0]))
    long = PathRequest(channel=0, seq=1, waypoints=waypoints, dwells=np.array([1.0, 0.0]))
    (alone,) = _run(_follower(), [long], 1.5)
    np.testing.assert_allclose(alone, [0.3, 0.0])  # still dwelling at the first waypoint
    beside = _run(_follower(), [short, long], 1.5)
    np.testing.assert_allclose(beside[0], [0.0, 0.0])  # the short dwell: back at the end
    np.testing.assert_array_equal(beside[1], alone)
    # One system run again, one context after the other: the second run is not the first's.
    system = _follower()
    _run(system, [short], 1.5)
    np.testing.assert_array_equal(_run(system, [long], 1.5)[0], alone)


def _between_ticks(override: float):
    """A follower on a 0.5 rad move of joint 0 (min-jerk), 0.0301 s in (between the 0.02 s ticks),
    its override fixed; (system, context)."""
    system = _follower()
    context = system.CreateDefaultContext()
    request = PathRequest(channel=0, seq=1, waypoints=np.array([[0.5, 0.0]]), dwells=np.array([0.0]))
    system.GetInputPort("path_requests").FixValue(context, AbstractValue.Make((request,)))
    system.GetInputPort("speed_override").FixValue(context, [override])
    simulator = Simulator(system, context)
    simulator.Initialize()
    simulator.AdvanceTo(0.0301)
    return system, context


def test_the_velocities_are_the_paths_at_the_positions_path_time_not_at_the_last_tick():
    """Regression (issue 51): the velocities were the path's at the last tick, a period stale for a
    safety controller that updates at the tick (it reads the state of the tick before)."""
    system, context = _between_ticks(0.5)
    q = system.GetOutputPort("positions")
    h = 1e-6
    context.SetTime(0.0301 - h)
    before = q.Eval(context).copy()
    context.SetTime(0.0301 + h)
    after = q.Eval(context).copy()
    context.SetTime(0.0301)
    slope = (after - before) / (2 * h)  # at override 0.5 between ticks: half the path's speed
    np.testing.assert_allclose(system.GetOutputPort("velocities").Eval(context), slope, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(system.GetOutputPort("velocities_full").Eval(context), 2.0 * slope,
                               rtol=1e-5, atol=1e-9)


def test_the_next_tick_ports_are_one_period_of_full_speed_path_ahead():
    """At override 1 the path time runs with the clock: the next-tick ports now are the present
    ports one period (0.02 s) later."""
    system, context = _between_ticks(1.0)
    ahead = {name: system.GetOutputPort(name).Eval(context).copy()
             for name in ("positions_full_next", "velocities_full_next")}
    Simulator(system, context).AdvanceTo(0.0301 + 0.02)
    assert system.GetOutputPort("positions").Eval(context)[0] > 1e-4  # the move is under way
    np.testing.assert_allclose(ahead["positions_full_next"], system.GetOutputPort("positions").Eval(context),
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ahead["velocities_full_next"],
                               system.GetOutputPort("velocities_full").Eval(context), rtol=1e-12, atol=1e-15)


def test_a_negative_override_backs_the_arm_off_along_its_path():
    """A safety controller's retreat: at override -1 the path time runs back at the clock's rate
    (its positions are the path's at the earlier time), and not before the path's start."""
    system, context = _between_ticks(1.0)
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.3)
    forward = system.GetOutputPort("positions").Eval(context).copy()
    system.GetInputPort("speed_override").FixValue(context, [-1.0])
    simulator.AdvanceTo(0.3 + 1e-9)  # the tick at 0.3 applies -1
    turning = system.GetOutputPort("positions").Eval(context).copy()
    simulator.AdvanceTo(0.4)
    back = system.GetOutputPort("positions").Eval(context).copy()
    assert back[0] < turning[0] <= forward[0] + 1e-12
    # 0.1 s back in path time: where the arm was at 0.2 s (forward at override 1 from the start)
    again, again_context = _between_ticks(1.0)
    Simulator(again, again_context).AdvanceTo(0.2)
    np.testing.assert_allclose(back, again.GetOutputPort("positions").Eval(again_context), atol=1e-9)
    np.testing.assert_allclose(system.GetOutputPort("velocities").Eval(context),
                               -again.GetOutputPort("velocities").Eval(again_context), atol=1e-9)
    simulator.AdvanceTo(2.0)
    np.testing.assert_allclose(system.GetOutputPort("positions").Eval(context), [0.0, 0.0], atol=1e-12)
