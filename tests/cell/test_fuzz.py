"""Fuzz: mutated scenarios (every leaf of every file in diagrams/ changed in type, sign, to NaN,
huge, empty or an unknown name; a seeded sample) are either refused by `validate` with a clean
message, or accepted by `validate` and by a 2 s `simulate` alike - never a traceback."""

from __future__ import annotations

import random

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
    code, text = _run(["simulate", str(mutant), "--duration", "2"], capsys)
    assert code == EXIT_OK, f"{label}: validate accepted it, simulate said: {text[-500:]}"
