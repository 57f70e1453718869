"""Immutable, append-only logs for recorders: their copies are free, so a run kept in a Context
costs no copies (DESIGN.md performance rules). Bottom layer: recorders of every layer use them."""

from __future__ import annotations


class AppendOnly:
    """An immutable append-only sequence: `append` returns a new value sharing the old items
    (chunks of CHUNK items), so a log kept in a Context grows at O(1) per item and its copies
    are free (`__deepcopy__` returns itself)."""

    CHUNK = 256
    __slots__ = ("_chunks", "_tail")

    def __init__(self, chunks: tuple = (), tail: tuple = ()):
        self._chunks = chunks
        self._tail = tail

    def append(self, item) -> AppendOnly:
        tail = self._tail + (item,)
        if len(tail) >= self.CHUNK:
            return AppendOnly(self._chunks + (tail,), ())
        return AppendOnly(self._chunks, tail)

    def extend(self, items) -> AppendOnly:
        out = self
        for item in items:
            out = out.append(item)
        return out

    def __iter__(self):
        for chunk in self._chunks:
            yield from chunk
        yield from self._tail

    def __len__(self) -> int:
        return self.CHUNK * len(self._chunks) + len(self._tail)

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self


class DecimatedTrace:
    """An immutable trace of at most `capacity` samples, evenly spaced: it keeps every
    `stride`-th sample offered and, when full, drops every other one and doubles `stride`, so
    a run of any length holds between capacity / 2 and capacity samples (memory flat in
    simulated time). `__deepcopy__` returns itself, as `AppendOnly`."""

    __slots__ = ("capacity", "stride", "offered", "_items")

    def __init__(self, capacity: int = 8192, stride: int = 1, offered: int = 0,
                 items: AppendOnly | None = None):
        if capacity < 2:
            raise ValueError(f"a trace keeps at least 2 samples, got capacity {capacity}")
        self.capacity = capacity
        self.stride = stride
        self.offered = offered
        self._items = items if items is not None else AppendOnly()

    def offer(self, item) -> DecimatedTrace:
        """This trace with `item` offered: kept when its index is a multiple of the stride."""
        if self.offered % self.stride:
            return DecimatedTrace(self.capacity, self.stride, self.offered + 1, self._items)
        items, stride = self._items.append(item), self.stride
        if len(items) >= self.capacity:
            # Kept items sit at multiples of `stride`; every other one sits at multiples of 2 * stride.
            items, stride = AppendOnly().extend(list(items)[::2]), 2 * stride
        return DecimatedTrace(self.capacity, stride, self.offered + 1, items)

    def __iter__(self):
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self
