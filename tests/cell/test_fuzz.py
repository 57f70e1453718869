"""Fuzz: mutated scenarios (every leaf of every file in diagrams/ changed in type, sign, to NaN,
huge, empty or an unknown name; a seeded sample) are either refused by `validate` with a clean
message, or accepted by `validate` and by a 2 s `simulate` alike - never a traceback."""

from __future__ import annotations

import random
import warnings

import pytest

from hrc_drake.cli import EXIT_BAD_INPUT, EXIT_OK, main
from tests.cell.fuzz import mutant_text, mutation_sites
from tests.conftest import DIAGRAMS

SAMPLE = 30


def _sample():
    sites = [(path, site) for path in sorted(DIAGRAMS.glob("*.yaml")) for site in mutation_sites(path)]
    return random.Random(20261202).sample(sites, SAMPLE)


def _run(args, capsys):
    try:
        code = main(args)
    except SystemExit as exit_:
        code = exit_.code
    captured = capsys.readouterr()
    return code, captured.out + captured.err


@pytest.mark.slow
@pytest.mark.parametrize("path, site", _sample(), ids=lambda v: v[0] if isinstance(v, tuple) else "")
def test_a_mutated_scenario_is_refused_cleanly_or_runs(path, site, tmp_path, capsys):
    label, where, new = site
    mutant = tmp_path / path.name
    mutant.write_text(mutant_text(path, where, new))
    code, text = _run(["validate", str(mutant)], capsys)
    assert code in (EXIT_OK, EXIT_BAD_INPUT) and "Traceback" not in text, (label, text)
    if code == EXIT_BAD_INPUT:
        assert "error: " in text, (label, text)
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, text = _run(["simulate", str(mutant), "--duration", "2"], capsys)
    assert code == EXIT_OK, f"{label}: validate accepted it, simulate said: {text[-500:]}"
    # a mutant may move a goal or the operator so that a reach misses: the operator says so,
    # which is expected here; any other warning of the cell's code is not
    unexpected = [str(w.message) for w in caught
                  if "hrc_drake" in str(w.filename) and "out of reach" not in str(w.message)]
    assert not unexpected, (label, unexpected)
