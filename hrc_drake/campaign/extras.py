"""Extra metrics: named functions that add columns to a campaign run's row from what the metrics
row does not hold (the event log, per-product samples).

A campaign names them in its file (`extra_metrics: [per_product]`) or in the Python API
(`make_campaign({..., "extra_metrics": [...]}, ...)`). A name is one registered here with
`@register_extra_metrics("name")`, or an import path `package.module:function` (so a function
defined outside `hrc_drake` is found by a Dask worker process too: the module must be importable
there). The function gets the run's `RunResult` and its `Scenario` and returns a dict of column
-> value; the row holds it as `<name>.<column>`. A value is a number, a bool, a string, or a list
of numbers (stored in runs.parquet as a list<double> column; `pandas.read_parquet` gives numpy
arrays). List columns are kept, not analysed: summary.csv and the tests take scalar columns only.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from dataclasses import dataclass

#: a value an extra-metrics function may return for a column
ExtraValue = float | int | bool | str | list[float]
#: (the run's `cell.run.RunResult`, its `cell.schema.Scenario`) -> {column: value}
ExtraFunction = Callable[[object, object], dict[str, ExtraValue]]


@dataclass(frozen=True)
class ExtraMetrics:
    """A named extra-metrics function and what its columns mean."""

    name: str
    function: ExtraFunction
    description: str = ""


_REGISTRY: dict[str, ExtraMetrics] = {}


def register_extra_metrics(name: str, description: str = ""):
    """Decorator: register `function(result, scenario) -> {column: value}` under `name`."""

    def register(function: ExtraFunction) -> ExtraFunction:
        if ":" in name or not name:
            raise ValueError(f"an extra metrics name has no ':' and is not empty, got {name!r}")
        _REGISTRY[name] = ExtraMetrics(name, function, description or (function.__doc__ or "").strip())
        return function

    return register


def registered_extra_metrics() -> dict[str, ExtraMetrics]:
    return dict(_REGISTRY)


def resolve_extra_metrics(name: str) -> ExtraMetrics:
    """The registered entry of `name`, or the function at the import path `module:function`;
    `KeyError` with what is known when there is neither."""
    if name in _REGISTRY:
        return _REGISTRY[name]
    module_name, _, attribute = name.partition(":")
    if module_name and attribute:
        try:
            function = getattr(importlib.import_module(module_name), attribute)
        except (ImportError, AttributeError) as err:
            raise KeyError(f"cannot import extra metrics '{name}': {err}") from None
        if not callable(function):
            raise KeyError(f"extra metrics '{name}' is not a function")
        return ExtraMetrics(name, function, (function.__doc__ or "").strip())
    known = ", ".join(sorted(_REGISTRY)) or "none"
    raise KeyError(f"unknown extra metrics '{name}' (registered: {known}; or give module:function)")


def extra_columns(names, result, scenario) -> dict[str, ExtraValue]:
    """The columns of every extra-metrics function in `names` for one run, `<name>.<column>`."""
    out: dict[str, ExtraValue] = {}
    for name in names:
        entry = resolve_extra_metrics(name)
        values = entry.function(result, scenario)
        if not isinstance(values, dict):
            raise TypeError(f"extra metrics '{name}' returned {type(values).__name__}, not a dict")
        label = name.rpartition(":")[2]  # an import path's columns are named by its function
        for column, value in values.items():
            out[f"{label}.{column}"] = _checked(name, column, value)
    return out


def _checked(name: str, column: str, value) -> ExtraValue:
    if isinstance(value, (bool, int, float, str)):
        return value
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        value = value.tolist()
        if not isinstance(value, list):
            return value
    if isinstance(value, (list, tuple)) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
    ):
        return [float(v) for v in value]
    raise TypeError(
        f"extra metrics '{name}' column '{column}': a number, bool, string or list of numbers, "
        f"got {type(value).__name__}"
    )


def blocked_intervals(events, agent: str) -> list[tuple[float, float]]:
    """The (wait_begin, wait_end) intervals of `agent`'s events; a wait still open ends at inf."""
    waits, start = [], None
    for event in sorted(events, key=lambda e: (e.time, e.seq)):
        if getattr(event, "agent", agent) != agent:
            continue
        if event.kind == "wait_begin":
            start = event.time
        elif event.kind == "wait_end" and start is not None:
            waits.append((start, event.time))
            start = None
    if start is not None:
        waits.append((start, math.inf))
    return waits


def blocked_between(waits: list[tuple[float, float]], begin: float, end: float) -> float:
    """The time of `waits` inside [begin, end]."""
    return sum(max(0.0, min(b, end) - max(a, begin)) for a, b in waits)


@register_extra_metrics("per_product")
def per_product(result, scenario) -> dict[str, ExtraValue]:
    """Per product, in the order they were finished (every type together, as `product_times`):
    `times` when each was finished (s); `cycle_times` the intervals between consecutive ones
    (thesis Fig. 7.19, 7.28); `operator_wait` the operator's blocked time (wait_begin to wait_end)
    within the interval from the previous product (or t = 0) to this one (Fig. 7.27);
    `operator_wait_after_last` its blocked time from the last product (or 0) to the run's end."""
    times = [float(t) for t in result.metrics["product_times"]]
    waits = blocked_intervals(result.log.events, scenario.operator.name)
    wait, previous = [], 0.0
    for t in times:
        wait.append(blocked_between(waits, previous, t))
        previous = t
    return {
        "times": times,
        "cycle_times": [b - a for a, b in zip(times, times[1:], strict=False)],
        "operator_wait": wait,
        "operator_wait_after_last": blocked_between(waits, previous, float(result.simulated_time)),
    }
