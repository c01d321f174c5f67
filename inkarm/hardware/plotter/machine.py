"""The emulated GRBL 1.1h machine: settings, parser state, the planner, the pen and the clock.

No port here: :class:`GrblMachine` takes lines and real-time bytes and produces replies, and
advances in machine time when told (:meth:`GrblMachine.advance`). The pseudo-terminal server
(:mod:`inkarm.hardware.plotter.emulator`) drives it against the wall clock; the time estimate
(:mod:`inkarm.hardware.plotter.timing`) drives it event by event, so both share one planner.

What GRBL 1.1h does and this machine does too (``protocol.c``, ``gcode.c``, ``system.c``,
``limits.c``, ``report.c``): a line is filtered (:mod:`.gcode_parser`), ``$`` lines go to the
system commands (:mod:`.dollar`), G-code is checked and run by :mod:`.interpreter`; motion
waits in the 15-block planner, a spindle or coolant change, G4, G10, G28.1/G30.1 and M0/M2/M30
wait for it to empty; during G4 the state is Idle. Alarms lock G-code out (``error:9``) until
``$X`` or ``$H``; a soft-limit alarm (a target outside ``[-travel, 0]`` with ``$20=1``, see
:mod:`.homing`) stops the motion, prints ``ALARM:2`` and ``[MSG:Reset to continue]`` and
freezes the main loop (no line, no status report) until a soft reset. With homing on
(``$22=1``) the machine powers up in alarm. A soft reset keeps the position, clears G92, the
modal state and the planner, and runs the ``$N`` start-up lines unless in alarm. Blocks run
between whole-step positions (``plan_buffer_line``); what the stepper does with them is
:mod:`.stepper`.

The pen is an RC servo on the spindle PWM: the spindle on with ``S >= pen_contact_s`` (as the
PWM gets it: clamped to ``$30``/``$31``, 0 when off) puts it down, ``M5`` or a lower S lifts
it; the servo needs ``pen_settle_s``. With a Z-axis pen, the pen touches at physical
``Z <= pen_contact_z_mm``. The ink canvas gets the physical position (from the corner where
the carriage powered up; after homing, machine ``-travel``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError
from inkarm.hardware.plotter import dollar, homing, stepper
from inkarm.hardware.plotter.gcode_parser import GcodeError, filter_line, parse_block
from inkarm.hardware.plotter.homing import HomingMixin
from inkarm.hardware.plotter.interpreter import ParserState, execute_block
from inkarm.hardware.plotter.planner import BLOCK_BUFFER, Planner
from inkarm.hardware.plotter.realtime import RealtimeCommands
from inkarm.hardware.plotter.reports import (
    BANNER,
    ReportCounters,
    StatusInputs,
    status_report,
)
from inkarm.hardware.plotter.settings import (
    DEFAULT_SETTINGS,
    GRBL_DEFAULTS,
    PLOTTER_SETTINGS,
    checked_settings,
)

VERSION = "1.1h"
ALARM_HARD_LIMIT, ALARM_SOFT_LIMIT, ALARM_ABORT_CYCLE, ALARM_HOMING_RESET = 1, 2, 3, 6
MSG_LOCK = "[MSG:'$H'|'$X' to unlock]"
MAX_SUBSTEP_S = 0.004
RESET_S = 0.03  # a soft reset to its banner (grbl-sim: 29-71 ms)
ALARM_DELAY_S = 0.5  # GRBL report.c report_alarm_message: delay_ms(500) after ALARM:N
DWELL_STEP_S = 0.05  # GRBL config.h DWELL_TIME_STEP [ms] / 1000
Z_PEN_START_MM = 5.0  # a Z pen powers up this far above the page
__all__ = ["DEFAULT_SETTINGS", "GRBL_DEFAULTS", "PLOTTER_SETTINGS", "GrblMachine", "PenConfig"]


@dataclass(frozen=True)
class PenConfig:
    """The emulated pen: the spindle S at and above which the servo puts it down and the time
    [s] the servo takes to get there; or, with ``contact_z_mm`` set, a Z-axis pen touching at
    and below that height [mm]; the force [N] it draws with."""

    contact_s: float = 500.0
    settle_s: float = 0.12
    contact_z_mm: float | None = None
    force_n: float = 1.0


class GrblMachine(RealtimeCommands, HomingMixin, stepper.StepperView):
    """A GRBL 1.1h controller with a pen (see the module docstring).

    Args:
        settings: ``$`` settings over :data:`DEFAULT_SETTINGS` (what ``$RST=$`` restores).
        pen: The pen servo.
        canvas: An ink canvas (``touch``/``lift``) under the pen, in physical [mm].
        trace: A list to append (time, x, y, z, touching) samples to (physical [mm]).
        home_distance_mm: Where the limit switches are, from the power-up point [mm] (None:
            the + switches at the far end of the travel, ``$130..$132``).
    """

    def __init__(self, settings: dict[int, float] | None = None, pen: PenConfig | None = None,
                 canvas=None, trace: list | None = None, home_distance_mm: float | None = None):
        self.settings, why = checked_settings(settings)
        if why:
            raise InputError(why, key="settings", value=settings)
        self.factory = dict(self.settings)
        self.pen = pen or PenConfig()
        self.canvas = canvas
        self.trace = trace
        self.outbox: list[str] = []
        self.time = 0.0
        self.position = np.zeros(3)  # machine position now [mm]
        if self.pen.contact_z_mm is not None:
            self.position[2] = self.pen.contact_z_mm + Z_PEN_START_MM
        self.params = np.zeros((8, 3))  # G54-G59, G28, G30 (GRBL keeps them in EEPROM)
        self.startup_lines = ["", ""]
        self.build_info = ""
        self.lines_done = 0
        self.streaming = False  # more lines wait in the receive buffer (set by the driver)
        self.sys_state = "Alarm" if self.settings[22] else "Idle"  # HOMING_INIT_LOCK
        self.pen_down_target = False
        self.pen_change_at = -math.inf
        self.build_planner()
        self._init_switches(home_distance_mm)
        self._reinit()

    # -- state -------------------------------------------------------------------------------

    def build_planner(self) -> None:
        s = self.settings
        self.planner = Planner(accel=[s[120], s[121], s[122]],
                               max_rate=[s[110] / 60.0, s[111] / 60.0, s[112] / 60.0],
                               deviation_mm=s[11])
        feed, rapid, _ = getattr(self, "overrides", (100, 100, 100))
        self.planner.set_overrides(feed, rapid)

    def _reinit(self) -> None:
        """GRBL's main() loop after power-up or an abort: everything but the position, the
        stored data and an alarm is reset; banner; start-up lines unless in alarm."""
        self.planner.clear()
        self.work: deque[tuple] = deque()
        self.gc = ParserState(coord_system=self.params[0].copy(),
                              position=self._quantised())
        self.counters = ReportCounters()
        self._reset_overrides()
        self.spindle_mode, self.spindle_rpm, self.flood = 5, 0.0, False
        self.programmed: tuple[int, float] = (5, 0.0)  # the spindle as last programmed
        self._pen_command(False)
        self.dwell_until = self.cycle_stop_at = self.hold_from = -math.inf
        self.motion_t0 = 0.0  # when the current cycle started [s]
        self.hold = self.jog_cancel = self.frozen = self.ok_after_reset = False
        self.pending_alarm = 0
        self.spindle_stopped = False
        self._pen_before_stop = False
        self.outbox += ["", BANNER]
        if self.settings[21] and any(self.switches()):  # GRBL's CHECK_LIMITS_AT_INIT
            self.sys_state = "Alarm"
            self.outbox.append("[MSG:Check Limits]")
        if self.sys_state in ("Alarm", "Sleep"):
            self.sys_state = "Alarm"
            self.outbox.append(MSG_LOCK)
        else:
            self.sys_state = "Idle"
            self.run_startup_lines()

    def run_startup_lines(self) -> None:
        """Run the stored ``$N`` lines, each answered ``>line:ok`` (or its error)."""
        for line in self.startup_lines:
            if line:
                self.run_gcode(line, f">{line}:")

    @property
    def alarm(self) -> int:
        """Non-zero while G-code is locked out (GRBL's alarm state)."""
        return 1 if self.sys_state == "Alarm" else 0

    @property
    def homing(self) -> bool:
        return self.sys_state == "Home"

    @property
    def state(self) -> str:
        """GRBL's state name as in a status report."""
        if self.sys_state in ("Alarm", "Check", "Sleep", "Home"):
            return self.sys_state
        if self.sys_state == "Jog":
            return "Jog"
        if self.hold:
            return "Hold:0" if self.cycle_done else "Hold:1"
        return "Idle" if self.cycle_done else "Run"

    @property
    def idle(self) -> bool:
        return self.state in ("Idle", "Check", "Alarm") and not self.work and \
            self.time >= self.dwell_until and self.cycle_done

    @property
    def pen_touching(self) -> bool:
        """Whether the pen is on the page now (servo settled down, or Z at the page)."""
        if self.pen.contact_z_mm is not None:
            return bool(self.physical()[2] <= self.pen.contact_z_mm + 1e-9)
        return self.pen_down_target and self.time >= self.pen_change_at + self.pen.settle_s

    def accepts_line(self) -> bool:
        """Whether the protocol loop may take the next line from the receive buffer."""
        return not self.work and not self.frozen and self.sys_state != "Sleep"

    # -- resets and alarms ------------------------------------------------------------------

    def soft_reset(self) -> None:
        """0x18: stop at once (ALARM:3 when motion was under way, ALARM:6 when homing; GRBL
        then waits 0.5 s), spindle off; after :data:`RESET_S` the banner; position kept."""
        delay = RESET_S
        if self.frozen and self.ok_after_reset:
            self.outbox.append("ok")
        if self.sys_state == "Home":
            self.outbox.append(f"ALARM:{ALARM_HOMING_RESET}")
            self.sys_state, delay = "Alarm", RESET_S + ALARM_DELAY_S
        elif not self.frozen and (self.state in ("Run", "Jog") or
                                  (self.hold and not self.planner.empty)):
            self.outbox.append(f"ALARM:{ALARM_ABORT_CYCLE}")
            self.sys_state, delay = "Alarm", RESET_S + ALARM_DELAY_S
        elif self.sys_state == "Check":
            self.sys_state = "Idle"
        self.planner.clear()
        self.hold = self.frozen = self.ok_after_reset = False
        self.pending_alarm = 0
        self._spindle_output(5, 0.0)
        self.flood = False
        self.work = deque([("delay", delay), ("reinit",)])
        self.pump()

    def raise_alarm(self, code: int) -> None:
        """Stop at once (a hard limit, or a fault on command), pen up, lock out G-code; a
        limit alarm freezes everything but a soft reset (``[MSG:Reset to continue]`` after
        GRBL's 0.5 s alarm delay)."""
        self.planner.clear()
        self.work.clear()
        self.hold = False
        self._spindle_output(5, 0.0)
        self.sys_state = "Alarm"
        self.outbox.append(f"ALARM:{code}")
        if code in (ALARM_HARD_LIMIT, ALARM_SOFT_LIMIT):
            self.work.extend([("delay", ALARM_DELAY_S), ("msg", "[MSG:Reset to continue]")])
            self.frozen = True

    def status_report(self, rx_free: int = 128) -> str | None:
        """The answer to ``?`` (None while frozen after a limit alarm or while a reset is
        under way: GRBL answers nothing then)."""
        if self.frozen or any(item[0] == "reinit" for item in self.work):
            return None  # (a reset under way: GRBL clears the request when it restarts)
        busy = self.state.split(":")[0] in ("Run", "Hold", "Jog", "Home")
        spindle = "" if self.spindle_rpm <= 0 or self.spindle_mode == 5 else \
            ("S" if self.spindle_mode == 3 else "C")
        inputs = StatusInputs(
            state=self.state, mpos=self._quantised(), wco=self.gc.wco(),
            blocks_free=BLOCK_BUFFER - self._blocks_used(), rx_free=rx_free,
            rate_mm_min=self._prep_speed() * 60.0 if busy else 0.0,
            spindle_rpm=self.spindle_rpm, overrides=tuple(self.overrides), spindle=spindle,
            flood=self.flood, pins=self.pins())
        return status_report(inputs, int(self.settings[10]), bool(self.settings[13]),
                             self.counters)

    # -- lines -------------------------------------------------------------------------------

    def take_line(self, raw: str) -> None:
        """Filter and run one received line; its reply comes when its work is done."""
        self.lines_done += 1
        line, overflow = filter_line(raw)
        if overflow:
            self.outbox.append("error:11")
        elif not line:
            self.outbox.append("ok")
        elif line[0] == "$":
            dollar.system_command(self, line)
        elif self.sys_state in ("Alarm", "Jog"):
            self.outbox.append("error:9")
        else:
            self.run_gcode(line, "")

    def run_gcode(self, line: str, prefix: str, jog: bool = False) -> int:
        """Check and queue one G-code line (``$J=`` when ``jog``); its reply is ``prefix``
        and ``ok`` or ``error:N`` once its work is done. Returns the status code."""
        try:
            actions = execute_block(self.gc, parse_block(line, 3 if jog else 0), self.params,
                                    jog=jog, arc_tolerance=self.settings[12])
        except GcodeError as e:
            self.outbox.append(f"{prefix}error:{e.code}")
            return e.code
        if jog:
            target, feed = actions[0][1], actions[0][2]
            if self.settings[20] and homing.outside_space(self.settings, target):
                self.outbox.append(f"{prefix}error:15")
                return 15
            self.gc.position = target.copy()
            self.work.append(("jog", target, feed / 60.0))
        else:
            self.work.extend(actions)
        self.work.append(("reply", prefix + "ok"))
        return 0

    # -- executing ---------------------------------------------------------------------------

    def pump(self) -> None:
        """Do the queued work as far as it can go now."""
        while self.work and (not self.frozen or self.work[0][0] in ("delay", "msg")):
            item = self.work[0]
            kind = item[0]
            if kind == "reinit":
                if self.time < self.dwell_until:
                    return
                self.work.popleft()
                self._reinit()
                continue
            check = self.sys_state == "Check"
            if kind == "line":
                if self.settings[20] and homing.outside_space(self.settings, item[1]):
                    self._soft_limit()
                    return
                if not check:
                    if self._blocks_used() >= BLOCK_BUFFER:
                        return
                    rapid = item[2] is None
                    rate = math.inf if rapid else item[2] / 60.0
                    self.planner.add(self._planned_end(), self._in_steps(item[1]), rate,
                                     self.lines_done, rapid=rapid)
            elif kind == "jog":
                if self._blocks_used() >= BLOCK_BUFFER:
                    return
                if self.planner.add(self._planned_end(), self._in_steps(item[1]), item[2],
                                    self.lines_done, override=False):
                    self.sys_state = "Jog"
            elif kind == "sync":
                if not check and not (self.planner.empty and self.cycle_done):
                    return
            elif kind == "dwell":
                if not check:  # GRBL's delay_sec: whole 50 ms steps, rounded up
                    steps = math.ceil(np.float32(20.0) * np.float32(item[1]))
                    self.dwell_until = self.time + DWELL_STEP_S * steps
            elif kind == "delay":  # (homing's debounce counts from the end of its move)
                base = self.cycle_stop_at if self.sys_state == "Home" else self.time
                self.dwell_until = min(max(base, self.time - item[1]), self.time) + item[1]
            elif kind == "spindle":
                if not check:
                    self.programmed = (item[1], item[2])
                    self._set_spindle(item[1], item[2])
            elif kind == "coolant":
                if not check:
                    self.flood = item[1] == 8
                    self.counters.ovr = 0
            elif kind == "wco":
                self.counters.wco = 0
            elif kind == "pause":  # M0: a feed hold; the line's ok comes after the resume
                if not check:
                    self._start_hold()
                    self.work[0] = ("paused",)
                    return
            elif kind == "paused":
                if self.hold:
                    return
            elif kind == "end":
                self._program_end(check)
            elif kind == "home phase":
                if not self._home_phase(item):
                    return
                if self.sys_state == "Alarm":
                    continue  # (the failed cycle replaced the work)
            elif kind == "homed":
                if not self.planner.empty or self.time < self.dwell_until:
                    return
                self.work.popleft()
                self._homed()
                continue
            elif kind in ("reply", "msg"):
                if self.time < self.dwell_until:
                    return
                self.outbox.append(item[1])
            self.work.popleft()

    def _planned_end(self) -> np.ndarray:
        return self.planner.blocks[-1].target if self.planner.blocks else \
            self._in_steps(self.position)

    def _in_steps(self, target: np.ndarray) -> np.ndarray:
        """A target [mm] as GRBL plans it (``plan_buffer_line``): whole steps, ``lround``
        of the target times ``$100``-``$102``; a block's length and direction are those of
        its step counts."""
        spm = self._steps_per_mm()
        scaled = np.asarray(target, dtype=float) * spm
        return np.sign(scaled) * np.floor(np.abs(scaled) + 0.5) / spm

    def _soft_limit(self) -> None:
        """GRBL's limits_soft_check: hold to a stop, then ALARM:2 and freeze."""
        self.work.clear()
        self.ok_after_reset = True
        if self.planner.empty or self.planner.speed <= 0:
            self.raise_alarm(ALARM_SOFT_LIMIT)
        else:
            self.pending_alarm = ALARM_SOFT_LIMIT
            self._start_hold()

    def next_event_s(self) -> float:
        """Machine time [s] until the next change the protocol waits for: the executing block
        ends, a hold takes effect or stops, the cycle ends, the dwell ends (inf: none)."""
        holding = self.hold and self.time >= self.hold_from
        t = self.planner.time_to_finish_block() if not holding else math.inf
        if holding and self.planner.speed > 0:
            t = self.planner.speed / max(self.planner.blocks[0].accel, 1e-9)
        if self.phase is not None and self.phase["approach"]:
            t = min(t, homing.HOMING_STEP_S)  # (a switch may close any moment)
        for when in (self.dwell_until, self.cycle_stop_at, self.override_at,
                     self.hold_from if self.hold else math.inf):
            if self.time < when < math.inf:
                t = min(t, when - self.time)
        return t

    def _idle_lock_s(self) -> float:
        """GRBL's st_go_idle waits ``$1`` ms (unless 255, or homing) before the cycle ends."""
        lock = self.settings[1]
        return 0.0 if lock == 255 or self.sys_state == "Home" else lock / 1000.0

    def advance(self, dt: float) -> None:
        """Let ``dt`` [s] of machine time pass: move along the plan, ink the canvas."""
        end = self.time + dt
        sampled = self.canvas is not None or self.trace is not None
        while self.time < end - 1e-12:
            step = min(MAX_SUBSTEP_S, end - self.time) if sampled else end - self.time
            if self.hold and self.time < self.hold_from:
                step = min(step, self.hold_from - self.time)
            self._apply_pending_override()
            step = min(step, max(self.override_at - self.time, 1e-9))
            if (self.phase is not None and self.phase["approach"]) or self.settings[21]:
                step = min(step, homing.HOMING_STEP_S)  # (watching the switches)
            holding = self.hold and self.time >= self.hold_from - 1e-12
            if not self.planner.empty and not self.frozen and \
                    not (holding and self.planner.speed <= 0):
                if self.cycle_stop_at < math.inf:  # a cycle starts: the first step comes
                    delay = 0.0 if self.streaming else stepper.START_S  # (see .stepper)
                    self.motion_t0 = self.time + delay
                self.cycle_stop_at = math.inf
                if self.time < self.motion_t0:
                    step = min(step, self.motion_t0 - self.time)
                    self.time += step
                    continue
                moved, _ = self.planner.advance(step, hold=holding)
                pos = self.planner.position()
                self.position = pos if pos is not None else self.planner.last_target.copy()
                self._lock_switches()
                if self.settings[21] and self.sys_state != "Home" and any(self.switches()):
                    self.raise_alarm(ALARM_HARD_LIMIT)  # a switch closed while moving
                if self.planner.empty or (holding and self.planner.speed <= 0):
                    self.cycle_stop_at = self.time + moved + self._idle_lock_s()
                    if holding and not self.planner.empty:  # (the last step comes early)
                        self.cycle_stop_at -= stepper.hold_tail_s(
                            self.planner.blocks[0], self._steps_per_mm(), self.hold_from,
                            self.time + moved)
            self.time += step
            self._ink()
            self._after_motion()
            if self.planner.empty and self.time >= max(self.dwell_until, self.cycle_stop_at) \
                    and not self.work:
                self.time = end  # nothing moves: jump to the end (no samples to take)
                self._ink()

    @property
    def cycle_done(self) -> bool:
        """Whether the motion has stopped and GRBL's cycle has ended (after ``$1``)."""
        stopped = self.planner.empty or (self.hold and self.planner.speed <= 0
                                         and self.time >= self.hold_from)
        return stopped and self.time >= self.cycle_stop_at

    def _after_motion(self) -> None:
        """A hold that has stopped: raise a pending soft-limit alarm, end a cancelled jog;
        a jog whose motion is done: back to Idle."""
        if not self.cycle_done:
            return
        if self.hold and self.pending_alarm:
            code, self.pending_alarm = self.pending_alarm, 0
            self.raise_alarm(code)
        elif self.jog_cancel:  # GRBL flushes the jog and syncs to the step counters
            self.position = self._quantised()
            self.planner.clear()
            self.work.clear()
            self.hold = self.jog_cancel = False
            self.sys_state = "Idle"
            self.gc.position = self.position.copy()
        elif self.sys_state == "Jog" and self.planner.empty and not self.hold:
            self.sys_state = "Idle"

    def _ink(self) -> None:
        where = self.physical()
        if self.trace is not None:
            self.trace.append((self.time, *where, self.pen_touching))
        if self.canvas is None:
            return
        if self.pen_touching:
            self.canvas.touch(where[:2], self.pen.force_n, self.time)
        elif self.canvas.in_contact:
            self.canvas.lift()
