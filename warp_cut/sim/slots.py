"""SlotTable: columns of equal length with spare capacity, for a topology edited in place.

Rows are slots. A deleted row stays in place as a dead slot (its key column set to -1), so
the indices of the survivors never change and an edit costs what it touches, not the size of
the table. Appending grows the capacity geometrically. Changed slots are remembered until
``take_dirty`` so that device mirrors can update just those rows.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SlotTable", "member"]


def member(slots, among) -> np.ndarray:
    """Mask (shape of ``slots``) of which of ``slots`` (non-negative integers) are in
    ``among`` (any shape): a lookup table as long as the largest slot. An edit's sets hold a
    few hundred slots, where this is some 20 times faster than ``np.isin``'s sort.

    Raises:
        ValueError: A slot is negative.
    """
    slots = np.asarray(slots, dtype=np.int64)
    among = np.asarray(among, dtype=np.int64).reshape(-1)
    if not slots.size or not among.size:
        return np.zeros(slots.shape, dtype=bool)
    if slots.min() < 0 or among.min() < 0:
        raise ValueError("member takes non-negative slots")
    table = np.zeros(int(max(slots.max(), among.max())) + 1, dtype=bool)
    table[among] = True
    return table[slots]


class SlotTable:
    """A table of named numpy columns.

    Args:
        columns: Name -> initial values, each shape (count, ...) (equal lengths).
        key: The name of the column whose value -1 marks a dead slot (an index column), or
            None for tables where liveness is kept only in ``alive``.

    Attributes:
        count: Used slots, dead ones included.
        key: The key column's name, or None.
        grown: True once the capacity changed since the last ``take_dirty`` (mirrors reallocate).

    Raises:
        ValueError: The columns differ in length.
    """

    def __init__(self, columns: dict[str, np.ndarray], key: str | None = None):
        lengths = {len(v) for v in columns.values()}
        if len(lengths) != 1:
            raise ValueError(f"columns must have equal lengths, got {lengths}")
        self.count = lengths.pop()
        self.key = key
        capacity = self.count + max(256, self.count // 8)  # room for a cut without regrowing
        self._cols: dict[str, np.ndarray] = {}
        for name, values in columns.items():
            values = np.asarray(values)
            buf = np.zeros((capacity,) + values.shape[1:], dtype=values.dtype)
            if name == key:
                buf[:] = -1
            buf[: self.count] = values
            self._cols[name] = buf
        self._alive = np.zeros(capacity, dtype=bool)
        self._alive[: self.count] = True
        if key is not None and self.count:
            keys = self._cols[key][: self.count]
            self._alive[: self.count] = np.all(keys.reshape(self.count, -1) >= 0, axis=1)
        self._dirty: list[np.ndarray] = []
        self.grown = False

    @property
    def capacity(self) -> int:
        """Allocated slots (used and spare)."""
        return len(self._alive)

    @property
    def alive(self) -> np.ndarray:
        """Which slots hold a live row: a view, shape (count,) bool."""
        return self._alive[: self.count]

    def alive_buffer(self) -> np.ndarray:
        """Liveness including unused spare slots (False): a view, shape (capacity,) bool."""
        return self._alive

    @property
    def live_count(self) -> int:
        """Live rows."""
        return int(self.alive.sum())

    def column(self, name: str) -> np.ndarray:
        """A column over all used slots, dead ones included: a view, shape (count, ...)."""
        return self._cols[name][: self.count]

    def buffer(self, name: str) -> np.ndarray:
        """A column including unused spare slots: a view, shape (capacity, ...)."""
        return self._cols[name]

    def live(self, name: str) -> np.ndarray:
        """A column over live slots only: a copy, shape (live_count, ...)."""
        return self.column(name)[self.alive]

    def live_slots(self) -> np.ndarray:
        """Slot indices of the live rows, shape (live_count,) int64, increasing."""
        return np.flatnonzero(self.alive)

    def append(self, **values) -> np.ndarray:
        """Append rows, growing the capacity if needed.

        Args:
            **values: Every column, each shape (k, ...) (equal lengths).

        Returns:
            The new rows' slot indices, shape (k,).

        Raises:
            ValueError: A column is missing or the lengths differ.
        """
        if set(values) != set(self._cols):
            raise ValueError(f"append needs columns {sorted(self._cols)}, got {sorted(values)}")
        n = {len(np.asarray(v)) for v in values.values()}
        if len(n) != 1:
            raise ValueError("appended columns must have equal lengths")
        n = n.pop()
        start = self.count
        if start + n > self.capacity:
            self._grow(start + n)
        for name, v in values.items():
            self._cols[name][start:start + n] = v
        self._alive[start:start + n] = True
        self.count = start + n
        slots = np.arange(start, start + n)
        self._dirty.append(slots)
        return slots

    def kill(self, slots) -> None:
        """Mark slots dead (their key column becomes -1).

        Args:
            slots: Slot indices, shape (k,).
        """
        slots = np.asarray(slots, dtype=np.int64)
        if not len(slots):
            return
        self._alive[slots] = False
        if self.key is not None:
            self._cols[self.key][slots] = -1
        self._dirty.append(slots)

    def set(self, name: str, slots, values) -> None:
        """Overwrite a column at some slots.

        Args:
            name: The column.
            slots: Slot indices, shape (k,).
            values: New values, shape (k, ...) or broadcastable to it.
        """
        slots = np.asarray(slots, dtype=np.int64)
        self._cols[name][slots] = values
        self._dirty.append(slots)

    def take_dirty(self) -> tuple[np.ndarray, bool]:
        """What changed since the last call; resets it.

        Returns:
            The unique changed slots, shape (k,) int64 sorted, and whether the capacity grew.
        """
        dirty = self.changed_slots()
        grown = self.grown
        self._dirty, self.grown = [], False
        return dirty, grown

    def changed_slots(self) -> np.ndarray:
        """The unique slots changed since the last ``take_dirty``, shape (k,) int64 sorted,
        without resetting them (``take_dirty`` still reports them)."""
        return np.unique(np.concatenate(self._dirty)) if self._dirty else np.zeros(0, np.int64)

    def rows(self, slots) -> dict[str, np.ndarray]:
        """Copies of every column at ``slots`` (k,), and ``"alive"`` (k,) bool: what
        ``put_rows`` writes into another table with the same columns."""
        slots = np.asarray(slots, dtype=np.int64)
        out = {name: buf[slots].copy() for name, buf in self._cols.items()}
        out["alive"] = self._alive[slots].copy()
        return out

    def put_rows(self, slots, rows: dict[str, np.ndarray], count: int) -> None:
        """Overwrite ``slots`` (k,) with ``rows`` (from ``rows`` of a table with the same
        columns) and set the used count, growing the capacity if needed; the slots become
        dirty. A replica table so follows its original edit by edit.

        Raises:
            ValueError: The columns differ from this table's.
        """
        if set(rows) != set(self._cols) | {"alive"}:
            raise ValueError(f"put_rows needs columns {sorted(self._cols)} and 'alive', got {sorted(rows)}")
        slots = np.asarray(slots, dtype=np.int64)
        if count > self.capacity:
            self._grow(count)
        for name, values in rows.items():
            (self._alive if name == "alive" else self._cols[name])[slots] = values
        self.count = int(count)
        self._dirty.append(slots)

    def _grow(self, needed: int) -> None:
        """Reallocate every column to at least ``needed`` slots (at least doubling)."""
        capacity = max(needed, 2 * self.capacity)
        for name, buf in self._cols.items():
            new = np.zeros((capacity,) + buf.shape[1:], dtype=buf.dtype)
            if name == self.key:
                new[:] = -1
            new[: self.count] = buf[: self.count]
            self._cols[name] = new
        alive = np.zeros(capacity, dtype=bool)
        alive[: self.count] = self._alive[: self.count]
        self._alive = alive
        self.grown = True
