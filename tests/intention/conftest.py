"""A small learned model for the intention tests."""

from __future__ import annotations

import pytest

from hrc_drake.intention.likelihood import IntentionLikelihoodLearner
from tests.intention.intention_reaches import reach_samples


@pytest.fixture(scope="session")
def small_model():
    learner = IntentionLikelihoodLearner(candidates=(1, 2, 3), random_state=0).fit(reach_samples())
    return learner.model_
