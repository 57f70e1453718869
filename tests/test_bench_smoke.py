"""Every `tools/bench_*.py` runs end to end on its `--smoke` setting (issue 55, item 12: a bench is
part of the product; `bench_campaign.py --quick` crashed for days and no test noticed).

The smoke setting proves the bench's whole path runs and prints its last line, one JSON object;
its figures mean nothing. It runs in this process (the tests' imports and compiled kernels are
shared), with one worker, in a few seconds, and writes nothing outside the folder it is run in.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from tests.conftest import load_tool

REPO = Path(__file__).resolve().parents[1]
BENCHES = sorted(p.stem for p in (REPO / "tools").glob("bench_*.py"))


def tracked_changes() -> str:
    """`git status` of the repository's tracked files (empty when git or the checkout is absent)."""
    try:
        done = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                              capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout if done.returncode == 0 else ""


@pytest.mark.parametrize("name", BENCHES)
def test_every_bench_runs_on_its_smoke_setting(name, tmp_path, monkeypatch, capsys):
    before = tracked_changes()
    monkeypatch.chdir(tmp_path)
    bench = load_tool(name)
    bench.main(["--smoke"])
    lines = [line for line in capsys.readouterr().out.splitlines() if line.strip()]
    assert lines, f"{name} --smoke printed nothing"
    last = json.loads(lines[-1])
    assert isinstance(last, dict) and last, f"{name} --smoke: the last line is not a JSON object"
    assert tracked_changes() == before, f"{name} --smoke changed files of the repository"
