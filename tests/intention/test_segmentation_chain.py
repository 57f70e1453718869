"""The compiled max-product on the segmenter's order-1 chain (issue 41 item 2) against the
FactorGraph computation it replaces, kept as the reference (`WindowProblem.graph_map_log_energy`)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from hrc_drake.intention import _kernels
from hrc_drake.intention import segmentation as seg

from .test_segmentation import CENTRES, PRECEDENCE, WINDOW, recording, stream


@pytest.fixture(scope="module")
def segmenter():
    rng = np.random.default_rng(1)
    library = [(a, recording(a, int(rng.integers(40, 80)), rng)) for a in range(3) for _ in range(6)]
    genetic = seg.GeneticSettings(population=16, generations=12)
    out = seg.Segmenter(WINDOW, batch_windows=10, centres=CENTRES, genetic=genetic, seed=0)
    return out.fit(library, PRECEDENCE, n_sequences=60, seed=3)


def _problem(n_actions: int, rng: np.random.Generator, n_windows: int = 12) -> seg.WindowProblem:
    model = seg.SegmentationModel(
        actions=tuple(range(n_actions)),
        edges=np.array([[0.0, 1.0], [0.0, 1.0]]),
        phi_obs=rng.uniform(0.0, 1.0, (2, 3, n_actions)),
        phi_seq=rng.uniform(-1.0, 1.0, (1, n_actions, n_actions)),
        w_obs=rng.uniform(0.2, 2.0, 2),
        w_seq=float(rng.uniform(0.2, 3.0)),
        mean_action_windows=3.0,
    )
    codes = rng.integers(0, 3, (n_windows, 2))
    bounds = np.stack([np.arange(n_windows), np.arange(1, n_windows + 1)], axis=1)
    return seg.WindowProblem(model, codes, bounds)


def test_compiled_chain_equals_brute_force():
    rng = np.random.default_rng(0)
    for _ in range(50):
        n_links, n_values = int(rng.integers(1, 6)), int(rng.integers(1, 4))
        unary, pair = rng.normal(size=(n_links, n_values)), rng.normal(size=(n_values, n_values))
        best = max(
            sum(unary[k, y[k]] for k in range(n_links)) + sum(pair[y[k], y[k - 1]] for k in range(1, n_links))
            for y in itertools.product(range(n_values), repeat=n_links)
        )
        assert _kernels.chain_max_log_energy(unary, pair) == pytest.approx(best, rel=1e-12, abs=1e-12)


def test_compiled_chain_equals_the_factor_graph_over_many_hypotheses():
    """Every hypothesis of 200 random ones on 10 random problems (2-5 actions), half of them with
    a message from deleted links on the first: within 1e-12 (summation order only)."""
    rng = np.random.default_rng(1)
    compared = 0
    for trial in range(10):
        problem = _problem(int(rng.integers(2, 6)), rng)
        for _ in range(20):
            rho = seg.random_hypothesis(problem.n_windows, problem.prior_rate, rng)
            chain = problem.links(seg.segment_counts(rho, problem.n_windows))
            if trial % 2:  # a message from a deleted part of the graph (4.1.4)
                chain[0].log_message = rng.normal(0.0, 5.0, problem.model.n_actions)
            reference = problem.graph_map_log_energy(chain)
            assert problem.map_log_energy(chain) == pytest.approx(reference, rel=1e-12, abs=1e-12)
            compared += 1
    assert compared == 200


def test_a_non_finite_chain_is_left_to_the_graph_and_its_error():
    problem = _problem(3, np.random.default_rng(2))
    chain = problem.links([6, 6])
    chain[1].log_message = np.full(3, -np.inf)
    with pytest.raises(ValueError, match="non-finite"):
        problem.graph_map_log_energy(chain)
    with pytest.raises(ValueError, match="non-finite"):
        problem.map_log_energy(chain)


def test_the_segmenter_segments_as_with_the_factor_graph(segmenter, monkeypatch):
    """Online segmentation of a stream: the same segments and the same GA results with the
    compiled chain as with the reference."""
    frames, _ = stream([0, 2, 1, 0], [33, 41, 27, 30], np.random.default_rng(11))

    def run():
        segmenter.reset()
        segments, results = [], []
        for frame in frames:
            closed = segmenter.update(frame)
            segments += closed
            if closed:
                results.append(tuple(segmenter._sliding.last_result.rho))
        return segments + segmenter.flush(), results

    compiled = run()
    monkeypatch.setattr(seg.WindowProblem, "map_log_energy", seg.WindowProblem.graph_map_log_energy)
    assert run() == compiled
    assert len(compiled[0]) >= 4
