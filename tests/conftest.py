import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DIAGRAMS = REPO / "diagrams"


def shared_data_dir() -> Path:
    return Path(os.environ.get("HRC_DRAKE_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture
def diagrams_dir() -> Path:
    return DIAGRAMS
