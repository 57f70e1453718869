"""Markov chain, MTD higher-order model (eqs. 5.4-5.9), Ching weights, PPM baseline."""

import numpy as np
import pytest
from scipy.optimize import minimize
from sklearn.exceptions import NotFittedError

from hrc_drake.prediction import (
    ChingHigherOrderModel,
    HigherOrderMarkovModel,
    MarkovChainModel,
    VariableOrderMarkovModel,
    make_sequence_model,
)
from hrc_drake.prediction.config import HigherOrderMarkovPredictor
from hrc_drake.prediction.markov import mtd_regression, simplex_least_squares, transition_matrices


def test_transition_matrices_hand_counts():
    q = transition_matrices([0, 1, 0, 1, 1], 2, order=1)
    # one step: from 0 always to 1; from 1 half to 0, half to 1 (columns are "from")
    np.testing.assert_allclose(q[0], [[0.0, 0.5], [1.0, 0.5]])
    # two steps: pairs (0,0), (1,1), (0,1)
    np.testing.assert_allclose(q[1], [[0.5, 0.0], [0.5, 1.0]])


def test_unseen_column_is_uniform():
    q = transition_matrices([0, 0, 0], 3, order=0)
    np.testing.assert_allclose(q[0][:, 1], [1 / 3] * 3)
    np.testing.assert_allclose(q[0][:, 0], [1, 0, 0])


def test_simplex_least_squares_two_weights_closed_form():
    rng = np.random.default_rng(1)
    for _ in range(5):
        a = rng.normal(size=(12, 2))
        b = rng.normal(size=12)
        d = a[:, 0] - a[:, 1]
        t = np.clip(d @ (b - a[:, 1]) / (d @ d), 0.0, 1.0)
        np.testing.assert_allclose(simplex_least_squares(a, b), [t, 1 - t], atol=1e-6)


def test_simplex_least_squares_matches_slsqp():
    rng = np.random.default_rng(2)
    a = rng.random((40, 5))
    b = rng.random(40)
    lam = simplex_least_squares(a, b)
    assert lam.sum() == pytest.approx(1.0) and np.all(lam >= 0)
    ref = minimize(
        lambda x: np.sum((a @ x - b) ** 2),
        np.full(5, 0.2),
        method="SLSQP",
        bounds=[(0, 1)] * 5,
        constraints=[{"type": "eq", "fun": lambda x: x.sum() - 1}],
    )
    assert np.sum((a @ lam - b) ** 2) <= ref.fun + 1e-7


def test_mtd_regression_rows():
    seq = [0, 1, 1, 0]
    q = transition_matrices(seq, 2, order=1)
    a, b = mtd_regression(seq, q)
    # targets t = 2, 3: block t holds [Q0 X_{t-1}, Q1 X_{t-2}] against X_t
    np.testing.assert_allclose(a[:2, 0], q[0][:, seq[1]])
    np.testing.assert_allclose(a[:2, 1], q[1][:, seq[0]])
    np.testing.assert_allclose(a[2:, 0], q[0][:, seq[2]])
    np.testing.assert_allclose(b, [0, 1, 1, 0])


def test_homm_prediction_is_eq_5_8():
    rng = np.random.default_rng(3)
    seq = list(rng.integers(0, 4, size=60))
    model = HigherOrderMarkovModel(order=2, buffer_size=None).fit(seq)
    history = seq[-5:]
    expected = sum(model.weights_[i] * model.matrices_[i][:, history[-1 - i]] for i in range(3))
    np.testing.assert_allclose(model.predict_proba(history), expected)
    assert model.weights_.sum() == pytest.approx(1.0) and np.all(model.weights_ >= 0)


def test_homm_learns_period_three_pattern_a_chain_cannot():
    seq = [0, 1, 0, 2] * 20
    homm = HigherOrderMarkovModel(order=2, buffer_size=None).fit(seq)
    chain = MarkovChainModel(buffer_size=None).fit(seq)
    assert homm.predict_proba([1, 0, 2, 0])[1] > 0.95
    assert homm.predict_proba([0, 2, 0, 1, 0])[2] > 0.95
    np.testing.assert_allclose(chain.predict_proba([2, 0]), [0.0, 0.5, 0.5])


def test_fifo_partial_fit_equals_fit_on_buffer():
    rng = np.random.default_rng(4)
    seq = list(rng.integers(0, 3, size=50))
    online = HigherOrderMarkovModel(order=2, buffer_size=15, actions=3)
    for a in seq:
        online.partial_fit(a)
    batch = HigherOrderMarkovModel(order=2, buffer_size=15, actions=3).fit(seq[-15:])
    np.testing.assert_allclose(online.counts_, batch.counts_)
    np.testing.assert_allclose(online.weights_, batch.weights_, atol=1e-9)
    vomm_online = VariableOrderMarkovModel(max_depth=3, buffer_size=15, actions=3)
    for a in seq:
        vomm_online.partial_fit(a)
    vomm_batch = VariableOrderMarkovModel(max_depth=3, buffer_size=15, actions=3).fit(seq[-15:])
    assert vomm_online.contexts_.keys() == vomm_batch.contexts_.keys()
    for key, counts in vomm_batch.contexts_.items():
        np.testing.assert_allclose(vomm_online.contexts_[key], counts)


def test_ching_weights_on_simplex():
    seq = [0, 1, 2, 0, 1, 3, 2, 4] * 10
    model = ChingHigherOrderModel(order=3, buffer_size=None).fit(seq)
    assert model.weights_.sum() == pytest.approx(1.0) and np.all(model.weights_ >= -1e-12)
    assert model.predict_proba(seq[-8:]).sum() == pytest.approx(1.0)


def test_ppm_hand_case():
    model = VariableOrderMarkovModel(max_depth=1, buffer_size=None).fit([0, 1, 0, 1])
    # order -1 uniform -> order 0 counts [2, 2] (2 escapes) -> context (0,) counts [0, 2] (1 escape)
    np.testing.assert_allclose(model.predict_proba([1, 0]), [1 / 6, 5 / 6])
    np.testing.assert_allclose(model.predict_proba([]), [0.5, 0.5])


def test_multi_step_is_matrix_power_for_a_chain():
    chain = MarkovChainModel(buffer_size=None).fit([0, 0, 1, 2, 0, 1, 1, 2, 0])
    q = chain.matrices_[0]
    np.testing.assert_allclose(chain.predict_proba_steps([1], 3), np.linalg.matrix_power(q, 3)[:, 1])


def test_labels_and_bad_input():
    model = HigherOrderMarkovModel(order=1, buffer_size=None).fit(["pick", "place", "pick", "place"])
    assert model.classes_ == ["pick", "place"]
    assert model.predict_proba(["place", "pick"])[1] > 0.9
    with pytest.raises(ValueError, match="unknown action 'screw'"):
        model.predict_proba(["screw"])
    with pytest.raises(ValueError, match="unknown action"):
        model.partial_fit("screw")
    # empty history: the buffer marginal (documented fallback)
    np.testing.assert_allclose(model.predict_proba([]), [0.5, 0.5])
    with pytest.raises(NotFittedError):
        HigherOrderMarkovModel().predict_proba([0])
    np.testing.assert_allclose(HigherOrderMarkovModel(actions=4).predict_proba([1]), [0.25] * 4)
    with pytest.raises(ValueError, match="buffer_size"):
        HigherOrderMarkovModel(buffer_size=0).fit([0, 1])
    with pytest.raises(ValueError, match="order"):
        HigherOrderMarkovModel(order=-1).fit([0, 1])


def test_one_symbol_history_and_factory():
    model = make_sequence_model(HigherOrderMarkovPredictor(order=3, buffer_size=50), ["a", "b", "c"])
    assert isinstance(model, HigherOrderMarkovModel) and model.order == 3
    for a in "abcabcabc":
        model.partial_fit(a)
    p = model.predict_proba(["b"])
    assert p.argmax() == 2 and p.sum() == pytest.approx(1.0)
    with pytest.raises(ValueError, match="not a predictor config"):
        make_sequence_model("lstm", ["a"])
    with pytest.raises(ValueError, match="integer"):
        make_sequence_model(HigherOrderMarkovPredictor(order=2.5), ["a"])


def test_predict_proba_many_equals_one_by_one():
    rng = np.random.default_rng(6)
    seq = [int(a) for a in rng.integers(0, 4, size=80)]
    histories = [seq[:k] for k in (0, 1, 2, 5, 30, 80)]
    for model in (
        HigherOrderMarkovModel(order=3, buffer_size=50, actions=4),
        MarkovChainModel(buffer_size=None, actions=4),
        VariableOrderMarkovModel(max_depth=2, buffer_size=None, actions=4),
    ):
        np.testing.assert_allclose(model.predict_proba_many(histories), 0.25)  # nothing observed yet
        model.fit(seq)
        expected = np.stack([model.predict_proba(h) for h in histories])
        np.testing.assert_allclose(model.predict_proba_many(histories), expected, rtol=1e-12)
        np.testing.assert_allclose(model.predict_proba_many(histories[-2:]), expected[-2:], rtol=1e-12)
    with pytest.raises(ValueError, match=r"histories\[1\]: .*unknown action 9"):
        model.predict_proba_many([[0], [1, 9]])
