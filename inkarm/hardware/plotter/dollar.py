"""GRBL 1.1h's ``$`` system commands (facts from ``system.c`` ``system_execute_line`` and
``settings.c``; inkarm's own code), run on a :class:`~inkarm.hardware.plotter.machine.
GrblMachine`.

====================  ================================================================
``$``                 the help line
``$$``                the settings (error:8 while running or holding)
``$#``                G54-G59, G28, G30, G92, TLO, PRB (only Idle or Alarm, else error:8)
``$G``                the parser's modal state
``$I`` / ``$I=text``  version ``[VER:1.1h.20190830:text]`` and ``[OPT:V,15,128]``; store text
``$N`` / ``$Nx=line`` the two start-up lines; storing runs the line first (Idle only)
``$C``                check mode on (Idle only) / off (with a soft reset)
``$X``                leave the alarm (``[MSG:Caution: Unlocked]``); no effect otherwise
``$H``                homing (error:5 without ``$22=1``)
``$J=line``           a jog (Idle or Jog only); error:15 outside the soft limits
``$RST=$ # *``        restore settings / clear coordinates / both, then a soft reset
``$SLP``              sleep until a soft reset (then in alarm)
``$x=value``          a setting (:mod:`.settings` checks); error:3 malformed, 2 no number
====================  ================================================================

Anything else after ``$`` with another letter is error:3 (``$XY``, ``$HX``), a missing
number error:2.
"""

from __future__ import annotations

import numpy as np

from inkarm.hardware.plotter.gcode_parser import read_float
from inkarm.hardware.plotter.reports import HELP, build_info, gcode_modes, ngc_parameters
from inkarm.hardware.plotter.settings import check_setting, setting_lines, store_setting

ERR_BAD_NUMBER, ERR_INVALID, ERR_DISABLED, ERR_IDLE = 2, 3, 5, 8


def system_command(m, line: str) -> None:
    """Run one ``$`` line on machine ``m``; its replies go to ``m.outbox`` or, for work that
    waits (homing, a jog, a start-up line), to ``m.work``."""
    code = _command(m, line)
    if code is None:
        return
    m.outbox.append("ok" if code == 0 else f"error:{code}")


def _command(m, line: str) -> int | None:
    """Status code of ``line`` (None: the reply is queued with its work)."""
    state, inches = m.sys_state, bool(m.settings[13])
    running = m.state.split(":")[0] in ("Run", "Hold")
    if len(line) == 1:
        m.outbox.append(HELP)
        return 0
    key = line[1]
    if key == "J":
        if m.state not in ("Idle", "Jog"):
            return ERR_IDLE
        if line[2:3] != "=":
            return ERR_INVALID
        m.run_gcode(line, "", jog=True)  # (queues its ok, or replies its error)
        return None
    if key in "$GCX":
        if len(line) != 2:
            return ERR_INVALID
        if key == "$":
            if running:
                return ERR_IDLE
            m.outbox.extend(setting_lines(m.settings))
        elif key == "G":
            m.outbox.append(gcode_modes(m.gc, inches))
        elif key == "C":
            return _check_mode(m)
        elif state == "Alarm":
            m.outbox.append("[MSG:Caution: Unlocked]")
            m.sys_state = "Idle"
        return 0
    if m.state not in ("Idle", "Alarm"):
        return ERR_IDLE
    if key == "#":
        if len(line) != 2:
            return ERR_INVALID
        m.outbox.extend(ngc_parameters(m.params, m.gc.coord_offset, m.gc.tool_length_offset,
                                       inches))
        return 0
    if key == "H":
        if not m.settings[22]:
            return ERR_DISABLED
        if len(line) != 2:
            return ERR_INVALID
        m.start_homing()
        m.work.append(("reply", "ok"))
        return None
    if key == "S":
        if line != "$SLP":
            return ERR_INVALID
        m.outbox.append("ok")
        m.raise_sleep()
        return None
    if key == "I":
        if len(line) == 2:
            m.outbox.extend(build_info(m.build_info))
            return 0
        if line[2] != "=":
            return ERR_INVALID
        m.build_info = line[3:]
        return 0
    if key == "R":
        return _restore(m, line)
    if key == "N" and len(line) == 2:
        m.outbox.extend(f"$N{i}={text}" for i, text in enumerate(m.startup_lines))
        return 0
    return _store(m, line, startup=key == "N")


def _check_mode(m) -> int | None:
    if m.sys_state == "Check":
        m.outbox.extend(["[MSG:Disabled]", "ok"])
        m.soft_reset()
        return None
    if m.state != "Idle":
        return ERR_IDLE
    m.sys_state = "Check"
    m.outbox.append("[MSG:Enabled]")
    return 0


def _restore(m, line: str) -> int | None:
    if len(line) != 6 or line[2:5] != "ST=" or line[5] not in "$#*":
        return ERR_INVALID
    what = line[5]
    if what in "$*":
        m.settings.clear()
        m.settings.update(m.factory)
        m.build_planner()
    if what in "#*":
        m.params[:] = np.zeros((8, 3))
    if what == "*":
        m.startup_lines = ["", ""]
        m.build_info = ""
    m.outbox.extend(["[MSG:Restoring defaults]", "ok"])
    m.soft_reset()
    return None


def _store(m, line: str, startup: bool) -> int | None:
    """``$x=value`` or ``$Nx=line``."""
    start = 2 if startup else 1
    if startup and m.state != "Idle":
        return ERR_IDLE
    read = read_float(line, start)
    if read is None:
        return ERR_BAD_NUMBER
    number, pos = read
    if line[pos:pos + 1] != "=":
        return ERR_INVALID
    if startup:
        text = line[pos + 1:]
        index = int(number)
        code = m.run_gcode(text, "")
        if code == 0 and 0 <= index < len(m.startup_lines):  # (GRBL does not check index)
            m.startup_lines[index] = text
        return None
    read = read_float(line, pos + 1)
    if read is None:
        return ERR_BAD_NUMBER
    value, end = read
    if end != len(line) or number > 255:
        return ERR_INVALID
    key = int(number)
    code = check_setting(m.settings, key, value)
    if code:
        return code
    store_setting(m.settings, key, value)
    if key in (11, 110, 111, 112, 120, 121, 122):
        m.build_planner()
    if key == 13:
        m.counters.wco = 0
    return 0


__all__ = ["system_command"]
