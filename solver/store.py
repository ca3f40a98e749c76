"""Where the solver keeps tables it builds once and reuses (air-bearing tables, film coefficients).

A store maps a key (a hash of every input a table depends on, the solver's source included) to a dict of
named arrays.  The solver only reads and writes through this protocol; it does no file I/O.  Its default is
:class:`MemoryStore`, one per process; the pipeline passes a store on disk
(:class:`pipeline.run.cache.DiskStore`), so that a table built by one process serves every later one.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

#: Tables a :class:`MemoryStore` keeps before it starts afresh (each is at most a few MB).
MEMORY_ENTRIES = 8


class ArrayStore(Protocol):
    """Named arrays by key: ``get`` returns None for a key it does not hold; ``put`` may silently not keep."""

    def get(self, key: str) -> dict[str, np.ndarray] | None: ...

    def put(self, key: str, arrays: dict[str, np.ndarray]) -> None: ...


class MemoryStore:
    """The last few tables of this process, in memory (emptied when full)."""

    def __init__(self, capacity: int = MEMORY_ENTRIES) -> None:
        self.capacity = capacity
        self._tables: dict[str, dict[str, np.ndarray]] = {}

    def get(self, key: str) -> dict[str, np.ndarray] | None:
        return self._tables.get(key)

    def put(self, key: str, arrays: dict[str, np.ndarray]) -> None:
        if key not in self._tables and len(self._tables) >= self.capacity:
            self._tables.clear()
        self._tables[key] = arrays
