"""Actions of several agents in a cell (thesis 6.3.3 collaborations, Fig. 7.3 early release):
the world's rendezvous, the executor's parts, holds and revoked commands, the net's release
transitions, and use case a of 7.2.1 as a whole cell."""

import math

import numpy as np
import pytest

from hrc_drake.cell.scenario import ScenarioError, load_scenario
from hrc_drake.cell.world import CellWorld
from hrc_drake.distributions import Distribution
from hrc_drake.messages import RobotCommand, WorldRequest, WorldSnapshot
from hrc_drake.robots.executor import ArmAgent, RobotMove, TaskExecutor
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.tracker import NetTracker


def _world():
    buffers = [Buffer("raw", kind="raw"), Buffer("mid", capacity=1, initial=1), Buffer("out", kind="product")]
    actions = [FlowAction("together", ["h", "left", "right"], ["mid"], ["out"])]
    return CellWorld(buffers, actions)


def _req(t, agent, kind, seq, action="together", patience=math.inf):
    return WorldRequest(time=t, agent=agent, action=action, kind=kind, seq=seq, patience=patience)


def test_a_shared_action_starts_when_all_its_agents_ask_and_ends_with_the_last():
    world = _world()
    world.handle_requests([_req(0.0, "h", "start", 1), _req(0.0, "left", "start", 1)])
    assert not world.granted and world.refused == {"h": 1, "left": 1} and world.parts["mid"] == 1
    world.handle_requests([_req(1.0, "right", "start", 1)])
    # one rendezvous: the part is taken once, every agent is granted and runs the action
    assert world.granted == {"h": 1, "left": 1, "right": 1} and world.parts["mid"] == 0
    assert world.running == {"h": "together", "left": "together", "right": "together"}
    world.handle_requests([_req(2.0, "left", "finish", 2)])
    assert world.finished_products == 0 and world.snapshot(2.0).joint == {"together": ("h", "right")}
    world.handle_requests([_req(3.0, "h", "finish", 2)])
    assert world.finished_products == 0
    world.handle_requests([_req(4.0, "right", "finish", 2)])
    assert world.finished_products == 1 and not world.joint and not world.running
    assert world.completions[-1].time == 4.0


def test_a_partner_that_arrives_renews_the_patience_of_those_waiting():
    buffers = [Buffer("raw", kind="raw"), Buffer("mid", capacity=1), Buffer("out", kind="product")]
    world = CellWorld(buffers, [FlowAction("pair", ["left", "right"], ["mid"], ["out"])])
    world.handle_requests([_req(0.0, "left", "start", 1, action="pair", patience=5.0)])
    world.handle_requests([_req(4.0, "right", "start", 1, action="pair", patience=5.0)])  # no part yet
    assert world.next_deadline() == 9.0
    world.handle_requests([], now=6.0)
    assert not world.withdrawn and set(world.pending) == {"left", "right"}
    world.handle_requests([], now=9.0)
    assert world.withdrawn == {"left": 1, "right": 1}
    # an agent that waits for ever renews nobody
    world = CellWorld(buffers, [FlowAction("pair", ["left", "right"], ["mid"], ["out"])])
    world.handle_requests([_req(0.0, "left", "start", 1, action="pair", patience=5.0),
                           _req(4.0, "right", "start", 1, action="pair")])
    assert world.next_deadline() == 5.0


def test_a_start_is_withdrawn_after_its_patience_and_the_others_keep_waiting():
    world = _world()
    world.handle_requests([_req(0.0, "left", "start", 1, patience=5.0), _req(0.0, "right", "start", 1)])
    assert world.next_deadline() == 5.0
    world.handle_requests([], now=4.9)
    assert "left" in world.pending and not world.withdrawn
    world.handle_requests([], now=5.0)
    assert world.withdrawn == {"left": 1} and "left" not in world.pending and "right" in world.pending
    # the human comes now: the withdrawn arm is not there, nothing starts
    world.handle_requests([_req(6.0, "h", "start", 1)])
    assert not world.granted and world.parts["mid"] == 1
    assert world.snapshot(6.0).withdrawn == {"left": 1}


def test_the_synchronous_start_of_a_shared_action_is_refused_clearly():
    with pytest.raises(ValueError, match="shared by"):
        _world().try_start("h", "together")


def _two_arm_executor():
    moves = {("left", "together"): RobotMove(np.zeros((1, 2)), np.zeros(1)),
             ("right", "together"): RobotMove(np.ones((2, 2)), np.zeros(2))}
    agents = [ArmAgent("left", 0, []), ArmAgent("right", 1, [])]
    return TaskExecutor(agents, moves, use_commands=True, requests=True, holds={("right", "together")})


def _kinds(ex, agent):
    return [(e.action, e.kind) for e in ex.events if e.agent == agent]


def test_each_arm_moves_its_own_part_and_the_holding_arm_ends_with_the_action():
    ex = _two_arm_executor()
    ex.update(0.0, [0, 0])
    commands = (RobotCommand(0.1, "left", "together", 1), RobotCommand(0.1, "right", "together", 2))
    ex.update(0.1, [0, 0], commands, WorldSnapshot())
    assert [r.kind for r in ex.new_requests] == ["start", "start"]
    granted = WorldSnapshot(granted={"left": 1, "right": 2}, joint={"together": ("h", "left", "right")})
    ex.update(0.2, [0, 0], (), granted)
    # the two parts differ: each arm got its own waypoints
    assert ex.path_requests[0].waypoints.shape == (1, 2) and ex.path_requests[1].waypoints.shape == (2, 2)
    ex.update(1.0, [1, 1], (), granted)
    # the left arm leaves at the end of its motion; the right one holds until the human is done
    assert _kinds(ex, "left")[-2:] == [("together", "end"), ("", "ready")]
    assert _kinds(ex, "right")[-1] == ("together", "begin") and ex.activity()["right"] == "together"
    assert [(r.agent, r.kind) for r in ex.new_requests] == [("left", "finish"), ("right", "finish")]
    ex.update(1.5, [1, 1], (), WorldSnapshot(granted={"left": 1, "right": 2}, joint={"together": ("h",)}))
    assert _kinds(ex, "right")[-1] == ("together", "begin")
    ex.update(2.0, [1, 1], (), WorldSnapshot(granted={"left": 1, "right": 2}))
    assert _kinds(ex, "right")[-2:] == [("together", "end"), ("", "ready")]


def test_a_revoked_command_makes_the_arm_ready_again():
    ex = _two_arm_executor()
    ex.update(0.0, [0, 0])
    ex.update(0.1, [0, 0], (RobotCommand(0.1, "left", "together", 1, give_up_after=15.0),), WorldSnapshot())
    assert ex.new_requests[0].patience == 15.0
    ex.update(0.2, [0, 0], (), WorldSnapshot(refused={"left": 1}))
    assert _kinds(ex, "left")[-1] == ("together", "wait_begin")
    ex.update(15.2, [0, 0], (), WorldSnapshot(refused={"left": 1}, withdrawn={"left": 1}))
    assert _kinds(ex, "left")[-2:] == [("together", "wait_end"), ("", "ready")]
    assert ex.activity()["left"] == "idle"


def _collaboration_flow(early: bool, joint_actions: str = "hold"):
    d = Distribution(kind="fixed", mean=10.0)
    release = {"left": Distribution(kind="fixed", mean=3.0)} if early else {}
    buffers = [Buffer("raw", kind="raw"), Buffer("mid", capacity=1), Buffer("out", kind="product")]
    flow = Flow(actions=[
        FlowAction("prep", ["human"], ["raw"], ["mid"], duration=Distribution(kind="fixed", mean=2.0)),
        FlowAction("together", ["human", "left", "right"], ["mid"], ["out"], duration=d,
                   early_release=release),
        FlowAction("solo", ["left"], ["raw"], ["out"], duration=Distribution(kind="fixed", mean=1.0)),
    ])
    return compile_flow(flow, buffers, "human", ["prep", "together"], ["left", "right"], wait_quantum=1.0,
                        joint_actions=joint_actions)


def test_early_release_returns_the_arm_before_the_collaboration_ends():
    net = _collaboration_flow(early=True)
    release = net.transition_index["together#1:release:left"]
    assert net.delays[release].mean == 3.0 and net.agents[release] == ("left",)
    end = net.transition_index["together#1:end"]
    assert net.agents[end] == ("right",)
    # the begin puts the left arm's part; its release gives the left arm back alone
    m = net.m0.copy()
    m[net.place_index["avail:left"]] = 0
    m[net.place_index["part:together#1:left"]] = 1
    assert net.enabled(m)[release]
    after = m + net.incidence[:, release]
    assert after[net.place_index["avail:left"]] == 1 and after[net.place_index["avail:right"]] == 1


def _solo_during_collaboration(early: bool) -> int:
    """How many `solo` actions the left arm starts while a collaboration is under way."""
    from hrc_drake.scheduling.baselines import RandomEnabledPolicy

    net = _collaboration_flow(early)
    run = simulate_cell(net, RandomEnabledPolicy(net, random_state=0), np.random.default_rng(0), n_cycles=3)
    human = [(t, kind) for t, agent, action, kind in run.events if (agent, action) == ("human", "together")]
    begins = [t for t, kind in human if kind == "begin"]
    ends = [t for t, kind in human if kind == "end"]
    windows = list(zip(begins, ends, strict=False))
    count = 0
    for t, agent, action, kind in run.events:
        if agent == "left" and action == "solo" and kind == "begin":
            count += any(a < t < b for a, b in windows)
    return count


def test_the_released_arm_works_while_the_collaboration_goes_on():
    assert _solo_during_collaboration(early=False) == 0
    assert _solo_during_collaboration(early=True) > 0


@pytest.mark.parametrize("joint_actions", ["simultaneous", "hold", "hold_unjoined"])
def test_the_robots_begin_of_a_collaboration_before_the_humans_keeps_one_human_token(joint_actions):
    net = _collaboration_flow(early=False, joint_actions=joint_actions.removesuffix("_unjoined"))
    tracker = NetTracker(net)
    tracker.human_event("prep", "begin", 0.0)
    tracker.human_event("prep", "end", 2.0)
    tracker.human_event("together", "wait_begin", 2.0)
    if joint_actions == "simultaneous":
        tracker.command(net.transition_index["together:commit"], 2.5)
    else:  # one arm holds; its partner joins (or the belief missed the join: the begin settles it)
        tracker.command(net.transition_index["together:commit:right"], 2.4)
        if joint_actions == "hold":
            tracker.command(net.transition_index["together:join:left"], 2.5)
    tracker.robot_event("right", "together", "begin", 2.6)  # the robots saw the grant first
    tracker.human_event("together", "begin", 2.7)
    human = [p for i, p in enumerate(net.places)
             if tracker.m[i] and p.startswith(("step:", "hwait:", "busy:"))]
    assert human == ["busy:together#1"]
    assert not any(tracker.m[i] for i, p in enumerate(net.places) if p.startswith(("held:", "cwait:")))


# ------------------------------------------------------------------ scenario checks and the cell


def _collab_text(diagrams_dir):
    return (diagrams_dir / "pcb_collab.yaml").read_text()


@pytest.mark.parametrize(
    "old, new, field, reason",
    [
        ("      - {name: check, arm: left, poses: [l_camera, l_camera, l_clear], dwell: 1.6}\n", "",
         "flow.actions[2].agents[0]", "'yumi_left' has no motion for 'check'"),
        ("      - {name: collab, arm: left, poses: [l_fixture, l_clear], dwell: 1.5}\n",
         "      - {name: collab, arm: left, poses: [l_fixture, l_clear], dwell: 1.5}\n"
         "      - {name: collab, arm: left, poses: [l_clear], dwell: 1.5}\n",
         "robots[0].actions[5].name", "duplicate name 'collab' on arm 'left'"),
        ("early_release: {yumi_left:", "early_release: {human:", "flow.actions[3].early_release.human",
         "not a robot agent"),
        ("program: []}\n      - {agent: yumi_left", "program: [fuse]}\n      - {agent: yumi_left",
         "robots[0].arms[0].program[0]", "'fuse' is an action of the left arm"),
    ],
)
def test_bad_shared_actions_are_refused_with_file_and_field(tmp_path, diagrams_dir, old, new, field, reason):
    text = _collab_text(diagrams_dir)
    assert old in text
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, new))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.field == field and reason in str(info.value)


def test_a_shared_action_without_a_scheduler_must_be_in_every_program(tmp_path, diagrams_dir):
    text = _collab_text(diagrams_dir)
    head = text[: text.index("predictor:")]
    path = tmp_path / "programs.yaml"
    arms = "program: []}\n      - {agent: yumi_left, arm: left, home: l_home, program: []}"
    path.write_text(head.replace(arms, "program: [check]}\n      - {agent: yumi_left, arm: left, "
                                       "home: l_home, program: [fuse, check]}"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.field == "flow.actions[3].agents[1]" and "not in the program" in str(info.value)


#: pcb_collab.yaml's flow without its durations (the timed schedulers' priors), patched by name:
#: a scheduler that reads none (the round robin) refuses them
UNTIMED = "flow: {actions: {fuse: {duration: null}, ic: {duration: null}, check: {duration: null}, " \
          "collab: {duration: null}}}\n"


def _run(path, duration=240.0):
    """The cell of `path` run as the thesis's experiments of Ch. 7 ran: without the ISO/TS 15066
    layer (the same for every scheduler compared; tests/safety and tools/bench_safety.py run the
    declared modes)."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import Tagged, load_scenario_with

    scenario = load_scenario_with(path, {"safety": Tagged("NoSafety", {})})
    return simulate(build_cell(scenario, path), duration, progress=None)


@pytest.mark.slow
def test_use_case_a_cell_best_scenario_beats_round_robin(tmp_path, diagrams_dir):
    best = _run(diagrams_dir / "pcb_collab.yaml")
    rr = tmp_path / "rr.yaml"
    # like with like: the round robin on the best-scenario scheduler's net (joint actions started together)
    round_robin = ("scheduler: !RoundRobinScheduler {programs: {yumi_left: [fuse, check]}, wait_quantum: 3, "
                   "joint_actions: simultaneous}\n")
    rr.write_text(f"extends: {diagrams_dir / 'pcb_collab.yaml'}\n{round_robin}{UNTIMED}")
    robin = _run(rr)
    for result in (best, robin):
        ends = {agent: [e.time for e in result.log.events if e.agent == agent and e.action == "collab"
                        and e.kind == "end"] for agent in ("human", "yumi_left", "yumi_right")}
        # one product per collaboration, when the last of its three agents ends its part
        done = min(len(ts) for ts in ends.values())
        assert result.metrics["products_finished"] == done > 0
        last = [max(ts[k] for ts in ends.values()) for k in range(done)]
        assert result.metrics["product_times"] == pytest.approx(last, abs=1e-3)
        # the left arm leaves the collaboration first (Fig. 7.3)
        assert all(left < right for left, right in zip(ends["yumi_left"], ends["yumi_right"], strict=False))
    # the scheduler's decisions are in the log (the Gantt chart marks them): a commitment to
    # the collaboration goes to both arms at once, revoked after T_wait = 5 t_w = 15 s
    commits = [c for c in best.log.decisions if c.action == "collab"]
    assert commits and {c.agent for c in commits} == {"yumi_left", "yumi_right"}
    assert all(c.give_up_after == 15.0 for c in commits)
    assert {c.time for c in commits if c.agent == "yumi_left"} == {c.time for c in commits
                                                                   if c.agent == "yumi_right"}
    waits = [c for c in best.log.decisions if c.action is None]
    assert waits and all(abs((c.time + c.wait) / 3.0 - round((c.time + c.wait) / 3.0)) < 1e-6 for c in waits)
    b, r = best.metrics, robin.metrics
    assert b["products_finished"] >= r["products_finished"] + 1
    assert b["mean_time_between_products"] < r["mean_time_between_products"]
    assert b["agents"]["human"]["wait_time"] < r["agents"]["human"]["wait_time"]


def test_the_tracker_follows_a_human_whose_intention_is_transition_0():
    """A flow whose first action is the human's compiles its intention as transition 0: the
    belief must still fire it (a falsy index once made the human's first action invisible)."""
    buffers = [Buffer("raw", kind="raw"), Buffer("mid", capacity=1), Buffer("out", kind="product")]
    flow = Flow(actions=[
        FlowAction("first", ["human"], ["raw"], ["mid"], duration=Distribution(kind="fixed", mean=2.0)),
        FlowAction("then", ["robot"], ["mid"], ["out"], duration=Distribution(kind="fixed", mean=1.0)),
    ])
    net = compile_flow(flow, buffers, "human", ["first"], ["robot"])
    assert net.transitions[0] == "intent:0"
    tracker = NetTracker(net)
    tracker.human_event("first", "begin", 0.0)
    assert tracker.m[net.place_index["busy:first#0"]] == 1
    tracker.human_event("first", "end", 2.0)
    assert tracker.m[net.place_index["buf:mid"]] == 1


def test_the_carts_cell_runs_the_flow_of_the_use_case_b_net(diagrams_dir):
    """diagrams/carts.yaml and `thesis_cells.use_case_b` are one flow: the event-level
    benchmark and the cell measure the same use case."""
    from hrc_drake.scheduling import thesis_cells as tc

    scenario = load_scenario(diagrams_dir / "carts.yaml")
    flow, buffers, pattern, robots = tc.use_case_b(1)
    assert scenario.flow.actions == flow.actions and scenario.operator.pattern == pattern
    cell_buffers = {b.name: (b.kind, b.capacity, b.initial) for b in scenario.layout.buffers}
    net_buffers = {b.name: (b.kind, b.capacity, b.initial) for b in buffers}
    # raw and product buffers carry no capacity
    for name, (kind, capacity, initial) in net_buffers.items():
        assert cell_buffers[name][0] == kind and cell_buffers[name][2] == initial
        if kind == "intermediate":
            assert cell_buffers[name][1] == capacity
    assert set(cell_buffers) == set(net_buffers)
    assert sorted(arm.agent for r in scenario.robots for arm in r.arms) == sorted(robots)
    assert scenario.scheduler.agent_costs == tc.USE_CASE_B_AGENT_COSTS


@pytest.mark.slow
@pytest.mark.parametrize("pattern", ["[ic, collab]", "[ic, ic, collab, collab]"])
@pytest.mark.parametrize("scheduler", [
    "!BestScenarioScheduler {collaboration: collab, human_action: ic, feed_action: fuse, wait_quantum: 3.0}",
    "!RoundRobinScheduler {programs: {yumi_left: [fuse, check]}, wait_quantum: 3.0}",
])
def test_the_use_case_a_cell_never_stalls(tmp_path, diagrams_dir, pattern, scheduler):
    """Seeds and patterns that once stalled the cell: the round robin's right arm commanded
    while it still held the collaboration (its commands then lagged one behind), the
    best-scenario right arm committing the left one while the human waited for a board."""
    for seed in (100, 101):
        path = tmp_path / f"run{seed}.yaml"
        path.write_text(f"extends: {diagrams_dir / 'pcb_collab.yaml'}\nseed: {seed}\n"
                        f"operator: {{pattern: {pattern}}}\nscheduler: {scheduler}\n"
                        + (UNTIMED if "RoundRobin" in scheduler else ""))
        result = _run(path, duration=300.0)
        # at most ~45 s per product for the slowest arm: a stall leaves only a few
        assert result.metrics["products_finished"] >= 6, (seed, result.metrics["product_times"])
        waits = [c for c in result.log.decisions if c.action is None]
        assert all(abs((c.time + c.wait) / 3.0 - round((c.time + c.wait) / 3.0)) < 1e-6 for c in waits)


def test_agent_costs_name_robot_agents(tmp_path, diagrams_dir):
    path = tmp_path / "bad_costs.yaml"
    path.write_text(f"extends: {diagrams_dir / 'carts.yaml'}\n"
                    "scheduler: !MonteCarloScheduler {agent_costs: {cart9: 0.0}}\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.field == "scheduler.agent_costs.cart9" and "not a robot agent" in str(info.value)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("name, duration, products",
                         [("carts.yaml", 200.0, 3), ("torch_clock_fuzzy.yaml", 150.0, 1)])
def test_use_cases_b_and_c_run_with_their_schedulers(diagrams_dir, name, duration, products):
    result = _run(diagrams_dir / name, duration)
    m = result.metrics
    assert m["products_finished"] >= products
    # every robot agent was commanded and worked (the carts too: each moved both ways)
    commanded = {c.agent for c in result.log.decisions if c.action is not None}
    assert commanded == set(m["agents"]) - {"human"}
    assert all(m["agents"][agent]["busy_time"] > 0 for agent in commanded)
    if name == "carts.yaml":
        moves = {e.action for e in result.log.events if getattr(e, "agent", "") in ("cart1", "cart2")
                 and e.kind == "end"}
        assert moves == {"cart1_go", "cart1_back", "cart2_go", "cart2_back"}
