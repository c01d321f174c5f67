"""A small cache of what is computed from arrays, keyed on the arrays' content.

The members of an ensemble are measured against the same plan: its resampling, its KD-tree
and its human-likeness are computed once and found again by content (dtype, shape and bytes
of every array, and the other arguments), never by identity, so a different or mutated plan
is computed afresh, never answered from the cache.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable
from typing import Any

import numpy as np


class ContentCache:
    """The last ``size`` results of :meth:`get`, least recently used dropped first."""

    def __init__(self, size: int = 4) -> None:
        self.size = size
        self._items: dict[Hashable, Any] = {}

    def get(self, arrays: Iterable[np.ndarray | None], compute: Callable[[], Any],
            *extra: Hashable) -> Any:
        """The result of ``compute()`` for ``arrays`` (None allowed) and ``extra``: computed
        at the first call with this content, then kept (an exception is not kept)."""
        key = (extra, tuple(None if a is None else (a.dtype.str, a.shape, a.tobytes())
                            for a in arrays))
        try:
            value = self._items.pop(key)
        except KeyError:
            value = compute()
            while len(self._items) >= self.size:
                del self._items[next(iter(self._items))]
        self._items[key] = value
        return value

    def __len__(self) -> int:
        return len(self._items)
