"""Property tests of the next-action models and the waiting-time tree on random action
sequences (Hypothesis): distributions, consistency of the batched, multi-step, online, cloned and
saved forms, documented errors, and repeatability."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hrc_drake.prediction import (
    ChingHigherOrderModel,
    HigherOrderMarkovModel,
    MarkovChainModel,
    SequenceModel,
    SuffixTreeModel,
    VariableOrderMarkovModel,
    WaitingTimePredictor,
)

buffer = st.one_of(st.none(), st.integers(3, 40))


@st.composite
def problems(draw):
    """(model, labels, sequence, histories): an unfitted model on an action set, a sequence of
    those actions and some histories to predict from."""
    m = draw(st.integers(1, 5))
    labels = list(range(m)) if draw(st.booleans()) else [f"a{i}" for i in range(m)]
    kind = draw(st.sampled_from(["mtd", "chain", "ching", "vomm", "tree"]))
    if kind == "mtd":
        model = HigherOrderMarkovModel(order=draw(st.integers(0, 3)), buffer_size=draw(buffer),
                                       actions=labels, refit_every=draw(st.integers(1, 3)))
    elif kind == "chain":
        model = MarkovChainModel(buffer_size=draw(buffer), actions=labels)
    elif kind == "ching":
        model = ChingHigherOrderModel(order=draw(st.integers(1, 3)), buffer_size=draw(buffer), actions=labels)
    elif kind == "vomm":
        model = VariableOrderMarkovModel(max_depth=draw(st.integers(0, 4)), buffer_size=draw(buffer),
                                         actions=labels)
    else:
        sets = []
        if m >= 2:
            for _ in range(draw(st.integers(0, 2))):
                sets.append(draw(st.lists(st.sampled_from(labels), min_size=2, max_size=m, unique=True)))
        model = SuffixTreeModel(order=draw(st.integers(1, 3)), affine_sets=sets,
                                forgetting=draw(st.floats(0.005, 1.0)), actions=labels,
                                learning_window=draw(st.integers(1, 40)),
                                learning_iterations=draw(st.integers(1, 3)))
    action = st.sampled_from(labels)
    n = draw(st.integers(0, 50))
    sequence = draw(st.lists(action, min_size=n, max_size=n))
    if n and draw(st.booleans()):  # a repeated pattern (the operator's cycle) with these slips
        pattern = draw(st.lists(action, min_size=1, max_size=4))
        sequence = [a if draw(st.integers(0, 9)) else pattern[k % len(pattern)]
                    for k, a in enumerate(sequence)]
    histories = draw(st.lists(st.lists(action, max_size=5), min_size=1, max_size=4))
    histories.append(sequence[max(len(sequence) - draw(st.integers(0, 6)), 0) :])  # what a cell asks
    return model, labels, sequence, histories


def assert_distribution(p, m):
    assert p.shape == (m,) and np.all(np.isfinite(p))
    assert np.all((p >= 0) & (p <= 1))
    assert abs(p.sum() - 1.0) <= 1e-9


def predictions(model, histories):
    return np.stack([model.predict_proba(h) for h in histories])


@settings(max_examples=120, deadline=None)
@given(problem=problems(), steps=st.integers(1, 4))
def test_models_give_consistent_distributions(problem, steps):
    model, labels, sequence, histories = problem
    m = len(labels)
    assert model.fit(sequence) is model
    single = predictions(model, histories)
    for p in single:
        assert_distribution(p, m)
    # the batched call is the same prediction (the suffix tree computes it another way)
    np.testing.assert_allclose(model.predict_proba_many(histories), single, rtol=0, atol=1e-9)
    for h, p in zip(histories, single, strict=True):
        np.testing.assert_allclose(model.predict_proba_steps(h, 1), p, rtol=0, atol=1e-12)
        # eqs. (5.14)-(5.15): two steps sum the next step over the first one
        two = sum(p[a] * model.predict_proba(list(h) + [labels[a]]) for a in range(m))
        np.testing.assert_allclose(model.predict_proba_steps(h, 2), two, rtol=0, atol=1e-9)
        assert_distribution(model.predict_proba_steps(h, steps), m)
    with pytest.raises(ValueError):
        model.predict_proba([labels[0], "no such action"])
    with pytest.raises(ValueError):
        model.predict_proba_steps(histories[0], 0)
    # the same sequence, the same model
    np.testing.assert_array_equal(predictions(type(model)(**model._params(), actions=labels).fit(sequence),
                                              histories), single)


@settings(max_examples=80, deadline=None)
@given(problem=problems(), more=st.lists(st.integers(0, 4), min_size=1, max_size=6))
def test_online_clone_and_saved_models_agree(problem, more):
    model, labels, sequence, histories = problem
    more = [labels[i % len(labels)] for i in more]
    model.fit(sequence)
    before = predictions(model, histories)
    clone = model.clone()
    for a in more:
        assert clone.partial_fit(a) is clone
    np.testing.assert_array_equal(predictions(model, histories), before)  # copy-on-write
    online = type(model)(**model._params(), actions=labels).fit(sequence)
    for a in more:
        online.partial_fit(a)
    np.testing.assert_array_equal(predictions(online, histories), predictions(clone, histories))
    # count-based models: fitting all at once equals fitting a prefix then the rest online
    exact_refit = not isinstance(model, SuffixTreeModel) and getattr(model, "refit_every", 1) == 1
    if exact_refit:
        batch = type(model)(**model._params(), actions=labels).fit(sequence + more)
        np.testing.assert_allclose(predictions(batch, histories), predictions(online, histories),
                                   rtol=0, atol=1e-9)
    saved = SequenceModel.from_dict(json.loads(json.dumps(online.to_dict())))
    assert type(saved) is type(model)
    np.testing.assert_allclose(predictions(saved, histories), predictions(online, histories),
                               rtol=0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(sequence=st.lists(st.integers(0, 6), max_size=20))
def test_labels_learned_at_fit(sequence):
    model = MarkovChainModel(buffer_size=None)
    if not sequence:
        with pytest.raises(ValueError, match="empty"):
            model.fit(sequence)
        return
    model.fit(sequence)
    assert model.classes_ == list(range(max(sequence) + 1))
    assert_distribution(model.predict_proba(sequence[-2:]), max(sequence) + 1)


durations = st.lists(st.floats(0.05, 12.0), max_size=4)


@settings(max_examples=80, deadline=None)
@given(problem=problems(), samples=st.lists(durations, min_size=5, max_size=5),
       elapsed=st.one_of(st.none(), st.floats(0.0, 30.0)), horizon=st.sampled_from([2.0, 5.0, 8.0]),
       resolution=st.sampled_from([0.25, 0.5, 1.0]), huge=st.floats(50.0, 1e308),
       levels=st.lists(st.floats(0.01, 0.99), min_size=1, max_size=3))
def test_waiting_time_cdfs(problem, samples, elapsed, horizon, resolution, huge, levels):
    model, labels, sequence, histories = problem
    model.fit(sequence)
    m = len(labels)

    def predictor(tail):
        waiting = WaitingTimePredictor(model, resolution=resolution, epsilon=1e-3)
        for label, values in zip(labels, samples, strict=False):
            for d in values:
                waiting.observe_duration(label, d)
        waiting.observe_duration(labels[0], tail)  # one sample past the horizon
        return waiting

    waiting = predictor(huge)
    history = histories[0]
    times, cdf = waiting.distributions(history, elapsed, horizon)
    assert times.shape == (int(round(horizon / resolution)) + 1,) and cdf.shape == (m, times.size)
    assert np.all(np.isfinite(cdf)) and np.all((cdf >= 0) & (cdf <= 1))
    assert np.all(np.diff(cdf, axis=1) >= 0)  # a CDF never decreases
    if elapsed is None or not history:  # nothing running: the next action starts now, eq. (5.37)
        np.testing.assert_allclose(cdf[:, 0], model.predict_proba(history), rtol=0, atol=1e-9)
    # durations past the horizon are dropped: how far past does not matter
    np.testing.assert_allclose(predictor(40.0).distributions(history, elapsed, horizon)[1], cdf,
                               rtol=0, atol=1e-12)
    np.testing.assert_array_equal(predictor(huge).distributions(history, elapsed, horizon)[1], cdf)
    pct = waiting.percentiles(history, elapsed, sorted(levels), horizon)
    assert pct.shape == (m, len(levels))
    assert np.all(np.isin(pct, times) | np.isinf(pct))
    assert np.all(pct[:, 1:] >= pct[:, :-1])  # a higher level is reached no earlier (inf: never)


bad_number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-1e3, 0.0))


@settings(max_examples=60, deadline=None)
@given(value=bad_number)
def test_waiting_time_arguments_are_checked(value):
    model = MarkovChainModel(buffer_size=None, actions=2).fit([0, 1, 1, 0])
    waiting = WaitingTimePredictor(model, resolution=0.5)
    ok = math.isfinite(value) and value > 0
    if ok:
        waiting.observe_duration(0, value)
        waiting.distributions([0], value, horizon=4.0)
        return
    with pytest.raises(ValueError):
        waiting.observe_duration(0, value)
    with pytest.raises(ValueError):
        waiting.distributions([0], 1.0, horizon=value)
    if not (math.isfinite(value) and value >= 0):
        with pytest.raises(ValueError):
            waiting.distributions([0], value, horizon=4.0)
    with pytest.raises(ValueError):
        waiting.percentiles([0], None, levels=(value,))
