"""The scripts of examples/ run as a newcomer runs them, and say what they claim."""

from __future__ import annotations

import importlib.util
import math

import pytest

from tests.conftest import REPO

EXAMPLES = REPO / "examples"


def _example(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_tracker_runs_alone_in_a_diagram_of_your_own(capsys):
    result = _example("tracker_in_your_diagram").main()
    assert result["samples"] > 100 and result["hidden_samples"] >= 25
    error = result["wrist_error_hidden_median_m"]
    assert math.isfinite(error) and error < 1.0
    assert "right wrist hidden" in capsys.readouterr().out


@pytest.mark.slow
def test_a_scenario_written_from_scratch_validates_runs_and_states_its_verdict(tmp_path, capsys):
    results = _example("new_scenario_from_scratch").main(tmp_path)
    out = capsys.readouterr().out
    assert "refused as it should be" in out and "layout.camera.noise_sdt" in out
    ssm, unsafe = results["as written (SSM)"], results["no safety system"]
    # the SSM cell is conforming: its verdict is the standard judge's count, SAFE or UNSAFE (the count
    # has moved with the controller's stopping model: 2 violations, then none)
    safety = ssm["safety"]
    assert safety["mode"] == "ssm" and safety["judge"]["conforming"]
    total = safety["violations_total"]
    assert total == sum(safety["violations"].values()) == len(safety["events"])
    assert safety["verdict_code"] == ("unsafe" if total else "safe")
    if total:
        assert safety["verdict"].startswith("UNSAFE: ISO/TS 15066 ssm, conforming judge: ")
        assert f"{total} violation" in safety["verdict"]
    else:
        assert safety["verdict"].startswith("SAFE: ISO/TS 15066 ssm, conforming judge, 0 violations")
    assert safety["verdict"] in out
    assert unsafe["safety"]["verdict_code"] == "no_safety_system"
    assert unsafe["safety"]["verdict"].startswith("NO SAFETY SYSTEM")
    assert unsafe["products_finished"] >= 1  # the cell works; SSM is what holds it
    assert (tmp_path / "lid_and_can.yaml").is_file()


@pytest.mark.slow
def test_a_campaign_from_python_gives_one_row_per_run(tmp_path, capsys):
    table = _example("campaign_from_python").main(tmp_path, duration=40.0, seeds=1)
    assert sorted(table["variant"]) == ["no_safety", "shipped"]
    assert (tmp_path / "runs.parquet").is_file() and (tmp_path / "summary.csv").is_file()
    assert "runs in" in capsys.readouterr().out
