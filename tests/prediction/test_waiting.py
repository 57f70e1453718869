"""Waiting times, Algorithm 1 and eq. (5.37), on cases derivable by hand."""

import numpy as np
import pytest

from hrc_drake.prediction import MarkovChainModel, WaitingTimePredictor, percentiles_from_cdf


def _two_action_chain():
    # P(0 -> 0) = P(0 -> 1) = 1/2, P(1 -> 0) = 1; durations 1 s and 2 s
    chain = MarkovChainModel(buffer_size=None).fit([0, 0, 1, 0, 0, 1, 0])
    waiting = WaitingTimePredictor(chain, resolution=0.5, epsilon=1e-6)
    for _ in range(3):
        waiting.observe_duration(0, 1.0)
        waiting.observe_duration(1, 2.0)
    return waiting


def test_cdf_of_a_two_action_chain():
    waiting = _two_action_chain()
    times, cdf = waiting.distributions([0], 0.0, horizon=6.0)
    # tau^1: the n-th 0 -> 1 attempt starts at t = n: P(tau^1 <= t) = 1 - 2^-floor(t)
    expected1 = np.where(times >= 1, 1 - 0.5 ** np.floor(times), 0.0)
    np.testing.assert_allclose(cdf[1], expected1, atol=1e-9)
    # tau^0: 0 again at t = 1 (p 1/2) or after 1 at t = 1 + 2 (p 1/2)
    expected0 = np.select([times >= 3, times >= 1], [1.0, 0.5], 0.0)
    np.testing.assert_allclose(cdf[0], expected0, atol=1e-9)
    np.testing.assert_allclose(
        waiting.percentiles([0], 0.0, (0.2, 0.5, 0.8), horizon=6.0), [[1, 1, 3], [1, 1, 3]]
    )
    _, single = waiting.distribution([0], 0.0, target=1, horizon=6.0)
    np.testing.assert_allclose(single, cdf[1], atol=1e-9)


def test_elapsed_time_shifts_the_residual():
    chain = MarkovChainModel(buffer_size=None).fit([0, 1] * 5)
    waiting = WaitingTimePredictor(chain, resolution=0.5)
    for d0, d1 in ((2.0, 3.0), (2.0, 3.0)):
        waiting.observe_duration(0, d0).observe_duration(1, d1)
    pct = waiting.percentiles([0, 1, 0], 0.5, (0.5,), horizon=10.0)
    np.testing.assert_allclose(pct[:, 0], [4.5, 1.5])
    # running longer than any sample: the action is about to end
    pct = waiting.percentiles([0, 1, 0], 5.0, (0.5,), horizon=10.0)
    np.testing.assert_allclose(pct[:, 0], [3.0, 0.0])
    # the finished action (elapsed None) leaves no residual either
    np.testing.assert_allclose(waiting.percentiles([0], None, (0.5,), horizon=10.0)[:, 0], [3.0, 0.0])


def test_mixed_durations_and_horizon_pruning():
    chain = MarkovChainModel(buffer_size=None).fit([0, 1] * 5)
    waiting = WaitingTimePredictor(chain, resolution=1.0)
    for d in (1.0, 3.0):
        waiting.observe_duration(0, d)
    waiting.observe_duration(1, 2.0)
    times, cdf = waiting.distributions([1], 0.0, horizon=4.0)
    # tau^0 = 2; tau^1 = 2 + T0 with T0 in {1, 3} equally likely
    np.testing.assert_allclose(cdf[0], [0, 0, 1, 1, 1])
    np.testing.assert_allclose(cdf[1], [0, 0, 0, 0.5, 0.5])
    assert np.all(np.diff(cdf, axis=1) >= -1e-12) and cdf.max() <= 1.0
    # a horizon shorter than the least start time: nothing can start
    _, short = waiting.distributions([1], 0.0, horizon=1.0)
    assert short.max() == 0.0
    assert np.all(np.isinf(percentiles_from_cdf(np.arange(2.0), short, [0.5])))


def test_bad_input():
    waiting = _two_action_chain()
    with pytest.raises(ValueError, match="finite"):
        waiting.observe_duration(0, float("nan"))
    with pytest.raises(ValueError, match="finite"):
        waiting.observe_duration(0, -1.0)
    with pytest.raises(ValueError, match="unknown action"):
        waiting.observe_duration(5, 1.0)
    with pytest.raises(ValueError, match="elapsed"):
        waiting.distributions([0], -1.0)
    with pytest.raises(ValueError, match="levels"):
        waiting.percentiles([0], 0.0, (0.0, 0.5))
    with pytest.raises(ValueError, match="SequenceModel"):
        WaitingTimePredictor(object())
    # no history: no running action, the next one starts now with the marginal probabilities
    times, cdf = waiting.distributions([], None, horizon=2.0)
    assert cdf[:, 0].sum() == pytest.approx(1.0)


def test_cached_predictions_follow_the_model():
    chain = MarkovChainModel(buffer_size=None).fit([0, 1, 0, 1, 0, 1])
    waiting = WaitingTimePredictor(chain, resolution=0.5)
    waiting.observe_duration(0, 1.0).observe_duration(1, 1.0)
    first = waiting.distributions([0], 0.0, horizon=4.0)[1]
    np.testing.assert_array_equal(waiting.distributions([0], 0.0, horizon=4.0)[1], first)  # warm cache
    # after 0 -> 0 is observed the chain changes: a stale cache would repeat `first`
    chain.partial_fit(0)
    waiting.observe_duration(0, 2.0)
    fresh = WaitingTimePredictor(chain, resolution=0.5)
    for code, duration in ((0, 1.0), (1, 1.0), (0, 2.0)):
        fresh.observe_duration(code, duration)
    updated = waiting.distributions([0], 0.0, horizon=4.0)[1]
    np.testing.assert_allclose(updated, fresh.distributions([0], 0.0, horizon=4.0)[1], atol=1e-12)
    assert not np.allclose(updated, first)


def test_deep_history_model_and_durations_longer_than_the_horizon():
    from hrc_drake.prediction import HigherOrderMarkovModel

    # a deterministic cycle 0 -> 1 -> 2 -> 0 with a 3rd-order model: tau^2 = 1 + 1, tau^0 = 1 + 1 + 1
    model = HigherOrderMarkovModel(order=3, buffer_size=None).fit([0, 1, 2] * 10)
    waiting = WaitingTimePredictor(model, resolution=0.5)
    for code in range(3):
        waiting.observe_duration(code, 1.0)
    waiting.observe_duration(2, 50.0)  # half of the a2 durations run past the horizon
    times, cdf = waiting.distributions([0, 1, 2, 0], 0.0, horizon=6.0)
    np.testing.assert_allclose(cdf[1], (times >= 1.0) * 1.0, atol=1e-9)
    np.testing.assert_allclose(cdf[2], (times >= 2.0) * 1.0, atol=1e-9)
    np.testing.assert_allclose(cdf[0], (times >= 3.0) * 0.5, atol=1e-9)  # needs a2 to end in time


def test_compiled_levels_equal_the_fft_reference_on_a_random_higher_order_model():
    from hrc_drake.prediction import HigherOrderMarkovModel

    rng = np.random.default_rng(5)
    sequence = rng.integers(0, 5, size=300).tolist()
    model = HigherOrderMarkovModel(order=2, buffer_size=None).fit(sequence)
    waiting = WaitingTimePredictor(model, resolution=0.2, epsilon=1e-4)
    for action in range(5):
        for duration in rng.gamma(4.0, 0.6 + 0.3 * action, size=12):
            waiting.observe_duration(action, duration)
    for history, elapsed in (([0, 3], 0.4), ([4, 4, 1], None), ([2], 1.5), ([], None)):
        times, compiled = waiting.distributions(history, elapsed, horizon=30.0)
        times_ref, reference = waiting.distributions(history, elapsed, horizon=30.0, compiled=False)
        np.testing.assert_array_equal(times, times_ref)
        np.testing.assert_allclose(compiled, reference, atol=1e-12)
        assert reference[:, -1].min() > 0.5  # the tree reached every action: the levels were tested
        _, targeted = waiting.distributions(history, elapsed, horizon=30.0, targets=[1])
        _, targeted_ref = waiting.distributions(history, elapsed, horizon=30.0, targets=[1], compiled=False)
        np.testing.assert_allclose(targeted, targeted_ref, atol=1e-12)
