"""IntentionEstimator in a small diagram fed by a scripted skeleton-estimate source."""

import numpy as np
import pytest

from tests.intention.intention_reaches import GOALS, straight_reach

pydrake = pytest.importorskip("pydrake")
from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder, LeafSystem  # noqa: E402

from hrc_drake.intention.bayes import IntentionEvent  # noqa: E402
from hrc_drake.intention.config import GmmBayesIntention  # noqa: E402
from hrc_drake.intention.systems import IntentionEstimator  # noqa: E402
from hrc_drake.messages import EventLog, GoalBelief, SkeletonEstimate  # noqa: E402


class ScriptedEstimates(LeafSystem):
    """Outputs the scripted SkeletonEstimate of the latest script time <= now."""

    def __init__(self, times, points, gaze):
        super().__init__()
        self.times, self.points, self.gaze = times, points, gaze
        self.DeclareAbstractOutputPort("estimate", lambda: AbstractValue.Make(SkeletonEstimate()), self._calc)

    def _calc(self, context, output):
        k = int(np.clip(np.searchsorted(self.times, context.get_time() + 1e-9) - 1, 0, len(self.times) - 1))
        output.set_value(
            SkeletonEstimate(
                time=float(self.times[k]), points=self.points[k], gaze=self.gaze[k], gaze_valid=True
            )
        )


def build(model, times, points, gaze, **kwargs):
    builder = DiagramBuilder()
    source = builder.AddSystem(ScriptedEstimates(times, points, gaze))
    estimator = builder.AddSystem(IntentionEstimator(GmmBayesIntention(**kwargs), ["A", "B", "C"], GOALS,
                                                     model=model))
    builder.Connect(source.get_output_port(0), estimator.GetInputPort("skeleton_estimate"))
    diagram = builder.Build()
    return diagram, estimator


def test_estimator_in_a_diagram_recognises_the_goal_and_logs_feedback(small_model):
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[1], duration=0.9, noise=0.003, rng=2)
    diagram, estimator = build(small_model, times, points, gaze)
    simulator = Simulator(diagram)
    context = estimator.GetMyContextFromRoot(simulator.get_mutable_context())
    simulator.AdvanceTo(0.02)
    belief = estimator.GetOutputPort("goal_belief").Eval(context)
    assert isinstance(belief, GoalBelief) and belief.goals == ("A", "B", "C")
    np.testing.assert_allclose(belief.probabilities, 1 / 3)
    simulator.AdvanceTo(1.0)
    belief = estimator.GetOutputPort("goal_belief").Eval(context)
    np.testing.assert_allclose(belief.probabilities.sum(axis=1), 1.0)
    assert belief.probabilities[1].argmax() == 1 and belief.probabilities[1, 1] > 0.8
    log = estimator.GetOutputPort("intention_events").Eval(context)
    assert isinstance(log, EventLog)
    assert [(e.hand, e.goal, e.kind) for e in log.events] == [("right", "B", "understood")]
    event = log.events[0]
    assert isinstance(event, IntentionEvent) and event.seq == 1 and 0.0 < event.time < 0.9
    assert log.since(1) == ()
    # a fresh simulation of the same diagram starts over
    simulator2 = Simulator(diagram)
    simulator2.AdvanceTo(0.1)
    log2 = estimator.GetOutputPort("intention_events").Eval(
        estimator.GetMyContextFromRoot(simulator2.get_context())
    )
    assert log2.events == ()


def test_understood_is_set_only_at_the_update_that_crossed(small_model):
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[0], duration=0.9, noise=0.003, rng=4)
    diagram, estimator = build(small_model, times, points, gaze, rate=30.0)
    simulator = Simulator(diagram)
    context = estimator.GetMyContextFromRoot(simulator.get_mutable_context())
    seen = []
    for k in range(1, 31):
        simulator.AdvanceTo(k / 30.0 + 1e-6)
        seen.append(estimator.GetOutputPort("goal_belief").Eval(context).understood)
    assert sum(len(u) for u in seen) == 1
    assert [u for u in seen if u] == [(("right", "A"),)]


def test_bad_rate_raises(small_model):
    with pytest.raises(ValueError, match="rate"):
        IntentionEstimator(GmmBayesIntention(rate=100.0), ["A", "B", "C"], GOALS, model=small_model)


def test_two_contexts_fed_different_reaches_stay_independent(small_model):
    """The run lives in the Context: two contexts of one system, fed different moving reaches and
    advanced in turn, end as each does alone (sampled goal centres: the generator is state too)."""
    config = GmmBayesIntention(n_goal_samples=5, goal_std=0.02)
    estimator = IntentionEstimator(config, ["A", "B", "C"], GOALS, model=small_model, seed=3)
    reaches = {
        name: straight_reach([0.85, 0.15, 0.9], GOALS[g], duration=0.9, noise=0.003, rng=5)
        for name, g in (("a", 0), ("b", 2))
    }

    def feed(context, name, t):
        times, points, gaze = reaches[name]
        k = int(min(len(times) - 1, round(t * 30.0)))
        estimator.GetInputPort("skeleton_estimate").FixValue(
            context, AbstractValue.Make(SkeletonEstimate(time=t, points=points[k], gaze=gaze[k])))

    def run(names):
        contexts = {n: estimator.CreateDefaultContext() for n in names}
        simulators = {n: Simulator(estimator, c) for n, c in contexts.items()}
        for n in names:
            feed(contexts[n], n, 0.0)
            simulators[n].Initialize()
        for k in range(1, 31):
            for n in names:
                feed(contexts[n], n, k / 30.0)
                simulators[n].AdvanceTo(k / 30.0 + 1e-6)
        return {n: estimator.GetOutputPort("goal_belief").Eval(contexts[n]) for n in names}

    together = run(["a", "b"])
    alone = run(["a"])
    np.testing.assert_array_equal(together["a"].probabilities, alone["a"].probabilities)
    assert together["a"].probabilities[1].argmax() == 0
    assert together["b"].probabilities[1].argmax() == 2


def _segmenter_stream(system, context, simulator, goals_in_order, seconds_each):
    """Drive the segmenter with the left wrist held at each goal in turn; the final event log."""
    from tests.intention.system_examples import GOALS as EXAMPLE_GOALS

    points = np.tile(np.linspace(0.0, 1.0, 8)[:, None] * [0.1, 0.2, 0.3], (1, 1))
    port = system.GetInputPort("skeleton_estimate")
    t = 0.0
    for k in goals_in_order:
        frame = points.copy()
        frame[6], frame[7] = EXAMPLE_GOALS[k], [0.0, 0.0, 2.0]
        port.FixValue(context, AbstractValue.Make(SkeletonEstimate(time=t, points=frame)))
        t += seconds_each
        simulator.AdvanceTo(t)
    return system.GetOutputPort("human_events").Eval(context)


def test_the_segmenter_system_reports_the_actions_of_its_stream():
    from hrc_drake.intention.systems import ActionSegmenterSystem
    from tests.intention.system_examples import SMALL_SEGMENTER, small_segmenter

    system = ActionSegmenterSystem(SMALL_SEGMENTER, small_segmenter(SMALL_SEGMENTER))
    logs = []
    for order in ([0, 1, 2, 0, 1, 2], [2, 0, 1, 2, 0, 1]):
        context = system.CreateDefaultContext()
        simulator = Simulator(system, context)
        simulator.Initialize()
        logs.append(_segmenter_stream(system, context, simulator, order, 1.8))
    names = "abc"
    for log, order in zip(logs, ([0, 1, 2, 0, 1, 2], [2, 0, 1, 2, 0, 1]), strict=True):
        begins = [e.action for e in log.events if e.kind == "begin"]
        # every action but the last (still held: no later segment closed it) is reported, in order
        assert begins == [names[k] for k in order[:len(begins)]] and len(begins) >= 4
        times = [e.time for e in log.events]
        assert times == sorted(times) and [e.seq for e in log.events] == list(range(1, len(log.events) + 1))
        first_end = next(e.time for e in log.events if e.kind == "end")
        assert abs(first_end - 1.8) < 0.5  # the first action ends when the wrist moves on
