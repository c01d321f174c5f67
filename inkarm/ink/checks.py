"""Range checks shared by the ink models: each refuses a value with an InputError that names the
model's field, the expected range and the value."""

from __future__ import annotations

import math

from inkarm.errors import InputError

# Ink model parameter ranges, generous for any pen a user could model.
WIDTH_RANGE_MM = (0.01, 25.0)
FORCE_SCALE_RANGE_N = (1e-3, 1e3)
THRESHOLD_RANGE_N = (0.0, 100.0)


def require_positive(owner: str, **values: float) -> None:
    """Refuse any of ``values`` (name -> value) that is not a positive finite number."""
    for name, value in values.items():
        if not (value > 0 and math.isfinite(value)):
            raise InputError(f"{owner}.{name}: expected a positive finite number, got {value!r}")


def require_range(owner: str, name: str, value: float, bounds: tuple[float, float],
                  what: str) -> None:
    """Refuse ``value`` outside the closed interval ``bounds`` (NaN included), naming the
    field ``name`` as the error's key."""
    lo, hi = bounds
    if not lo <= value <= hi:
        raise InputError(f"{owner} expects {what} in [{lo:g}, {hi:g}], got {value!r}",
                         key=name, value=value)


def require_opacity(owner: str, name: str, value: float) -> None:
    """Refuse an opacity outside (0, 1]."""
    if not 0 < value <= 1:
        raise InputError(f"{owner} expects an opacity in (0, 1], got {value!r}", key=name,
                         value=value)
