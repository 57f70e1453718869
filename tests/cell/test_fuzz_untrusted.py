"""A seeded sample of the import and text fuzz families (tools/fuzz_scenarios.py --family import,
text; issue 55): each case refused cleanly, or accepted with whole outputs, never an input
changed."""

from __future__ import annotations

import random

import pytest

from tests.cell.fuzz_untrusted import import_cases, text_cases
from tests.conftest import load_tool

IMPORT_SAMPLE, TEXT_SAMPLE = 8, 3


@pytest.fixture(scope="module")
def fuzz():
    module = load_tool("fuzz_scenarios")
    return module


@pytest.mark.parametrize("label, setup", random.Random(20261207).sample(import_cases(), IMPORT_SAMPLE))
def test_an_import_case_is_clean(fuzz, tmp_path, label, setup):
    outcome, message = fuzz.check_import_case(setup, tmp_path / "case.yaml")
    assert outcome in ("refused", "accepted"), f"{label}: {message}"


@pytest.mark.parametrize("label, text", random.Random(20261207).sample(text_cases(), TEXT_SAMPLE))
def test_a_text_case_is_clean(fuzz, tmp_path, label, text):
    outcome, message = fuzz.check_text_case(text, tmp_path / "case.yaml")
    assert outcome in ("refused", "accepted"), f"{label}: {message}"
