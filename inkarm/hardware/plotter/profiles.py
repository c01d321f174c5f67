"""Pen profiles: how a plotter's pen goes up and down, and how fast it may draw, as data.

A profile is a TOML file (built-ins in ``hardware/plotter/profiles/``: ``servo``, ``z``; or any
file by its path), in the spirit of vpype-gcode's profiles::

    description = "RC-servo pen on the spindle PWM"
    units = "mm"                 # "mm" (G21) or "in" (G20): the units of the G-code written
    header = ["G90", "G94", "M5"] # after the units line
    footer = ["M5", "G0 X0 Y0"]
    pen_down = ["M3 S1000"]      # lines that put the pen down ...
    pen_up = ["M5"]              # ... and lift it
    pen_down_dwell_s = 0.15      # G4 P after them: the servo's travel time [s]
    pen_up_dwell_s = 0.15
    draw_speed_mm_s = 60.0       # pen-down feed for a drawing without timing [mm/s]
    max_draw_speed_mm_s = 150.0  # the pen-down feed never exceeds this (a slower pen-down)
    min_draw_speed_mm_s = 2.0
    max_line_rate_hz = 400.0     # lines per second the firmware executes at most
    precision = 3                # decimals of the coordinates
    page_origin = "auto"         # where the page's lower-left corner goes in machine space:
                                 # "auto", "lower-left", ..., "machine-zero", "current", [x, y]
    homing = "auto"              # "auto": $H when $22=1; "skip": $X (no switches to home on)

Travel (pen up) is ``G0``, at the machine's rapid rate. The page placement and homing are
:mod:`inkarm.hardware.plotter.workspace`'s (its docstring has the choices and GRBL's facts).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from inkarm.hardware.plotter.workspace import HOMINGS, ORIGINS, Placement
from inkarm.io.profile_files import builtin_names, load_named
from inkarm.io.toml import TomlReader

PROFILE_DIR = Path(__file__).with_name("profiles")
KEYS = ("description", "units", "header", "footer", "pen_down", "pen_up", "pen_down_dwell_s",
        "pen_up_dwell_s", "draw_speed_mm_s", "max_draw_speed_mm_s", "min_draw_speed_mm_s",
        "max_line_rate_hz", "precision", "page_origin", "homing")
DEFAULT_PROFILE = "servo"


@dataclass(frozen=True)
class PenProfile:
    """A checked pen profile (see the module docstring). Lengths [mm], times [s]."""

    name: str
    description: str = ""
    units: str = "mm"
    header: tuple[str, ...] = ("G90", "G94")
    footer: tuple[str, ...] = ()
    pen_down: tuple[str, ...] = ("M3 S1000",)
    pen_up: tuple[str, ...] = ("M5",)
    pen_down_dwell_s: float = 0.15
    pen_up_dwell_s: float = 0.15
    draw_speed_mm_s: float = 60.0
    max_draw_speed_mm_s: float = 150.0
    min_draw_speed_mm_s: float = 2.0
    max_line_rate_hz: float = 400.0
    precision: int = 3
    placement: Placement = field(default_factory=Placement)

    @property
    def unit_mm(self) -> float:
        """Millimetres per G-code unit."""
        return 25.4 if self.units == "in" else 1.0

    def start_lines(self) -> list[str]:
        """The units line (``G21`` or ``G20``) and the header: what every job starts with."""
        return ["G20" if self.units == "in" else "G21", *self.header]

    def xy(self, x_mm: float, y_mm: float) -> str:
        """The ``X Y`` words of a point [mm], in the profile's units and precision."""
        p, unit = self.precision, self.unit_mm
        return f"X{x_mm / unit:.{p}f} Y{y_mm / unit:.{p}f}"

    def feed(self, speed_mm_s: float) -> str:
        """The ``F`` word of a speed [mm/s] (G-code feeds are per minute)."""
        return f"F{speed_mm_s * 60.0 / self.unit_mm:.1f}"

    def pen_lines(self, down: bool) -> list[str]:
        """The lines that put the pen down (or lift it), with their dwell."""
        lines = list(self.pen_down if down else self.pen_up)
        dwell = self.pen_down_dwell_s if down else self.pen_up_dwell_s
        if dwell > 0:
            lines.append(f"G4 P{dwell:.3f}")
        return lines


def profile_names() -> tuple[str, ...]:
    """The built-in profiles."""
    return builtin_names(PROFILE_DIR)


def load_profile(name_or_path: str | Path | None = None) -> PenProfile:
    """A built-in profile by name, or a profile file by path (ending in ``.toml``)."""
    return load_named(name_or_path or DEFAULT_PROFILE, PROFILE_DIR, "pen profile", parse_profile)


def parse_profile(data: dict, source: str, name: str) -> PenProfile:
    """Check the tables of a profile file; errors name ``source`` and the key."""
    rd = TomlReader(source)
    rd.keys(data, KEYS, "")
    kw: dict = {}
    if "description" in data:
        kw["description"] = rd.text(data["description"], "description")
    if "units" in data:
        kw["units"] = rd.choice(data["units"], "units", ("mm", "in"))
    for key in ("header", "footer", "pen_down", "pen_up"):
        if key in data:
            value = data[key]
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise rd.error(key, "expected an array of G-code lines (strings)", value=value)
            if key in ("pen_down", "pen_up") and not value:
                raise rd.error(key, "expected at least one G-code line (the pen would never "
                               "move)", value=value)
            for i, line in enumerate(value):
                bad = next((c for c in line if not " " <= c <= "~"), None)
                if bad is not None:
                    # GRBL acts on some bytes wherever they come (0x18: soft reset, "?", "!",
                    # "~", 0x80-0xFF: real-time commands), so a line carries printable ASCII
                    raise rd.error(f"{key}[{i}]", "expected one G-code line of printable "
                                   f"ASCII, got the character {bad!r} (U+{ord(bad):04X})",
                                   value=line)
                if any(c in line for c in "?!~"):
                    raise rd.error(f"{key}[{i}]", "expected G-code without '?', '!' or '~' "
                                   "(GRBL's real-time status, hold and resume commands)",
                                   value=line)
                if len(line) > 79:
                    raise rd.error(f"{key}[{i}]", "expected one G-code line of at most 79 "
                                   "characters", value=line)
            kw[key] = tuple(value)
    for key in ("pen_down_dwell_s", "pen_up_dwell_s"):
        if key in data:
            kw[key] = rd.number(data[key], key, 0.0, maximum=60.0)
    for key in ("draw_speed_mm_s", "max_draw_speed_mm_s", "min_draw_speed_mm_s"):
        if key in data:
            kw[key] = rd.number(data[key], key, 0.0, strict=True, maximum=5000.0)
    if "max_line_rate_hz" in data:
        kw["max_line_rate_hz"] = rd.number(data["max_line_rate_hz"], "max_line_rate_hz", 1.0,
                                           maximum=10000.0)
    if "precision" in data:
        kw["precision"] = rd.integer(data["precision"], "precision", 0, 6)
    if "page_origin" in data or "homing" in data:
        kw["placement"] = parse_placement(rd, data, "")
    profile = PenProfile(name=name, **kw)
    if profile.min_draw_speed_mm_s > profile.max_draw_speed_mm_s:
        raise rd.error("min_draw_speed_mm_s", f"expected at most max_draw_speed_mm_s "
                       f"({profile.max_draw_speed_mm_s:g}), got {profile.min_draw_speed_mm_s:g}",
                       value=profile.min_draw_speed_mm_s)
    return profile


def parse_placement(rd: TomlReader, data: dict, prefix: str,
                    base: Placement | None = None) -> Placement:
    """The ``page_origin`` and ``homing`` keys of a table (a pen profile, a scenario's
    ``[plotter]``) over ``base``; errors name ``prefix`` + the key."""
    base = base or Placement()
    origin, homing = base.origin, base.homing
    if "page_origin" in data:
        value = data["page_origin"]
        if isinstance(value, str):
            origin = rd.choice(value, f"{prefix}page_origin", ORIGINS)
        elif isinstance(value, list) and len(value) == 2:
            origin = (rd.number(value[0], f"{prefix}page_origin[0]", -10000.0, maximum=10000.0),
                      rd.number(value[1], f"{prefix}page_origin[1]", -10000.0, maximum=10000.0))
        else:
            raise rd.error(f"{prefix}page_origin", "expected one of " + ", ".join(ORIGINS)
                           + " or the page's lower-left corner [x, y] in machine "
                           "coordinates [mm]", value=value)
    if "homing" in data:
        homing = rd.choice(data["homing"], f"{prefix}homing", HOMINGS)
    return Placement(origin, homing)
