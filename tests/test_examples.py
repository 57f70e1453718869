"""The scripts of examples/ run as a newcomer runs them, and say what they claim."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.messages import R_WRIST
from tests.conftest import REPO

EXAMPLES = REPO / "examples"


def _example(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_example_is_run_here():
    # a new example gets its test in this file (run quickly: shorten it by an argument if needed)
    source = Path(__file__).read_text()
    missing = [path.name for path in sorted(EXAMPLES.glob("*.py")) if f'"{path.stem}' not in source]
    assert not missing, f"examples no test runs: {missing}"


def test_the_particle_filter_beats_holding_where_a_hand_passes_behind_a_post(capsys):
    module = _example("tracker_in_your_diagram")
    result = module.main()
    out = capsys.readouterr().out
    for setting in ("passing", "resting"):
        pf, hold = result[setting]["particle filter"], result[setting]["hold last seen"]
        assert len(pf) == len(hold) >= 30  # both trackers scored on the same hidden frames
        assert np.all(np.isfinite(pf)) and np.all(np.isfinite(hold))
    passing = result["passing"]
    # what the example is there to show: the filter's motion model and constraints beat holding
    assert np.median(passing["particle filter"]) < np.median(passing["hold last seen"])
    assert "hand passing behind the post (8 sweeps)" in out and "the particle filter is closer" in out
    # scoring, checked on a noise-free camera: holding errs by exactly the distance from where the
    # wrist was last seen (a frame misaligned by one would be off by 2-5 cm while the hand sweeps)
    times, truth = module.sweeps()
    held = module.track(times, truth, noise_std=0.0)["hold last seen"]
    camera = DepthCameraModel(module.CAMERA["position"], module.CAMERA["target"], occluders=[module.POST])
    hidden = camera.is_hidden(truth)[:, R_WRIST]
    last_seen = np.maximum.accumulate(np.where(hidden, 0, np.arange(len(times))))
    expected = np.linalg.norm(truth[hidden, R_WRIST] - truth[last_seen[hidden], R_WRIST], axis=1)
    np.testing.assert_allclose(held, expected, atol=1e-9)


def test_the_context_example_runs_as_a_script_and_says_what_each_check_shows():
    script = EXAMPLES / "test_a_system_through_its_context.py"
    # from another folder, with plain python: the script finds the package itself
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=script.anchor,
                         timeout=120, env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0].endswith("pick 1.00, place 0.00, screw 0.00")
    assert lines[1].startswith("A new Context of the same system, fed nothing: pick 0.33, place 0.33, "
                               "screw 0.33")
    assert lines[2:] == ["passed: the predictor learns the cycle and names the next action",
                         "passed: two contexts of one system are independent"]


@pytest.mark.slow
def test_a_scenario_written_from_scratch_validates_stores_cans_and_states_its_verdicts(tmp_path, capsys):
    results = _example("new_scenario_from_scratch").main(tmp_path)
    out = capsys.readouterr().out
    assert "refused as it should be" in out and "layout.camera.noise_sdt" in out
    pfl, ssm, unsafe = results["as written (PFL)"], results["SSM only"], results["no safety system"]
    # the first cell works: several cans in its 60 s, safe by the standard's conforming judge
    assert pfl["products_finished"] >= 3
    assert pfl["safety"]["mode"] == "pfl" and pfl["safety"]["judge"]["conforming"]
    assert pfl["safety"]["verdict_code"] == "safe" and pfl["safety"]["violations_total"] == 0
    assert ssm["safety"]["mode"] == "ssm" and ssm["safety"]["judge"]["conforming"]
    assert unsafe["safety"]["verdict_code"] == "no_safety_system"
    assert unsafe["safety"]["verdict"].startswith("NO SAFETY SYSTEM")
    # the camera sees the whole operator: no body part went unmeasured under PFL
    assert pfl["safety"]["unobserved_s"] == 0
    for metrics in results.values():
        assert metrics["safety"]["verdict"] in out
    assert f"PFL stores {pfl['products_finished']} cans" in out
    assert (tmp_path / "lid_and_can.yaml").is_file() and (tmp_path / "lid_and_can_ssm.yaml").is_file()


@pytest.mark.slow
def test_a_campaign_from_python_gives_one_row_per_run(tmp_path, capsys):
    table = _example("campaign_from_python").main(tmp_path, duration=40.0, seeds=1)
    assert sorted(table["variant"]) == ["no_safety", "shipped"]
    assert (tmp_path / "runs.parquet").is_file() and (tmp_path / "summary.csv").is_file()
    out = capsys.readouterr().out
    assert "runs in" in out and "Per 40 s run, mean of 1 seed(s): as shipped" in out


def test_your_own_robot_from_its_urdf_runs_a_cell_and_says_what_it_read(tmp_path, capsys):
    metrics = _example("your_own_robot").main(["--out", str(tmp_path), "--duration", "45"])
    out = capsys.readouterr().out
    assert "6 joints read from the URDF, shoulder_pan_joint" in out
    assert metrics["products_finished"] >= 1 and f"{metrics['products_finished']} products" in out
    assert metrics["safety"]["verdict_code"] == "safe" and metrics["safety"]["verdict"] in out
    assert "robots[0].chains[0].tool_frame: no link 'ur5e_tol'" in out
    assert (tmp_path / "my_cobot.urdf").is_file() and (tmp_path / "my_cell.yaml").is_file()
