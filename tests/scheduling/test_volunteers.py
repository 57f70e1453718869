"""Simulated volunteers (`scheduling.volunteers`): the learning-curve sampler against its formula,
the people drawn from the population, the between-subjects test on toy cases with known answers,
the power by resampling, and the event-level simulator taking a person's durations."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import mannwhitneyu, skew

from hrc_drake.distributions import Distribution
from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.compiler import compile_flow
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.volunteers import (
    Volunteer,
    VolunteerPopulation,
    action_moments,
    between_subjects_p,
    draw_volunteer,
    human_wait_per_product,
    people_needed,
    power_by_resampling,
)


def _person(rate=0.85, speed=1.2):
    return Volunteer(speed=speed, learning_rate=rate, means={"pad": 8.0}, cvs={"pad": 0.2}, reference=5)


@pytest.mark.parametrize("repetition", [1, 2, 5, 9])
def test_the_learning_curve_sampler_follows_its_formula(repetition):
    person = _person()
    b = -math.log2(0.85)
    expected = 1.2 * 8.0 * (repetition / 5) ** -b
    assert person.mean_duration("pad", repetition) == pytest.approx(expected)
    draws = np.array([person.duration("pad", repetition, np.random.default_rng(k)) for k in range(20000)])
    assert draws.mean() == pytest.approx(expected, rel=0.01)
    assert draws.std() / draws.mean() == pytest.approx(0.2, rel=0.05)
    assert skew(draws) > 0.3  # right-skewed (a log-normal of CV 0.2 has skewness ~0.6)
    assert draws.min() > 0


def test_practice_makes_a_person_faster_by_the_learning_rate_per_doubling():
    person = _person(rate=0.8)
    assert person.mean_duration("pad", 5) == pytest.approx(1.2 * 8.0)  # the flow's mean at the reference
    for n in (1, 2, 3, 4):
        assert person.mean_duration("pad", 2 * n) / person.mean_duration("pad", n) == pytest.approx(0.8)
    with pytest.raises(ValueError, match="repetition"):
        person.mean_duration("pad", 0)
    # a learning rate of 1 is a stationary person
    assert _person(rate=1.0).mean_duration("pad", 9) == _person(rate=1.0).mean_duration("pad", 1)


def test_people_drawn_from_the_population():
    population = VolunteerPopulation()
    means, cvs = action_moments({"pad": Distribution(kind="normal", mean=8.0, std=1.5)})
    assert means["pad"] == pytest.approx(8.0, rel=0.02) and cvs["pad"] == pytest.approx(1.5 / 8.0, rel=0.05)
    people = [draw_volunteer(population, means, cvs, np.random.default_rng(k)) for k in range(4000)]
    speeds = np.array([p.speed for p in people])
    rates = np.array([p.learning_rate for p in people])
    assert speeds.mean() == pytest.approx(1.0, abs=0.01) and speeds.std() == pytest.approx(0.15, rel=0.08)
    assert rates.min() >= 0.80 and rates.max() <= 0.95
    # same seed, same person
    again = draw_volunteer(population, means, cvs, np.random.default_rng(7))
    assert again == draw_volunteer(population, means, cvs, np.random.default_rng(7))
    with pytest.raises(ValueError, match="learning_rates"):
        VolunteerPopulation(learning_rates=(0.9, 0.8))
    with pytest.raises(ValueError, match="speed_cv"):
        VolunteerPopulation(speed_cv=float("nan"))


def test_the_between_subjects_test_on_toy_groups_with_known_answers():
    a, b = [[1.0, 2.0], [3.0]], [[4.0, 5.0], [6.0]]
    # pooled (the thesis's test): 3 below 3, exact one-sided p = 1 / C(6, 3)
    assert between_subjects_p(a, b) == pytest.approx(1 / 20)
    # per person: medians 1.5, 3 below 4.5, 6: p = 1 / C(4, 2)
    assert between_subjects_p(a, b, unit="people") == pytest.approx(1 / 6)
    # the other direction
    assert between_subjects_p(b, a) == pytest.approx(1.0)
    # as scipy on the pooled samples
    rng = np.random.default_rng(0)
    ga = [rng.normal(0, 1, 8) for _ in range(5)]
    gb = [rng.normal(0.5, 1, 8) for _ in range(5)]
    assert between_subjects_p(ga, gb) == pytest.approx(
        mannwhitneyu(np.concatenate(ga), np.concatenate(gb), alternative="less").pvalue)
    with pytest.raises(ValueError, match="unit"):
        between_subjects_p(a, b, unit="trials")
    with pytest.raises(ValueError, match="at least one sample"):
        between_subjects_p([[]], b)


def test_power_by_resampling_finds_a_sure_effect_and_no_effect():
    rng = np.random.default_rng(1)
    lower = [rng.normal(10, 1, 8) for _ in range(20)]
    higher = [rng.normal(20, 1, 8) for _ in range(20)]
    same = [x.copy() for x in lower]  # one population: the test's size, alpha
    assert power_by_resampling(lower, higher, 5, np.random.default_rng(2), draws=200) == 1.0
    assert power_by_resampling(lower, same, 5, np.random.default_rng(2), draws=400) < 0.1
    with pytest.raises(ValueError, match="group_size"):
        power_by_resampling(lower, higher, 21, np.random.default_rng(2))
    # a person-level effect hidden in each person's speed: more people, more power
    people_a = [rng.normal(10 + rng.normal(0, 1.5), 3, 8) for _ in range(60)]
    people_b = [rng.normal(11 + rng.normal(0, 1.5), 3, 8) for _ in range(60)]
    needed, powers = people_needed(people_a, people_b, np.random.default_rng(3), draws=200, unit="people")
    assert list(powers) == sorted(powers) and powers[5] < 0.8
    assert needed is None or powers[needed] >= 0.8
    assert max(powers) <= 30  # at most half of a pool of 60
    assert people_needed(lower, same, np.random.default_rng(3), draws=100)[0] is None


def _one_human_action_net():
    buffers = [Buffer("raw", kind="raw"), Buffer("product", kind="product")]
    flow = Flow(actions=[FlowAction("pad", ["human"], ["raw"], ["product"],
                                    duration=Distribution(kind="normal", mean=8.0, std=1.5))])
    return compile_flow(flow, buffers, "human", ["pad"], [])


class _Recorder:
    def __init__(self):
        self.asked = []

    def duration(self, action, repetition, rng):
        self.asked.append((action, repetition))
        return float(repetition)  # the n-th pad takes n s


class _NoRobots:
    def decide(self, marking, agent, now=0.0, elapsed=None):
        raise AssertionError("no robot to decide for")

    def observe(self, transition, delay):
        pass


def test_the_event_simulator_takes_the_persons_durations_repetition_by_repetition():
    net = _one_human_action_net()
    operator = _Recorder()
    run = simulate_cell(net, _NoRobots(), np.random.default_rng(0), n_products=4, operator=operator)
    assert operator.asked == [("pad", 1), ("pad", 2), ("pad", 3), ("pad", 4)]
    assert run.product_times == pytest.approx([1.0, 3.0, 6.0, 10.0])
    assert human_wait_per_product(run).tolist() == [0.0, 0.0, 0.0, 0.0]


def test_a_small_study_runs_end_to_end():
    """tools/volunteer_study.py on use case b with 3 people per arm, 3 products each."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
    from volunteer_study import compare, run_pool

    from hrc_drake.scheduling import thesis_cells as tc
    from hrc_drake.scheduling.montecarlo import MonteCarloPolicy

    flow, buffers, pattern, robots = tc.use_case_b(1)
    net = compile_flow(flow, buffers, "human", pattern, robots, wait_quantum=3.0, cost_robot=0.5,
                       agent_costs=tc.USE_CASE_B_AGENT_COSTS)
    human = {a.name: a.duration for a in flow.actions if "human" in a.agents}
    pools = {}
    for offset, durations in enumerate(("empirical", "uniform_support")):
        def policy(net, seed, durations=durations):
            return MonteCarloPolicy(net, n_trials=10, horizon=15.0, random_state=seed, durations=durations)

        pools[durations] = run_pool(net, policy, human, 3, 3, 50 + offset, VolunteerPopulation(), 600.0, "t")
    assert [r["speed"] for r in pools["empirical"]] != [r["speed"] for r in pools["uniform_support"]]
    assert all(r["products"] == 3 and len(r["cycles"]) == 2 for rows in pools.values() for r in rows)
    result = compare(pools, "empirical", "uniform_support", "cycles", seed=0, draws=20)
    assert 0 <= result["between_subjects"]["p_less"] <= 1 and result["between_subjects"]["people"] == 3
    assert result["people_needed_p05"] is None or result["people_needed_p05"] >= 5
