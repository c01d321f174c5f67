"""AxiDraw profiles: a machine's travel, resolution, pen servo and speed limits, as data.

A profile is a TOML file (built-ins in ``hardware/axidraw/profiles/``: ``v3``, ``v3_a3``; or
any file by its path ending in ``.toml``); every key is optional over the V3's values::

    model = "V3"
    travel_mm = [299.974, 217.932]  # carriage travel from home (x right, y towards the user)
    steps_per_mm = 80.0             # motor steps per mm along a motor axis (2032/in at 16x)
    pen_pos_up = 60                 # pen heights [% of the servo's span]
    pen_pos_down = 30
    pen_rate_raise = 75             # servo speeds [% of full speed]
    pen_rate_lower = 50
    pen_delay_up_ms = 0             # extra wait after the servo has moved [ms]
    pen_delay_down_ms = 0
    speed_pendown_mm_s = 50.21      # speed limits [mm/s] and accelerations [mm/s^2]
    speed_penup_mm_s = 150.63
    accel_pendown_mm_s2 = 762.0
    accel_penup_mm_s2 = 1143.0
    cornering_mm = 0.0508           # junction deviation: how fast a corner is taken
    min_draw_speed_mm_s = 2.0       # the slowest pen-down speed planned
    time_slice_ms = 25              # longest move while accelerating [ms]
    min_move_ms = 20                # shortest move a drawn curve is cut into [ms]
    servo_min = 9855                # the servo's 0 % and 100 % pulses [1/12 MHz]
    servo_max = 27831
    servo_sweep_ms = 200            # full-span sweep at 100 % rate [ms]
    servo_move_min_ms = 45          # the servo's travel time: min + slope x % moved [ms]
    servo_move_slope_ms = 2.69
    servo_timeout_ms = 60000        # servo power off after this long idle (SR, v2.6.0)
    page_origin = [0.0, 0.0]        # the sheet's upper-left corner in machine mm

The pen's servo values, rates and wait times follow the AxiDraw software (evil-mad/axidraw,
``pen_handling.py``): a height of p % is the pulse ``servo_min + (servo_max - servo_min) p /
100`` (``SC,4``/``SC,5``); a rate of r % moves ``(servo_max - servo_min) x 0.24 / sweep x r``
units per 24 ms (``SC,11``/``SC,12``); and the wait after ``SP`` is the 4th-power blend of the
servo's travel time (``min + slope x distance``) and the sweep time (``sweep x distance /
rate``), zero when up and down are within 0.9 % of each other, plus the delay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

from inkarm.hardware.axidraw.ebb import MAX_STEP_RATE
from inkarm.io.profile_files import builtin_names, load_named
from inkarm.io.toml import TomlReader

PROFILE_DIR = Path(__file__).with_name("profiles")
DEFAULT_PROFILE = "v3"
SERVO_PERIOD_S = 0.024  # the EBB's RC servo repeat period: 8 channels x 3 ms


@dataclass(frozen=True)
class AxiDrawProfile:
    """A checked AxiDraw profile (module docstring). Lengths [mm], times [ms] as named."""

    name: str = DEFAULT_PROFILE
    description: str = ""
    model: str = "V3"
    travel_mm: tuple[float, float] = (299.974, 217.932)
    steps_per_mm: float = 80.0
    pen_pos_up: float = 60.0
    pen_pos_down: float = 30.0
    pen_rate_raise: float = 75.0
    pen_rate_lower: float = 50.0
    pen_delay_up_ms: int = 0
    pen_delay_down_ms: int = 0
    speed_pendown_mm_s: float = 50.21
    speed_penup_mm_s: float = 150.63
    accel_pendown_mm_s2: float = 762.0
    accel_penup_mm_s2: float = 1143.0
    cornering_mm: float = 0.0508
    min_draw_speed_mm_s: float = 2.0
    time_slice_ms: int = 25
    min_move_ms: int = 20
    servo_min: int = 9855
    servo_max: int = 27831
    servo_sweep_ms: float = 200.0
    servo_move_min_ms: float = 45.0
    servo_move_slope_ms: float = 2.69
    servo_timeout_ms: int = 60000
    page_origin: tuple[float, float] = (0.0, 0.0)

    def servo_position(self, percent: float) -> int:
        """The pulse [1/12 MHz] of a pen height [%] (``SC,4``/``SC,5``)."""
        return round(self.servo_min + (self.servo_max - self.servo_min) * percent / 100.0)

    def servo_rate(self, percent: float) -> int:
        """The servo rate [1/12 MHz per 24 ms] of a rate [%] (``SC,11``/``SC,12``)."""
        span = self.servo_max - self.servo_min
        return round(span * SERVO_PERIOD_S * 1000.0 / self.servo_sweep_ms * percent / 100.0)

    def pen_move_ms(self, up: bool) -> int:
        """How long [ms] ``SP`` waits after raising (or lowering) the pen."""
        distance = abs(self.pen_pos_up - self.pen_pos_down)
        rate = self.pen_rate_raise if up else self.pen_rate_lower
        delay = self.pen_delay_up_ms if up else self.pen_delay_down_ms
        if distance < 0.9:
            travel = 0
        else:
            travel = int(((self.servo_move_slope_ms * distance + self.servo_move_min_ms) ** 4
                          + (self.servo_sweep_ms * distance / rate) ** 4) ** 0.25)
        return max(0, travel + delay)

    def max_speed_mm_s(self) -> float:
        """The fastest carriage speed in any direction [mm/s]: a 45-degree move steps one motor
        at sqrt(2) x steps_per_mm per mm, at most 25 kHz."""
        return MAX_STEP_RATE / (self.steps_per_mm * math.sqrt(2.0))


def profile_names() -> tuple[str, ...]:
    """The built-in profiles."""
    return builtin_names(PROFILE_DIR)


def load_profile(name_or_path: str | Path | None = None) -> AxiDrawProfile:
    """A built-in profile by name, or a profile file by path (ending in ``.toml``)."""
    return load_named(name_or_path or DEFAULT_PROFILE, PROFILE_DIR, "AxiDraw profile",
                      parse_profile)


NUMBERS = {  # key: (minimum, strict, maximum)
    "steps_per_mm": (1.0, False, 1000.0), "pen_pos_up": (0.0, False, 100.0),
    "pen_pos_down": (0.0, False, 100.0), "pen_rate_raise": (1.0, False, 100.0),
    "pen_rate_lower": (1.0, False, 100.0), "speed_pendown_mm_s": (0.0, True, 1000.0),
    "speed_penup_mm_s": (0.0, True, 1000.0), "accel_pendown_mm_s2": (0.0, True, 100000.0),
    "accel_penup_mm_s2": (0.0, True, 100000.0), "cornering_mm": (0.0, True, 10.0),
    "min_draw_speed_mm_s": (0.0, True, 1000.0), "servo_sweep_ms": (1.0, False, 60000.0),
    "servo_move_min_ms": (0.0, False, 10000.0), "servo_move_slope_ms": (0.0, False, 1000.0),
}
INTEGERS = {  # key: (low, high)
    "pen_delay_up_ms": (0, 10000), "pen_delay_down_ms": (0, 10000), "time_slice_ms": (5, 200),
    "min_move_ms": (1, 200), "servo_min": (1, 65535), "servo_max": (1, 65535),
    "servo_timeout_ms": (0, 2**32 - 1),
}


def parse_profile(data: dict, source: str, name: str) -> AxiDrawProfile:
    """Check a profile file's keys and values; errors name ``source`` and the key."""
    rd = TomlReader(source)
    allowed = tuple(f.name for f in fields(AxiDrawProfile) if f.name != "name")
    rd.keys(data, allowed, "")
    kw: dict = {}
    for key in ("description", "model"):
        if key in data:
            kw[key] = rd.text(data[key], key)
    for key, (low, strict, high) in NUMBERS.items():
        if key in data:
            kw[key] = rd.number(data[key], key, low, strict=strict, maximum=high)
    for key, (low, high) in INTEGERS.items():
        if key in data:
            kw[key] = rd.integer(data[key], key, low, high)
    for key, low in (("travel_mm", 1.0), ("page_origin", -10000.0)):
        if key in data:
            v = rd.array(data[key], key, 1)
            if v.shape != (2,):
                raise rd.error(key, f"expected [x, y] in mm, got {len(v)} numbers",
                               value=data[key])
            for i in range(2):
                rd.number(float(v[i]), f"{key}[{i}]", low, maximum=10000.0)
            kw[key] = (float(v[0]), float(v[1]))
    profile = AxiDrawProfile(name=name, **kw)
    fastest = profile.max_speed_mm_s()
    for key in ("speed_pendown_mm_s", "speed_penup_mm_s"):
        if getattr(profile, key) > fastest:
            raise rd.error(key, f"expected at most {fastest:.4g} mm/s at {profile.steps_per_mm:g} "
                           f"steps/mm (a motor steps at most {MAX_STEP_RATE:g} steps/s)",
                           value=getattr(profile, key))
    if profile.min_draw_speed_mm_s > profile.speed_pendown_mm_s:
        raise rd.error("min_draw_speed_mm_s", f"expected at most speed_pendown_mm_s "
                       f"({profile.speed_pendown_mm_s:g}), got {profile.min_draw_speed_mm_s:g}",
                       value=profile.min_draw_speed_mm_s)
    if profile.min_move_ms > profile.time_slice_ms:
        raise rd.error("min_move_ms", f"expected at most time_slice_ms "
                       f"({profile.time_slice_ms}), got {profile.min_move_ms}",
                       value=profile.min_move_ms)
    if profile.servo_min >= profile.servo_max:
        raise rd.error("servo_min", f"expected less than servo_max ({profile.servo_max}), got "
                       f"{profile.servo_min}", value=profile.servo_min)
    return profile


__all__ = ["DEFAULT_PROFILE", "AxiDrawProfile", "load_profile", "parse_profile",
           "profile_names"]
