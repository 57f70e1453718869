"""Contract examples of the human systems (see tests/contract.py)."""

import numpy as np
from pydrake.systems.sensors import ImageDepth32F

from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import DepthCameraModel, RenderedCameraModel
from hrc_drake.human.operator import OperatorTask, SyntheticOperator
from hrc_drake.human.systems import (
    DepthCamera,
    OperatorSource,
    RecordedSkeletonSource,
    RenderedSkeletonCamera,
)
from hrc_drake.messages import HUMAN_AGENT, Capsules, WorldSnapshot, no_capsules
from tests.contract import SystemExample


def _operator() -> SyntheticOperator:
    """A one-action operator (as in tests/human/test_human_systems.py) with short actions."""
    body = BodyModel()
    tasks = {"pick": OperatorTask("pick", [np.array([0.65, 0.3, 0.8]), np.array([0.6, 0.0, 0.8])], "right",
                                  lambda rng: 0.3)}
    return SyntheticOperator(body, tasks, ["pick"], body.rest_q((1.05, 0.0), np.pi), np.random.default_rng(0))


def operator_source() -> SystemExample:
    """A: no world (every action starts at once: the operator reaches and emits begin/end);
    B: a world that refuses every start request (the operator asks, then waits at rest)."""
    system = OperatorSource(_operator(), rate=50.0)
    refusing = WorldSnapshot(time=0.0, buffers={"raw": 0}, activity={HUMAN_AGENT: "idle"},
                             refused={HUMAN_AGENT: 10**6})
    return SystemExample(system, {}, {"world": refusing}, duration=0.5)


def operator_source_granting() -> SystemExample:
    """A world granting every request against one refusing them (the request protocol)."""
    system = OperatorSource(_operator(), rate=50.0)
    granting = WorldSnapshot(time=0.0, buffers={"raw": 1}, activity={HUMAN_AGENT: "idle"},
                             granted={HUMAN_AGENT: 10**6})
    refusing = WorldSnapshot(time=0.0, buffers={"raw": 0}, activity={HUMAN_AGENT: "idle"},
                             refused={HUMAN_AGENT: 10**6})
    return SystemExample(system, {"world": granting}, {"world": refusing}, duration=0.5)


def _recording():
    times = np.linspace(0.0, 1.0, 11)
    body = BodyModel()
    rest = body.points(body.rest_q((1.0, 0.0), np.pi))
    points = rest[None] + np.linspace(0.0, 0.2, 11)[:, None, None] * np.array([1.0, 0.0, 0.0])
    tracked = np.ones((11, 8), dtype=bool)
    tracked[4:7, 6] = False  # the left wrist lost for a while: held at its last tracked value
    return times, points, tracked


def recorded_skeleton_source() -> SystemExample:
    """No inputs and no state: every output is a function of the context's time only, so two
    contexts run to the same time cannot differ (inputs_matter=False). The test still checks
    that the outputs are pure and that a restart reproduces them."""
    system = RecordedSkeletonSource(*_recording())
    return SystemExample(system, {}, {}, duration=0.45, inputs_matter=False)


def depth_camera() -> SystemExample:
    """A: the operator in plain view; B: a fat capsule (a robot link) between camera and operator
    hides every point."""
    body = BodyModel()
    model = DepthCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0], [], noise_std=0.005, rate=30.0)
    system = DepthCamera(model, rng_seed=3)
    skeleton = body.points(body.rest_q((1.05, 0.0), np.pi)).ravel()
    gaze = np.array([-1.0, 0.0, 0.0])
    wall = Capsules(np.array([[0.2, -1.0, 1.2]]), np.array([[0.2, 1.0, 1.2]]), np.array([0.6]))
    return SystemExample(
        system,
        {"skeleton": skeleton, "gaze": gaze, "occluding_capsules": no_capsules()},
        {"skeleton": skeleton, "gaze": gaze, "occluding_capsules": wall},
        duration=0.2,
    )


def depth_image(depth, width: int = 64, height: int = 48) -> ImageDepth32F:
    """A depth image (m) of one value everywhere."""
    image = ImageDepth32F(width, height)
    image.mutable_data[:] = depth
    return image


def rendered_skeleton_camera() -> SystemExample:
    """A: an empty depth image (nothing in range: every point in view is seen, with jitter);
    B: a wall 0.6 m from the camera hides every point."""
    body = BodyModel()
    model = RenderedCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0], width=64, height=48, rate=30.0)
    system = RenderedSkeletonCamera(model, rng_seed=3)
    skeleton = body.points(body.rest_q((1.05, 0.0), np.pi)).ravel()
    gaze = np.array([-1.0, 0.0, 0.0])
    return SystemExample(
        system,
        {"skeleton": skeleton, "gaze": gaze, "depth_image": depth_image(np.inf)},
        {"skeleton": skeleton, "gaze": gaze, "depth_image": depth_image(0.6)},
        duration=0.2,
    )


EXAMPLES = {
    RenderedSkeletonCamera: rendered_skeleton_camera,
    OperatorSource: operator_source,
    RecordedSkeletonSource: recorded_skeleton_source,
    DepthCamera: depth_camera,
}
#: More examples of one class (the contract test takes one per class).
MORE_EXAMPLES = {"operator_granting": operator_source_granting}
