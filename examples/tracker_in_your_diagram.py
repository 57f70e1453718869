"""One system alone in your own Diagram: the occlusion-aware particle filter (thesis Ch. 9) fed
by a real recording (the KTH hand-over giver, shipped in data/), its estimate logged by Drake's
`VectorLogSink`.

    python3 examples/tracker_in_your_diagram.py

Prints how far the estimate stays from the recorded wrist while it is hidden for a second, beside
holding its last seen position.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import LogVectorOutput

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hrc_drake.datasets import dataset_dir  # noqa: E402
from hrc_drake.human.importers import Placement, place_in_cell, read_kth, resample, synthesize_missing  # noqa: E402
from hrc_drake.human.systems import RecordedSkeletonSource  # noqa: E402
from hrc_drake.messages import R_WRIST, SkeletonEstimate  # noqa: E402
from hrc_drake.perception.config import ParticleFilterTracker  # noqa: E402
from hrc_drake.perception.systems import OcclusionTracker  # noqa: E402

RATE = 30.0


class EstimatePoints(LeafSystem):
    """The estimate's 8 mean points as a 24-vector, so a `VectorLogSink` can record them."""

    def __init__(self):
        super().__init__()
        self._estimate = self.DeclareAbstractInputPort("skeleton_estimate", _abstract(SkeletonEstimate()))
        self.DeclareVectorOutputPort("points", BasicVector(24), self._calc)

    def _calc(self, context, output):
        output.SetFromVector(np.nan_to_num(self._estimate.Eval(context).points).ravel())


def _abstract(value):
    from pydrake.common.value import AbstractValue

    return AbstractValue.Make(value)


def hidden_wrist_recording(seconds: float = 4.0):
    """The giver's skeleton at the camera rate, in a cell frame, its right wrist hidden 2-3 s."""
    recording = read_kth(dataset_dir("kth_handover"), "giver")
    placed, _, _ = place_in_cell(synthesize_missing(recording), Placement())
    placed = resample(placed, RATE)
    keep = placed.times <= seconds
    times, truth, tracked = placed.times[keep], placed.points[keep], placed.tracked[keep].copy()
    hidden = (times >= 2.0) & (times < 3.0)
    tracked[hidden, R_WRIST] = False
    return times, truth, tracked, hidden


def main() -> dict:
    times, truth, tracked, hidden = hidden_wrist_recording()
    builder = DiagramBuilder()
    source = builder.AddSystem(RecordedSkeletonSource(times, truth, tracked))
    # is_hidden answers the depth-map test L_c1 of eq. (9.10); None: no depth constraint
    tracker = builder.AddSystem(OcclusionTracker(ParticleFilterTracker(particles=200), is_hidden=None,
                                                 workspace_center=np.zeros(3),
                                                 workspace_size=np.array([0.6, 0.8, 0.6]), rate=RATE, seed=1))
    points = builder.AddSystem(EstimatePoints())
    builder.Connect(source.GetOutputPort("skeleton_frame"), tracker.GetInputPort("skeleton_frame"))
    builder.Connect(tracker.GetOutputPort("skeleton_estimate"), points.get_input_port())
    logger = LogVectorOutput(points.get_output_port(), builder, publish_period=1.0 / RATE)
    diagram = builder.Build()

    simulator = Simulator(diagram)
    simulator.AdvanceTo(float(times[-1]))
    log = logger.FindLog(simulator.get_context())
    wrist = log.data().T.reshape(-1, 8, 3)[:, R_WRIST]
    at = np.clip(np.searchsorted(times, log.sample_times(), side="right") - 1, 0, len(times) - 1)
    error = np.linalg.norm(wrist - truth[at, R_WRIST], axis=1)
    while_hidden = hidden[at] & np.isfinite(error)
    last_seen = truth[np.flatnonzero(~hidden)[np.flatnonzero(~hidden) < np.argmax(hidden)][-1], R_WRIST]
    held = np.linalg.norm(truth[at, R_WRIST] - last_seen, axis=1)  # holding the last seen position
    result = {"samples": int(len(error)), "hidden_samples": int(while_hidden.sum()),
              "wrist_error_hidden_median_m": float(np.median(error[while_hidden])),
              "hold_error_hidden_median_m": float(np.median(held[while_hidden]))}
    print(f"{result['samples']} estimates logged; right wrist hidden in {result['hidden_samples']}: "
          f"median error {result['wrist_error_hidden_median_m']:.3f} m (holding the last seen "
          f"position: {result['hold_error_hidden_median_m']:.3f} m)")
    return result


if __name__ == "__main__":
    main()
