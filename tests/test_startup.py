"""`import hrc_drake`, `hrc-drake --help` and `hrc-drake validate` import only what they use (no timing
asserted)."""

import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

PROBE = """
import contextlib, io, json, sys
from hrc_drake.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        code = main(sys.argv[1:])
    except SystemExit as stop:
        code = stop.code
heavy = ("pydrake", "sklearn", "scipy.stats", "scipy.optimize", "matplotlib")
print(json.dumps({"code": code, "loaded": sorted({m.split(".")[0] if m.split(".")[0] != "scipy" else
    ".".join(m.split(".")[:2]) for m in sys.modules if m.startswith(heavy)})}))
"""


def _run(*args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run(
        [sys.executable, "-c", PROBE, *args], capture_output=True, text=True, env=env, cwd=REPO, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_help_loads_neither_drake_nor_scipy_nor_sklearn():
    result = _run("--help")
    assert result == {"code": 0, "loaded": []}


def test_validate_loads_no_scikit_learn_scipy_stats_or_optimize():
    result = _run("validate", str(REPO / "diagrams" / "torch_clock.yaml"))
    assert result["code"] == 0
    assert "pydrake" in result["loaded"]  # the typed YAML loader and IK
    assert not {"sklearn", "scipy.stats", "scipy.optimize", "matplotlib"} & set(result["loaded"])


def test_import_hrc_drake_loads_neither_drake_nor_numba_nor_scipy_nor_pandas():
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    code = ("import json, sys, hrc_drake; print(json.dumps(sorted({m.split('.')[0] for m in sys.modules} & "
            "{'pydrake', 'numba', 'scipy', 'pandas', 'sklearn', 'matplotlib'})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=REPO,
                         check=True)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []


def test_simulating_torch_clock_without_reports_loads_no_scikit_learn_scipy_stats_or_plots():
    """The default cell's run imports neither the proactive planner's GPDM (scikit-learn) nor
    scipy.stats (0.6 s each of a first run) nor matplotlib: modules it never calls."""
    result = _run("simulate", str(REPO / "diagrams" / "torch_clock.yaml"), "--duration", "2")
    assert result["code"] == 0
    assert not {"sklearn", "scipy.stats", "matplotlib"} & set(result["loaded"]), result
