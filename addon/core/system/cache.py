"""Work kept between renders, under one policy: each ``Cache`` holds at most ``kept`` entries
(and, with ``size``, at most ``budget`` bytes), drops the least recently used first, and is safe
to use from several threads (a final render, the viewport and previews ask at once). A value
that depends on a file is keyed on the file's modification time and size (``stamp``), so an
edited file is read again.

Every cache is listed in ``CACHES`` under its name; ``clear_all`` empties them.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from pathlib import Path

__all__ = ["CACHES", "Cache", "clear_all", "stamp"]

CACHES: dict[str, Cache] = {}


class Cache:
    """A bounded cache (module docstring).

    name:   its name in ``CACHES``
    kept:   entries kept at most
    size:   bytes of a value, to keep the values within ``budget`` bytes (the newest value is
            kept whatever its size)
    """

    def __init__(self, name: str, kept: int, size: Callable[[object], int] | None = None,
                 budget: int | None = None) -> None:
        self.name, self.kept, self.size, self.budget = name, int(kept), size, budget
        self._values: OrderedDict[Hashable, object] = OrderedDict()
        self._lock = threading.RLock()
        CACHES[name] = self

    def get(self, key: Hashable, default=None):
        """The value of ``key`` (now the most recently used), or ``default``."""
        with self._lock:
            if key not in self._values:
                return default
            self._values.move_to_end(key)
            return self._values[key]

    def __contains__(self, key: Hashable) -> bool:
        with self._lock:
            return key in self._values

    def put(self, key: Hashable, value) -> None:
        """Keep ``value`` under ``key`` as the most recently used; drop the least recently used
        beyond the bounds."""
        with self._lock:
            self._values[key] = value
            self._values.move_to_end(key)
            while len(self._values) > self.kept:
                self._values.popitem(last=False)
            if self.size is not None and self.budget is not None:
                total = sum(self.size(v) for v in self._values.values())
                while total > self.budget and len(self._values) > 1:
                    _, old = self._values.popitem(last=False)
                    total -= self.size(old)

    def get_or_make(self, key: Hashable, make: Callable[[], object]):
        """The value of ``key``, made by ``make()`` and kept when missing. One thread makes it
        while others asking for any key of this cache wait (the work is not done twice)."""
        with self._lock:
            if key in self._values:
                return self.get(key)
            value = make()
            self.put(key, value)
            return value

    def keys(self) -> list:
        """The keys, least recently used first."""
        with self._lock:
            return list(self._values)

    def values(self) -> list:
        """The values, least recently used first."""
        with self._lock:
            return list(self._values.values())

    def pop(self, key: Hashable, default=None):
        with self._lock:
            return self._values.pop(key, default)

    def clear(self) -> None:
        with self._lock:
            self._values.clear()

    def __len__(self) -> int:
        with self._lock:
            return len(self._values)


def clear_all() -> None:
    """Empty every cache."""
    for cache in CACHES.values():
        cache.clear()


def stamp(path: str | os.PathLike) -> tuple[int, int]:
    """(modification time in ns, size in bytes) of a file; raises ``OSError``."""
    st = Path(path).stat()
    return (st.st_mtime_ns, st.st_size)
