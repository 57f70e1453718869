"""A Drake LeafSystem that ticks a mutable Python core at a fixed period.

The core lives on the system, not in the context (DESIGN.md: keep big objects out of abstract
state). A one-number discrete state counts the ticks; output ports declared with
`prerequisites_of_calc=self.ticket()` are recomputed exactly when a tick changed the core.
One simulation per system object.
"""

from __future__ import annotations

from pydrake.systems.framework import LeafSystem


class TickedSystem(LeafSystem):
    """A LeafSystem around a mutable core ticked at `period`; outputs depend on the tick count.

    Subclasses define `tick(context)`, which advances the core to the context's time.
    """

    def __init__(self, period: float, offset: float = 0.0):
        super().__init__()
        self._tick_index = self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(period, offset, self._on_tick)
        self.period = period

    def _on_tick(self, context, discrete_state):
        self.tick(context)
        discrete_state.get_mutable_vector(self._tick_index).SetAtIndex(
            0, context.get_discrete_state(self._tick_index).GetAtIndex(0) + 1
        )

    def ticket(self):
        return {self.xd_ticket()}
