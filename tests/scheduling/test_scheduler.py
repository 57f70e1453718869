import numpy as np

from hrc_drake.scheduling import thesis_cells as tc
from hrc_drake.scheduling.baselines import RandomEnabledPolicy, RoundRobinPolicy
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.learning import DurationModel
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy, simulate_trials


def _net_7_6():
    flow, buffers, pattern, robots = tc.fig_7_6()
    return compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=1.0)


def test_trials_respect_horizon_and_costs_are_waits():
    net = _net_7_6()
    roots = net.agent_transitions("robot")
    batch = simulate_trials(net, net.m0, DurationModel(net), np.random.default_rng(0), 50, 10.0, roots)
    assert batch.paths.shape[0] == 50
    assert np.all(batch.costs >= 0) and np.all(batch.costs <= 10.0 * (1 + 1) + 1e-9)
    assert np.allclose(batch.costs, batch.robot_wait + batch.human_wait)
    # the only waiting human place costs c_H = 1: a robot that always waits leaves the human 0 s idle
    # at first, then the collaboration needs it; trials whose first move is the wait pay >= 1 s
    wait = net.transition_index["robot:wait"]
    first_wait = batch.paths[:, 0] == wait
    assert first_wait.any() and np.all(batch.robot_wait[first_wait] >= 1.0 - 1e-9)


def test_seeded_scheduler_is_reproducible():
    net = _net_7_6()
    picks = []
    for _ in range(2):
        s = MonteCarloPolicy(net, n_trials=60, horizon=10.0, random_state=3)
        picks.append([s.decide(net.m0, "robot") for _ in range(3)] + [s.last_percentiles_])
    assert picks[0] == picks[1]


def test_duration_model_learns_sliding_window():
    net = _net_7_6()
    model = DurationModel(net, window=3, min_samples=2)
    j = net.transition_index["action2#0:end"]
    assert abs(model.mean(j) - 3.0) < 1e-9  # prior U[2, 4]
    for d in (10.0, 20.0, 30.0, 40.0):
        model.partial_fit(j, d)
    assert list(model.samples_[j]) == [20.0, 30.0, 40.0]
    assert set(np.unique(model.sample(j, np.random.default_rng(0), 50))) <= {20.0, 30.0, 40.0}
    back = DurationModel.from_json(net, model.to_json())
    assert list(back.samples_[j]) == [20.0, 30.0, 40.0]


def test_cell_simulator_round_robin_hand_checked():
    # Fig. 7.6 with fixed durations: the robot's program is action1; the human alternates
    # action2 (3 s) and the collaboration action3 (6 s) that the robot joins when asked.
    flow, buffers, pattern, robots = tc.fig_7_6()
    flow.actions[1].duration.kind, flow.actions[1].duration.mean = "fixed", 3.0
    flow.actions[2].duration.kind, flow.actions[2].duration.mean = "fixed", 6.0
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=1.0)
    run = simulate_cell(net, RoundRobinPolicy(net), np.random.default_rng(0), n_cycles=3)
    # t=0 robot action1 (3 s), human action2 (3 s); at 3 both done, collab 3-9; cycle = 9 s
    # after the first cycle action1 runs 9-12 while the human does action2 9-12 -> cycles of 9 s
    assert np.allclose(run.cycle_times, [9.0, 9.0, 9.0])
    assert len(run.product_times) == 3
    assert run.idle["human"] == 0.0
    kinds = [(e[1], e[2], e[3]) for e in run.events[:3]]
    assert ("robot", "action1", "begin") in kinds and ("human", "action2", "begin") in kinds


def test_monte_carlo_runs_in_the_cell_and_is_seeded():
    flow, buffers, pattern, robots = tc.fig_7_11()
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
    runs = [
        simulate_cell(
            net,
            MonteCarloPolicy(net, n_trials=40, horizon=20.0, random_state=1),
            np.random.default_rng(7),
            n_cycles=1,
        )
        for _ in range(2)
    ]
    assert runs[0].events == runs[1].events
    assert len(runs[0].cycle_ends) == 1 and len(runs[0].product_times) >= 1
    random_enabled = simulate_cell(net, RandomEnabledPolicy(net, random_state=0), np.random.default_rng(7),
                                   n_cycles=1)
    assert len(random_enabled.cycle_ends) == 1


def test_compiled_trials_equal_the_numpy_trials_draw_for_draw():
    nets = [_net_7_6()] + [compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0)
                           for flow, buffers, pattern, robots in (tc.use_case_a(), tc.use_case_b())]
    checked = 0
    for net in nets:
        for k, who in enumerate(net.robot_agents):
            roots = net.agent_transitions(who)
            roots = [j for j in roots if net.controllable[j] and net.enabled(net.m0)[j]]
            if not roots:
                continue
            durations = DurationModel(net)
            elapsed = np.where(~net.controllable, 0.4 * k, 0.0)  # clocks conditioned on elapsed time
            # the literal trials, and the earlier ones (every variant of their generation)
            earlier = {"stratified_roots": True, "common_random_numbers": True, "wait_grid": True}
            for rollout, variant in (("uniform", {}), ("work_first", {}), ("uniform", earlier)):
                runs = [simulate_trials(net, net.m0, durations, np.random.default_rng(5 + k), 40, 25.0, roots,
                                        elapsed, now=0.7, rollout=rollout, compiled=compiled, **variant)
                        for compiled in (True, False)]
                np.testing.assert_array_equal(runs[0].paths, runs[1].paths)
                np.testing.assert_array_equal(runs[0].costs, runs[1].costs)
                np.testing.assert_array_equal(runs[0].human_wait, runs[1].human_wait)
                assert runs[0].paths.shape[1] > 3 and max(np.unique(c).size for c in runs[0].paths.T) > 2
                checked += 1
    assert checked >= 9
