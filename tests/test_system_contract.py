"""Every LeafSystem of the package keeps its run in its Context (DESIGN.md, the Drake-native issue).

The classes are found by walking `hrc_drake`; each needs an example in a
`tests/<area>/system_examples.py` (see `tests/contract.py`). For each: two contexts driven with
different inputs stay independent; evaluating an output twice gives equal values and changes
nothing; `Simulator.Initialize()` on a reset context reproduces the first run.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import LeafSystem

import hrc_drake
from tests.contract import (
    SystemExample,
    new_context,
    output_values,
    simulate,
    state_values,
    values_equal,
)

TESTS = Path(__file__).resolve().parent


def package_leaf_systems() -> list[type]:
    """Every concrete LeafSystem class defined in hrc_drake (abstract bases set ABSTRACT_SYSTEM)."""
    found = {}
    for info in pkgutil.walk_packages(hrc_drake.__path__, "hrc_drake."):
        module = importlib.import_module(info.name)
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if (
                issubclass(cls, LeafSystem)
                and cls.__module__ == module.__name__
                and not cls.__dict__.get("ABSTRACT_SYSTEM", False)
            ):
                found[f"{cls.__module__}.{cls.__qualname__}"] = cls
    return [found[k] for k in sorted(found)]


def all_examples() -> dict:
    examples = {}
    for path in sorted(TESTS.glob("*/system_examples.py")):
        module = importlib.import_module(f"tests.{path.parent.name}.system_examples")
        examples.update(module.EXAMPLES)
    return examples


SYSTEMS = package_leaf_systems()
EXAMPLES = all_examples()


def _example(cls) -> SystemExample:
    if cls not in EXAMPLES:
        pytest.fail(
            f"{cls.__module__}.{cls.__qualname__} has no contract example: add a factory to "
            "EXAMPLES in tests/<area>/system_examples.py (see tests/contract.py)"
        )
    example = EXAMPLES[cls]()
    assert type(example.system) is cls
    return example


def _assert_same(a: dict, b: dict, what: str) -> None:
    for name in a:
        assert values_equal(a[name], b[name]), f"output '{name}' differs: {what}"


def test_the_walk_finds_the_systems():
    names = {cls.__name__ for cls in SYSTEMS}
    assert {"PathFollower", "OcclusionTracker", "Scheduler", "MetricsRecorder"} <= names


@pytest.mark.parametrize("cls", SYSTEMS, ids=lambda c: c.__name__)
def test_two_contexts_stay_independent(cls):
    example = _example(cls)
    context_a = new_context(example, example.inputs_a)
    context_b = new_context(example, example.inputs_b)
    sim_a, sim_b = Simulator(example.system, context_a), Simulator(example.system, context_b)
    sim_a.Initialize()
    sim_b.Initialize()
    for k in range(1, 5):
        sim_a.AdvanceTo(example.duration * k / 4)
        sim_b.AdvanceTo(example.duration * k / 4)
    after_a = output_values(example, context_a)
    after_b = output_values(example, context_b)
    alone = new_context(example, example.inputs_a)
    simulate(example, alone, example.duration)
    _assert_same(output_values(example, alone), after_a, "a context run alone vs beside another")
    if example.inputs_matter:
        assert not all(values_equal(after_a[n], after_b[n]) for n in after_a), (
            "the example's two input sets give equal outputs: it cannot catch shared state"
        )


@pytest.mark.parametrize("cls", SYSTEMS, ids=lambda c: c.__name__)
def test_outputs_are_pure(cls):
    example = _example(cls)
    context = new_context(example, example.inputs_a)
    simulate(example, context, example.duration)
    before = state_values(context)
    first = output_values(example, context)
    second = output_values(example, context)
    _assert_same(first, second, "evaluated twice")
    after = state_values(context)
    assert len(before) == len(after)
    for x, y in zip(before, after, strict=True):
        assert x is y or values_equal(x, y), "evaluating outputs changed the state"


@pytest.mark.parametrize("cls", SYSTEMS, ids=lambda c: c.__name__)
def test_initialize_restarts_the_run(cls):
    example = _example(cls)
    context = new_context(example, example.inputs_a)
    simulator = simulate(example, context, example.duration)
    first = output_values(example, context)
    context.SetTime(0.0)
    example.system.SetDefaultContext(context)
    simulator.Initialize()
    simulator.AdvanceTo(example.duration)
    _assert_same(first, output_values(example, context), "after a restart on a reset context")
