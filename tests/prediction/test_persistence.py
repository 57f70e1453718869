"""JSON round trips of the sequence models and the waiting-time predictor (no pickle)."""

import json

import numpy as np
import pytest

from hrc_drake.prediction import (
    ChingHigherOrderModel,
    HigherOrderMarkovModel,
    MarkovChainModel,
    SequenceModel,
    SuffixTreeModel,
    VariableOrderMarkovModel,
    WaitingTimePredictor,
)


def _models():
    return [
        SuffixTreeModel(order=2, affine_sets=[["a", "b"]], forgetting=0.05, learning_window=40),
        HigherOrderMarkovModel(order=2, buffer_size=30, refit_every=3),
        MarkovChainModel(buffer_size=20),
        ChingHigherOrderModel(order=2, buffer_size=40),
        VariableOrderMarkovModel(max_depth=3, buffer_size=40),
    ]


@pytest.mark.parametrize("model", _models(), ids=lambda m: type(m).__name__)
def test_round_trip_then_identical_learning(model):
    rng = np.random.default_rng(0)
    labels = ["a", "b", "c", "d"]
    seq = [labels[i] for i in rng.integers(0, 4, size=260)]
    model.fit(seq[:20])
    for action in seq[20:200]:
        model.partial_fit(action)
    saved = json.dumps(model.to_dict())  # plain JSON, no numpy types
    copy = SequenceModel.from_dict(json.loads(saved))
    assert type(copy) is type(model) and copy.classes_ == labels
    history = seq[195:200]
    np.testing.assert_array_equal(copy.predict_proba(history), model.predict_proba(history))
    # the copy keeps learning exactly like the original
    for action in seq[200:]:
        model.partial_fit(action)
        copy.partial_fit(action)
    np.testing.assert_array_equal(copy.predict_proba(seq[-4:]), model.predict_proba(seq[-4:]))
    assert copy.to_dict() == model.to_dict()


def test_from_dict_bad_input():
    with pytest.raises(ValueError, match="missing keys"):
        SequenceModel.from_dict({"model": "MarkovChainModel"})
    with pytest.raises(ValueError, match="unknown model 'Lstm'"):
        SequenceModel.from_dict({"model": "Lstm", "params": {}, "classes": [0], "buffer": []})
    data = MarkovChainModel(buffer_size=None).fit([0, 1, 0]).to_dict()
    with pytest.raises(ValueError, match="unknown model"):  # a subclass loader refuses other models
        SuffixTreeModel.from_dict(data)
    with pytest.raises(ValueError, match="unknown action 7"):
        SequenceModel.from_dict({**data, "buffer": [0, 7]})
    tree = SuffixTreeModel(order=2).fit([0, 1, 2, 0, 1, 2]).to_dict()
    tree["state"]["tokens"].append([99, 1000])
    with pytest.raises(ValueError, match="missing branch"):
        SequenceModel.from_dict(tree)


def test_waiting_time_round_trip():
    chain = MarkovChainModel(buffer_size=None).fit(["x", "y", "x", "y", "x"])
    waiting = WaitingTimePredictor(chain, resolution=0.5, min_durations={"x": 0.5})
    for duration in (1.0, 1.5, 2.0):
        waiting.observe_duration("x", duration).observe_duration("y", duration + 1)
    copy = WaitingTimePredictor.from_dict(json.loads(json.dumps(waiting.to_dict())), chain)
    np.testing.assert_array_equal(copy.durations("y"), waiting.durations("y"))
    assert copy.min_durations == {"x": 0.5}
    np.testing.assert_array_equal(
        copy.distributions(["x"], 0.2, 10.0)[1], waiting.distributions(["x"], 0.2, 10.0)[1]
    )
    with pytest.raises(ValueError, match="params"):
        WaitingTimePredictor.from_dict({}, chain)
