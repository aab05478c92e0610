"""A run's history: one preallocated array per recorded quantity, written as a ring.

A batch run keeps every sample (capacity = steps + 1); a live session keeps the newest few
thousand. Appending a chunk is one slice assignment per key, reading a series one slice (two
when the ring has wrapped), so a reader never restacks records.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np


class History:
    """Per-key arrays (N lanes, capacity, ...) filled as a ring.

    Args:
        capacity: samples kept per lane (the newest).
    """

    def __init__(self, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"history capacity must be >= 1 sample, got {capacity}")
        self.capacity = capacity
        self.count = 0  # samples ever appended
        self.data: dict[str, np.ndarray] = {}

    @property
    def complete(self) -> bool:
        """Whether every sample since t = 0 is still held."""
        return self.count <= self.capacity

    def __len__(self) -> int:
        return min(self.count, self.capacity)

    def append(self, records: dict[str, np.ndarray]) -> None:
        """Append T samples: records name → (N, T, ...), the same names every time."""
        T = next(iter(records.values())).shape[1]
        if not self.data:
            self.data = {
                key: np.zeros((v.shape[0], self.capacity, *v.shape[2:]), dtype=float)
                for key, v in records.items()
            }
        keep = min(T, self.capacity)
        slots = (self.count + T - keep + np.arange(keep)) % self.capacity
        first, last = slots[0], slots[-1]
        for key, values in records.items():
            values = values[:, T - keep :]
            if first <= last:  # one contiguous slice
                self.data[key][:, first : last + 1] = values
            else:
                self.data[key][:, slots] = values
        self.count += T

    def adopt(self, records: dict[str, np.ndarray]) -> None:
        """Make a whole run's records the history, as they are (no copy): name → (N, T, ...),
        samples 0 … T − 1, the same names as before. Only while the history holds sample 0
        alone, which they restate; its capacity becomes T."""
        if self.count != 1:
            raise ValueError(f"history: adopting a run needs sample 0 alone, not {self.count}")
        T = next(iter(records.values())).shape[1]
        self.data = dict(records)
        self.capacity = self.count = T

    def reserve(self, capacity: int) -> None:
        """Hold at least `capacity` samples from now on (a run whose duration grew); only
        while nothing has been dropped yet, so the order stays the ring's."""
        if capacity <= self.capacity:
            return
        if self.count > self.capacity:
            raise ValueError("history: cannot grow a ring that has already dropped samples")
        for key, values in self.data.items():
            grown = np.zeros((values.shape[0], capacity, *values.shape[2:]))
            grown[:, : self.count] = values[:, : self.count]
            self.data[key] = grown
        self.capacity = capacity

    def backfill_first(self, records: dict[str, np.ndarray], keys: Iterable[str]) -> None:
        """Copy the first sample of `records` (the first step's) into sample 0 for `keys`."""
        if self.count == 1:
            for key in keys:
                if key in records:
                    self.data[key][:, 0] = records[key][:, 0]

    def _order(self) -> np.ndarray | slice:
        if self.count <= self.capacity:
            return slice(0, self.count)
        start = self.count % self.capacity
        return np.r_[start : self.capacity, 0:start]

    def series(self, lane: int, copy: bool = True) -> dict[str, np.ndarray]:
        """A lane's samples, oldest first, (T, ...) per key: copies, or with copy=False views
        while every sample is held (copies once the ring has wrapped). A view stays valid
        only as long as the ring does not wrap: a history with room for the whole run (a
        batch run) never overwrites a sample, and `reserve` moves to new arrays."""
        order = self._order()
        if copy or not self.complete:
            return {key: np.array(values[lane, order]) for key, values in self.data.items()}
        return {key: values[lane, order] for key, values in self.data.items()}

    def latest(self, lane: int) -> dict[str, np.ndarray]:
        """A lane's newest sample (copies)."""
        i = (self.count - 1) % self.capacity
        return {key: np.array(values[lane, i]) for key, values in self.data.items()}

    def newest(self) -> dict[str, np.ndarray]:
        """Every lane's newest sample, (N, ...) per key (views)."""
        i = (self.count - 1) % self.capacity
        return {key: values[:, i] for key, values in self.data.items()}
