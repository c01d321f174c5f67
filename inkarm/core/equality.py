"""Value equality for the shared types, which hold NumPy arrays."""

from __future__ import annotations

import numpy as np


def same(a, b) -> bool:
    """Value equality that holds for NumPy arrays too: same shape and the same values element
    by element (exactly; NaN equal to NaN, so that a value equals itself), None only equal to
    None, and dicts, lists and tuples compared item by item with the same rule."""
    if a is None or b is None:
        return a is None and b is None
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape:
            return False
        try:
            return bool(np.array_equal(a, b, equal_nan=True))
        except TypeError:  # non-numeric arrays: NaN has no meaning there
            return bool(np.array_equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    return bool(a == b)
