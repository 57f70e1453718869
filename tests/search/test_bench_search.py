"""tools/bench_search.py's set-up: the repeated falsifications are honest comparisons (budgets past
TPE's random start, a seed per repeat, random search seeded apart), and its medians."""

from __future__ import annotations

import pytest

from tests.conftest import load_tool


@pytest.fixture(scope="module")
def bench():
    module = load_tool("bench_search")
    return module


@pytest.mark.parametrize("mode", ["quick", "full"])
def test_each_repeat_is_its_own_search_past_the_random_start(bench, mode):
    from hrc_drake.search.spec import random_search_seed

    for name, modes in bench.FALSIFY.items():
        repeats, changes = modes[mode]
        assert repeats >= 2
        searches = [bench._load(name, seed=r, **dict(changes)) for r in range(repeats)]
        seeds = [s.optimizer.seed for s in searches]
        assert seeds == list(range(repeats))
        assert not {random_search_seed(s) for s in seeds} & set(seeds)
        for search in searches:
            assert search.preset == "falsify" and search.compare_random
            assert search.candidates > search.optimizer.n_startup_trials  # TPE guides some candidates
    optimise = bench._load("optimise_pcb_ic", **dict(bench.OPTIMISE[mode]))
    assert optimise.preset == "optimise" and optimise.duration >= 100  # products, so a cycle time


def test_runs_to_the_first_violation_median_counts_none_as_never(bench):
    assert bench._median_runs([1, 1, 3]) == 1
    assert bench._median_runs([4, None, 2]) == 4
    assert bench._median_runs([None, None, 2]) is None
