"""Typed predictor configs: YAML tags, validation with field paths, today's defaults, and the
copy-on-write clones of the cores they build."""

import copy
import dataclasses
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import hrc_drake.prediction.config as config_module
from hrc_drake.errors import ConfigError
from hrc_drake.prediction.config import (
    ChingPredictor,
    HigherOrderMarkovPredictor,
    MarkovChainPredictor,
    NoPredictor,
    PredictorConfig,
    SuffixTreePredictor,
    VariableOrderMarkovPredictor,
)
from hrc_drake.prediction.factory import make_sequence_model, make_waiting_predictor

ACTIONS = ["a", "b", "c"]
KINDS = [HigherOrderMarkovPredictor, MarkovChainPredictor, ChingPredictor, VariableOrderMarkovPredictor,
         SuffixTreePredictor]


def test_every_field_is_typed_and_documented():
    for cls in [NoPredictor, *KINDS]:
        for f in dataclasses.fields(cls):
            assert f.type in (int, float, str, bool, list[float], list[list[str]]), (cls, f.name)
    lines = Path(config_module.__file__).read_text().splitlines()
    for i, line in enumerate(lines):
        if re.match(r"^    \w+: [^=]+ = ", line):
            assert lines[i - 1].lstrip().startswith("#"), f"undocumented field: {line.strip()}"


def test_yaml_tags_choose_the_kind():
    yaml = pytest.importorskip("pydrake.common.yaml")

    @dataclass
    class Holder:
        predictor: PredictorConfig = field(default_factory=NoPredictor)

    loaded = yaml.yaml_load_typed(
        schema=Holder, data="predictor: !SuffixTreePredictor {order: 2, affine_sets: [[a, b]], rate: 4.0}"
    )
    assert loaded.predictor == SuffixTreePredictor(order=2, affine_sets=[["a", "b"]], rate=4.0)
    loaded = yaml.yaml_load_typed(schema=Holder, data="predictor: !HigherOrderMarkovPredictor {order: 2}")
    assert loaded.predictor == HigherOrderMarkovPredictor(order=2)


@pytest.mark.parametrize(
    "config, field_path",
    [
        (HigherOrderMarkovPredictor(order=0), "p.order"),
        (HigherOrderMarkovPredictor(order=11), "p.order"),
        (HigherOrderMarkovPredictor(rate=0.0), "p.rate"),
        (HigherOrderMarkovPredictor(rate=float("nan")), "p.rate"),
        (MarkovChainPredictor(buffer_size=-1), "p.buffer_size"),
        (ChingPredictor(refit_every=0), "p.refit_every"),
        (VariableOrderMarkovPredictor(max_depth=20), "p.max_depth"),
        (SuffixTreePredictor(forgetting=0.0), "p.forgetting"),
        (SuffixTreePredictor(affine_sets=[["a"]]), "p.affine_sets[0]"),
        (SuffixTreePredictor(resolution=float("inf")), "p.resolution"),
        (SuffixTreePredictor(percentile_levels=[0.5, 1.0]), "p.percentile_levels"),
        (SuffixTreePredictor(max_nodes=0), "p.max_nodes"),
        (SuffixTreePredictor(epsilon=1.0), "p.epsilon"),
    ],
)
def test_validate_names_the_field(config, field_path):
    with pytest.raises(ConfigError) as err:
        config.validate("p")
    assert err.value.field == field_path


def test_defaults_are_todays():
    for cls in KINDS:
        cls().validate("predictor")
        assert cls().rate == 2.0  # cell/plugins.py default before the typed configs
    from hrc_drake.cell.legacy import translate

    old = {"kind": "homm", "params": {"order": 2}}
    assert translate("predictor", old) == [("predictor", HigherOrderMarkovPredictor(order=2))]
    assert translate("predictor", {"kind": "none"}) == [("predictor", NoPredictor())]
    with pytest.raises(ConfigError, match="predictor.kind"):
        translate("predictor", {"kind": "lstm"})


@pytest.mark.parametrize("cls", KINDS)
def test_clone_is_copy_on_write(cls):
    """Learning on a clone leaves the original (and what it predicts) exactly as it was."""
    config = cls(affine_sets=[["a", "b"]]) if cls is SuffixTreePredictor else cls()
    model = make_sequence_model(config, ACTIONS)
    waiting = make_waiting_predictor(config, model)
    rng = np.random.default_rng(1)
    for k in range(60):
        action = ACTIONS[k % 3] if rng.random() < 0.8 else ACTIONS[rng.integers(3)]
        model.partial_fit(action)
        waiting.observe_duration(action, 1.0 + rng.random())
    before = json.dumps(model.to_dict()), json.dumps(waiting.to_dict())
    p_before = model.predict_proba(["a", "b"])
    w_before = waiting.percentiles(["a", "b"], 0.3)
    deep = copy.deepcopy(model)
    copy_model = model.clone()
    copy_waiting = waiting.clone(copy_model)
    for action in "ccbbaacc":
        copy_model.partial_fit(action)
        copy_waiting.observe_duration(action, 5.0)
        deep.partial_fit(action)
    assert (json.dumps(model.to_dict()), json.dumps(waiting.to_dict())) == before
    np.testing.assert_array_equal(model.predict_proba(["a", "b"]), p_before)
    np.testing.assert_array_equal(waiting.percentiles(["a", "b"], 0.3), w_before)
    assert json.dumps(copy_model.to_dict()) != before[0]
    # the clone learns exactly what a deep copy would
    assert json.dumps(copy_model.to_dict()) == json.dumps(deep.to_dict())
