"""The emulated GRBL 1.1 machine: settings, parser state, the planner, the pen and the clock.

No port here: :class:`GrblMachine` takes lines and real-time bytes and produces replies, and
advances in machine time when told (:meth:`GrblMachine.advance`). The pseudo-terminal server
(:mod:`inkarm.hardware.plotter.emulator`) drives it against the wall clock; the time estimate
(:mod:`inkarm.hardware.plotter.timing`) drives it event by event, so both share one planner.

What GRBL does and this machine does too: a line's modal state is applied when it is parsed,
its motion is queued in the planner (the line waits while the planner is full); M3/M4/M5 and G4
wait until the planner is empty (GRBL synchronises the buffer for the spindle and dwells), G4
then waits P seconds before ``ok``; a target outside ``[0, $130..$132]`` with soft limits on
(``$20=1``) holds the motion to a stop and raises ALARM:2; an alarm locks out G-code
(``error:9``) until ``$X`` or ``$H``. The machine's space is positive, its origin at the page's
lower-left corner (GRBL's ``HOMING_FORCE_SET_ORIGIN``).

The pen is an RC servo on the spindle PWM: ``M3 S>=pen_contact_s`` puts it down, ``M5`` (or a
lower S) lifts it; the servo needs ``pen_settle_s`` to get there, and the pen touches the page
only once down. With a Z-axis pen, the pen touches at ``Z <= pen_contact_z_mm``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError
from inkarm.hardware.plotter.gcode_parser import MAX_LINE, GcodeError, normalise, parse_block
from inkarm.hardware.plotter.planner import BLOCK_BUFFER, Planner

VERSION = "1.1h"
BANNER = f"Grbl {VERSION} ['$' for help]"
DEFAULT_SETTINGS = {
    0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 1, 11: 0.010, 12: 0.002, 13: 0,
    20: 1, 21: 0, 22: 0, 23: 0, 24: 25.0, 25: 3000.0, 26: 250, 27: 1.0, 30: 1000, 31: 0,
    32: 0, 100: 80.0, 101: 80.0, 102: 400.0, 110: 12000.0, 111: 12000.0, 112: 3000.0,
    120: 1500.0, 121: 1500.0, 122: 500.0, 130: 300.0, 131: 300.0, 132: 40.0,
}
ALARM_HARD_LIMIT, ALARM_SOFT_LIMIT, ALARM_ABORT_CYCLE = 1, 2, 3
POSITIVE_SETTINGS = (11, 12, 110, 111, 112, 120, 121, 122)  # rates, accelerations, tolerances


def setting_error(key: int, value: float) -> str:
    """Why ``$key=value`` is refused (GRBL's error:3 unknown, error:4 negative; a rate,
    acceleration or tolerance of 0 is refused too, as it would stall the planner); empty when
    it is fine."""
    if key not in DEFAULT_SETTINGS:
        return "error:3"
    if not math.isfinite(value) or value < 0 or (key in POSITIVE_SETTINGS and value == 0):
        return "error:4"
    return ""
MAX_SUBSTEP_S = 0.004
Z_PEN_START_MM = 5.0  # machine time between pen samples on the canvas


@dataclass(frozen=True)
class PenConfig:
    """The emulated pen: the spindle S at and above which the servo puts it down and the time
    [s] the servo takes to get there; or, with ``contact_z_mm`` set, a Z-axis pen touching at
    and below that height [mm]; the force [N] it draws with."""

    contact_s: float = 500.0
    settle_s: float = 0.12
    contact_z_mm: float | None = None
    force_n: float = 1.0


class GrblMachine:
    """A GRBL 1.1 controller with a pen (see the module docstring).

    Args:
        settings: ``$`` settings overriding :data:`DEFAULT_SETTINGS`.
        pen: The pen servo.
        canvas: An ink canvas (``touch``/``lift``) under the pen, page [mm] = machine [mm].
    """

    def __init__(self, settings: dict[int, float] | None = None, pen: PenConfig | None = None,
                 canvas=None, trace: list | None = None):
        self.settings = dict(DEFAULT_SETTINGS)
        for key, value in (settings or {}).items():
            if setting_error(key, value):
                raise InputError(f"${key}={value}: expected a GRBL 1.1 setting with a value "
                                 ">= 0 (> 0 for rates, accelerations and tolerances)",
                                 key="settings", value=(key, value))
            self.settings[key] = value
        self.pen = pen or PenConfig()
        self.canvas = canvas
        self.trace = trace  # (time, x, y, z, touching) per sample, when a list is given
        self.outbox: list[str] = []
        self.time = 0.0
        self.position = np.zeros(3)  # machine position now [mm]
        self.planned = np.zeros(3)  # where the queued motion ends (GRBL's gc_state.position)
        self.offset = np.zeros(3)  # G92 offset [mm]
        self.lines_done = 0
        if self.pen.contact_z_mm is not None:  # a Z pen powers up lifted above the page
            self.position[2] = self.pen.contact_z_mm + Z_PEN_START_MM
        self._build_planner()
        self._power_up()

    # -- state -------------------------------------------------------------------------------

    def _build_planner(self) -> None:
        s = self.settings
        self.planner = Planner(
            accel=[s[120], s[121], s[122]],
            max_rate=[s[110] / 60.0, s[111] / 60.0, s[112] / 60.0],
            deviation_mm=s[11])

    def _power_up(self) -> None:
        self.planner.clear()
        self.work: deque[tuple] = deque()
        self.modal = {"motion": 0, "units": 21, "distance": 90, "plane": 17, "feed mode": 94,
                      "coordinate system": 54, "spindle": 5}
        self.feed = 0.0  # [mm/s]; 0 until an F word
        self.spindle_s = 0.0
        self.spindle_on = False
        self.dwell_until = -math.inf
        self.hold = False
        self.alarm = 0 if not self.settings[22] else -1  # -1: locked until $H or $X
        self.pending_alarm = 0
        self.spindle_stopped = False  # by the spindle-stop override, in a hold
        self._pen_before_stop = False
        self.resume_at: float | None = None  # when a resumed hold starts moving [s]
        self.homing = False
        self.pen_down_target = False
        self.pen_change_at = -math.inf
        self.planned = self.position.copy()
        self.outbox.append("")
        self.outbox.append(BANNER)
        if self.alarm:
            self.outbox.append("[MSG:'$H'|'$X' to unlock]")

    @property
    def state(self) -> str:
        """GRBL's state name as in a status report."""
        if self.alarm:
            return "Alarm"
        if self.homing:
            return "Home"
        if self.hold:
            return "Hold:0" if self.planner.speed <= 0 else "Hold:1"
        if not self.planner.empty or self.time < self.dwell_until:
            return "Run"
        return "Idle"

    @property
    def idle(self) -> bool:
        return self.state == "Idle" and not self.work

    @property
    def pen_touching(self) -> bool:
        """Whether the pen is on the page now (servo settled down, or Z at the page)."""
        if self.pen.contact_z_mm is not None:
            return bool(self.position[2] <= self.pen.contact_z_mm + 1e-9)
        return self.pen_down_target and self.time >= self.pen_change_at + self.pen.settle_s

    def accepts_line(self) -> bool:
        """Whether the protocol loop may take the next line from the receive buffer."""
        return not self.work

    # -- real-time commands -------------------------------------------------------------------

    def feed_hold(self) -> None:
        if not self.alarm and (not self.planner.empty or self.homing):
            self.hold = True

    def cycle_start(self) -> None:
        """``~``: resume from a hold; a pen lifted by the spindle-stop override goes back
        down first and the motion waits for the servo to settle."""
        if not self.hold:
            return
        if self.spindle_stopped:
            self.spindle_stopped = False
            self._pen_command(self._pen_before_stop)
            self.resume_at = self.time + self.pen.settle_s
            return
        self.hold = False  # (released while braking: re-plan from the current speed)
        self.planner.recalculate()

    def toggle_spindle_stop(self) -> None:
        """0x9E, GRBL 1.1's spindle-stop override: only in a finished hold (Hold:0), it stops
        the spindle, which lifts a servo pen; ``~`` restores it before the motion resumes."""
        if not (self.hold and self.planner.speed <= 0 and self.resume_at is None):
            return
        if not self.spindle_stopped:
            self._pen_before_stop = self.pen_down_target
            self.spindle_stopped = True
            self._pen_command(False)
        else:
            self.spindle_stopped = False
            self._pen_command(self._pen_before_stop)

    def soft_reset(self) -> None:
        """0x18: kill motion (ALARM:3 when it was moving), spindle off, flush (the power-up
        state clears the planner, the work queue, a hold and homing), banner."""
        moving = not self.planner.empty and self.planner.speed > 0
        self._pen_command(False)
        if moving:
            self.outbox.append(f"ALARM:{ALARM_ABORT_CYCLE}")
        self._power_up()
        if moving:
            self.alarm = ALARM_ABORT_CYCLE

    def raise_alarm(self, code: int) -> None:
        """Stop at once (a hard limit, or a fault on command), pen up, lock out G-code."""
        self.planner.clear()
        self.work.clear()
        self.hold = False
        self.homing = False
        self._pen_command(False)
        self.alarm = code
        self.planned = self.position.copy()
        self.outbox.append(f"ALARM:{code}")

    def status_report(self) -> str:
        mask = int(self.settings[10])
        x, y, z = self.position / (25.4 if self.settings[13] else 1.0)  # $13: report inches
        fields = [self.state, f"MPos:{x:.3f},{y:.3f},{z:.3f}"]
        if mask & 2:
            fields.append(f"Bf:{BLOCK_BUFFER - len(self.planner.blocks)},128")
        fields.append(f"FS:{self.planner.speed * 60:.0f},{self.spindle_s:.0f}")
        if np.any(self.offset):
            fields.append("WCO:" + ",".join(f"{v:.3f}" for v in self.offset))
        if self.spindle_on:
            fields.append("A:S")
        return "<" + "|".join(fields) + ">"

    # -- lines -------------------------------------------------------------------------------

    def take_line(self, raw: str) -> None:
        """Parse one received line and queue its work (ending with its reply)."""
        self.lines_done += 1
        if len(raw) > MAX_LINE:
            self.outbox.append("error:11")
            return
        line = normalise(raw)
        if not line:
            self.outbox.append("ok")
            return
        if line.startswith("$"):
            self._system(line)
            return
        if self.alarm:
            self.outbox.append("error:9")
            return
        try:
            self._gcode(parse_block(line))
        except GcodeError as e:
            self.outbox.append(f"error:{e.code}")

    def _system(self, line: str) -> None:
        if line == "$$":
            self.outbox.extend(f"${k}={_fmt(k, v)}" for k, v in sorted(self.settings.items()))
        elif line == "$I":
            self.outbox.extend([f"[VER:{VERSION}.20190825:]", "[OPT:V,15,128]"])
        elif line == "$G":
            m = self.modal
            self.outbox.append(f"[GC:G{m['motion']} G{m['coordinate system']} G{m['plane']} "
                               f"G{m['units']} G{m['distance']} G{m['feed mode']} "
                               f"M{m['spindle']} M9 T0 F{self.feed * 60:.0f} "
                               f"S{self.spindle_s:.0f}]")
        elif line == "$X":
            if self.alarm:
                self.outbox.append("[MSG:Caution: Unlocked]")
            self.alarm = 0
        elif line == "$H":
            if not self.settings[22]:
                self.outbox.append("error:5")
                return
            self.alarm = 0
            self.work.extend([("sync",), ("home",), ("reply", "ok")])
            return
        elif "=" in line and line[1:].split("=")[0].isdigit():
            key, _, value = line[1:].partition("=")
            try:
                number = float(value)
            except ValueError:
                self.outbox.append("error:2")
                return
            error = setting_error(int(key), number)
            if error:
                self.outbox.append(error)
                return
            if not self.planner.empty:
                self.outbox.append("error:8")  # GRBL: $ commands only when idle
                return
            self.settings[int(key)] = number
            self._build_planner()
        else:
            self.outbox.append("error:3")
            return
        self.outbox.append("ok")

    def _gcode(self, block) -> None:
        modal, values = self.modal, block.values
        motion = block.g.get("motion")
        non_modal = block.g.get("non-modal")
        axes = block.axes
        if motion is None and axes and non_modal is None:
            motion = modal["motion"]
        if motion is not None and not axes and motion in (0, 1):
            raise GcodeError(26, "no axis words")
        if motion in (2, 3) and not ({"I", "J"} & set(values)):
            raise GcodeError(26, "an arc needs I or J (R is not supported)")
        if "F" in values and values["F"] <= 0 and motion != 0:
            raise GcodeError(22, "feed rate must be > 0")
        units = block.g.get("units", modal["units"])
        scale = 25.4 if units == 20 else 1.0
        if motion in (1, 2, 3) and "F" not in values and self.feed <= 0:
            raise GcodeError(22, "undefined feed rate")
        if non_modal == 4 and "P" not in values:
            raise GcodeError(26, "G4 needs P")
        # The block is valid: apply it in GRBL's order of execution.
        for group in ("units", "distance", "plane", "feed mode", "coordinate system"):
            if group in block.g:
                modal[group] = block.g[group]
        if "F" in values:
            self.feed = values["F"] * scale / 60.0
        if "S" in values:
            self.spindle_s = values["S"]
        if "spindle" in block.m or ("S" in values and self.spindle_on):
            on = block.m.get("spindle", modal["spindle"]) in (3, 4)
            modal["spindle"] = block.m.get("spindle", modal["spindle"])
            self.work.extend([("sync",), ("spindle", on, self.spindle_s)])
        if non_modal == 4:
            self.work.extend([("sync",), ("dwell", max(values["P"], 0.0))])
        if non_modal == 92:
            for i, a in enumerate("XYZ"):
                if a in axes:
                    self.offset[i] = self.planned[i] - axes[a] * scale
            axes = {}
            motion = None
        if motion is not None:
            modal["motion"] = motion
        if motion is not None and axes:
            target = self.planned.copy()
            for i, a in enumerate("XYZ"):
                if a in axes:
                    value = axes[a] * scale
                    target[i] = (target[i] + value if modal["distance"] == 91
                                 else value + self.offset[i])
            if motion in (0, 1):
                self._queue_line(target, motion)
            else:
                self._queue_arc(target, values, scale, clockwise=motion == 2)
        if block.m.get("stopping") in (2, 30):
            self.work.extend([("sync",), ("spindle", False, self.spindle_s)])
            modal["spindle"] = 5
        self.work.append(("reply", "ok"))

    def _queue_line(self, target: np.ndarray, motion: int) -> None:
        if self.settings[20]:
            travel = np.array([self.settings[130], self.settings[131], self.settings[132]])
            if np.any(target < -1e-6) or np.any(target > travel + 1e-6):
                self.work.append(("soft limit",))
                return
        feed = math.inf if motion == 0 else self.feed
        self.work.append(("move", target.copy(), feed))
        self.planned = target

    def _queue_arc(self, target: np.ndarray, values: dict, scale: float,
                   clockwise: bool) -> None:
        """GRBL's arc: chords within ``$12`` of the circle (mc_arc's segment count)."""
        start = self.planned.copy()
        centre = start[:2] + np.array([values.get("I", 0.0), values.get("J", 0.0)]) * scale
        r0, r1 = start[:2] - centre, target[:2] - centre
        radius = float(np.hypot(*r0))
        if abs(radius - np.hypot(*r1)) > max(0.005, 0.001 * radius) or radius <= 0:
            raise GcodeError(33, "the arc's end is not on its circle")
        angle = math.atan2(r0[0] * r1[1] - r0[1] * r1[0], float(np.dot(r0, r1)))
        if clockwise and angle >= -1e-9:
            angle -= 2 * math.pi
        elif not clockwise and angle <= 1e-9:
            angle += 2 * math.pi
        tol = self.settings[12]
        n = max(1, int(abs(0.5 * angle * radius) / math.sqrt(tol * (2 * radius - tol))))
        for k in range(1, n + 1):
            if k == n:
                point = target.copy()
            else:
                a = angle * k / n
                c, s = math.cos(a), math.sin(a)
                point = start.copy()
                point[:2] = centre + np.array([c * r0[0] - s * r0[1], s * r0[0] + c * r0[1]])
                point[2] = start[2] + (target[2] - start[2]) * k / n
            self._queue_line(point, 1)

    # -- executing ---------------------------------------------------------------------------

    def pump(self) -> None:
        """Do the queued work as far as it can go now."""
        while self.work and not self.alarm:
            item = self.work[0]
            kind = item[0]
            if kind == "move":
                if self.planner.full:
                    return
                start = self.planner.blocks[-1].target if self.planner.blocks else self.position
                self.planner.add(start, item[1], item[2], self.lines_done)
            elif kind == "sync":
                if not self.planner.empty or self.hold:
                    return
            elif kind == "dwell":
                self.dwell_until = self.time + item[1]
            elif kind == "spindle":
                self.spindle_on = item[1]
                self._pen_command(item[1] and item[2] >= self.pen.contact_s)
            elif kind == "home":
                self.homing = True
                self.planner.add(self.position, np.zeros(3), self.settings[25] / 60.0)
                self.planned = np.zeros(3)
            elif kind == "reply":
                if self.time < self.dwell_until or (self.homing and not self.planner.empty):
                    return
                self.homing = False
                self.outbox.append(item[1])
            elif kind == "soft limit":
                self.work.clear()
                self.pending_alarm = ALARM_SOFT_LIMIT
                self.feed_hold()
                if self.planner.empty:
                    self.raise_alarm(ALARM_SOFT_LIMIT)
                return
            self.work.popleft()

    def _pen_command(self, down: bool) -> None:
        if down != self.pen_down_target:
            self.pen_down_target = down
            self.pen_change_at = self.time

    def next_event_s(self) -> float:
        """Machine time [s] until the next change the protocol waits for: the executing block
        ends or the dwell ends (inf when nothing is under way)."""
        t = self.planner.time_to_finish_block() if not self.hold else math.inf
        if self.time < self.dwell_until:
            t = min(t, self.dwell_until - self.time)
        return t

    def advance(self, dt: float) -> None:
        """Let ``dt`` [s] of machine time pass: move along the plan, ink the canvas."""
        end = self.time + dt
        sampled = self.canvas is not None or self.trace is not None
        while self.time < end - 1e-12:
            step = min(MAX_SUBSTEP_S, end - self.time) if sampled else end - self.time
            if not self.planner.empty and not self.alarm:
                self.planner.advance(step, hold=self.hold)
                pos = self.planner.position()
                self.position = pos if pos is not None else self.planner.last_target.copy()
            self.time += step
            if self.resume_at is not None and self.time >= self.resume_at:
                self.resume_at = None
                self.hold = False
                self.planner.recalculate()
            self._ink()
            if self.hold and self.planner.speed <= 0 and self.pending_alarm:
                code, self.pending_alarm = self.pending_alarm, 0
                self.raise_alarm(code)
            if self.planner.empty and self.time >= self.dwell_until and not self.work:
                self.time = end  # nothing moves: jump to the end (no samples to take)
                self._ink()

    def _ink(self) -> None:
        if self.trace is not None:
            self.trace.append((self.time, *self.position, self.pen_touching))
        if self.canvas is None:
            return
        if self.pen_touching:
            self.canvas.touch(self.position[:2], self.pen.force_n, self.time)
        elif self.canvas.in_contact:
            self.canvas.lift()


def _fmt(key: int, value: float) -> str:
    """A setting as ``$$`` prints it: whole-number settings as integers, others to 3 places."""
    return str(int(value)) if isinstance(DEFAULT_SETTINGS.get(key), int) else f"{value:.3f}"
