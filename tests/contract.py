"""The contract every LeafSystem of the package keeps (DESIGN.md "Systems are descriptions"),
and the example each system gives the contract test.

A test package lists its systems' examples in `system_examples.py` as
`EXAMPLES = {SystemClass: factory}`; a factory returns a `SystemExample`: the system and two
different sets of fixed input values. `tests/test_system_contract.py` finds every LeafSystem
class by walking the package and fails for one without an example.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import PortDataType


@dataclass
class SystemExample:
    """A system and two input sets (port name -> value; vectors as arrays) that drive it
    differently. `duration`: seconds each run lasts. `inputs_matter`: whether the outputs after
    a run with A must differ from those with B (so that a system sharing state between
    contexts cannot pass by accident)."""

    system: object
    inputs_a: dict = field(default_factory=dict)
    inputs_b: dict = field(default_factory=dict)
    duration: float = 1.0
    inputs_matter: bool = True
    #: outputs left out of comparisons (e.g. poses for a viewer), by name
    skip_outputs: tuple[str, ...] = ()


Factory = Callable[[], SystemExample]


def fix_inputs(system, context, inputs: dict) -> None:
    for name, value in inputs.items():
        port = system.GetInputPort(name)
        if port.get_data_type() == PortDataType.kVectorValued:
            port.FixValue(context, np.asarray(value, dtype=float))
        else:
            port.FixValue(context, AbstractValue.Make(value))


def new_context(example: SystemExample, inputs: dict):
    context = example.system.CreateDefaultContext()
    fix_inputs(example.system, context, inputs)
    return context


def output_values(example: SystemExample, context) -> dict:
    system = example.system
    out = {}
    for i in range(system.num_output_ports()):
        port = system.get_output_port(i)
        if port.get_name() in example.skip_outputs:
            continue
        value = port.Eval(context)
        out[port.get_name()] = np.array(value, copy=True) if isinstance(value, np.ndarray) else value
    return out


def state_values(context) -> list:
    """The context's state: abstract values (objects) and discrete vectors (copies)."""
    values = [context.get_abstract_state(i).get_value() for i in range(context.num_abstract_states())]
    values += [
        np.array(context.get_discrete_state(i).get_value(), copy=True)
        for i in range(context.num_discrete_state_groups())
    ]
    return values


def values_equal(a, b) -> bool:
    """Deep equality of port and state values: dataclasses, tuples, dicts, arrays (NaN == NaN)."""
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    if isinstance(a, np.ndarray):
        if a.shape != b.shape:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, float):
        return a == b or (np.isnan(a) and np.isnan(b))
    if dataclasses.is_dataclass(a):
        return all(
            values_equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
        )
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(values_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(values_equal(a[k], b[k]) for k in a)
    if hasattr(a, "ids") and hasattr(a, "value"):  # FramePoseVector
        ids_a, ids_b = list(a.ids()), list(b.ids())
        return ids_a == ids_b and all(
            np.array_equal(a.value(i).GetAsMatrix4(), b.value(i).GetAsMatrix4()) for i in ids_a
        )
    if hasattr(a, "GetAsMatrix4"):
        return bool(np.array_equal(a.GetAsMatrix4(), b.GetAsMatrix4()))
    if hasattr(a, "core"):  # hrc_drake.systems.Frozen
        return values_equal(vars_of(a.core), vars_of(b.core))
    if hasattr(a, "__dict__"):
        return values_equal(vars_of(a), vars_of(b))
    return a == b


def vars_of(obj) -> dict:
    return dict(vars(obj)) if hasattr(obj, "__dict__") else {"value": obj}


def simulate(example: SystemExample, context, until: float):
    simulator = Simulator(example.system, context)
    simulator.Initialize()
    simulator.AdvanceTo(until)
    return simulator
