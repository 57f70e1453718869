"""Suffix tree (thesis 5.2): operators I and O, tokens, domains D1-D3, priors, weights."""

import math

import numpy as np
import pytest

from hrc_drake.prediction import SuffixTreeModel
from hrc_drake.prediction.suffix_tree import (
    activation,
    affine_prior,
    distance_i,
    distance_o,
    occurrence_counts,
    occurrence_positions,
)


def test_table_5_1():
    y = [[2, 1, 3, 3, 2]]
    counts = occurrence_counts(y, 4)[0]
    assert list(counts[1:]) == [1, 2, 2]
    pos = occurrence_positions(y, 4)[0]
    assert list(pos[1, :2]) == [2, 0]
    assert list(pos[2, :2]) == [1, 5]
    assert list(pos[3, :2]) == [3, 4]


def test_distances():
    assert distance_i([1, 2, 3], [3, 2, 1], 4) == 0
    # positions: 1 at 1 vs 3, 3 at 3 vs 1
    assert distance_o([1, 2, 3], [3, 2, 1], 4) == 4
    assert distance_i([1, 1, 2], [1, 2, 2], 3) == 2
    assert distance_o([0, 1], [0, 1], 2) == 0


def test_activation_eq_5_26():
    assert activation([1, 3], 5, 0.5) == pytest.approx(math.exp(-2.0) + math.exp(-1.0))


def _tree(alpha=0.3):
    return SuffixTreeModel(order=2, forgetting=alpha, actions=3).fit([0, 1, 2, 0, 1, 2, 0])


def test_tokens_cases_a_and_b():
    model = _tree()
    # first branch at step sigma+1 = 3 with token 3; case a) adds tokens, case b) new branches
    assert model.token_sets_ == {(0, 1, 2): [3, 6], (1, 2, 0): [4, 7], (2, 0, 1): [5]}
    assert sorted(model.branches_) == [(0, 1, 2), (1, 2, 0), (2, 0, 1)]


def test_domains_and_phi():
    alpha = 0.3
    model = _tree(alpha)
    k = 8  # the step being predicted
    branches = {(0, 1, 2): [3, 6], (1, 2, 0): [4, 7], (2, 0, 1): [5]}
    act = {b: activation(t, k, alpha) for b, t in branches.items()}
    # context (0, 1): 2 -> branch exists (D1); 0, 1 -> no permutation of the counts (D3)
    assert list(model.domains([0, 1])) == [3, 3, 1]
    phi = model.phi_v([0, 1])
    assert phi[2] == pytest.approx(act[(0, 1, 2)])  # eq. (5.27)
    x = (0, 1, 0)
    expected3 = np.mean([act[b] / (distance_i(b, x, 3) + distance_o(b, x, 3)) for b in branches])
    assert phi[0] == pytest.approx(expected3)  # eqs. (5.31)-(5.32)
    # context (1, 0): 2 -> (1, 0, 2) is a permutation of every branch (D2)
    assert list(model.domains([1, 0])) == [3, 3, 2]
    x = (1, 0, 2)
    expected2 = np.mean([act[b] / distance_o(b, x, 3) for b in branches])
    assert model.phi_v([1, 0])[2] == pytest.approx(expected2)  # eqs. (5.28)-(5.30)


def test_affine_prior_eq_5_33():
    alpha = 0.2
    members = np.array([[True, True, False]])
    phi = affine_prior([0, 1], members, alpha)[0]  # A_{k-1} = 1, A_{k-2} = 0
    e1, e2 = math.exp(-alpha), math.exp(-2 * alpha)
    np.testing.assert_allclose(phi, [e1 - e2, -e1 + e2, 0.0])
    members3 = np.array([[True, True, True]])
    phi3 = affine_prior([2], members3, alpha)[0]
    np.testing.assert_allclose(phi3, [e1, e1, -0.5 * e1])


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    seq = list(rng.integers(0, 4, size=80))
    model = SuffixTreeModel(order=2, affine_sets=[[0, 1], [2, 3]], actions=4).fit(seq)
    w = np.array([0.7, -0.3, 0.4])
    value, grad = model._objective(w)
    steps = np.eye(3) * 1e-6
    numeric = np.array([(model._objective(w + h)[0] - model._objective(w - h)[0]) / 2e-6 for h in steps])
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-7)
    assert model.log_likelihood() >= model.log_likelihood(np.ones(3)) - 1e-12


def test_probabilities_and_multi_step_eq_5_15():
    seq = [0, 1, 2, 0, 2, 1] * 8
    model = SuffixTreeModel(order=2, affine_sets=[[1, 2]], actions=3).fit(seq)
    history = seq[-4:]
    p1 = model.predict_proba(history)
    assert p1.sum() == pytest.approx(1.0) and p1.argmax() == seq[0]
    two = sum(p1[a] * model.predict_proba(history[1:] + [a]) for a in range(3))
    np.testing.assert_allclose(model.predict_proba_steps(history, 2), two)


def test_memory_bounded_over_a_shift():
    rng = np.random.default_rng(5)
    model = SuffixTreeModel(order=2, forgetting=0.05, actions=4)
    life = math.ceil(math.log(1e3) / 0.05)
    for a in rng.integers(0, 4, size=3000):
        model.partial_fit(int(a))
    assert model.n_tokens_ <= life + 1  # one token per step, ages 0..life
    assert sum(len(t) for t in model.token_sets_.values()) == model.n_tokens_
    assert len(model._branch_index) <= 64 + 16 and len(model.buffer_) <= life + 3


def test_bad_input():
    with pytest.raises(ValueError, match="at least 2"):
        SuffixTreeModel(order=2, affine_sets=[[0]], actions=3).fit([0, 1, 2])
    with pytest.raises(ValueError, match=r"affine_sets\[0\].*unknown action 7"):
        SuffixTreeModel(order=2, affine_sets=[[0, 7]], actions=3).fit([0, 1, 2])
    with pytest.raises(ValueError, match="forgetting"):
        SuffixTreeModel(forgetting=0.0, actions=3).fit([0, 1])
    model = _tree()
    with pytest.raises(ValueError, match="order=2"):
        model.domains([0])
    # short histories: documented fallbacks, valid distributions
    for history in ([], [2]):
        p = model.predict_proba(history)
        assert p.sum() == pytest.approx(1.0)
    assert model.predict_proba([2]).argmax() == 0


def _literal_phi_v(model, context, alpha):
    """Phi_v of eqs. (5.21)-(5.32) straight from the text: loops over branches and tokens."""
    m, step = model.n_actions_, model.n_observed_ + 1
    tokens = model.token_sets_
    out = []
    for a in range(m):
        y = tuple(context) + (a,)
        act = {b: activation(t, step, alpha) for b, t in tokens.items()}
        if y in act:  # D1, (5.27)
            out.append(act[y])
            continue
        same = [b for b in act if distance_i(b, y, m) == 0]
        if same:  # D2, (5.28)-(5.30)
            out.append(np.mean([act[b] / distance_o(b, y, m) for b in same]))
        else:  # D3, (5.31)-(5.32)
            out.append(np.mean([act[b] / (distance_i(b, y, m) + distance_o(b, y, m)) for b in act]))
    return np.array(out)


@pytest.mark.parametrize("order", [1, 2, 4])
def test_batched_features_match_the_text(order):
    rng = np.random.default_rng(order)
    alpha = 0.1
    stages = [[0, 1], [2], [3, 4, 5]]
    seq = [int(a) for _ in range(25) for stage in stages for a in rng.permutation(stage)]
    seq = [int(rng.integers(0, 6)) if rng.random() < 0.1 else a for a in seq]
    model = SuffixTreeModel(order=order, affine_sets=[[0, 1], [3, 4, 5]], forgetting=alpha, actions=6)
    model.fit(seq)
    contexts = [tuple(seq[i : i + order]) for i in range(0, 60, 3)]
    contexts += [tuple(int(a) for a in rng.integers(0, 6, size=order)) for _ in range(10)]
    domains, phi = model._domains_and_phi_many(np.array(contexts))
    assert {1, 2, 3} <= set(domains.ravel())  # all three domains are exercised
    for row, context in enumerate(contexts[:12]):
        np.testing.assert_allclose(phi[row], _literal_phi_v(model, context, alpha), rtol=1e-12)
    for row, context in enumerate(contexts):
        ref_domain, ref_phi = model._domains_and_phi(context)
        np.testing.assert_array_equal(domains[row], ref_domain)
        np.testing.assert_allclose(phi[row], ref_phi, rtol=1e-12, atol=1e-15)
    many = model.predict_proba_many([list(seq[:5]), *map(list, contexts), [], [seq[0]]])
    single = np.stack([model.predict_proba(h) for h in [list(seq[:5]), *map(list, contexts), [], [seq[0]]]])
    np.testing.assert_allclose(many, single, rtol=1e-12, atol=1e-15)
