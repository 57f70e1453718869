import os
import sys
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


def load_tool(name: str):
    """The module of `tools/<name>.py` (the tools are scripts, not a package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, REPO / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # a tool's dataclasses look their module up there
    spec.loader.exec_module(module)
    return module



@pytest.fixture
def diagrams_dir() -> Path:
    return DIAGRAMS


def record_compile_ahead(monkeypatch) -> list:
    """Replace `kernels.compile_ahead` by a recorder: the returned list gets the groups of each
    call and "wait" for each wait of what it returned (which compiles nothing)."""
    from hrc_drake import kernels

    calls = []

    class Ahead(kernels.KernelsAhead):
        def wait(self):
            calls.append("wait")
            return 0.0

    def compile_ahead(groups, processes=None):
        calls.append(list(groups))
        return Ahead()

    monkeypatch.setattr(kernels, "compile_ahead", compile_ahead)
    return calls
