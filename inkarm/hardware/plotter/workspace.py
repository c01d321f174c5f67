"""Where the page lies in a GRBL plotter's machine space, and the set-up at connect: settings,
homing, the work offset that puts the page there, check mode.

Facts of GRBL 1.1h this module relies on (gnea/grbl, HOMING_FORCE_SET_ORIGIN off, the default):

* limits.c ``limits_go_home``: after ``$H`` an axis that homed toward + (``$23`` bit clear)
  stands at machine -``$27`` (the pull-off), one that homed toward - at -``$13x`` + ``$27``:
  machine space is [-max travel, 0] per axis either way (``$130``, ``$131``, ``$132`` [mm]).
* system.c ``system_check_travel_limits`` and motion_control.c ``mc_line``: with soft limits
  (``$20=1``) a line whose machine target leaves [-max travel, 0] raises ALARM:2, in check mode
  too; settings.c refuses ``$20=1`` (error:10) unless homing is on (``$22=1``).
* main.c ``HOMING_INIT_LOCK``: with ``$22=1`` GRBL starts in Alarm (``[MSG:'$H'|'$X' to
  unlock]``) until homed or unlocked; ``$X`` unlocks without homing.
* gcode.c: ``G10 L2 P1 X.. Y..`` sets G54's offset (kept in EEPROM; axes not named keep theirs);
  work position = machine position - (G54 + G92 offsets); a reset clears G92 (``gc_init``).
* report.c ``report_ngc_parameters``: ``$#`` prints ``[G54:x,y,z]`` .. ``[G59:..]``,
  ``[G28:..]``, ``[G30:..]``, ``[G92:..]``, ``[TLO:z]``, ``[PRB:x,y,z:0]``.
* system.c ``$C``: check mode only from Idle (else error:8); toggling it off resets GRBL.

Page placement (a pen profile's ``page_origin``): where the page's lower-left corner (work 0, 0)
goes, in machine coordinates [mm]: ``"lower-left"`` (the travel's minimum corner, machine
(-$130, -$131)), ``"lower-right"``, ``"upper-left"``, ``"upper-right"`` (the page's matching
corner at the travel's), ``"machine-zero"`` (work = machine: GRBL's power-on position without
homing), ``"current"`` (where the pen stands once set up), or ``[x, y]``. ``"auto"``: lower-left
on a machine that homes, machine-zero on one that does not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError
from inkarm.hardware.plotter import homing
from inkarm.hardware.plotter.settings import GRBL_DEFAULTS
from inkarm.hardware.plotter.stream import GrblError, GrblStreamer

ORIGINS = ("auto", "lower-left", "lower-right", "upper-left", "upper-right", "machine-zero",
           "current")
HOMINGS = ("auto", "skip")  # auto: $H whenever $22=1; skip: $X (a machine without switches)
HOME_TIMEOUT_S = 180.0  # the longest homing cycle waited for [s, wall]
TOLERANCE_MM = 1e-3


@dataclass(frozen=True)
class Placement:
    """Where the page goes (see the module docstring) and how the machine is homed."""

    origin: str | tuple[float, float] = "auto"
    homing: str = "auto"


@dataclass(frozen=True)
class Workspace:
    """The machine as set up for a job.

    Attributes:
        settings: The ``$`` settings by number.
        origin_mm: The page's lower-left corner in machine coordinates [mm].
        homed: Whether ``$H`` ran (or the machine was taken as homed: ``homing = "skip"``).
        offsets: ``$#`` after the set-up: name -> values (G54 .. G59, G28, G30, G92, TLO).
    """

    settings: dict[int, float]
    origin_mm: tuple[float, float]
    homed: bool
    offsets: dict[str, tuple[float, ...]]


def read_settings(streamer: GrblStreamer) -> dict[int, float]:
    """The device's ``$`` settings (``$$``), by number."""
    settings = {}
    for line in streamer.command("$$"):
        key, _, value = line.partition("=")
        if key.startswith("$") and key[1:].isdigit():
            try:
                settings[int(key[1:])] = float(value.split()[0])
            except (ValueError, IndexError):
                continue
    return settings


def read_offsets(streamer: GrblStreamer) -> dict[str, tuple[float, ...]]:
    """``$#``: each ``[NAME:a,b,c]`` line as NAME -> numbers (``[PRB:x,y,z:1]`` keeps x, y,
    z)."""
    offsets: dict[str, tuple[float, ...]] = {}
    for line in streamer.command("$#"):
        if line.startswith("[") and line.endswith("]") and ":" in line:
            name, _, values = line[1:-1].partition(":")
            try:
                offsets[name] = tuple(float(v) for v in values.split(":")[0].split(","))
            except ValueError:
                continue
    return offsets


def homes(settings: dict[int, float]) -> bool:
    """Whether the machine's space is GRBL's homed one ([-max travel, 0]): homing is on
    (``$22=1``; with ``homing = "skip"`` the machine is taken as standing at home)."""
    return bool(settings.get(22, 0))


def xy_travel(settings: dict[int, float]) -> np.ndarray:
    """The x and y travel ``$130``, ``$131`` [mm] of a device's settings (GRBL's defaults for
    those it did not report)."""
    return homing.travel({**GRBL_DEFAULTS, **settings})[:2]


def homed_position(settings: dict[int, float]) -> tuple[float, float]:
    """Where ``$H`` leaves x and y, in machine coordinates [mm] (limits.c, see the module
    docstring)."""
    return tuple(float(v) for v in homing.homed_position({**GRBL_DEFAULTS, **settings})[:2])


def page_origin(placement: Placement, settings: dict[int, float], page_mm: tuple[float, float],
                here_mm: tuple[float, float]) -> tuple[float, float]:
    """The page's lower-left corner in machine coordinates [mm] (module docstring);
    ``here_mm``: where the pen will stand when the offset is set."""
    origin = placement.origin
    if not isinstance(origin, str):
        return (float(origin[0]), float(origin[1]))
    if origin == "auto":
        origin = "lower-left" if homes(settings) else "machine-zero"
    if origin == "machine-zero":
        return (0.0, 0.0)
    if origin == "current":
        return (float(here_mm[0]), float(here_mm[1]))
    travel = xy_travel(settings)
    vertical, horizontal = origin.split("-")
    x = -travel[0] if horizontal == "left" else -page_mm[0]
    y = -travel[1] if vertical == "lower" else -page_mm[1]
    return (x, y)


def check_reach(origin: tuple[float, float], lo: np.ndarray, hi: np.ndarray,
                settings: dict[int, float], homed: bool) -> None:
    """Refuse a job whose page points ``lo``..``hi`` [mm] leave the machine's travel, naming
    the drawing's point that leaves it first (its lowest or highest x or y on the page), the
    travel and the setting: with a homed space the machine targets must lie in [-$13x, 0]
    (GRBL raises ALARM:2 with soft limits on, or drives into the frame without); without one
    the span must fit the travel, and the targets lie in [0, $13x] from the power-on position
    (taken as the travel's lower-left corner, as ``inkarm gcode``'s travel check takes the
    page's)."""
    travel_xy = xy_travel(settings)
    travels = f"$130 = {travel_xy[0]:g} mm, $131 = {travel_xy[1]:g} mm"
    for axis, name in enumerate("XY"):
        key = 130 + axis
        travel = float(travel_xy[axis])
        a, b = origin[axis] + float(lo[axis]), origin[axis] + float(hi[axis])
        if homed and (a < -travel - TOLERANCE_MM or b > TOLERANCE_MM):
            low = a < -travel - TOLERANCE_MM
            page = float(lo[axis] if low else hi[axis])
            raise InputError(
                f"the drawing's {'lowest' if low else 'highest'} {name.lower()} on the page, "
                f"{name} = {page:.2f} mm, is machine {name} {a if low else b:.2f} mm with the "
                f"page origin at machine {name} {origin[axis]:.2f} mm: the job reaches machine "
                f"{name} {a:.2f} to {b:.2f} mm (page {name} {float(lo[axis]):.2f} to "
                f"{float(hi[axis]):.2f} mm), outside GRBL's homed travel [-{travel:g}, 0] mm "
                f"(${key}, {name} max travel) with {travels}: move the page (the pen "
                f"profile's page_origin) or the drawing (the scenario's [placement]), or "
                f"raise ${key}",
                key=f"${key}", value=travel)
        if not homed and b - a > travel + TOLERANCE_MM:
            raise InputError(
                f"the job spans {b - a:.2f} mm in {name}, more than the machine's travel "
                f"${key} = {travel:g} mm ({name} max travel) with {travels}: page {name} "
                f"{float(lo[axis]):.2f} to {float(hi[axis]):.2f} mm; scale the drawing (the "
                f"scenario's [placement] fit_to_margins_mm or scale)", key=f"${key}",
                value=travel)
        if not homed and (a < -TOLERANCE_MM or b > travel + TOLERANCE_MM):
            low = a < -TOLERANCE_MM
            raise InputError(
                f"the drawing's {'lowest' if low else 'highest'} {name.lower()} on the page, "
                f"{name} = {float(lo[axis] if low else hi[axis]):.2f} mm, is machine {name} "
                f"{a if low else b:.2f} mm with the page origin at machine {name} "
                f"{origin[axis]:.2f} mm: outside the travel [0, {travel:g}] mm (${key}, {name} "
                f"max travel) with {travels}, from where a machine without homing ($22=0) was "
                f"switched on (its lower-left corner, as `inkarm gcode` takes it): move or "
                f"scale the drawing (the scenario's [placement]) or the page origin",
                key=f"${key}", value=travel)


def set_up(streamer: GrblStreamer, placement: Placement, page_mm: tuple[float, float],
           extent_mm: tuple[np.ndarray, np.ndarray] | None = None,
           check_mode: bool = False) -> Workspace:
    """Read ``$$``; refuse a job beyond the travel (before anything moves); home (``$H``)
    when ``$22=1`` (``$X`` instead in check mode or with ``homing = "skip"``, or when an
    earlier alarm locked a machine without homing); put the page origin in G54 (``G10 L2
    P1``) and select it; enter check mode (``$C``) when asked. The streamer keeps the work
    offset that reports without ``WCO:`` need."""
    settings = read_settings(streamer)
    if settings.get(13):
        raise InputError("the device reports inches ($13=1); inkarm reads positions in "
                         "millimetres: set $13=0", key="$13", value=settings[13])
    homed = homes(settings)
    will_home = homed and placement.homing == "auto" and not check_mode
    status = streamer.status()
    here = homed_position(settings) if will_home else status.mpos[:2]
    origin = page_origin(placement, settings, page_mm, here)
    if extent_mm is not None:
        check_reach(origin, *extent_mm, settings, homed)
    if will_home:
        streamer.home(HOME_TIMEOUT_S)
    elif status.state.startswith("Alarm"):
        streamer.unlock()
    streamer.command(f"G10 L2 P1 X{origin[0]:.3f} Y{origin[1]:.3f}")
    streamer.command("G54")
    offsets = read_offsets(streamer)
    if any(abs(v) > 1e-9 for v in offsets.get("G92", ())):
        streamer.command("G92.1")
        offsets = read_offsets(streamer)
    g54 = offsets.get("G54", (origin[0], origin[1], 0.0))
    if abs(g54[0] - origin[0]) > TOLERANCE_MM or abs(g54[1] - origin[1]) > TOLERANCE_MM:
        raise GrblError(f"G10 L2 P1 set G54 to {g54[:2]}, expected {origin} (see $#)",
                        key="--port", value=streamer.port)
    g92 = offsets.get("G92", (0.0, 0.0, 0.0))
    wco = [g + o for g, o in zip((*g54, 0.0, 0.0)[:3], (*g92, 0.0, 0.0)[:3], strict=True)]
    wco[2] += offsets.get("TLO", (0.0,))[0]
    streamer.wco = (wco[0], wco[1], wco[2])
    if check_mode:
        streamer.command("$C")
    return Workspace(settings, origin, homed, offsets)


def leave_check_mode(streamer: GrblStreamer) -> None:
    """``$C`` again: GRBL leaves check mode with a soft reset; wait for its banner."""
    streamer.command("$C")
    streamer.wake()
