"""The safety controller and monitor as Drake systems, and in a whole cell."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantValueSource, MatrixGain

from hrc_drake.human.body import BodyModel
from hrc_drake.messages import (
    L_WRIST,
    R_WRIST,
    Capsules,
    PathRequest,
    SkeletonEstimate,
    SkeletonFrame,
    SweptVolumes,
    no_capsules,
)
from hrc_drake.robots.path import JointPathFollower
from hrc_drake.robots.systems import PathFollower
from hrc_drake.safety.config import Hybrid
from hrc_drake.safety.judge import VIOLATION_KINDS
from hrc_drake.safety.regions import BODY_CAPSULES, RegionCapsules
from hrc_drake.safety.rules import SafetyRules
from hrc_drake.safety.systems import (
    ContactSensing,
    HumanRegions,
    RobotPointDynamics,
    SafetyController,
    SafetyMonitor,
)
from tests.contract import SystemExample, new_context
from tests.safety.arms import two_link_arm, two_link_kinematics
from tests.safety.system_examples import (
    ZONES,
    _operator,
    _setup,
    monitor_judge,
    safety_controller,
    safety_monitor,
)

REPO = Path(__file__).resolve().parents[2]


def _run(example, inputs, duration=0.3):
    context = new_context(example, inputs)
    simulator = Simulator(example.system, context)
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return context


def test_the_controller_slows_near_the_operator_and_not_far_from_him():
    example = safety_controller()
    near = _run(example, example.inputs_a)
    far = _run(example, example.inputs_b)
    override = example.system.GetOutputPort("speed_override")
    assert override.Eval(far)[0] == pytest.approx(1.0)
    assert override.Eval(near)[0] < 1.0


def test_the_controller_holds_the_robot_until_it_has_seen_the_operator():
    example = safety_controller()
    unseen = {**example.inputs_b, "skeleton_estimate": SkeletonEstimate(points=np.full((8, 3), np.nan))}
    context = _run(example, unseen, duration=0.5)
    assert example.system.GetOutputPort("speed_override").Eval(context)[0] < 1.0
    status = example.system.GetOutputPort("status").Eval(context)
    assert status[1] == 0.0  # the command is a stop
    assert example.system.protective_stops(context) == 1


def test_the_requested_override_is_layered_under_the_safety_limit():
    example = safety_controller()
    # the thesis's own rule asks for 0.3: the robot brakes to it at the stopping model's rate
    context = _run(example, {**example.inputs_b, "requested_override": [0.3]}, duration=1.0)
    assert example.system.GetOutputPort("speed_override").Eval(context)[0] == pytest.approx(0.3)
    # the thesis's rule is no safety command: braking to it is not a protective stop
    assert example.system.protective_stops(context) == 0


def test_the_override_falls_no_faster_than_the_stopping_model():
    example = safety_controller()
    system = example.system
    context = _run(example, example.inputs_b, duration=0.1)
    assert system.GetOutputPort("speed_override").Eval(context)[0] == pytest.approx(1.0)
    # the operator appears near the arm's tip: the command drops (to 0.10), the applied override
    # only by a dt / v
    _, near, _ = _operator(2.4)
    system.GetInputPort("skeleton_estimate").FixValue(context, SkeletonEstimate(points=near))
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.1 + 1.0 / 30.0 + 1e-9)
    status = system.GetOutputPort("status").Eval(context)
    fastest = 1.5 * abs(1.0 + 0.8 * np.exp(0.3j))  # the tip at 1.5 rad/s on its lever (q2 = 0.3)
    step = 5.0 / 30.0 / fastest  # a dt / v_max: what one 30 Hz period may take off
    assert status[1] < status[0]
    # the update at t = 0.1 s (processed on leaving it) and the one at 0.133 s
    assert 1.0 - 2 * step - 1e-6 <= status[0] <= 1.0 - step + 1e-6
    # the command is below what braking reaches in a period: the robot is inside S_p at its speed,
    # so this is a protective stop (ISO/TS 15066 5.5.4), counted once, braking toward 0
    assert status[1] > 0.0 and status[1] < 1.0 - step
    assert status[3] == 1.0 and system.protective_stops(context) == 1


def test_a_command_the_braking_reaches_is_a_speed_reduction_not_a_stop():
    example = safety_controller()
    system = example.system
    slower = {**example.inputs_b, "velocities_full": [0.2, 0.0]}
    context = _run(example, slower, duration=0.1)
    # the operator nearer: a command below 1 (0.76), within one period's braking (0.47)
    _, nearer, _ = _operator(2.4)
    system.GetInputPort("skeleton_estimate").FixValue(context, SkeletonEstimate(points=nearer))
    Simulator(system, context).AdvanceTo(0.1 + 1.0 / 30.0 + 1e-9)
    status = system.GetOutputPort("status").Eval(context)
    fastest = 0.2 * abs(1.0 + 0.8 * np.exp(0.3j))
    step = 5.0 / 30.0 / fastest
    assert 1.0 - step < status[1] < 1.0  # slowed, by less than a period's braking
    assert status[0] == pytest.approx(status[1])
    assert status[3] == 0.0 and system.protective_stops(context) == 0


def test_two_monitor_contexts_keep_their_own_runs():
    example = safety_monitor()
    a, b = _run(example, example.inputs_a), _run(example, example.inputs_b)
    run_a, run_b = example.system.run(a), example.system.run(b)
    assert run_a.samples == run_b.samples == 10
    # trace rows: (time, min clearance, clearance and S_p of the SSM pair nearest its S_p, in breach)
    assert all(len(row) == 5 for row in (*run_a.trace, *run_b.trace))
    trace_a = [row[1] for row in run_a.trace]
    trace_b = [row[1] for row in run_b.trace]
    assert max(trace_a) < 0.0 < min(trace_b)  # the near operator overlaps the arm, the far one does not
    assert not any(row[4] for row in (*run_a.trace, *run_b.trace))  # the arm rests: never a breach
    # the arm rests (fixed positions) inside the near operator's reach: its contacts are logged, but
    # the robot's motion made none of them, so none is a violation; the far operator is never touched
    near, far = example.system.summary(a), example.system.summary(b)
    assert near["mode"] == "hybrid" and near["contact_count"] >= 1 and near["violations_total"] == 0
    assert near["verdict_code"] == "safe" and near["verdict"].startswith("SAFE: ISO/TS 15066 hybrid")
    assert all(c["kind"] == "contact" and not c["violation"] for c in near["contacts"])
    assert near["closest_approach_m"] == pytest.approx(min(trace_a), abs=1e-4)
    assert [e.kind for e in example.system.episodes(a)] == ["contact"] * near["contact_count"]
    assert far["contact_count"] == 0 and far["violations_total"] == 0 and far["verdict_code"] == "safe"
    assert far["closest_approach_m"] == pytest.approx(min(trace_b), abs=1e-4)
    # every skeleton point was measured at every sample
    assert near["unobserved_s"] == far["unobserved_s"] == 0.0


@pytest.mark.slow
def test_a_cell_reports_its_safety_verdict_and_writes_the_safety_report(tmp_path):
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate, write_report
    from hrc_drake.cell.scenario import load_scenario

    path = REPO / "diagrams" / "torch_clock.yaml"
    scenario = load_scenario(path)
    cell = build_cell(scenario, path)
    result = simulate(cell, 20.0, progress=None)
    safety = result.metrics["safety"]
    for key in ("mode", "verdict_code", "verdict", "violations", "violations_total", "ssm_breach_s",
                "margin_m", "worst_ratio", "protective_stops", "stops_measured", "stop_ratio_worst",
                "unobserved_s", "closest_approach_m", "events", "contacts", "contact_count", "judge",
                "safety_distance"):
        assert key in safety
    assert "time_below_sp_moving_s" not in safety
    assert safety["mode"] == "pfl"  # its declared mode since issue 52
    assert set(safety["violations"]) == set(VIOLATION_KINDS)
    assert safety["violations_total"] == sum(safety["violations"].values()) == len(safety["events"])
    # torch_clock's PFL mode is conforming: safe or unsafe by the standard judge's count
    assert safety["verdict_code"] == ("unsafe" if safety["violations_total"] else "safe")
    if safety["violations_total"]:
        assert safety["verdict"].startswith("UNSAFE: ISO/TS 15066 pfl, conforming judge: ")
        assert f"{safety['violations_total']} violation" in safety["verdict"]
    else:
        assert safety["verdict"].startswith("SAFE: ISO/TS 15066 pfl, conforming judge, 0 violations")
    paths = write_report(cell, result, tmp_path)
    assert (tmp_path / "safety.png") in paths and (tmp_path / "safety.png").stat().st_size > 10_000
    assert json.loads((tmp_path / "metrics.json").read_text())["safety"]["mode"] == "pfl"


def test_the_controller_keeps_the_separation_at_its_next_tick_where_the_path_turns_toward_the_operator():
    """Regression (issue 51, torch_clock_fuzzy seed 9): a path turning toward the face within one
    period raised the pair's approach before the next tick could answer; the judge found 2 cm of
    breach with no stop begun. The controller now also checks the state one period of path ahead."""
    example = safety_controller()
    system = example.system
    _, near, _ = _operator(2.4)
    at_corner = {**example.inputs_b, "skeleton_estimate": SkeletonEstimate(points=near),
                 "velocities_full": [0.0, 0.0]}  # the path at rest now (a corner), fast a period on
    turning = {**at_corner, "positions_full_next": [0.0, 0.3], "velocities_full_next": [1.5, 0.0]}
    command = system.GetOutputPort("status")
    present_only = _run(example, at_corner, duration=0.05)
    assert command.Eval(present_only)[1] == 1.0
    with_next = _run(example, turning, duration=0.05)
    # the same command as a controller whose present is that next state
    as_present = _run(example, {**at_corner, "velocities_full": [1.5, 0.0]}, duration=0.05)
    assert command.Eval(with_next)[1] == pytest.approx(command.Eval(as_present)[1], abs=1e-12)
    assert command.Eval(with_next)[1] < 0.5


def test_the_contact_sensing_reads_the_deepest_overlap_of_a_robot_link_with_the_body():
    """Link 2 of the two-link arm lies along x from (1, 0, 0.9) to (1.8, 0, 0.9), radius 0.05; a body
    capsule upright at (1.4, 0.09), radius 0.05: their axes 0.09 apart, 1 cm of overlap."""
    plant, _ = two_link_arm(height=0.9)
    system = ContactSensing(RobotPointDynamics(plant, two_link_kinematics(plant)), 2, 1.0 / 30.0)
    context = system.CreateDefaultContext()
    system.GetInputPort("positions").FixValue(context, [0.0, 0.0])
    body = Capsules(np.array([[1.4, 0.09, 0.5]]), np.array([[1.4, 0.09, 1.3]]), np.array([0.05]))
    system.GetInputPort("human_capsules").FixValue(context, body)
    Simulator(system, context).AdvanceTo(0.01)
    assert system.GetOutputPort("contact_depth").Eval(context)[0] == pytest.approx(0.01, abs=1e-12)
    clear = Capsules(np.array([[1.4, 0.2, 0.5]]), np.array([[1.4, 0.2, 1.3]]), np.array([0.05]))
    system.GetInputPort("human_capsules").FixValue(context, clear)
    Simulator(system, context).AdvanceTo(0.05)
    assert system.GetOutputPort("contact_depth").Eval(context)[0] == 0.0


def test_after_a_sensed_contact_the_robot_brakes_then_backs_off_along_its_path():
    """The operator far, the tip at 1.5 rad/s on its 1.766 m lever (2.649 m/s): a contact of 1 cm
    at t = 0.1 s. The robot brakes at 5 m/s^2 (a protective stop, counted once), then backs off
    with its fastest point at the retreat speed, 0.25 m/s: override -0.25 / 2.649. A robot whose
    path is at rest did not make the contact: it holds."""
    example = safety_controller()
    system = example.system
    context = _run(example, {**example.inputs_b, "contact_depth": [0.0]}, duration=0.1)
    assert system.GetOutputPort("speed_override").Eval(context)[0] == pytest.approx(1.0)
    system.GetInputPort("contact_depth").FixValue(context, [0.01])
    simulator = Simulator(system, context)
    fastest = 1.5 * abs(1.0 + 0.8 * np.exp(0.3j))
    simulator.AdvanceTo(0.1 + 1.0 / 30.0 + 1e-9)  # the updates at 0.1 and 0.133 s
    status = system.GetOutputPort("status").Eval(context)
    assert status[1] == pytest.approx(-0.25 / fastest)
    assert status[0] == pytest.approx(1.0 - 2 * 5.0 / 30.0 / fastest) and status[3] == 1.0
    simulator.AdvanceTo(1.0)
    status = system.GetOutputPort("status").Eval(context)
    assert status[0] == pytest.approx(-0.25 / fastest) and status[3] == 0.0
    assert system.protective_stops(context) == 1
    # the contact over: backing off ends retreat_time (0.3 s) after it, then forward again
    system.GetInputPort("contact_depth").FixValue(context, [0.0])
    simulator.AdvanceTo(1.5)
    assert system.GetOutputPort("speed_override").Eval(context)[0] > 0.0
    at_rest = _run(example, {**example.inputs_b, "velocities_full": [0.0, 0.0], "contact_depth": [0.01]},
                   duration=0.2)
    assert system.GetOutputPort("speed_override").Eval(at_rest)[0] == 0.0


def test_without_contact_reaction_the_robot_does_not_read_its_contact_sensing():
    config = Hybrid(position_uncertainty="fixed", contact_reaction=False)
    plant, kinematics, _, limits, _ = _setup()
    rules = SafetyRules(config, limits, RegionCapsules().regions, ZONES)
    body, _, _ = _operator(4.0)
    system = SafetyController(rules, RobotPointDynamics(plant, kinematics), HumanRegions(body, config), 2)
    example = safety_controller()
    context = new_context(SystemExample(system, example.inputs_b, example.inputs_b),
                          {**example.inputs_b, "contact_depth": [0.01]})
    Simulator(system, context).AdvanceTo(0.3)
    assert system.GetOutputPort("speed_override").Eval(context)[0] == pytest.approx(1.0)


def test_the_next_tick_is_checked_only_with_both_of_its_ports():
    """A diagram that connects only the next tick's positions (not its velocities) checks the
    present only (`apply_safety_config` connects both or neither)."""
    example = safety_controller()
    context = _run(example, {**example.inputs_b, "positions_full_next": [0.0, 0.3]}, duration=0.05)
    assert example.system.GetOutputPort("speed_override").Eval(context)[0] == 1.0


def test_a_robot_at_rest_that_is_touched_stays_at_rest():
    """The person made the contact (the robot's path moves, but the robot stands still: the thesis's
    rule asks for 0): it neither backs off nor moves on while touched (a robot moving under a face
    that leans on it is a violation), and it is a protective stop."""
    example = safety_controller()
    system = example.system
    context = _run(example, {**example.inputs_b, "requested_override": [0.0], "contact_depth": [0.0]},
                   duration=1.0)
    assert system.GetOutputPort("speed_override").Eval(context)[0] == 0.0
    system.GetInputPort("requested_override").FixValue(context, [1.0])
    system.GetInputPort("contact_depth").FixValue(context, [0.01])
    Simulator(system, context).AdvanceTo(1.5)
    status = system.GetOutputPort("status").Eval(context)
    assert status[0] == 0.0 and status[1] == 0.0 and status[3] == 1.0
    # the contact over, it moves on (forward: it did not make the contact)
    system.GetInputPort("contact_depth").FixValue(context, [0.0])
    Simulator(system, context).AdvanceTo(1.7)
    assert system.GetOutputPort("speed_override").Eval(context)[0] > 0.0


def test_a_contact_at_the_detection_threshold_is_not_sensed_and_just_past_it_is():
    """The edge of the contact detection (0.5 mm): at it the robot goes on at full speed; 0.01 mm
    deeper it brakes (a protective stop) toward backing off."""
    from hrc_drake.safety.systems import CONTACT_DETECTION

    example = safety_controller()
    system = example.system
    at_edge = _run(example, {**example.inputs_b, "contact_depth": [CONTACT_DETECTION]}, duration=0.2)
    assert system.GetOutputPort("speed_override").Eval(at_edge)[0] == 1.0
    assert CONTACT_DETECTION == 0.0005
    past = _run(example, {**example.inputs_b, "contact_depth": [0.00051]}, duration=0.2)
    status = system.GetOutputPort("status").Eval(past)
    assert status[1] < 0.0 and system.protective_stops(past) == 1


class _WalkingOperator(LeafSystem):
    """A scripted operator facing the robot (yaw pi) who walks along x from x0 to x1 between t0 and
    t1 s, then stands: outputs "estimate" (`SkeletonEstimate`, exact) and "capsules" (the truth)."""

    def __init__(self, x0: float, x1: float, t0: float, t1: float):
        super().__init__()
        self.body, self.x0, self.x1, self.t0, self.t1 = BodyModel(), x0, x1, t0, t1
        self.DeclareAbstractOutputPort("estimate", lambda: AbstractValue.Make(SkeletonEstimate()),
                                       lambda c, out: out.set_value(SkeletonEstimate(points=self.body.points(
                                           self._q(c.get_time())))))
        self.DeclareAbstractOutputPort("capsules", lambda: AbstractValue.Make(no_capsules()),
                                       lambda c, out: out.set_value(Capsules(*self.body.capsules(
                                           self._q(c.get_time())))))

    def _q(self, t: float):
        walked = min(max((t - self.t0) / (self.t1 - self.t0), 0.0), 1.0)
        return self.body.rest_q((self.x0 + walked * (self.x1 - self.x0), 0.0), np.pi)


def _swing_toward_operator(speed_profile: str, duration: float = 3.0):
    """The two-link arm's shoulder swings from -1.2 rad to 0 (1.5 rad/s at most: the tip 2.65 m/s)
    toward an operator who walks in from x = 3.5 to 2.6 m between 0.6 and 0.9 s: a path follower,
    the hybrid controller with `speed_profile`, and the judge. Returns (protective stops, judge's
    summary, shoulder angle at the end, time the shoulder first came within 1 mrad of 0)."""
    plant, kinematics, _, limits, _ = _setup()
    config = Hybrid(position_uncertainty="fixed", speed_profile=speed_profile)
    rules = SafetyRules(config, limits, RegionCapsules().regions, ZONES)
    dynamics = RobotPointDynamics(plant, kinematics)
    builder = DiagramBuilder()
    steps = config.preview_steps()
    follower = builder.AddSystem(PathFollower(
        JointPathFollower(np.array([-1.2, 0.0]), [np.arange(2)], [np.array([1.5, 1.5])],
                          velocity_fraction=1.0),
        period=1.0 / 30.0, hold_new_paths=True, preview_steps=steps, preview_step=config.preview_step))
    request = PathRequest(0, 1, np.array([[0.0, 0.0]]), np.array([0.0]))
    source = builder.AddSystem(ConstantValueSource(AbstractValue.Make((request,))))
    builder.Connect(source.get_output_port(), follower.GetInputPort("path_requests"))
    operator = builder.AddSystem(_WalkingOperator(3.5, 2.6, 0.6, 0.9))
    controller = builder.AddSystem(SafetyController(rules, dynamics, HumanRegions(operator.body, config), 2))
    for name in ("positions", "velocities_full", "positions_full_next", "velocities_full_next"):
        builder.Connect(follower.GetOutputPort(name), controller.GetInputPort(name))
    if steps:
        builder.Connect(follower.GetOutputPort("path_preview"), controller.GetInputPort("path_preview"))
    builder.Connect(operator.GetOutputPort("estimate"), controller.GetInputPort("skeleton_estimate"))
    builder.Connect(controller.GetOutputPort("speed_override"), follower.GetInputPort("speed_override"))
    monitor = builder.AddSystem(SafetyMonitor((monitor_judge(plant, kinematics, config),), dynamics, 2,
                                              1.0 / 30.0, "hybrid"))
    builder.Connect(operator.GetOutputPort("capsules"), monitor.GetInputPort("human_capsules"))
    builder.Connect(follower.GetOutputPort("positions"), monitor.GetInputPort("positions"))
    pick = np.zeros((1, 6))
    pick[0, 3] = 1.0  # the status's stopped flag
    stop = builder.AddSystem(MatrixGain(pick))
    builder.Connect(controller.GetOutputPort("status"), stop.get_input_port())
    builder.Connect(stop.get_output_port(), monitor.GetInputPort("protective_stop"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    arrived = None
    for tick in range(1, int(round(duration * 30)) + 1):
        simulator.AdvanceTo(tick / 30.0)
        shoulder = follower.GetOutputPort("positions").Eval(follower.GetMyContextFromRoot(root))[0]
        if arrived is None and shoulder > -1e-3:
            arrived = tick / 30.0
    stops = controller.protective_stops(controller.GetMyContextFromRoot(root))
    return stops, monitor.summary(monitor.GetMyContextFromRoot(root), stops), shoulder, arrived


def test_the_predictive_profile_keeps_s_p_without_the_stop_the_reactive_controller_makes():
    """Issue 52: the operator walks in while the arm swings toward him. The reactive controller's
    permissible speed falls faster than braking at 5 m/s^2 follows (a protective stop); the
    predictive profile saw the lower speed over the path ahead and slowed early at 2.5 m/s^2: no
    stop. The judge finds S_p kept on the truth in both, and both arms arrive."""
    reactive = _swing_toward_operator("reactive")
    predictive = _swing_toward_operator("predictive")
    assert reactive[0] >= 1 and predictive[0] == 0
    for _, summary, shoulder, arrived in (reactive, predictive):
        assert summary["violations_total"] == 0 and summary["verdict"].startswith("SAFE")
        assert shoulder == pytest.approx(0.0, abs=1e-9) and arrived is not None
    # slowing early costs little: it arrives within 0.3 s of the reactive arm
    assert predictive[3] - reactive[3] < 0.3


def test_the_predictive_profile_brakes_at_the_planning_deceleration_toward_the_speed_ahead():
    """The operator (at x = 2.4 m) far but for one preview sample: sample 2 (0.2 s of path ahead)
    puts link 2 where the rules allow o_2 (0.10). The profile allows sqrt(o_2^2 + 2 a_p tau_1 / V)
    now, tau_1 = 0.1 s (the sample before) and V the fastest point's speed at full path speed up
    to sample 2 (the tip: 1.5 rad/s on its lever, 2.649 m/s); held long enough, the override
    settles there."""
    plant, kinematics, _, limits, _ = _setup()
    config = Hybrid(position_uncertainty="fixed", speed_profile="predictive", preview_horizon=0.3)
    rules = SafetyRules(config, limits, RegionCapsules().regions, ZONES)
    body, near, _ = _operator(2.4)
    dynamics = RobotPointDynamics(plant, kinematics)
    system = SafetyController(rules, dynamics, HumanRegions(body, config), 2)
    far_q, near_q, velocity = [-1.5, 0.3], [0.0, 0.3], [1.5, 0.0]
    preview = np.concatenate([far_q, velocity, near_q, velocity, far_q, [0.0, 0.0]])
    inputs = {"positions": far_q, "velocities_full": velocity, "path_preview": preview,
              "skeleton_estimate": SkeletonEstimate(points=near)}
    context = new_context(SystemExample(system, inputs, inputs), inputs)
    Simulator(system, context).AdvanceTo(1.0)
    dynamics.set_state(near_q, velocity)
    robot, moved = dynamics.capsules()
    regions, z_d, lost = HumanRegions(body, config)(SkeletonEstimate(points=near))
    allowed, _ = rules.override(robot, moved, regions, z_d, dynamics.effective_mass, 0.0,
                                np.full((1, len(RegionCapsules())), -np.inf), 0.0, lost)
    fastest = 1.5 * abs(1.0 + 0.8 * np.exp(0.3j))
    expected = math.sqrt(allowed**2 + 2.0 * 2.5 * 0.1 / fastest)
    assert 0.0 < allowed and expected < 1.0
    status = system.GetOutputPort("status").Eval(context)
    assert status[1] == 1.0  # the present is free: the rules' command is 1, the profile slows
    assert status[0] == pytest.approx(expected, rel=1e-9) and status[3] == 0.0
    assert system.protective_stops(context) == 0
    # the reactive controller ignores the preview (it has no port for it)
    reactive = SafetyController(SafetyRules(Hybrid(position_uncertainty="fixed"), limits,
                                            RegionCapsules().regions, ZONES), dynamics,
                                HumanRegions(body, config), 2)
    assert reactive.GetInputPort("path_preview").size() == 0


def test_a_lost_head_rides_on_the_seen_thorax_and_a_lost_thorax_on_the_seen_head():
    """Camera Z_d (3 x 1 cm noise + 2.0 m/s x the time unseen): after 5 s a point the camera lost
    alone has Z_d 10.03 m; a head lost while the thorax is seen, or a thorax lost while the head is
    seen, is carried at their last measured offset, within the neck's 0.1 m (Z_d 0.13 m), and
    placed by the point that is seen (here the stale estimate is 1 m off). Both lost: uncapped."""
    config = Hybrid(position_uncertainty="camera")
    body, points, _ = _operator(2.0)
    regions = HumanRegions(body, config, camera_noise=0.01)
    cutter = RegionCapsules()
    offset = points[1] - points[0]
    torso = [cutter.names.index("abdomen"), cutter.names.index("chest")]
    face = cutter.names.index("face")

    def uncertainty(lost):
        stale = points.copy()
        stale[lost] += [1.0, 0.0, 0.0]  # where the camera last saw them
        unseen = np.zeros(8)
        unseen[lost] = 5.0
        capsules, z_d, _ = regions(SkeletonEstimate(points=stale), unseen, offset)
        return capsules, z_d

    truth = cutter.cut(*body.capsules_from_points(points))
    capsules, z_d = uncertainty([1])  # the head lost, the thorax seen
    assert z_d[face] == pytest.approx(0.03 + 0.1)
    np.testing.assert_allclose(capsules[1][face], truth[1][face])
    capsules, z_d = uncertainty([0])  # the thorax lost, the head seen
    np.testing.assert_allclose(z_d[torso], 0.03 + 0.1)
    np.testing.assert_allclose(capsules[0][torso], truth[0][torso])
    _, z_d = uncertainty([0, 1])  # both lost: nothing to carry them
    np.testing.assert_allclose(z_d[torso], 0.03 + 10.0)


@pytest.mark.parametrize("source", ["camera", "tracker"])
def test_the_age_of_a_measurement_grows_z_d_by_the_human_speed(source):
    """The judge holds S_p against the truth now; the controller's measurement is `age` s old, and
    a hand moves v_h = 2.0 m/s x age since (issue 52: a particle filter's estimate half a camera
    period old, 7 cm behind a hand at 2 m/s, let a robot 1.4 mm into S_p). By hand: camera Z_d
    3 x 1 cm + 2.0 x 1/60 s; tracker 3 x its spread (0.5 cm) + the same."""
    config = Hybrid(position_uncertainty=source)
    body, points, _ = _operator(2.0)
    regions = HumanRegions(body, config, camera_noise=0.01)
    estimate = SkeletonEstimate(points=points, spread=np.full(8, 0.005))
    _, fresh, _ = regions(estimate, np.zeros(8), None)
    _, aged, _ = regions(estimate, np.zeros(8), None, age=1.0 / 60.0)
    base = 0.03 if source == "camera" else 0.015
    np.testing.assert_allclose(fresh, base)
    np.testing.assert_allclose(aged, base + 2.0 / 60.0)
    # per point: only the regions whose points are old grow (the left wrist: the left hand)
    age = np.zeros(8)
    age[L_WRIST] = 0.1
    _, one, _ = regions(estimate, np.zeros(8), None, age=age)
    hand = RegionCapsules().names.index("left_hand")
    assert one[hand] == pytest.approx(base + 0.2)
    assert np.sum(one > base + 1e-12) < len(one) and one.min() == pytest.approx(base)


def test_the_controller_reads_the_camera_where_it_measured_and_the_estimate_elsewhere():
    """A tracker's estimate 10 cm behind the hand (and its small spread) against the camera's fresh
    frame: the controller's left wrist is the camera's, with the camera's Z_d; a point the camera
    lost, or a frame older than the estimate, leaves the estimate's."""
    example = safety_controller()
    system = example.system
    _, truth, _ = _operator(2.0)
    lagging = truth.copy()
    lagging[L_WRIST] += [0.1, 0.0, 0.0]
    estimate = SkeletonEstimate(time=0.95, points=lagging, spread=np.full(8, 0.002))
    tracked = np.ones(8, dtype=bool)
    tracked[R_WRIST] = False
    frame_points = truth.copy()
    frame_points[R_WRIST] = np.nan
    frame = SkeletonFrame(time=0.95, points=frame_points, tracked=tracked)
    inputs = {**example.inputs_b, "skeleton_estimate": estimate, "skeleton_frame": frame}
    context = new_context(example, inputs)
    merged, measured_at = system._measurement(context)
    np.testing.assert_allclose(merged.points[L_WRIST], truth[L_WRIST])
    np.testing.assert_allclose(merged.points[R_WRIST], lagging[R_WRIST])
    assert merged.spread[L_WRIST] == system.regions.camera_noise and merged.spread[R_WRIST] == 0.002
    np.testing.assert_allclose(measured_at, 0.95)
    system.GetInputPort("skeleton_frame").FixValue(context, replace(frame, time=0.9))  # older
    stale, _ = system._measurement(context)
    np.testing.assert_allclose(stale.points, lagging)


def test_the_profile_on_swept_volumes_slows_earlier_where_the_person_is_going():
    """Issue 52, item 1: with `preview_human: swept_volumes` the preview samples see the person
    where the motion model says they may be within its horizon (here 0.8 m closer than now), with
    the standard's S_h on top; the present's command is the same, the planned override lower."""
    plant, kinematics, _, limits, _ = _setup()
    body, now_points, _ = _operator(2.4)
    _, going_points, _ = _operator(1.6)
    start, end, radius = body.capsules_from_points(going_points)
    swept = SweptVolumes(names=BODY_CAPSULES, start=start, end=end, radius=radius, horizon=0.3)
    far_q, near_q, velocity = [-1.5, 0.3], [0.0, 0.3], [1.5, 0.0]
    preview = np.concatenate([far_q, velocity, near_q, velocity, far_q, [0.0, 0.0]])
    inputs = {"positions": far_q, "velocities_full": velocity, "path_preview": preview,
              "skeleton_estimate": SkeletonEstimate(points=now_points), "swept_volumes": swept}
    status = {}
    for where in ("present", "swept_volumes"):
        config = Hybrid(position_uncertainty="fixed", speed_profile="predictive", preview_horizon=0.3,
                        preview_human=where)
        rules = SafetyRules(config, limits, RegionCapsules().regions, ZONES)
        system = SafetyController(rules, RobotPointDynamics(plant, kinematics), HumanRegions(body, config), 2)
        context = new_context(SystemExample(system, inputs, inputs), inputs)
        Simulator(system, context).AdvanceTo(1.0)
        status[where] = system.GetOutputPort("status").Eval(context)
    assert status["present"][1] == status["swept_volumes"][1] == 1.0  # the present is free in both
    assert status["swept_volumes"][0] < status["present"][0] - 0.05


def test_swept_volumes_in_the_preview_cover_the_present_body():
    """A swept capsule that does not hold the present one is widened to hold both."""
    from hrc_drake.safety.systems import _union

    present = (np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]), np.array([0.1]))
    inside = (np.array([[0.0, 0.0, -0.1]]), np.array([[0.0, 0.0, 1.1]]), np.array([0.3]))
    np.testing.assert_allclose(_union(present, inside)[2], 0.3)
    away = (np.array([[1.0, 0.0, 0.0]]), np.array([[1.0, 0.0, 1.0]]), np.array([0.2]))
    np.testing.assert_allclose(_union(present, away)[2], 1.0 + 0.1)


def test_a_lost_point_s_time_unseen_already_covers_the_age():
    """A point unmeasured for 0.1 s grows v_h x 0.1 s; the age of the estimate (within that time)
    adds nothing (both run to now). By hand, camera source: 3 x 1 cm + 2.0 x 0.1 s."""
    config = Hybrid(position_uncertainty="camera")
    body, points, _ = _operator(2.0)
    regions = HumanRegions(body, config, camera_noise=0.01)
    unseen = np.zeros(8)
    unseen[L_WRIST] = 0.1
    _, z_d, _ = regions(SkeletonEstimate(points=points), unseen, None, age=1.0 / 60.0)
    hand = RegionCapsules().names.index("left_hand")
    assert z_d[hand] == pytest.approx(0.03 + 0.2)
    assert z_d.min() == pytest.approx(0.03 + 2.0 / 60.0)
