"""The content-keyed cache of what an ensemble's members share (the plan's side of the
metrics): found again by content, never by identity; a different or mutated input computed
afresh; bounded."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.analysis.content_cache import ContentCache


def test_a_result_is_found_by_content_and_recomputed_for_any_other():
    cache, calls = ContentCache(2), []

    def get(arrays, *extra):
        return cache.get(arrays, lambda: calls.append(1) or sum(a.sum() for a in arrays
                                                               if a is not None), *extra)

    a = np.arange(6.0).reshape(2, 3)
    assert get([a, None]) == 15.0 and len(calls) == 1
    assert get([a.copy(), None]) == 15.0 and len(calls) == 1  # same content, another object
    for other in ([a.reshape(3, 2), None], [a.astype(np.float32), None], [a], [None, a]):
        get(other)  # another shape, dtype, or split: another key
    assert len(calls) == 5
    assert get([a, None], "at 5 px/mm") == 15.0 and len(calls) == 6  # other arguments count
    a[0, 0] = 100.0  # mutated in place: not the cached content
    assert get([a, None], "at 5 px/mm") == 115.0 and len(calls) == 7
    assert len(cache) == 2  # bounded: the least recently used dropped


def test_a_failed_computation_is_not_kept():
    cache = ContentCache(2)

    def fail():
        raise ValueError("no")

    with pytest.raises(ValueError):
        cache.get([np.zeros(3)], fail)
    assert len(cache) == 0 and cache.get([np.zeros(3)], lambda: 1) == 1
