"""The torch-and-clock cell (diagrams/torch_clock.yaml) run in the Drake simulation with the Monte
Carlo scheduler in charge of both YuMi arms."""

from pathlib import Path

import pytest

pytest.importorskip("pydrake")

from pydrake.systems.analysis import Simulator  # noqa: E402

from hrc_drake.cell.build import build_cell  # noqa: E402
from hrc_drake.cell.metrics import summarize  # noqa: E402
from hrc_drake.cell.scenario import load_scenario  # noqa: E402
from hrc_drake.messages import RobotEvent  # noqa: E402
from hrc_drake.safety.config import NoSafety  # noqa: E402
from hrc_drake.scheduling.config import MonteCarloScheduler  # noqa: E402
from hrc_drake.scheduling.montecarlo import MonteCarloPolicy  # noqa: E402

SCENARIO = Path(__file__).resolve().parents[2] / "diagrams" / "torch_clock.yaml"


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_torch_clock_cell_runs_with_the_monte_carlo_scheduler():
    scenario = load_scenario(SCENARIO)
    scenario.scheduler = MonteCarloScheduler(n_trials=40, horizon=20.0)
    # the scheduler's commands and the products they make, not the cell's safety stops (tests/safety)
    scenario.safety = NoSafety()
    cell = build_cell(scenario)
    # the run's commands live in its Context: simulate here and read them from it
    simulator = Simulator(cell.diagram)
    simulator.Initialize()
    simulator.AdvanceTo(120.0)
    log = cell.log(simulator.get_context())
    metrics = summarize(log, 120.0, cell.agents, cell.product_actions)
    scheduler = cell.system("scheduler")
    context = scheduler.GetMyContextFromRoot(simulator.get_context())
    commands = scheduler.commands(context)
    begins = [
        e for e in log.events if isinstance(e, RobotEvent) and e.kind == "begin" and e.action
    ]
    agents = {"yumi_left", "yumi_right"}
    assert {c.agent for c in commands} == agents
    assert {e.agent for e in begins} == agents
    for agent in agents:
        commanded = [c for c in commands if c.agent == agent and c.action is not None]
        started = [e for e in begins if e.agent == agent]
        # every action a robot starts is the next one the scheduler commanded it, issued before
        # the start; only the last command may still be pending at the end of the run
        assert len(commanded) - 1 <= len(started) <= len(commanded)
        for c, e in zip(commanded, started, strict=False):
            assert e.action == c.action
            assert c.time <= e.time + 1e-9
    # a wait lasts the net's quantum t_w (6.3.1), as the trials model it (not the grid variant)
    quantum = scheduler.net.wait_quantum
    waits = [c for c in commands if c.action is None]
    assert waits and all(abs(c.wait - quantum) < 1e-9 for c in waits)
    # torches and clocks get finished (the first after ~65 s: a torch takes six actions)
    assert metrics["products_finished"] >= 2
    assert cell.world(simulator.get_context()).finished_products == metrics["products_finished"]
    policy = scheduler.core(context).policy
    assert isinstance(policy, MonteCarloPolicy)
    assert policy.n_trials == 40 and policy.horizon == 20.0
