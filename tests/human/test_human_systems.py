"""Drake adapters: OperatorSource + DepthCamera in a diagram, RecordedSkeletonSource."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.human.operator import OperatorTask, SyntheticOperator
from hrc_drake.human.systems import DepthCamera, OperatorSource, RecordedSkeletonSource
from hrc_drake.messages import EventLog, SkeletonFrame
from tests.human.system_examples import MORE_EXAMPLES


def build(capsules=None):
    body = BodyModel()
    tasks = {"pick": OperatorTask("pick", [np.array([0.65, 0.3, 0.8]), np.array([0.6, 0.0, 0.8])], "right",
                                  lambda rng: 0.8)}
    op = SyntheticOperator(body, tasks, ["pick"], body.rest_q((1.05, 0.0), np.pi), np.random.default_rng(0))
    builder = DiagramBuilder()
    source = builder.AddSystem(OperatorSource(op, rate=50.0))
    camera = builder.AddSystem(DepthCamera(DepthCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0], [],
                                                            noise_std=0.005, rate=30.0), rng_seed=3))
    builder.Connect(source.GetOutputPort("skeleton"), camera.GetInputPort("skeleton"))
    builder.Connect(source.GetOutputPort("gaze"), camera.GetInputPort("gaze"))
    if capsules is not None:
        const = builder.AddSystem(ConstantValueSource(AbstractValue.Make(capsules)))
        builder.Connect(const.get_output_port(0), camera.GetInputPort("occluding_capsules"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    return op, source, camera, simulator


def test_operator_and_camera_simulate_two_seconds():
    op, source, camera, simulator = build()
    context = simulator.get_mutable_context()
    cam_context = camera.GetMyContextFromRoot(context)
    first = camera.GetOutputPort("skeleton_frame").Eval(cam_context)
    assert first.time == 0.0 and first.tracked.all()
    simulator.AdvanceTo(2.0)
    src_context = source.GetMyContextFromRoot(context)
    op = source.operator(src_context)  # the run's operator lives in the context
    log = source.GetOutputPort("human_events").Eval(src_context)
    assert isinstance(log, EventLog)
    assert [(e.kind, e.time) for e in log.events[:3]] == [("begin", 0.0), ("end", 0.8), ("begin", 0.8)]
    assert [e.seq for e in log.since(1)] == list(range(2, len(log.events) + 1))
    skeleton = source.GetOutputPort("skeleton").Eval(src_context).reshape(8, 3)
    np.testing.assert_allclose(skeleton, op.points(2.0))
    np.testing.assert_allclose(source.GetOutputPort("q").Eval(src_context), op.q(2.0))
    np.testing.assert_allclose(source.GetOutputPort("gaze").Eval(src_context), op.gaze(2.0))
    frame = camera.GetOutputPort("skeleton_frame").Eval(camera.GetMyContextFromRoot(context))
    assert isinstance(frame, SkeletonFrame)
    assert frame.time == pytest.approx(2.0)
    assert frame.tracked.all()
    assert np.abs(frame.points - op.points(frame.time)).max() < 0.03
    head = op.points(frame.time)[1]
    to_camera = (np.array([-0.2, 0.0, 1.8]) - head) / np.linalg.norm(np.array([-0.2, 0.0, 1.8]) - head)
    assert frame.gaze_valid == (np.arccos(frame.gaze @ to_camera) <= 1.2)
    np.testing.assert_allclose(frame.gaze, op.gaze(frame.time), atol=1e-12)


def test_camera_capsule_input_hides_points():
    # a fat capsule between camera and operator hides everything
    capsules = (np.array([[0.2, -1.0, 1.2]]), np.array([[0.2, 1.0, 1.2]]), np.array([0.6]))
    _, _, camera, simulator = build(capsules)
    simulator.AdvanceTo(0.5)
    frame = camera.GetOutputPort("skeleton_frame").Eval(camera.GetMyContextFromRoot(simulator.get_context()))
    assert not frame.tracked.any() and np.all(np.isnan(frame.points))
    assert not frame.gaze_valid


def test_recorded_source():
    times = np.array([0.0, 0.5, 1.0])
    points = np.arange(72, dtype=float).reshape(3, 8, 3)
    tracked = np.ones((3, 8), dtype=bool)
    tracked[1, 2] = False
    source = RecordedSkeletonSource(times, points, tracked)
    context = source.CreateDefaultContext()
    for t, index in ((0.2, 0), (0.5, 1), (0.7, 1), (3.0, 2)):
        context.SetTime(t)
        frame = source.GetOutputPort("skeleton_frame").Eval(context)
        assert frame.time == times[index]
        np.testing.assert_array_equal(frame.tracked, tracked[index])
    context.SetTime(0.6)
    assert np.all(np.isnan(source.GetOutputPort("skeleton_frame").Eval(context).points[2]))
    with pytest.raises(ValueError, match="strictly increase"):
        RecordedSkeletonSource(times[::-1], points, tracked)
    with pytest.raises(ValueError, match="rate"):
        OperatorSource(None, rate=100.0)


def test_camera_frames_are_pure_and_reproducible():
    frames = []
    for _ in range(2):
        op, source, camera, simulator = build()
        simulator.AdvanceTo(1.0)
        context = camera.GetMyContextFromRoot(simulator.get_context())
        frames.append(camera.GetOutputPort("skeleton_frame").Eval(context))
    np.testing.assert_array_equal(frames[0].points, frames[1].points)
    # The frame is the pose at the context's time; within one frame period the noise is the same.
    op, source, camera, simulator = build()
    simulator.AdvanceTo(1.0)
    root = simulator.get_context()
    source_context = source.GetMyContextFromRoot(root)
    truth = source.GetOutputPort("skeleton").Eval(source_context).reshape(8, 3)
    frame = camera.GetOutputPort("skeleton_frame").Eval(camera.GetMyContextFromRoot(root))
    assert frame.time == pytest.approx(1.0)
    noise = frame.points - truth
    simulator.AdvanceTo(1.0 + 0.5 / 30.0)
    truth = source.GetOutputPort("skeleton").Eval(source_context).reshape(8, 3)
    later = camera.GetOutputPort("skeleton_frame").Eval(camera.GetMyContextFromRoot(root))
    np.testing.assert_allclose(later.points - truth, noise, atol=1e-12)
    simulator.AdvanceTo(1.0 + 1.5 / 30.0)
    truth = source.GetOutputPort("skeleton").Eval(source_context).reshape(8, 3)
    nxt = camera.GetOutputPort("skeleton_frame").Eval(camera.GetMyContextFromRoot(root))
    assert not np.allclose(nxt.points - truth, noise)


def test_operator_contexts_granted_and_refused_stay_independent():
    """The request protocol: a context whose world grants starts acting, one whose world refuses
    waits, even advanced in lockstep (the contract example with a granting world)."""
    example = MORE_EXAMPLES["operator_granting"]()
    source = example.system
    sims = []
    for inputs in (example.inputs_a, example.inputs_b):
        context = source.CreateDefaultContext()
        source.GetInputPort("world").FixValue(context, AbstractValue.Make(inputs["world"]))
        sims.append(Simulator(source, context))
        sims[-1].Initialize()
    for t in (0.1, 0.2, 0.5):
        for sim in sims:
            sim.AdvanceTo(t)
    granted, refused = (source.GetOutputPort("human_events").Eval(s.get_context()).events for s in sims)
    assert [e.kind for e in granted][:2] == ["begin", "end"]
    assert [e.kind for e in refused] == ["wait_begin"]
    requests = source.GetOutputPort("world_requests").Eval(sims[1].get_context()).events
    assert [(r.action, r.kind) for r in requests] == [("pick", "start")]
