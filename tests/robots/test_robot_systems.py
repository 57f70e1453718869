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
