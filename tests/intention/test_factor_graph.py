"""FactorGraph (thesis App. C) against independent brute force: the joint is enumerated with
numpy broadcasting from the raw inputs of each factor, never through the library."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp

from hrc_drake.intention.factor_graph import BPReport, FactorGraph

# ---------------------------------------------------------------------------------------------
# brute force


def log_joint(cards: list[int], specs: list[tuple[list[int], np.ndarray]]) -> np.ndarray:
    """log E over all joint assignments: the sum of every factor's log table, broadcast."""
    joint = np.zeros(cards)
    for variables, log_table in specs:
        order = np.argsort(variables)
        shape = [1] * len(cards)
        for v in variables:
            shape[v] = cards[v]
        joint = joint + np.transpose(log_table, order).reshape(shape)
    return joint


def condition(joint: np.ndarray, evidence: dict[int, int]) -> np.ndarray:
    out = np.full(joint.shape, -np.inf)
    index = tuple(evidence.get(v, slice(None)) for v in range(joint.ndim))
    out[index] = joint[index]
    return out


def brute_marginals(joint: np.ndarray) -> list[np.ndarray]:
    z = logsumexp(joint)
    return [
        np.exp(logsumexp(joint, axis=tuple(a for a in range(joint.ndim) if a != v)) - z)
        for v in range(joint.ndim)
    ]


# ---------------------------------------------------------------------------------------------
# random models: the graph and, beside it, the log tables it should hold


class Model:
    def __init__(self, cards: list[int]):
        self.cards = cards
        self.graph = FactorGraph()
        self.specs: list[tuple[list[int], np.ndarray]] = []
        self.weights = {"w1": 0.7, "w2": -1.3}
        for v, k in enumerate(cards):
            self.graph.add_variable(f"V{v}", k)

    def add(self, rng: np.random.Generator, variables: list[int], scale: float) -> None:
        names = [f"V{v}" for v in variables]
        shape = tuple(self.cards[v] for v in variables)
        kind = rng.choice(["table", "exp", "corr"]) if len(variables) > 1 else rng.choice(["table", "exp"])
        if kind == "corr" and self.cards[variables[0]] == self.cards[variables[1]] and len(variables) == 2:
            w = float(rng.normal(0.0, scale))
            if rng.random() < 0.5:
                self.graph.add_correlation_factor(*names, weight=w)
            else:
                w = self.weights["w1"]
                self.graph.add_correlation_factor(*names, weight_name="w1")
            self.specs.append((variables, w * np.eye(shape[0])))
        elif kind == "exp":
            phi = rng.normal(0.0, scale, shape)
            name = str(rng.choice(["w1", "w2"]))
            self.graph.add_exponential_factor(names, phi, weight_name=name)
            self.specs.append((variables, self.weights[name] * phi))
        else:
            table = np.exp(rng.normal(0.0, scale, shape))
            if rng.random() < 0.3:  # exact zeros are allowed in simple factors
                table.flat[rng.integers(table.size)] = 0.0
            self.graph.add_factor(names, table)
            with np.errstate(divide="ignore"):
                self.specs.append((variables, np.log(table)))

    def finish(self) -> np.ndarray:
        used = self.graph.weights()
        self.graph.set_weights({name: w for name, w in self.weights.items() if name in used})
        return log_joint(self.cards, self.specs)


def random_cards(rng: np.random.Generator, n: int) -> list[int]:
    cards = list(rng.integers(2, 5, n))
    while np.prod(cards) > 60_000:
        cards[int(np.argmax(cards))] -= 1
    return [int(k) for k in cards]


def random_tree(seed: int, scale: float = 1.5) -> tuple[Model, np.ndarray]:
    """A random hypertree of factors with 2-3 variables, unary factors, and one factor repeated
    over the same variables (merged by the graph, so still a tree)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 11))
    model = Model(random_cards(rng, n))
    attached, rest = [0], list(rng.permutation(np.arange(1, n)))
    while rest:
        k = min(int(rng.integers(1, 3)), len(rest))
        new, rest = [int(v) for v in rest[:k]], rest[k:]
        variables = [int(rng.choice(attached)), *new]
        model.add(rng, list(rng.permutation(variables)), scale)
        attached += new
    for v in range(n):
        if rng.random() < 0.6:
            model.add(rng, [v], scale)
    first = model.specs[0][0]
    model.add(rng, list(rng.permutation(first)), scale)
    return model, model.finish()


def random_loopy(seed: int) -> tuple[Model, np.ndarray]:
    """Variables 0-3 on a cycle, the others hung on as a random tree, extra random pairwise
    factors; strong unary factors and weak couplings."""
    rng = np.random.default_rng(1000 + seed)
    n = int(rng.integers(6, 11))
    model = Model(random_cards(rng, n))
    for a, b in [(0, 1), (1, 2), (2, 3), (3, 0)]:
        model.add(rng, [a, b], 0.3)
    for v in range(4, n):
        model.add(rng, [int(rng.integers(v)), v], 0.3)
    for _ in range(int(rng.integers(0, 3))):
        a, b = (int(x) for x in rng.choice(n, 2, replace=False))
        model.add(rng, [a, b], 0.3)
    for v in range(n):
        model.add(rng, [v], 1.5)
    return model, model.finish()


def random_evidence(rng: np.random.Generator, joint: np.ndarray, first: int = 0) -> dict[int, int]:
    """A few variables (from `first` on) set to the values of a joint sample, so the evidence is
    possible."""
    p = np.exp(joint - logsumexp(joint)).ravel()
    sample = np.unravel_index(rng.choice(p.size, p=p), joint.shape)
    pool = np.arange(first, joint.ndim)
    chosen = rng.choice(pool, int(rng.integers(1, min(3, len(pool) - 1) + 1)), replace=False)
    return {int(v): int(sample[v]) for v in chosen}


def named(evidence: dict[int, int]) -> dict[str, int]:
    return {f"V{v}": x for v, x in evidence.items()}


def score(joint: np.ndarray, assignment: dict[str, int]) -> float:
    return float(joint[tuple(assignment[f"V{v}"] for v in range(joint.ndim))])


# ---------------------------------------------------------------------------------------------
# exact inference on trees


@pytest.mark.parametrize("seed", range(25))
@pytest.mark.parametrize("with_evidence", [False, True])
def test_tree_marginals_map_and_log_partition_match_brute_force(seed, with_evidence):
    model, joint = random_tree(seed)
    g = model.graph
    evidence = random_evidence(np.random.default_rng(seed), joint) if with_evidence else {}
    cond = condition(joint, evidence)

    marg = g.marginals(named(evidence))
    assert g.last_report == BPReport("sum", True, True, 1, 0.0)
    for v, p in enumerate(brute_marginals(cond)):
        np.testing.assert_allclose(marg[f"V{v}"], p, atol=1e-9, rtol=0)

    np.testing.assert_allclose(g.log_partition(named(evidence)), logsumexp(cond), atol=1e-9)

    best = g.map(named(evidence))
    assert g.last_report.exact and g.last_report.mode == "max"
    assert all(best[f"V{v}"] == x for v, x in evidence.items())
    assert score(cond, best) == pytest.approx(cond.max(), abs=1e-9)
    assert g.log_energy(best) == pytest.approx(score(joint, best), abs=1e-9)


def test_thesis_example_fig_c7_marginals_are_flat_but_map_is_consistent():
    """Table C.1 / eq. (C.24)-(C.25): with X = 0 and Y = 1 both marginals are (0.5, 0.5), yet only
    A == B maximises the joint (ties go to the lowest values)."""
    g = FactorGraph()
    for name in "XABY":
        g.add_variable(name, 2)
    g.add_factor(["A", "X"], [[1.0, 0.1], [0.1, 1.0]])
    g.add_factor(["A", "B"], [[2.0, 0.0], [0.0, 2.0]])
    g.add_factor(["B", "Y"], [[1.0, 0.1], [0.1, 1.0]])
    marg = g.marginals({"X": 0, "Y": 1})
    np.testing.assert_allclose(marg["A"], [0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(marg["B"], [0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(marg["X"], [1.0, 0.0])
    assert g.map({"X": 0, "Y": 1}) == {"X": 0, "A": 0, "B": 0, "Y": 1}
    assert g.log_partition({"X": 0, "Y": 1}) == pytest.approx(np.log(0.4), abs=1e-12)


def test_ties_are_broken_deterministically_to_the_lowest_values():
    g = FactorGraph()
    for name in "ABCD":
        g.add_variable(name, 3)
    g.add_factor(["A", "B"], np.ones((3, 3)))
    g.add_factor(["B", "C", "D"], np.ones((3, 3, 3)))
    assert g.map() == {"A": 0, "B": 0, "C": 0, "D": 0}


def test_map_backtracks_where_every_max_marginal_ties():
    """Anti-correlated pairs: every max-marginal is flat, so decoding them one by one would give
    the impossible all-zeros; backtracking gives an optimal (and repeatable) assignment."""
    g = FactorGraph()
    for name in "ABCDE":
        g.add_variable(name, 2)
    for a, b in ["AB", "BC", "CD", "CE"]:
        g.add_factor([a, b], [[0.0, 1.0], [1.0, 0.0]])
    best = g.map()
    assert g.log_energy(best) == 0.0
    assert best == g.map()
    assert best["A"] != best["B"] != best["C"] != best["D"] and best["E"] == best["D"]


def test_variables_without_factors_and_evidence_on_them():
    g = FactorGraph()
    g.add_variable("A", 2)
    g.add_variable("free", 3)
    g.add_variable("seen", 4)
    g.add_factor(["A"], [1.0, 3.0])
    marg = g.marginals({"seen": 2})
    np.testing.assert_allclose(marg["A"], [0.25, 0.75])
    np.testing.assert_allclose(marg["free"], np.full(3, 1 / 3))
    np.testing.assert_allclose(marg["seen"], [0, 0, 1, 0])
    assert g.map({"seen": 2}) == {"A": 1, "free": 0, "seen": 2}
    assert g.log_partition() == pytest.approx(np.log(4.0 * 3 * 4))


def test_evidence_that_cuts_the_only_cycle_makes_inference_exact():
    rng = np.random.default_rng(5)
    g = FactorGraph()
    for name in "ABC":
        g.add_variable(name, 3)
    tables = {pair: np.exp(rng.normal(0, 2, (3, 3))) for pair in [(0, 1), (1, 2), (0, 2)]}
    for (a, b), t in tables.items():
        g.add_factor(["ABC"[a], "ABC"[b]], t)
    joint = log_joint([3, 3, 3], [([a, b], np.log(t)) for (a, b), t in tables.items()])
    g.marginals()
    assert not g.last_report.exact
    marg = g.marginals({"C": 1})
    assert g.last_report.exact
    for v, p in enumerate(brute_marginals(condition(joint, {2: 1}))):
        np.testing.assert_allclose(marg["ABC"[v]], p, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# loopy graphs


@pytest.mark.parametrize("seed", range(15))
@pytest.mark.parametrize("with_evidence", [False, True])
def test_loopy_bp_converges_and_approximates_brute_force(seed, with_evidence):
    model, joint = random_loopy(seed)
    g = model.graph
    evidence = random_evidence(np.random.default_rng(seed), joint, first=4) if with_evidence else {}
    cond = condition(joint, evidence)
    marg = g.marginals(named(evidence), tol=1e-10)
    report = g.last_report
    assert not report.exact and report.mode == "sum"  # the evidence leaves the cycle 0-1-2-3
    assert report.converged and report.max_change < 1e-10 and 1 < report.iterations < 1000
    for v, p in enumerate(brute_marginals(cond)):
        np.testing.assert_allclose(marg[f"V{v}"], p, atol=0.05, rtol=0)
    assert g.log_partition(named(evidence)) == pytest.approx(logsumexp(cond), abs=0.05)

    # max-product on loops is approximate: with weak couplings the decoded max-marginals still
    # give the optimum on all these seeds (the score of the assignment is what is compared)
    best = g.map(named(evidence))
    assert not g.last_report.exact and g.last_report.converged
    assert all(best[f"V{v}"] == x for v, x in evidence.items())
    assert score(cond, best) >= cond.max() - 1e-9


def test_loopy_report_says_not_converged_when_stopped_early():
    model, _ = random_loopy(0)
    model.graph.marginals(max_iter=2, damping=0.0)
    report = model.graph.last_report
    assert not report.exact and not report.converged and report.iterations == 2 and report.max_change > 0


# ---------------------------------------------------------------------------------------------
# long chains


def chain(n: int, seed: int) -> tuple[FactorGraph, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    pair = rng.normal(0.0, 8.0, (n - 1, 2, 2))  # strong: the direct product underflows at once
    unary = rng.normal(0.0, 4.0, (n, 2))
    g = FactorGraph()
    for i in range(n):
        g.add_variable(i, 2)
    for i in range(n - 1):
        g.add_factor([i, i + 1], np.exp(pair[i]))
    for i in range(n):
        g.add_factor([i], np.exp(unary[i]))
    return g, pair, unary


def forward_backward(pair: np.ndarray, unary: np.ndarray, evidence: dict[int, int]) -> np.ndarray:
    unary = unary.copy()
    for i, x in evidence.items():
        unary[i, 1 - x] = -np.inf
    n = len(unary)
    alpha, beta = np.zeros((n, 2)), np.zeros((n, 2))
    alpha[0] = unary[0]
    for t in range(1, n):
        alpha[t] = logsumexp(alpha[t - 1][:, None] + pair[t - 1], axis=0) + unary[t]
    for t in range(n - 2, -1, -1):
        beta[t] = logsumexp(pair[t] + (unary[t + 1] + beta[t + 1])[None, :], axis=1)
    post = alpha + beta
    return np.exp(post - logsumexp(post, axis=1, keepdims=True))


def viterbi_score(pair: np.ndarray, unary: np.ndarray) -> float:
    delta = unary[0]
    for t in range(1, len(unary)):
        delta = np.max(delta[:, None] + pair[t - 1], axis=0) + unary[t]
    return float(np.max(delta))


def test_long_chain_marginals_are_finite_and_match_forward_backward():
    n = 2000
    g, pair, unary = chain(n, seed=3)
    evidence = {100: 1, 1500: 0}
    marg = g.marginals(evidence)
    got = np.array([marg[i] for i in range(n)])
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(got, forward_backward(pair, unary, evidence), atol=1e-9, rtol=0)

    best = g.map()
    value = sum(pair[i, best[i], best[i + 1]] for i in range(n - 1)) + sum(
        unary[i, best[i]] for i in range(n)
    )
    assert value == pytest.approx(viterbi_score(pair, unary), abs=1e-6)


# ---------------------------------------------------------------------------------------------
# learning with shared weights


TRUE_WEIGHTS = {"w_Y": 0.8, "w_O": 1.2, "w_c": -0.6}


def learning_model() -> tuple[FactorGraph, list[int], list]:
    """Y1-Y2-Y3-Y4 (3 values) with one shared w_Y, eq. (4.2); O_i - Y_i (2 values) with one
    shared w_O, eq. (4.1); C - Y4 a learnable correlation; a fixed simple prior on Y1."""
    rng = np.random.default_rng(11)
    q_yy = rng.uniform(0.0, 2.0, (3, 3))
    phi_oy = rng.uniform(-1.0, 1.0, (2, 3))
    prior = np.array([1.0, 2.0, 0.5])
    g = FactorGraph()
    names = ["Y1", "Y2", "Y3", "Y4", "O1", "O2", "O3", "O4", "C"]
    for name in names:
        g.add_variable(name, 2 if name.startswith("O") else 3)
    cards = [3, 3, 3, 3, 2, 2, 2, 2, 3]
    terms = []  # (variables, weight name or None, table: phi or log table)
    for k in range(3):
        g.add_exponential_factor([names[k + 1], names[k]], q_yy, weight_name="w_Y", weight=0.0)
        terms.append(([k + 1, k], "w_Y", q_yy))
    for k in range(4):
        g.add_exponential_factor([names[4 + k], names[k]], phi_oy, weight_name="w_O", weight=0.0)
        terms.append(([4 + k, k], "w_O", phi_oy))
    g.add_correlation_factor("C", "Y4", weight_name="w_c", weight=0.0)
    terms.append(([8, 3], "w_c", np.eye(3)))
    g.add_factor(["Y1"], prior)
    terms.append(([0], None, np.log(prior)))
    return g, cards, terms


def brute_features(cards, terms, weights):
    """log joint and the summed features of each weight, over all assignments."""
    joint = log_joint(cards, [(v, t if w is None else weights[w] * t) for v, w, t in terms])
    feats = {name: log_joint(cards, [(v, t) for v, w, t in terms if w == name]) for name in weights}
    return joint, feats


def draw_samples(n: int, seed: int):
    _, cards, terms = learning_model()
    joint, _ = brute_features(cards, terms, TRUE_WEIGHTS)
    p = np.exp(joint - logsumexp(joint)).ravel()
    idx = np.random.default_rng(seed).choice(p.size, size=n, p=p)
    return np.stack(np.unravel_index(idx, cards), axis=1)


def test_fit_recovers_the_generating_shared_weights():
    n = 5000  # the standard errors below are <= 0.035, so 0.15 is over 4 of them
    samples = draw_samples(n, seed=2)
    g, cards, terms = learning_model()
    report = g.fit(samples)
    assert report.converged and report.gradient_norm < 1e-5
    fitted = g.weights()
    assert report.weights == fitted

    # at the fitted weights the brute-force gradient of eq. (C.38) vanishes: the expected
    # features under the model equal the empirical ones ...
    joint, feats = brute_features(cards, terms, fitted)
    p = np.exp(joint - logsumexp(joint))
    cells = tuple(samples.T)
    for name in fitted:
        assert np.sum(p * feats[name]) == pytest.approx(np.mean(feats[name][cells]), abs=1e-5)
    assert report.log_likelihood == pytest.approx(np.mean(joint[cells]) - logsumexp(joint), abs=1e-8)

    # ... and the generating weights are recovered within a few standard errors, from the Fisher
    # information (the covariance of the features) at the true weights
    joint, feats = brute_features(cards, terms, TRUE_WEIGHTS)
    p = np.exp(joint - logsumexp(joint)).ravel()
    f = np.stack([feats[name].ravel() for name in TRUE_WEIGHTS])
    centred = f - (f @ p)[:, None]
    stderr = np.sqrt(np.diag(np.linalg.inv((centred * p) @ centred.T)) / n)
    assert np.all(4 * stderr < 0.15)
    for k, name in enumerate(TRUE_WEIGHTS):
        assert abs(fitted[name] - TRUE_WEIGHTS[name]) < 0.15, (name, fitted[name], stderr[k])


def test_fit_accepts_dict_samples_gradient_ascent_and_l2():
    samples = draw_samples(1500, seed=4)
    g, _, _ = learning_model()
    reference = g.fit(samples).weights

    g, _, _ = learning_model()
    dicts = [dict(zip(g.variables, (int(x) for x in row), strict=True)) for row in samples]
    assert g.fit(dicts).weights == pytest.approx(reference, abs=1e-6)

    g, _, _ = learning_model()
    report = g.fit(samples, method="gradient", learning_rate=0.1, max_iter=400, tol=1e-4)
    assert report.converged
    assert report.weights == pytest.approx(reference, abs=5e-3)

    g, _, _ = learning_model()
    shrunk = g.fit(samples, l2=1.0).weights
    assert sum(w * w for w in shrunk.values()) < sum(w * w for w in reference.values())


# ---------------------------------------------------------------------------------------------
# bad input


def small_graph() -> FactorGraph:
    g = FactorGraph()
    g.add_variable("A", 2)
    g.add_variable("B", 2)
    g.add_variable("C", 3)
    g.add_exponential_factor(["A", "B"], np.eye(2), weight_name="w")
    g.add_factor(["B", "C"], np.ones((2, 3)))
    return g


@pytest.mark.parametrize(
    ("action", "match"),
    [
        (lambda g: g.add_variable("A", 2), "duplicate variable 'A'"),
        (lambda g: g.add_variable("D", 0), "cardinality of variable 'D'"),
        (lambda g: g.add_variable("D", 2.5), "cardinality of variable 'D'"),
        (lambda g: g.add_factor(["A", "Z"], np.ones((2, 2))), "unknown variable 'Z'"),
        (lambda g: g.add_factor(["A", "A"], np.ones((2, 2))), "repeated variable"),
        (lambda g: g.add_factor(["A", "C"], np.ones((2, 2))), r"shape \(2, 2\), expected \(2, 3\)"),
        (lambda g: g.add_factor(["A"], [1.0, -0.5]), "negative entries"),
        (lambda g: g.add_factor(["A"], [1.0, np.nan]), "non-finite"),
        (lambda g: g.add_factor(["A"], [np.inf, 1.0]), "non-finite"),
        (lambda g: g.add_factor(["A"], [0.0, 0.0]), "all zero"),
        (lambda g: g.add_exponential_factor(["A"], [1.0, np.inf], "w"), "phi .* non-finite"),
        (lambda g: g.add_exponential_factor(["C"], [1.0, 2.0], "w"), r"phi .* shape \(2,\)"),
        (lambda g: g.add_exponential_factor(["A"], [1.0, 2.0], "w", weight=3.0), "weight 'w' already"),
        (lambda g: g.add_correlation_factor("A", "C", weight=1.0), "correlation factor between 'A'"),
        (lambda g: g.add_correlation_factor("A", "Q"), "unknown variable 'Q'"),
        (lambda g: g.set_weights({"nope": 1.0}), "unknown weight name 'nope'"),
        (lambda g: g.set_weights({"w": np.nan}), "weight 'w' must be finite"),
        (lambda g: g.marginals({"C": 3}), "evidence for 'C' is 3, out of range 0..2"),
        (lambda g: g.marginals({"C": 1.0}), "evidence for 'C'"),
        (lambda g: g.map({"Z": 0}), "evidence for unknown variable 'Z'"),
        (lambda g: g.marginals(damping=1.0), "damping"),
        (lambda g: g.marginals(max_iter=0), "max_iter"),
        (lambda g: g.fit(np.zeros((4, 2), dtype=int)), r"one column per variable .* shape \(4, 2\)"),
        (lambda g: g.fit(np.array([[0, 0, 3]])), "value 3 of variable 'C' out of range 0..2"),
        (lambda g: g.fit(np.array([[0.5, 0, 1]])), "integer"),
        (lambda g: g.fit([{"A": 0, "B": 1}]), r"missing variables \['C'\]"),
        (lambda g: g.fit([{"A": 0, "B": 1, "C": 0, "D": 1}]), r"unknown variables \['D'\]"),
        (lambda g: g.fit(np.zeros((1, 3), dtype=int), method="newton"), "unknown fit method"),
    ],
)
def test_bad_input_raises_a_value_error_naming_it(action, match):
    with pytest.raises(ValueError, match=match):
        action(small_graph())


def test_impossible_evidence_and_samples_are_reported():
    g = FactorGraph()
    g.add_variable("A", 2)
    g.add_variable("B", 2)
    g.add_factor(["A", "B"], [[1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="zero probability"):
        g.marginals({"A": 0, "B": 1})
    g.add_variable("C", 2)
    g.add_factor(["B", "C"], [[1.0, 0.0], [1.0, 1.0]])
    with pytest.raises(ValueError, match="zero probability"):
        g.map({"A": 0, "C": 1})
    g.add_exponential_factor(["C"], [0.0, 1.0], weight_name="w")
    with pytest.raises(ValueError, match="sample 1 has zero probability"):
        g.fit(np.array([[0, 0, 0], [0, 1, 0]]))
    with pytest.raises(ValueError, match="no learnable weights"):
        FactorGraph().fit(np.zeros((1, 0), dtype=int))


# ---------------------------------------------------------------------------------------------
# zeros on loopy graphs (Z = 0 and impossible MAPs)

NOT_EQUAL = 1.0 - np.eye(2)


def ring(n: int, cards: int = 2, table=None) -> FactorGraph:
    """n variables on a cycle of "not equal" factors (or `table`)."""
    g = FactorGraph()
    for v in range(n):
        g.add_variable(f"V{v}", cards)
    for v in range(n):
        g.add_factor([f"V{v}", f"V{(v + 1) % n}"], 1.0 - np.eye(cards) if table is None else table)
    return g


@pytest.mark.parametrize("query", [lambda g: g.marginals(), lambda g: g.log_partition(), lambda g: g.map()])
def test_triangle_of_not_equal_factors_has_no_possible_assignment(query):
    """Three binary variables pairwise different: Z = 0. Loopy BP keeps uniform, converged messages
    (so it used to answer uniform marginals, log Z = 0 and a MAP of probability zero); the query
    now raises, and the report says no assignment is possible."""
    g = ring(3)
    with pytest.raises(ValueError, match="zero probability"):
        query(g)
    report = g.last_report
    assert not report.exact and report.feasible is False


def test_even_ring_of_not_equal_factors_maps_to_a_possible_assignment():
    """Four binary variables in a ring of "not equal": the max-marginals are flat, so their argmax
    (all zeros) is impossible; the MAP is one of the two alternating assignments."""
    g = ring(4)
    best = g.map()
    assert g.last_report.feasible is True and not g.last_report.exact
    assert g.log_energy(best) == 0.0
    assert [best[f"V{v}"] for v in range(4)] in ([0, 1, 0, 1], [1, 0, 1, 0])
    np.testing.assert_allclose(g.marginals()["V0"], [0.5, 0.5])
    assert g.last_report.feasible is True


def test_evidence_that_leaves_no_possible_assignment_on_a_loop_raises():
    """A 5-ring of "not equal" on 3 values, its neighbours V1 and V2 equal to the observed E and F:
    E = 0, F = 1 leaves the ring loopy and possible; E = F = 1 makes V1 = V2, which their "not
    equal" forbids."""
    g = ring(5, cards=3)
    for observed, hidden in (("E", "V1"), ("F", "V2")):
        g.add_variable(observed, 3)
        g.add_factor([observed, hidden], np.eye(3))
    best = g.map({"E": 0, "F": 1})
    assert g.last_report.feasible is True and not g.last_report.exact
    assert np.isfinite(g.log_energy(best))
    with pytest.raises(ValueError, match="evidence has zero probability"):
        g.marginals({"E": 1, "F": 1})
    assert g.last_report.feasible is False


def test_search_that_gives_up_is_reported_as_unknown(monkeypatch):
    """Four variables pairwise different on 3 values (K4 is not 3-colourable): arc consistency does
    not see it, the search does after a few values; with a budget of one value it gives up and the
    report says so (feasible None) instead of claiming either answer."""
    import hrc_drake.intention.factor_graph as fg

    g = FactorGraph()
    for v in range(4):
        g.add_variable(v, 3)
    for a in range(4):
        for b in range(a + 1, 4):
            g.add_factor([a, b], 1.0 - np.eye(3))
    with pytest.raises(ValueError, match="zero probability"):
        g.marginals()
    monkeypatch.setattr(fg, "SEARCH_BUDGET", 1)
    g.add_variable("free", 2)  # a new structure: the verdict kept above is not reused
    g.marginals()
    assert g.last_report.feasible is None and not g.last_report.exact


@pytest.mark.parametrize("seed", range(40))
def test_loopy_zeros_against_brute_force(seed):
    """Random loopy graphs of 2-3 valued variables whose pairwise tables are a third zeros: a query
    raises exactly when the brute-force joint has no possible assignment, and otherwise the MAP is
    possible (a finite score)."""
    rng = np.random.default_rng(7000 + seed)
    n = int(rng.integers(4, 8))
    cards = [int(k) for k in rng.integers(2, 4, n)]
    g, specs = FactorGraph(), []
    for v in range(n):
        g.add_variable(f"V{v}", cards[v])
    pairs = [(v, (v + 1) % n) for v in range(n)] + [tuple(int(x) for x in rng.choice(n, 2, replace=False))]
    for a, b in pairs:
        table = np.exp(rng.normal(0.0, 1.0, (cards[a], cards[b])))
        table[rng.random(table.shape) < 0.35] = 0.0
        if not table.any():
            table[0, 0] = 1.0
        g.add_factor([f"V{a}", f"V{b}"], table)
        with np.errstate(divide="ignore"):
            specs.append(([a, b], np.log(table)))
    joint = log_joint(cards, specs)
    if not np.isfinite(joint).any():
        for query in (g.marginals, g.map, g.log_partition):
            with pytest.raises(ValueError, match="zero probability"):
                query()
            assert g.last_report.feasible is False
        return
    best = g.map()
    assert g.last_report.feasible is True
    assert np.isfinite(score(joint, best))
    marg = g.marginals()
    assert all(np.isfinite(p).all() for p in marg.values())


def test_loopy_zeros_seeds_cover_both_outcomes():
    """The brute-force sweep above meets both possible and impossible graphs (else it tests one)."""
    outcomes = set()
    for seed in range(40):
        rng = np.random.default_rng(7000 + seed)
        n = int(rng.integers(4, 8))
        cards = [int(k) for k in rng.integers(2, 4, n)]
        specs = []
        pairs = [(v, (v + 1) % n) for v in range(n)] + [
            tuple(int(x) for x in rng.choice(n, 2, replace=False))
        ]
        for a, b in pairs:
            table = np.exp(rng.normal(0.0, 1.0, (cards[a], cards[b])))
            table[rng.random(table.shape) < 0.35] = 0.0
            if not table.any():
                table[0, 0] = 1.0
            with np.errstate(divide="ignore"):
                specs.append(([a, b], np.log(table)))
        outcomes.add(bool(np.isfinite(log_joint(cards, specs)).any()))
    assert outcomes == {True, False}
