"""The cell systems without output ports keep the contract on what they record.

`tests/test_system_contract.py` compares outputs; `MetricsRecorder` and `ReplayMarkers` have
none, so their examples there set inputs_matter=False. Here the same examples are run against
the same contract, comparing what each run recorded: the recorder's `log(context)`, the
markers' state (the goals flashing after intention events).
"""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator

from hrc_drake.cell.metrics import DecimatedTrace, SampleStats, summarize
from hrc_drake.cell.systems import HumanCapsules, MetricsRecorder
from tests.cell.system_examples import EXAMPLES, MORE_EXAMPLES, metrics_recorder, replay_markers
from tests.contract import new_context, output_values, simulate, state_values, values_equal


def recorded(example, context):
    if isinstance(example.system, MetricsRecorder):
        return example.system.log(context)
    return state_values(context)


@pytest.mark.parametrize("factory", [metrics_recorder, replay_markers], ids=lambda f: f.__name__)
def test_recording_systems_keep_their_runs_in_their_contexts(factory):
    example = factory()
    assert example.system.num_output_ports() == 0
    context_a = new_context(example, example.inputs_a)
    context_b = new_context(example, example.inputs_b)
    sim_a, sim_b = Simulator(example.system, context_a), Simulator(example.system, context_b)
    sim_a.Initialize()
    sim_b.Initialize()
    for k in range(1, 5):
        sim_a.AdvanceTo(example.duration * k / 4)
        sim_b.AdvanceTo(example.duration * k / 4)
    alone = new_context(example, example.inputs_a)
    simulator = simulate(example, alone, example.duration)
    first = recorded(example, alone)
    assert values_equal(first, recorded(example, context_a)), "a context run alone vs beside another"
    assert not values_equal(recorded(example, context_a), recorded(example, context_b)), (
        "the example's two input sets record the same run: it cannot catch shared state"
    )
    # Reading the record changes nothing; a restart on a reset context records the same run.
    before = state_values(alone)
    assert values_equal(first, recorded(example, alone))
    assert all(x is y for x, y in zip(before, state_values(alone), strict=True))
    alone.SetTime(0.0)
    example.system.SetDefaultContext(alone)
    simulator.Initialize()
    simulator.AdvanceTo(example.duration)
    assert values_equal(first, recorded(example, alone)), "after a restart on a reset context"


def test_human_capsules_from_points_match_the_body_model():
    """The "points" source (a recorded skeleton) gives the capsules of the "q" source through
    the same pose, and both examples' input sets give different capsules."""
    q_example = EXAMPLES[HumanCapsules]()
    p_example = MORE_EXAMPLES["human_capsules_from_points"]()
    outs = []
    for inputs in ("inputs_a", "inputs_b"):
        q_out = output_values(q_example, new_context(q_example, getattr(q_example, inputs)))
        p_out = output_values(p_example, new_context(p_example, getattr(p_example, inputs)))
        np.testing.assert_array_equal(q_out["points"], p_out["points"])
        for x, y in zip(q_out["capsules"], p_out["capsules"], strict=True):
            np.testing.assert_allclose(x, y, atol=1e-12)
        outs.append(p_out["capsules"])
    assert not np.allclose(outs[0].start, outs[1].start)


def test_a_decimated_trace_keeps_evenly_spaced_samples_within_its_capacity():
    trace = DecimatedTrace(capacity=8)
    for k in range(1000):
        trace = trace.offer(k)
        kept = list(trace)
        assert 0 < len(kept) < 8 and kept[0] == 0
        assert kept == list(range(0, k + 1, trace.stride))[: len(kept)], k
        assert kept[-1] > k - 2 * trace.stride  # the newest kept sample is at most one step old
    assert trace.stride == 256 and len(trace) == 4 and trace.offered == 1000


def test_sample_stats_are_exact_over_every_sample():
    stats = SampleStats()
    for distance, override in ((0.4, 1.0), (np.inf, 0.5), (-0.02, 0.0), (0.3, 0.5)):
        stats = stats.add(distance, override)
    assert (stats.count, stats.min_distance, stats.override_sum) == (4, -0.02, 2.0)


def test_the_recorder_thins_its_samples_but_not_its_figures():
    """With room for 8 samples, a 5 s run at 0.1 s keeps 7 evenly spaced ones; the figures
    count all 51 samples."""
    example = metrics_recorder()
    bounded = MetricsRecorder(period=0.1, max_samples=8)
    context = bounded.CreateDefaultContext()
    for name, value in example.inputs_a.items():
        port = bounded.GetInputPort(name)
        if isinstance(value, list) or isinstance(value, np.ndarray):
            port.FixValue(context, np.asarray(value, dtype=float))
        else:
            port.FixValue(context, AbstractValue.Make(value))
    simulator = Simulator(bounded, context)
    simulator.AdvanceTo(5.0)
    log = bounded.log(context)
    assert len(log.times) == 7 and log.sample_stride == 8  # samples 0, 8, ..., 48 of 0..50
    np.testing.assert_allclose(np.diff(log.times), 0.1 * log.sample_stride)
    assert log.stats.count == 51
    assert np.isfinite(log.stats.min_distance) and log.stats.override_sum == 51.0
    full = summarize(log, 5.0, ["human"], {})
    assert full["mean_speed_override"] == 1.0
    assert full["min_human_robot_distance"] == round(min(log.distances), 4)


def test_robot_capsules_given_again_while_the_positions_stay_the_same():
    """RobotCapsules keeps the last positions' capsules: the same value while they stay, a fresh
    computation's as soon as they change (two contexts taking turns)."""
    from tests.cell.system_examples import _irb140, robot_capsules

    example = robot_capsules()
    system = example.system
    plant, kinematics = _irb140()
    scratch = plant.CreateDefaultContext()
    contexts = [new_context(example, example.inputs_a), new_context(example, example.inputs_b)]
    port = system.get_output_port()
    seen = []
    for turn in (0, 1, 1, 0, 0, 1):
        value = port.Eval(contexts[turn])
        q = system.get_input_port().Eval(contexts[turn])[: plant.num_positions()]
        plant.SetPositions(scratch, q)
        for x, y in zip(value, kinematics.capsules(scratch), strict=True):
            np.testing.assert_array_equal(x, y)
        seen.append(value)
    outputs = [AbstractValue.Make(seen[0]) for _ in range(2)]
    for output in outputs:
        system._calc(contexts[0], output)
    assert outputs[0].get_value() is outputs[1].get_value()  # unchanged positions: the kept value
