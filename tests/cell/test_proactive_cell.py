"""The proactive-path cell of thesis 8.2.4 (diagrams/box_usb_proactive.yaml): the planner fills
its databases, replans, and the robot follows the proactive path of r_1."""

from pathlib import Path

import numpy as np
import pytest

from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate
from hrc_drake.cell.scenario import Tagged, load_scenario_with

SCENARIO = Path(__file__).resolve().parents[2] / "diagrams" / "box_usb_proactive.yaml"


@pytest.mark.slow
def test_the_planner_replans_r1_and_the_robot_follows_it():
    # the planner of 8.2 alone: the cell's ISO/TS 15066 mode slows the robot's r_1 runs, so the
    # first replanning comes later than 270 s (tests/safety checks the modes)
    scenario = load_scenario_with(SCENARIO, {"safety": Tagged("NoSafety", {})})
    cell = build_cell(scenario, SCENARIO)
    result = simulate(cell, 270.0, progress=None)
    planner = cell.diagram.GetSubsystemByName("proactive_planner")
    core = planner.core(planner.GetMyContextFromRoot(result.context))
    assert core.ready and core.seq_ >= 1
    report = core.reports_[0]
    # P_RH's row of r_1 (eq. 8.22): the operator took covers from both buffers within the window
    assert all(0.0 <= w <= 1.0 for w in report.weights) and 0.0 < sum(report.weights) <= 1.0 + 1e-9
    # r_1's nominal path bows over buffer 2, inside the clouds' field: STOMP bends it away
    assert report.proactive_cost < 0.9 * report.nominal_cost
    assert np.max(np.abs(core.path_ - core.nominal)) > 0.1
    np.testing.assert_allclose(core.path_[[0, -1]], core.nominal[[0, -1]])
    paths = planner.GetOutputPort("proactive_paths").Eval(planner.GetMyContextFromRoot(result.context))
    assert paths.seq == core.seq_ and paths.by_action()[("yumi_left", "move_to_check_2")].shape == (42, 7)
    ends = [e.time for e in result.log.events
            if getattr(e, "action", "") == "move_to_check_2" and e.kind == "end"]
    assert any(t > report.time for t in ends)  # r_1 ran again after the replanning
    print(f"\nreplannings at {[round(r.time, 1) for r in core.reports_]} s, weights "
          f"{[r.weights for r in core.reports_]}, "
          f"J {report.nominal_cost:.1f} -> {report.proactive_cost:.1f}, "
          f"GPDM {report.gpdm_s:.2f} s, clouds {report.cloud_s:.2f} s, STOMP {report.stomp_s:.2f} s")
