import pytest

pytest.importorskip("pydrake")

from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder, LeafSystem  # noqa: E402

from hrc_drake.messages import EventLog, HumanEvent, RobotEvent  # noqa: E402
from hrc_drake.scheduling import thesis_cells as tc  # noqa: E402
from hrc_drake.scheduling.config import MonteCarloScheduler, RoundRobinScheduler  # noqa: E402
from hrc_drake.scheduling.systems import Scheduler  # noqa: E402


class ScriptedLog(LeafSystem):
    """Emits a fixed list of events, each once its time has come."""

    def __init__(self, events):
        super().__init__()
        self.events = events
        self.DeclareAbstractOutputPort("log", lambda: AbstractValue.Make(EventLog()), self._calc)

    def _calc(self, context, output):
        t = context.get_time()
        output.set_value(EventLog(tuple(e for e in self.events if e.time <= t + 1e-9)))


def test_scheduler_answers_ready_events_in_a_diagram():
    flow, buffers, pattern, robots = tc.fig_7_6()
    robot_events = [
        RobotEvent(0.0, "robot", "", "ready", 1),
        RobotEvent(0.3, "robot", "action1", "begin", 2),
        RobotEvent(3.3, "robot", "action1", "end", 3),
        RobotEvent(3.3, "robot", "", "ready", 4),
    ]
    human_events = [HumanEvent(0.0, "action2", "begin", 1), HumanEvent(3.0, "action2", "end", 2)]
    builder = DiagramBuilder()
    human = builder.AddSystem(ScriptedLog(human_events))
    robot = builder.AddSystem(ScriptedLog(robot_events))
    sched = builder.AddSystem(
        Scheduler.from_flow(flow, buffers, "human", pattern, robots, RoundRobinScheduler(rate=10.0), seed=0)
    )
    builder.Connect(human.get_output_port(), sched.GetInputPort("human_events"))
    builder.Connect(robot.get_output_port(), sched.GetInputPort("robot_events"))
    diagram = builder.Build()
    sim = Simulator(diagram)
    sim.AdvanceTo(4.0)
    ctx = sched.GetMyContextFromRoot(sim.get_context())
    commands = sched.GetOutputPort("robot_commands").Eval(ctx).events
    # round robin: action1 first; at 3.3 the human (done with action2 at 3.0) waits for the
    # collaboration whose parts are both there -> the robot commits to action3
    assert [(c.agent, c.action) for c in commands] == [("robot", "action1"), ("robot", "action3")]
    assert [c.seq for c in commands] == [1, 2]
    assert commands[1].time == pytest.approx(3.3)
    tracker = sched.core(ctx).tracker
    m = tracker.net.marking_dict(tracker.m)
    assert m.get("cwait:action3") == 1 and m.get("hwait:1") == 1


def test_monte_carlo_scheduler_system_builds_and_answers():
    flow, buffers, pattern, robots = tc.fig_7_11()
    builder = DiagramBuilder()
    robot = builder.AddSystem(
        ScriptedLog([RobotEvent(0.0, "r1", "", "ready", 1), RobotEvent(0.0, "r2", "", "ready", 2)])
    )
    human = builder.AddSystem(ScriptedLog([]))
    sched = builder.AddSystem(
        Scheduler.from_flow(
            flow, buffers, "human", pattern, robots,
            MonteCarloScheduler(n_trials=30, horizon=20.0, wait_quantum=3.0), seed=1,
        )
    )
    builder.Connect(human.get_output_port(), sched.GetInputPort("human_events"))
    builder.Connect(robot.get_output_port(), sched.GetInputPort("robot_events"))
    sim = Simulator(builder.Build())
    sim.AdvanceTo(0.5)
    ctx = sched.GetMyContextFromRoot(sim.get_context())
    commands = sched.GetOutputPort("robot_commands").Eval(ctx).events
    assert sorted(c.agent for c in commands) == ["r1", "r2"]
    for c in commands:
        assert c.action in ("A1", "B1", None)
        assert c.wait == (3.0 if c.action is None else 0.0)


def _best_scenario_commands(waiting: float):
    """The use case a scheduler of 7.2 when both arms are free at 0 and the forecast says the
    human starts the collaboration in `waiting` s (its 0.2 and 0.8 percentiles)."""
    import numpy as np

    from hrc_drake.messages import Forecast
    from hrc_drake.scheduling.config import BestScenarioScheduler

    flow, buffers, pattern, robots = tc.use_case_a(1)
    forecast = Forecast(time=0.0, actions=("ic", "collab"), next_probabilities=np.array([0.5, 0.5]),
                        percentile_levels=np.array([0.2, 0.5, 0.8]),
                        waiting_percentiles=np.array([[1.0, 2.0, 3.0], [waiting, waiting + 1, waiting + 2]]))

    class Constant(LeafSystem):
        def __init__(self):
            super().__init__()
            self.DeclareAbstractOutputPort("forecast", lambda: AbstractValue.Make(forecast),
                                           lambda context, out: out.set_value(forecast))

    builder = DiagramBuilder()
    robot = builder.AddSystem(ScriptedLog([RobotEvent(0.0, "yumi_left", "", "ready", 1),
                                           RobotEvent(0.0, "yumi_right", "", "ready", 2)]))
    human = builder.AddSystem(ScriptedLog([]))
    source = builder.AddSystem(Constant())
    config = BestScenarioScheduler(collaboration="collab", horizon=60.0)
    sched = builder.AddSystem(Scheduler.from_flow(flow, buffers, "human", pattern, robots, config, seed=0))
    builder.Connect(human.get_output_port(), sched.GetInputPort("human_events"))
    builder.Connect(robot.get_output_port(), sched.GetInputPort("robot_events"))
    builder.Connect(source.get_output_port(), sched.GetInputPort("forecast"))
    sim = Simulator(builder.Build())
    sim.AdvanceTo(0.2)
    ctx = sched.GetMyContextFromRoot(sim.get_context())
    return [(c.agent, c.action) for c in sched.GetOutputPort("robot_commands").Eval(ctx).events]


def test_the_best_scenario_scheduler_reads_the_forecast():
    # the human is near: both arms commit to the collaboration at once (one command per arm)
    assert _best_scenario_commands(0.5) == [("yumi_left", "collab"), ("yumi_right", "collab")]
    # far: the left arm fuses first, the right arm (no work of its own) waits
    assert _best_scenario_commands(25.0) == [("yumi_left", "fuse"), ("yumi_right", None)]
