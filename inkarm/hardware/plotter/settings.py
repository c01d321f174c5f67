"""GRBL 1.1h's ``$`` settings: their defaults, the checks ``$x=value`` runs, and how ``$$``
prints them.

Facts (GRBL 1.1h ``defaults.h`` DEFAULTS_GENERIC, ``settings.c``
``settings_store_global_setting``, ``report.c`` ``report_grbl_settings``):

* :data:`GRBL_DEFAULTS` are the stock firmware's values; :data:`PLOTTER_SETTINGS` are inkarm's
  plotter profile over them (steps, rates, accelerations, travel, homing seek rate);
  :data:`DEFAULT_SETTINGS` is the two together, what the emulator powers up with.
* A negative value is refused with error:4; ``$0`` below 3 with error:6; ``$20=1`` while
  homing (``$22``) is off with error:10; an unknown number with error:3. ``$22=0`` turns soft
  limits off too. Whole-number settings keep the integer part of the value.
* ``$$`` prints whole-number and flag settings as integers, ``$30``/``$31`` with no decimals,
  the others with three (GRBL's ``printFloat``: half rounds up).
"""

from __future__ import annotations

import math

import numpy as np

GRBL_DEFAULTS: dict[int, float] = {
    0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 1, 11: 0.010, 12: 0.002, 13: 0,
    20: 0, 21: 0, 22: 0, 23: 0, 24: 25.0, 25: 500.0, 26: 250, 27: 1.0, 30: 1000.0, 31: 0.0,
    32: 0, 100: 250.0, 101: 250.0, 102: 250.0, 110: 500.0, 111: 500.0, 112: 500.0,
    120: 10.0, 121: 10.0, 122: 10.0, 130: 200.0, 131: 200.0, 132: 200.0,
}
PLOTTER_SETTINGS: dict[int, float] = {
    25: 3000.0, 100: 80.0, 101: 80.0, 102: 400.0, 110: 12000.0, 111: 12000.0, 112: 3000.0,
    120: 1500.0, 121: 1500.0, 122: 500.0, 130: 300.0, 131: 300.0, 132: 40.0,
}
DEFAULT_SETTINGS: dict[int, float] = {**GRBL_DEFAULTS, **PLOTTER_SETTINGS}
INTEGER_SETTINGS = frozenset({0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 32})
FLAG_SETTINGS = frozenset({4, 5, 6, 13, 20, 21, 22, 32})
RPM_SETTINGS = frozenset({30, 31})

# GRBL 1.1h report.h status codes used by the settings.
ERR_INVALID_STATEMENT, ERR_NEGATIVE, ERR_STEP_PULSE, ERR_SOFT_LIMIT = 3, 4, 6, 10


def grbl_float(value: float, decimals: int) -> str:
    """``value`` as GRBL's ``printFloat`` writes it: in single precision, scaled by
    10^decimals, half rounded up, a minus sign for any negative value (so ``-0.0001`` is
    ``-0.000``, while ``-0.0`` is ``0.000``)."""
    v = np.float32(value)
    sign = "-" if v < 0 else ""
    v = np.float32(abs(v))
    d = decimals
    while d >= 2:
        v = np.float32(v * np.float32(100))
        d -= 2
    if d:
        v = np.float32(v * np.float32(10))
    v = np.float32(v + np.float32(0.5))
    whole = int(v) if math.isfinite(float(v)) else 0
    text = str(whole).rjust(decimals + 1, "0")
    if decimals:
        text = text[:-decimals] + "." + text[-decimals:]
    return sign + text


def check_setting(settings: dict[int, float], key: int, value: float) -> int:
    """GRBL's status code for ``$key=value`` given the current ``settings`` (0: accepted)."""
    if not math.isfinite(value) or value < 0:
        return ERR_NEGATIVE
    if key not in GRBL_DEFAULTS:
        return ERR_INVALID_STATEMENT
    if key == 0 and math.trunc(value) < 3:
        return ERR_STEP_PULSE
    if key == 20 and math.trunc(value) and not settings.get(22):
        return ERR_SOFT_LIMIT
    return 0


def store_setting(settings: dict[int, float], key: int, value: float) -> None:
    """Store an accepted setting as GRBL keeps it (integers truncated, flags 0/1, the
    setting in single precision; ``$22=0`` clears ``$20``)."""
    if key in FLAG_SETTINGS:
        settings[key] = 1 if math.trunc(value) else 0
    elif key in INTEGER_SETTINGS:
        settings[key] = math.trunc(value) & (0xFFFF if key == 26 else 0xFF)
    else:
        settings[key] = float(np.float32(value))
    if key == 22 and not settings[22]:
        settings[20] = 0


def checked_settings(overrides: dict[int, float] | None) -> tuple[dict[int, float], str]:
    """:data:`DEFAULT_SETTINGS` with ``overrides`` stored in turn (``$22`` before ``$20``);
    returns the settings and, when one is refused, why (naming the setting)."""
    settings = dict(DEFAULT_SETTINGS)
    items = sorted((overrides or {}).items(), key=lambda kv: (kv[0] == 20, kv[0]))
    for key, value in items:
        code = check_setting(settings, int(key), float(value))
        if code:
            return settings, (f"${key}={value}: GRBL 1.1h refuses it (error:{code}; expected "
                              "a known setting >= 0, $0 >= 3, $20=1 only with $22=1)")
        store_setting(settings, int(key), float(value))
    return settings, ""


def setting_lines(settings: dict[int, float]) -> list[str]:
    """The lines ``$$`` prints, in GRBL's order."""
    lines = []
    for key in sorted(GRBL_DEFAULTS):
        value = settings[key]
        if key in INTEGER_SETTINGS:
            text = str(int(value))
        else:
            text = grbl_float(value, 0 if key in RPM_SETTINGS else 3)
        lines.append(f"${key}={text}")
    return lines


__all__ = ["DEFAULT_SETTINGS", "GRBL_DEFAULTS", "PLOTTER_SETTINGS", "check_setting",
           "checked_settings", "grbl_float", "setting_lines", "store_setting"]
