"""The emulated AxiDraw: an EiBotBoard (firmware 3.0.3) driving two steppers in the AxiDraw's
H-bot and a pen-lift servo over a sheet of paper (an ink canvas).

No port here: :class:`EbbMachine` takes command lines and produces the firmware's replies
(:mod:`.ebb_commands`), and advances in machine time when told (:meth:`EbbMachine.advance`);
:mod:`.emulator` serves it on a pseudo-terminal against the wall clock.

Mechanics (``geometry.py``; AxiDraw travel from ``axidraw_conf.py`` of evil-mad/axidraw):

* Steps move the motors only while their driver is enabled; a step is ``16 / microsteps``
  sixteenth-steps (``EM``'s resolution), and the carriage moves by
  :func:`inkarm.hardware.axidraw.geometry.carriage_mm` of the two motors' sixteenth-steps.
* The machine frame has its origin where the carriage was at power-up (the home corner, upper
  left as seen from the front), x to the right, y towards the user. The carriage cannot leave
  ``[0, travel]``: driven into the frame, it stops there and the motors skip (the lost steps
  stay lost, as on the real machine; :attr:`EbbMachine.frame_hits` counts such ticks).
* The page: the sheet's upper-left corner lies at ``sheet_origin_mm`` in the machine frame
  ((0, 0) by default: the sheet against the home corner, as the AxiDraw guide places it). The
  canvas's page frame has y up from the sheet's lower-left corner, so a carriage at machine
  (x, y) is at page ``(x - x0, height - (y - y0))``.
* The pen (:mod:`.ebb_servo`) inks the canvas while its height is at or below the contact
  height: the carriage is sampled every 2 ms of motion (and every 2 ms while the servo moves),
  each sample a ``Canvas.touch`` at 1 N; a lift ends the stroke. Samples are skipped while the
  pen is up and still (pen-up travel costs one sample per move).
"""

from __future__ import annotations

import inspect

import numpy as np

from inkarm.errors import InputError
from inkarm.hardware.axidraw import ebb_commands
from inkarm.hardware.axidraw.ebb_motion import TICK_S, MotionQueue
from inkarm.hardware.axidraw.ebb_parse import Line, strip_checksum
from inkarm.hardware.axidraw.ebb_servo import PEN_RPN, PenServo
from inkarm.hardware.axidraw.geometry import carriage_mm

INCH = 25.4
# (x, y) travel [mm] per model: axidraw_conf x/y_travel_default and _V3A3 (inches)
TRAVEL_MM = {"V3": (11.81 * INCH, 8.58 * INCH), "V3A3": (16.93 * INCH, 11.69 * INCH)}
SAMPLE_TICKS = 50  # ink sample every 2 ms of motion
PEN_FORCE_N = 1.0  # the contact force given to the ink model
MICROSTEPS = {1: 16, 2: 8, 3: 4, 4: 2, 5: 1}  # EM's Enable1 -> microsteps per full step


def travel_mm(model: str) -> tuple[float, float]:
    """(x, y) travel [mm] of an AxiDraw model ("V3" or "V3A3")."""
    try:
        return TRAVEL_MM[model]
    except KeyError:
        raise InputError(f"expected an AxiDraw model, one of {', '.join(TRAVEL_MM)}, got "
                         f"{model!r}", key="model", value=model, choices=tuple(TRAVEL_MM)) from None


class EbbMachine:
    """The EBB's state, the carriage, the pen and the clock (see the module docstring).

    Args:
        model: "V3" (travel 300 x 218 mm) or "V3A3" (430 x 297 mm).
        canvas: An ink canvas the pen draws on, in page [mm] (None: no ink).
        sheet_origin_mm: Machine (x, y) [mm] of the sheet's upper-left corner.
        contact_pct: Pen height [%] at and below which the pen touches the paper.
    """

    def __init__(self, model: str = "V3", canvas=None, sheet_origin_mm=(0.0, 0.0),
                 contact_pct: float = 40.0) -> None:
        self.model = model
        self.travel = travel_mm(model)
        self.canvas = canvas
        self.sheet_origin = (float(sheet_origin_mm[0]), float(sheet_origin_mm[1]))
        self.contact_pct = contact_pct
        self.carriage = np.zeros(2)  # machine frame [mm]
        self.frame_hits = 0
        self.outbox: list[str] = []
        self.trace: list | None = None
        self.tag = ""  # ST's nickname (flash: survives R)
        self._reset_state()

    def _reset_state(self) -> None:
        """Power-on state of the firmware (``R`` re-runs it; the carriage stays put)."""
        self.queue = MotionQueue(self)
        self.servo = PenServo(self.contact_pct)
        self.servo.time = getattr(self, "time", 0.0)
        self.time = self.servo.time
        self.queue.tick = round(self.time / TICK_S)
        self.enabled = [False, False]
        self.microsteps = 16
        self.pen_up = True  # PenState (QP, QG bit 4)
        self.pen_rpn = PEN_RPN  # g_servo2_RPn
        self.use_servo = True
        self.future = False
        self.ack = True
        self.limit_checks = True
        self.auto_enable = True
        self.checksums = False
        self.button = False
        self.node_count = 0
        self.variables = [0] * 32
        self.user = {}  # other CU parameters, stored only
        self._motor16 = np.zeros(2)  # motor positions [1/16 steps]
        self._offset = self.carriage.copy()  # carriage minus geometry (lost steps move it)
        self._pending = None  # the command waiting in the parser, a generator
        self._waiting = None
        self._line: Line | None = None

    # -- commands --------------------------------------------------------------------------------

    def accepts_line(self) -> bool:
        """Whether the parser is free (not spinning on a full FIFO)."""
        return self._pending is None

    def take_line(self, text: str, reply: bool = True) -> None:
        """Parse and run one command (``text`` without its terminator); the reply goes to
        :attr:`outbox` now or, for a command waiting for FIFO room, once it is queued."""
        if self.checksums:
            text, refusal = strip_checksum(text, self.future)
            if refusal:
                if reply:
                    self.outbox.append(refusal)
                return
        line = Line(text, future=self.future, ack=self.ack)
        result = ebb_commands.dispatch(self, line)
        if inspect.isgenerator(result):
            self._pending, self._line, self._reply = result, line, reply
            self._waiting = None
            self.pump()
            return
        self._done(line, reply)

    def pump(self) -> None:
        """Resume the waiting command if what it waits for has come."""
        while self._pending is not None:
            if self._waiting is not None and not self._waiting():
                return
            try:
                self._waiting = next(self._pending)
            except StopIteration:
                line, reply = self._line, self._reply
                self._pending = self._waiting = self._line = None
                self._done(line, reply)

    def _done(self, line: Line, reply: bool) -> None:
        text = line.finish()
        if reply and text:
            self.outbox.append(text)

    # -- hooks called by the motion queue when an entry executes ---------------------------------

    def on_servo(self, payload, tick: int) -> None:
        """A servo move executes: (position, rate, rpn); the pen state follows (up when the
        position is the pen-up one)."""
        position, rate, rpn = payload
        self._sync_servo(tick * TICK_S)
        self._drive_servo(position, rate, rpn)
        if rpn == self.pen_rpn:
            self.pen_up = position == self.servo.up

    def servo_now(self, position: int, rate: int, rpn: int) -> None:
        """A servo move that skips the FIFO (``SP,2``/``SP,3``): always the pen going up."""
        self._drive_servo(position, rate, rpn)
        if rpn == self.pen_rpn:
            self.pen_up = True

    def _drive_servo(self, position: int, rate: int, rpn: int) -> None:
        if not self.use_servo or rpn != PEN_RPN:
            return  # the AxiDraw's servo is on B1 only
        if position == 0:
            self.servo.enabled = False
            self.servo.value = self.servo.target = 0.0
            return
        if self.servo.value == 0:
            self.servo.value = float(position)
        self.servo.move_to(position, rate)

    def on_enable(self, payload, tick: int) -> None:
        """``EM`` executes: enables and the microstep mode."""
        ea1, ea2 = payload
        self.enabled[0] = ea1 > 0
        if ea1 in MICROSTEPS:
            self.microsteps = MICROSTEPS[ea1]
        self.enabled[1] = ea2 > 0

    def on_engraver(self, payload, tick: int) -> None:
        """``SE`` through the queue: the engraver output is not modelled."""

    # -- time ------------------------------------------------------------------------------------

    def advance(self, dt: float) -> None:
        """Let ``dt`` [s] of machine time pass: run the queue, move the carriage and the pen,
        ink the canvas."""
        end_tick = self.queue.tick + max(0, round(dt / TICK_S))
        for start, used, sampler in self.queue.run(end_tick):
            self._follow(start, used, sampler)
        self._sync_servo(end_tick * TICK_S)
        self.time = end_tick * TICK_S
        self.pump()

    def _follow(self, start: int, used: int, sampler) -> None:
        """Move the carriage along a span of ``used`` ticks; while the pen may touch, ink at a
        sample every :data:`SAMPLE_TICKS`."""
        scale = 16.0 / self.microsteps
        live = np.array(self.enabled, dtype=float) * scale
        quiet = (not self.servo.touching and self.servo.next_change_s() > (start + used) * TICK_S
                 and (self.canvas is None or not self.canvas.in_contact))
        offsets = np.array([used]) if quiet else np.unique(
            np.append(np.arange(SAMPLE_TICKS, used, SAMPLE_TICKS), used))
        motors = self._motor16 + sampler(offsets) * live
        dx, dy = carriage_mm(motors[:, 0], motors[:, 1])
        raw = np.column_stack([dx, dy]) + self._offset
        inside = np.all((raw >= 0.0) & (raw <= self.travel), axis=1)
        for k, offset in enumerate(offsets):
            if inside[k]:
                self.carriage = raw[k].copy()
            else:
                self._place(motors[k])
            self._sync_servo((start + int(offset)) * TICK_S)
            if not inside[k]:
                raw = np.column_stack([dx, dy]) + self._offset
                inside = np.all((raw >= 0.0) & (raw <= self.travel), axis=1)
        self._motor16 = motors[-1]

    def _place(self, motors: np.ndarray) -> None:
        """The carriage for motor positions ``motors`` [1/16 steps], held inside the frame (a
        carriage pushed against it loses the steps: the offset moves)."""
        dx, dy = carriage_mm(motors[0], motors[1])
        raw = np.array([float(dx), float(dy)]) + self._offset
        held = np.clip(raw, 0.0, self.travel)
        if not np.array_equal(raw, held):
            self.frame_hits += 1
            self._offset += held - raw
        self.carriage = held

    def _sync_servo(self, t: float) -> None:
        """Bring the servo to ``t`` [s], inking at the carriage's place in steps small enough to
        catch the pen landing."""
        while self.servo.time < t - 1e-12:
            busy = self.servo.next_change_s() <= self.servo.time
            step_to = min(t, self.servo.time + 0.002) if busy else t
            self.servo.advance(step_to)
            self.time = max(self.time, self.servo.time)
            self._ink()
        self._ink()

    def page_xy(self) -> tuple[float, float]:
        """The carriage in the canvas's page frame [mm] (see the module docstring)."""
        height = self.canvas.size_mm[1] if self.canvas is not None else 0.0
        x0, y0 = self.sheet_origin
        return float(self.carriage[0] - x0), float(height - (self.carriage[1] - y0))

    def _ink(self) -> None:
        touching = self.servo.touching
        if self.trace is not None:
            self.trace.append((self.servo.time, *self.carriage, touching))
        if self.canvas is None:
            return
        if touching:
            self.canvas.touch(self.page_xy(), PEN_FORCE_N, self.servo.time)
        elif self.canvas.in_contact:
            self.canvas.lift()

    # -- what the commands read ------------------------------------------------------------------

    @property
    def idle(self) -> bool:
        """Nothing executing, queued or waiting in the parser."""
        return self.queue.idle and self._pending is None

    def motion_status(self) -> tuple[int, int, int, int]:
        return self.queue.status()

    def position_mm(self) -> tuple[float, float]:
        """The carriage in the machine frame [mm]."""
        return float(self.carriage[0]), float(self.carriage[1])

    def reset(self) -> None:
        """``R``: the firmware's power-on state (the carriage and the pen stay where they are)."""
        horn, time = self.servo.horn, self.time
        motors = self._motor16.copy()
        offset = self._offset.copy()
        self._reset_state()
        self.servo.horn = horn
        self.time = self.servo.time = time
        self._motor16, self._offset = motors, offset


__all__ = ["TRAVEL_MM", "EbbMachine", "travel_mm"]
