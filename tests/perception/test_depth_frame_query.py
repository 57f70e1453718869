"""The tracker's L_c1 (eq. 9.10) reads the rendered camera's depth image when it is given one
(issue 15 item 1), never the analytic test."""

import numpy as np
import pytest

pytest.importorskip("pydrake")

from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder  # noqa: E402

from hrc_drake.human.camera import RenderedCameraModel  # noqa: E402
from hrc_drake.messages import L_WRIST  # noqa: E402
from hrc_drake.perception.config import ParticleFilterTracker  # noqa: E402
from hrc_drake.perception.systems import OcclusionTracker  # noqa: E402
from tests.perception.test_systems import POSE, FrameSource  # noqa: E402


def test_the_tracker_reads_the_depth_image_it_is_given():
    """A wall 1.1 m from a camera looking along +x hides x > 0.13 (tolerance 0.03): the lost
    wrist's particles stay there; the analytic `is_hidden` is never called."""
    model = RenderedCameraModel([-1.0, 0.0, 1.2], [0.0, 0.0, 1.2], width=64, height=48, depth_tolerance=0.03)
    depth = model.depth_frame(0.0, np.full((48, 64), 1.1, dtype=np.float32))

    def analytic(points, capsules=None):
        raise AssertionError("the tracker used the analytic camera's test")

    builder = DiagramBuilder()
    source = builder.AddSystem(FrameSource())
    tracker = builder.AddSystem(OcclusionTracker(ParticleFilterTracker(particles=200), analytic,
                                                 [0.6, 0.2, 1.1], [0.5, 0.6, 0.6], rate=30.0, seed=1))
    builder.Connect(source.get_output_port(), tracker.GetInputPort("skeleton_frame"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = tracker.GetMyContextFromRoot(simulator.get_mutable_context())
    tracker.GetInputPort("depth_frame").FixValue(context, AbstractValue.Make(depth))
    simulator.AdvanceTo(0.6)
    est = tracker.GetOutputPort("skeleton_estimate").Eval(context)
    assert not est.tracked[L_WRIST]
    hidden = depth.is_hidden(est.particles[L_WRIST])
    assert hidden.mean() > 0.95
    assert np.linalg.norm(est.points[L_WRIST] - POSE[L_WRIST]) < 0.2
