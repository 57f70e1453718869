"""OcclusionTracker Drake system: ports, a short simulation, the speed override output."""

import numpy as np
import pytest

pytest.importorskip("pydrake")

from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder, LeafSystem  # noqa: E402

from hrc_drake.messages import L_WRIST, Capsules, SkeletonEstimate, SkeletonFrame  # noqa: E402
from hrc_drake.perception.config import HoldLastSeenTracker, KalmanTracker, ParticleFilterTracker  # noqa: E402
from hrc_drake.perception.systems import OcclusionTracker  # noqa: E402

POSE = np.array([
    [0.0, 0.0, 1.40], [0.0, 0.0, 1.65], [0.0, 0.2, 1.40], [0.0, -0.2, 1.40],
    [0.0, 0.2, 1.10], [0.0, -0.2, 1.10], [0.27, 0.2, 1.10], [0.27, -0.2, 1.10],
])


class FrameSource(LeafSystem):
    """Frames stamped with the current time; the left wrist is lost after 0.3 s."""

    def __init__(self):
        super().__init__()
        self.DeclareAbstractOutputPort("skeleton_frame", lambda: AbstractValue.Make(SkeletonFrame()),
                                       self._calc)

    def _calc(self, context, output):
        t = np.floor(context.get_time() * 30.0 + 1e-6) / 30.0  # the last camera tick
        pts = POSE.copy()
        if t > 0.3:
            pts[L_WRIST] = np.nan
        output.set_value(SkeletonFrame(time=t, points=pts, tracked=np.all(np.isfinite(pts), axis=1)))


@pytest.mark.parametrize("kind", ["particle_filter", "kalman"])
def test_tracker_in_a_diagram(kind):
    builder = DiagramBuilder()
    source = builder.AddSystem(FrameSource())
    calls = []

    def is_hidden(points, capsules=None):
        calls.append(capsules)
        return points[..., 0] > 0.15

    config = ParticleFilterTracker(particles=100) if kind == "particle_filter" else KalmanTracker()
    tracker = builder.AddSystem(OcclusionTracker(config, is_hidden, [0.6, 0.2, 1.1], [0.5, 0.6, 0.6],
                                                 rate=30.0, seed=1))
    builder.Connect(source.get_output_port(), tracker.GetInputPort("skeleton_frame"))
    heard = []
    tracker.listeners.append(lambda frame, estimate: heard.append((frame.time, estimate.time,
                                                                   bool(frame.tracked[L_WRIST]))))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    tracker_context = tracker.GetMyContextFromRoot(context)
    tracker.GetInputPort("occluding_capsules").FixValue(
        tracker_context, AbstractValue.Make(Capsules(np.zeros((1, 3)), np.ones((1, 3)), np.array([0.05]))))
    simulator.AdvanceTo(0.6)
    est = tracker.GetOutputPort("skeleton_estimate").Eval(tracker_context)
    assert isinstance(est, SkeletonEstimate)
    assert est.time == pytest.approx(0.6, abs=1 / 30 + 1e-9)
    assert not est.tracked[L_WRIST] and est.tracked[0]
    assert np.all(np.isfinite(est.points))
    assert est.particles.shape == (8, 50, 3) and np.all(np.isfinite(est.particles))
    # One call per new frame (updates at 1/60, 3/60, ... 35/60 s), each with its own frame's estimate.
    assert len(heard) == 18
    assert all(f == e for f, e, _ in heard)
    assert np.all(np.diff([f for f, _, _ in heard]) > 0)
    assert [seen for _, _, seen in heard] == [f <= 0.3 + 1e-9 for f, _, _ in heard]
    speed = tracker.GetOutputPort("speed_override").Eval(tracker_context)[0]
    assert speed in (0.3, 1.0)
    if kind == "particle_filter":
        # The hidden wrist stays on the crown around the elbow, out of the workspace box.
        assert speed == 1.0
        assert np.linalg.norm(est.points[L_WRIST] - POSE[L_WRIST]) < 0.2
        assert calls and calls[-1] is not None  # the capsules reached the depth query


@pytest.mark.parametrize("center, expected", [([0.27, 0.2, 1.1], 0.3), ([0.27, 0.2, 2.5], 1.0)])
def test_hold_last_seen_tracker_slows_on_the_held_point(center, expected):
    """HoldLastSeenTracker: the lost wrist stays where it was seen, and the slow-down rule of
    9.1.3 reads it (slow while it is inside the workspace box); core listeners see the core."""
    builder = DiagramBuilder()
    source = builder.AddSystem(FrameSource())
    box = np.array([0.1, 0.1, 0.1])  # a small box round the wrist's last seen point, or away from it
    tracker = builder.AddSystem(OcclusionTracker(HoldLastSeenTracker(), None, center, box, rate=30.0))
    builder.Connect(source.get_output_port(), tracker.GetInputPort("skeleton_frame"))
    regions = []
    tracker.core_listeners.append(lambda frame, core: regions.append(core.region_contains(POSE)[0][L_WRIST]))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.6)
    context = tracker.GetMyContextFromRoot(simulator.get_context())
    est = tracker.GetOutputPort("skeleton_estimate").Eval(context)
    assert not est.tracked[L_WRIST]
    np.testing.assert_allclose(est.points[L_WRIST], POSE[L_WRIST])
    assert tracker.GetOutputPort("speed_override").Eval(context)[0] == expected
    assert len(regions) == 18 and all(regions)


def test_shipped_tracker_campaign_loads_every_tracker_and_camera():
    """diagrams/campaigns/trackers.yaml: the !HoldLastSeenTracker tag and the kf2 / kf4 orders
    reach the scenarios (item 3 of issue 15)."""
    from pathlib import Path

    from hrc_drake.campaign.spec import load_campaign
    from hrc_drake.cell.scenario import load_scenario_with

    campaign = load_campaign(Path(__file__).resolve().parents[2] / "diagrams" / "campaigns" / "trackers.yaml")
    assert set(campaign.variants) == {"pf", "kf2", "kf4", "hold"}
    assert set(campaign.scenarios) == {"pcb_occlusion", "pcb_occlusion_rendered"}
    path = campaign.scenarios["pcb_occlusion"]
    assert isinstance(load_scenario_with(path, campaign.variants["hold"]).tracker, HoldLastSeenTracker)
    assert load_scenario_with(path, campaign.variants["kf2"]).tracker.order == 2
