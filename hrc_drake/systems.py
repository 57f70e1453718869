"""Drake helpers shared by every `systems.py` (the bottom layer beside `messages`).

The pattern of the house (DESIGN.md "Systems are descriptions; runs live in Contexts"): what
changes during a run is abstract or discrete state of the Context, declared from the system's
config and set again by an initialization event, so that `Simulator.Initialize()` on a reset
context starts clean and two contexts of one system never share anything that changes.

Large core state (particle clouds, suffix trees, GP training sets, event logs) is kept as an
immutable value: its copies return the value itself, and an update builds a new value
(copy-on-write, `thaw`), so Drake's copies of abstract state cost nothing.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import AbstractStateIndex, Context, EventStatus, LeafSystem, State

from hrc_drake.messages import Immutable


class Frozen(Immutable):
    """Holds a mutable core as an immutable state value: nobody changes `core` in place.

    An update takes a private copy with `thaw()`, changes it, and stores `Frozen(copy)`. A
    core class may define `clone()` (a cheaper copy that shares what it never writes);
    otherwise `copy.deepcopy` is used.
    """

    __slots__ = ("core",)

    def __init__(self, core: Any):
        self.core = core

    def thaw(self) -> Any:
        """A private copy of the core that the caller may change."""
        return clone(self.core)

    def __repr__(self) -> str:
        return f"Frozen({type(self.core).__name__})"


def clone(core: Any) -> Any:
    """`core.clone()` where the class defines it, else a deep copy."""
    method = getattr(core, "clone", None)
    return method() if callable(method) else copy.deepcopy(core)


def declare_state(
    system: LeafSystem, initial: Callable[[Context | None], Any]
) -> int:
    """Declare abstract state whose value `initial(context)` is set again at initialization.

    `initial(None)` gives the model value of the default context; at every
    `Simulator.Initialize()` the value is rebuilt from the context (e.g. its time), so a run
    restarted on a reset context starts clean. The value should be immutable
    (`messages.Immutable` or `Frozen`). Returns the state index (an int).
    """
    index = int(system.DeclareAbstractState(AbstractValue.Make(initial(None))))

    def _initialize(context: Context, state: State) -> EventStatus:
        state.get_mutable_abstract_state(index).set_value(initial(context))
        return EventStatus.Succeeded()

    system.DeclareInitializationUnrestrictedUpdateEvent(_initialize)
    return index


def get_state(context: Context, index: int) -> Any:
    """The abstract state value `index` of a leaf context."""
    return context.get_abstract_state(index).get_value()


def set_state(state: State, index: int, value: Any) -> None:
    """Set abstract state `index` in the `State` an unrestricted update is writing."""
    state.get_mutable_abstract_state(index).set_value(value)


def state_ticket(system: LeafSystem, index: int, *more) -> set:
    """Prerequisites of an output that is a function of abstract state `index` (an int from
    `declare_state`) and of the other tickets `more` (e.g. `system.time_ticket()`)."""
    return {system.abstract_state_ticket(AbstractStateIndex(int(index))), *more}


def input_or(port, context: Context, default: Any) -> Any:
    """The value on `port`, or `default` when the port is not connected or fixed."""
    return port.Eval(context) if port.HasValue(context) else default


def declare_periodic_discrete_update(
    system: LeafSystem, period: float, offset: float, update: Callable[[Context, Any], EventStatus]
) -> None:
    """A periodic update of discrete state only, `update(context, discrete_values)`, declared
    as an unrestricted update.

    Why: at one event time Drake applies every unrestricted update before it computes the
    discrete ones, so a discrete update reads outputs again, recomputed from the new state
    (an expensive chain, e.g. camera -> estimate, is then evaluated twice per tick). Declared
    unrestricted, it reads the same pre-update context as the other systems. A system whose
    inputs no unrestricted update of its time recomputes dearly (the path follower) uses a true
    discrete update instead: then a tick at which no unrestricted update succeeds copies no
    abstract state.
    """

    def _unrestricted(context: Context, state: State) -> EventStatus:
        return update(context, state.get_mutable_discrete_state())

    system.DeclarePeriodicUnrestrictedUpdateEvent(period, offset, _unrestricted)
