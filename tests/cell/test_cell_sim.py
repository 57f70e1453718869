import json
import warnings

import numpy as np
import pytest

from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate
from hrc_drake.cell.scenario import Tagged, load_scenario, load_scenario_with
from hrc_drake.cli import main
from hrc_drake.messages import L_WRIST, R_WRIST


@pytest.fixture(scope="module")
def torch_run():
    from tests.conftest import DIAGRAMS

    path = DIAGRAMS / "torch_clock.yaml"
    # the cell's flow, not its safety: without the safety controller. Under it (the path braked on
    # its fastest point, T_s = V / a) the first product comes after 120 s (2 in 300 s, seed 7;
    # issue 52: safe and still fast)
    scenario = load_scenario_with(path, {"safety": Tagged("NoSafety", {})})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cell = build_cell(scenario, path)
        result = simulate(cell, 120.0, progress=None)
    return cell, result


def test_agents_work_and_wait(torch_run):
    cell, result = torch_run
    events = result.log.events
    by_agent = {}
    for e in events:
        by_agent.setdefault(getattr(e, "agent", "human"), []).append((e.action, e.kind))
    assert ("H1", "begin") in by_agent["human"] and ("H1", "end") in by_agent["human"]
    assert ("R1", "end") in by_agent["yumi_right"]
    assert ("L1", "end") in by_agent["yumi_left"]
    # Experiment B: the operator needs the dial (R3) for H4 and waits for it at some point.
    assert any(kind == "wait_begin" for _, kind in by_agent["human"])
    human_begins = [a for a, k in by_agent["human"] if k == "begin"]
    assert human_begins[:5] == ["H1", "H4", "H2", "H5", "H3"][: len(human_begins[:5])]
    assert result.metrics["products_finished"] >= 1
    assert result.metrics["agents"]["human"]["wait_time"] > 0


def test_operator_reaches_its_goals(torch_run):
    cell, result = torch_run
    points = np.array([x for x in result.log.human_points if x is not None]).reshape(-1, 8, 3)
    wrists = points[:, [L_WRIST, R_WRIST], :]
    goals = {b.name: np.asarray(b.position) + [0, 0, 0.06] for b in cell.scenario.layout.buffers}
    # Sampled at 10 Hz, the wrist passes within a few cm of every place it reaches in H1.
    for place in ("torch_front", "body_feeder", "torch_body"):
        closest = np.min(np.linalg.norm(wrists - goals[place], axis=-1))
        assert closest < 0.05, (place, closest)


def test_events_are_ordered_and_products_counted(torch_run):
    cell, result = torch_run
    ends = [e for e in result.log.events if e.kind == "end" and e.action in ("H3", "H5")]
    assert result.metrics["products_finished"] == len(ends)
    assert cell.world(result.context).finished_products == len(ends)
    assert result.metrics["realtime_factor"] > 0


def test_throughput_and_each_products_own_cycle_on_a_real_run(torch_run):
    """products per hour = products / duration x 3600; a torch's cycle runs from the first of R1
    (its front) and H2 (its batteries) to H3, a clock's from the first of R3 (dial) and L2
    (glass) to H5 (no part is in a buffer at t = 0: the first product takes the first parts)."""
    cell, result = torch_run
    m = result.metrics
    n = m["products_finished"]
    assert n >= 1 and m["products_per_hour"] == pytest.approx(n / 120.0 * 3600.0, abs=1e-3)
    assert sum(p["finished"] for p in m["products"].values()) == n

    def first(action: str, kind: str) -> float:
        return min(e.time for e in result.log.events if e.action == action and e.kind == kind)

    for product, starts, last in (("torch_out", ("R1", "H2"), "H3"), ("clock_out", ("R3", "L2"), "H5")):
        p = m["products"][product]
        assert len(p["cycle_times"]) == p["finished"]
        if p["finished"]:
            begun = min(first(a, "begin") for a in starts)
            assert p["cycle_times"][0] == pytest.approx(first(last, "end") - begun, abs=1e-3)
            assert p["cycle_time_median"] == pytest.approx(float(np.median(p["cycle_times"])), abs=1e-3)
    assert any(p["finished"] for p in m["products"].values())


def test_dynamic_mode_tracks_the_path(tmp_path):
    from tests.conftest import DIAGRAMS

    scenario = load_scenario(DIAGRAMS / "torch_clock.yaml")
    scenario.robots[0].mode = "dynamic"
    scenario.robots[0].time_step = 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cell = build_cell(scenario)
        from pydrake.systems.analysis import Simulator

        simulator = Simulator(cell.diagram)
        simulator.AdvanceTo(4.0)
    context = simulator.get_context()
    plant_context = cell.plant.GetMyContextFromRoot(context)
    follower = cell.diagram.GetSubsystemByName("path_follower")
    wanted = follower.GetOutputPort("positions").Eval(follower.GetMyContextFromRoot(context))
    actual = cell.plant.GetPositions(plant_context)
    assert np.max(np.abs(actual - wanted)) < 0.1
    # The right arm has left its home pose.
    executor = cell.executor
    assert any(e.kind == "begin" for e in executor.executor(executor.GetMyContextFromRoot(context)).events)


def test_simulate_command_writes_report_and_replay(tmp_path, diagrams_dir, capsys):
    out = tmp_path / "out"
    replay = tmp_path / "replay.html"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(
            [
                "simulate",
                str(diagrams_dir / "torch_clock.yaml"),
                "--duration",
                "12",
                "--seed",
                "3",
                "--out",
                str(out),
                "--replay",
                str(replay),
            ]
        )
    assert code == 0
    printed = capsys.readouterr().out
    for line in ("simulated time", "wall time", "realtime factor", "products per hour", "mean time between"):
        assert line in printed
    # the verdict first, then throughput and each type's cycle time, then the rest
    heads = ("SAFE", "UNSAFE", "NO SAFETY", "NON-", "products per hour", "  torch_out", "mean time between",
             "simulated time")
    lines = [line for line in printed.splitlines() if line.startswith(heads)]
    assert [line.split()[0] for line in lines[1:]] == ["products", "torch_out", "mean", "simulated"], lines
    assert lines[0].split()[0] in ("SAFE:", "UNSAFE:", "NO", "NON-CONFORMING:"), lines
    assert "mean cycle time" not in printed
    metrics = json.loads((out / "metrics.json").read_text())
    assert list(metrics)[:4] == ["run", "verdict", "products_per_hour", "products"]
    assert metrics["verdict"] == metrics["safety"]["verdict"] and "verdict" in metrics["definitions"]
    assert metrics["simulated_time"] == 12.0
    assert set(metrics["agents"]) == {"human", "yumi_right", "yumi_left"}
    assert (out / "events.csv").read_text().startswith("time,agent,action,kind,seq")
    assert (out / "gantt.png").stat().st_size > 10_000
    html = replay.read_text()
    assert html.startswith("<!DOCTYPE html>") or "<html" in html[:200]
    # the replay's card holds the run's verdict and products (issue 54, item 6)
    from html import escape

    card = html[html.index('id="hrc-verdict"'):html.index('id="hrc-legend"')]
    assert escape(metrics["safety"]["verdict"]) in card
    assert f"{metrics['products_finished']} products finished" in card
    assert "http://" not in html.split("<script", 1)[0]


def _quiet_build_and_run(scenario, path, duration):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cell = build_cell(scenario, path)
        result = simulate(cell, duration, progress=None)
    return cell, result


def test_a_cell_can_hold_a_yumi_and_an_irb140(diagrams_dir):
    from hrc_drake.config_common import Pose
    from hrc_drake.robots.config import Arm, NamedPose, Robot, RobotAction

    path = diagrams_dir / "torch_clock.yaml"
    scenario = load_scenario(path)
    scenario.robots.append(
        Robot(
            name="irb",
            model="irb140",
            base=Pose(xyz=[0.3, 1.0, 0.45], rpy=[0.0, 0.0, -1.5708]),
            poses=[
                NamedPose(name="irb_home", arm="arm", joints=[0.0, 0.0, 0.0, 0.0, 0.5, 0.0]),
                NamedPose(name="irb_drop", arm="arm", target=Pose(xyz=[0.3, 0.45, 0.85])),
            ],
            actions=[RobotAction(name="store", arm="arm", poses=["irb_drop", "irb_home"], dwell=0.5)],
            arms=[Arm(agent="irb140", arm="arm", home="irb_home", program=["store"])],
        )
    )
    cell, result = _quiet_build_and_run(scenario, path, 15.0)
    assert "irb140" in result.metrics["agents"]
    assert result.metrics["agents"]["irb140"]["actions_finished"] >= 2
    assert cell.plant.num_positions() == 2 * 7 + 4 + 6


def test_a_recorded_skeleton_replaces_the_operator(tmp_path, diagrams_dir):
    from hrc_drake.cell.scenario import Tagged, _raw_document, dump_raw  # tag-aware (the cells' !Hybrid)
    from hrc_drake.human.body import BodyModel
    from hrc_drake.human.recorded import save_skeleton_csv

    body = BodyModel()
    times = np.arange(0.0, 20.0, 1 / 30)
    q = np.tile(body.rest_q((1.0, 0.0), np.pi), (len(times), 1))
    q[:, 8] = 0.6 + 0.5 * np.sin(times)  # the right shoulder swings
    points = body.points(q)
    tracked = np.ones((len(times), 8), dtype=bool)
    tracked[100:130, 7] = False
    points[100:130, 7] = np.nan
    save_skeleton_csv(tmp_path / "skeleton.csv", times, points, tracked)
    raw = _raw_document((diagrams_dir / "torch_clock.yaml").read_text())
    raw["operator"]["recorded"] = "skeleton.csv"
    # the recording's plumbing alone: its swinging arm 0.3 m from the robot's path holds the
    # robot under the cell's ISO/TS 15066 mode (tests/safety run the modes)
    raw["safety"] = Tagged("NoSafety", {})
    (tmp_path / "cell.yaml").write_text(dump_raw(raw))
    scenario = load_scenario(tmp_path / "cell.yaml")
    cell, result = _quiet_build_and_run(scenario, tmp_path / "cell.yaml", 18.0)
    recorded = np.array([p for p in result.log.human_points if p is not None]).reshape(-1, 8, 3)
    assert np.all(np.isfinite(recorded))
    assert np.ptp(recorded[:, 7, 2]) > 0.1  # the recorded wrist moves in the cell
    assert result.metrics["agents"]["yumi_right"]["actions_finished"] >= 1
    raw["operator"]["recorded"] = "missing.csv"
    (tmp_path / "bad.yaml").write_text(dump_raw(raw))
    from hrc_drake.cell.scenario import ScenarioError

    with pytest.raises(ScenarioError, match="operator.recorded"):
        build_cell(load_scenario(tmp_path / "bad.yaml"), tmp_path / "bad.yaml")


def test_world_snapshot_reports_the_truth(torch_run):
    cell, result = torch_run
    snapshot = cell.diagram.GetOutputPort("world").Eval(result.context)
    world = cell.world(result.context)
    assert snapshot.buffers == world.parts
    assert snapshot.finished_products == world.finished_products > 0
    assert set(snapshot.activity) >= {"yumi_right", "yumi_left"}
