"""GRBL 1.1h's reports as text: the status report with its field cadence, ``$#``, ``$G``,
``$I`` and the help line (facts from ``report.c``; inkarm's own code).

The status report ``<State|MPos:x,y,z|Bf:p,r|FS:f,s|WCO:x,y,z|Ov:f,r,s|A:SF>``:

* ``MPos`` with ``$10`` bit 0 set, else ``WPos`` (machine position less the work offset);
  ``Bf:`` (free planner blocks, free receive-buffer bytes) with bit 1. ``Ln:`` is never
  printed: stock GRBL is built without line numbers. ``Pn:`` lists the closed limit
  switches (the control pins and the probe are never active here).
* ``FS:`` the speed now [mm/min] (0 unless moving, homing, jogging or holding) and the
  spindle speed as the PWM got it (clamped to ``$30``/``$31``, 0 when off).
* ``WCO:`` when its counter is 0, then the counter restarts at 29 while busy (Run, Hold,
  Jog, Home) or 9 otherwise; printing it moves a 0 override counter to 1 (no ``Ov:`` in the
  same report). ``Ov:`` likewise with 19 (busy) or 9, and only with ``Ov:`` comes ``A:``
  (spindle ``S``/``C``, flood ``F``), when an accessory is on. A reset zeroes both counters;
  a work-offset change zeroes the WCO counter, a spindle or coolant change or an override
  change the override counter.
* Coordinates with 3 decimals (4 and inches with ``$13=1``), rates with 0 (1 in inches).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.hardware.plotter.planner import BLOCK_BUFFER
from inkarm.hardware.plotter.settings import grbl_float

VERSION = "1.1h"
BUILD = "20190830"
BANNER = f"Grbl {VERSION} ['$' for help]"
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"
OVR_BUSY, OVR_IDLE, WCO_BUSY, WCO_IDLE = 20, 10, 30, 10  # config.h REPORT_*_REFRESH_*_COUNT
BUSY_STATES = ("Run", "Hold", "Jog", "Home", "Door")
BLOCKS = BLOCK_BUFFER  # BLOCK_BUFFER_SIZE - 1
RX_BYTES = 128
COORD_NAMES = ("G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30")


@dataclass
class ReportCounters:
    """GRBL's ``sys.report_wco_counter`` and ``sys.report_ovr_counter``."""

    wco: int = 0
    ovr: int = 0


@dataclass(frozen=True)
class StatusInputs:
    """What one status report shows (machine-side values, mm and mm/min)."""

    state: str
    mpos: np.ndarray
    wco: np.ndarray
    blocks_free: int
    rx_free: int
    rate_mm_min: float
    spindle_rpm: float
    overrides: tuple[int, int, int]
    spindle: str  # "", "S" or "C"
    flood: bool
    pins: str = ""  # closed limit switches, "XYZ"


def axis_values(values, inches: bool) -> str:
    """Three coordinates as GRBL prints them (mm, or inches with ``$13=1``)."""
    if inches:
        return ",".join(grbl_float(float(v) / 25.4, 4) for v in values)
    return ",".join(grbl_float(float(v), 3) for v in values)


def status_report(s: StatusInputs, mask: int, inches: bool, counters: ReportCounters) -> str:
    """One ``?`` answer; advances ``counters`` as GRBL does (see the module docstring)."""
    busy = s.state.split(":")[0] in BUSY_STATES
    position = np.asarray(s.mpos, dtype=np.float32)
    if not mask & 1:
        position = position - np.asarray(s.wco, dtype=np.float32)
    fields = [s.state, ("MPos:" if mask & 1 else "WPos:") + axis_values(position, inches)]
    if mask & 2:
        fields.append(f"Bf:{s.blocks_free},{s.rx_free}")
    rate = grbl_float(s.rate_mm_min / 25.4, 1) if inches else grbl_float(s.rate_mm_min, 0)
    fields.append(f"FS:{rate},{grbl_float(s.spindle_rpm, 0)}")
    if s.pins:
        fields.append("Pn:" + s.pins)
    if counters.wco > 0:
        counters.wco -= 1
    else:
        counters.wco = (WCO_BUSY if busy else WCO_IDLE) - 1
        if counters.ovr == 0:
            counters.ovr = 1
        fields.append("WCO:" + axis_values(s.wco, inches))
    if counters.ovr > 0:
        counters.ovr -= 1
    else:
        counters.ovr = (OVR_BUSY if busy else OVR_IDLE) - 1
        fields.append("Ov:" + ",".join(str(v) for v in s.overrides))
        accessories = s.spindle + ("F" if s.flood else "")
        if accessories:
            fields.append("A:" + accessories)
    return "<" + "|".join(fields) + ">"


def ngc_parameters(params: np.ndarray, g92: np.ndarray, tlo: float, inches: bool) -> list[str]:
    """The ``$#`` lines: G54-G59, G28, G30 (machine mm), G92, TLO and the probe."""
    lines = [f"[{name}:{axis_values(params[i], inches)}]" for i, name in enumerate(COORD_NAMES)]
    lines.append(f"[G92:{axis_values(g92, inches)}]")
    lines.append(f"[TLO:{axis_values([tlo], inches)}]")
    lines.append(f"[PRB:{axis_values(np.zeros(3), inches)}:0]")
    return lines


def gcode_modes(state, inches: bool) -> str:
    """The ``$G`` line of a :class:`~inkarm.hardware.plotter.interpreter.ParserState` (the
    feed in inches per minute with ``$13=1``)."""
    motion = state.motion
    motion_text = f"38.{round((motion - 38) * 10)}" if motion > 38 else str(int(motion))
    feed = grbl_float(state.feed / 25.4, 1) if inches else grbl_float(state.feed, 0)
    return (f"[GC:G{motion_text} G{state.coord + 54} G{state.plane} G{state.units} "
            f"G{state.distance} G{state.feed_mode} M{state.spindle} M{state.coolant} "
            f"T{state.tool} F{feed} S{grbl_float(state.spindle_speed, 0)}]")


def build_info(info: str) -> list[str]:
    """The ``$I`` lines (variable spindle, 15 planner blocks, 128 receive bytes)."""
    return [f"[VER:{VERSION}.{BUILD}:{info}]", f"[OPT:V,{BLOCKS},{RX_BYTES}]"]


__all__ = ["BANNER", "HELP", "VERSION", "ReportCounters", "StatusInputs", "build_info",
           "gcode_modes", "ngc_parameters", "status_report"]
