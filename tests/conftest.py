import os
from pathlib import Path

import pytest

try:
    from hypothesis import settings

    # The property tests draw the same examples on every run (a test suite that passes once
    # passes again); HYPOTHESIS_PROFILE=explore draws new ones, to look for more failures.
    settings.register_profile("repeatable", derandomize=True)
    settings.register_profile("explore", derandomize=False)
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))
except ImportError:  # the property tests skip without Hypothesis
    pass

REPO = Path(__file__).resolve().parents[1]
DIAGRAMS = REPO / "diagrams"



@pytest.fixture
def diagrams_dir() -> Path:
    return DIAGRAMS
