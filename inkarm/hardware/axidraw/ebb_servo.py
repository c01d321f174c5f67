"""The pen-lift RC servo of an AxiDraw on the EiBotBoard: the pulse width the firmware outputs,
its slew, the servo's power and the height of the pen.

Firmware facts (EBB firmware 3.0.3, ``RCServo2.c`` and the 1 ms timer in ``UBW.c``; command
reference ``SC``, ``SP``, ``SR``, ``S2`` and FAQ 1):

* Pulse widths are in units of 1/12 MHz (83.3 ns). At boot the pen-up position (``SC,4``,
  "servo_min") is 22565, pen-down (``SC,5``, "servo_max") 15302, both rates (``SC,11``/``12``)
  400; the servo starts at the up position with its power off.
* 8 channels of 3 ms (``SC,8``, ``SC,9``): each channel's pulse repeats every 24 ms, and at each
  repeat the pulse moves by the rate towards its target (rate 0: at once); a channel's first
  pulse starts at its target.
* A servo move (``SP``, ``TP``) switches the servo power on and restarts the power timeout
  (``SR``, 60 s at boot; 0 keeps it on); when it runs out, the power goes off.

AxiDraw facts (``axidraw_conf.py`` of evil-mad/axidraw): the pen height in percent of the
lift's range is linear in the pulse width, 0 % at 9855 and 100 % at 27831 units; the servo
itself takes about 2.69 ms per percent of travel (``servo_move_slope``).

Emulator model (not in either source): the horn follows the pulse at that speed while powered
and stays where it is while unpowered; the pen tip touches the paper at or below
``contact_pct`` (40 % by default: the pen set in its holder so that it touches a little above
the AxiDraw software's default pen-down height, 30 %, and well below its pen-up height, 60 %).
"""

from __future__ import annotations

import math

SERVO_0_PCT = 9855.0  # pulse width at 0 % pen height (axidraw_conf servo_min)
SERVO_100_PCT = 27831.0  # pulse width at 100 % (axidraw_conf servo_max)
UNITS_PER_PCT = (SERVO_100_PCT - SERVO_0_PCT) / 100.0
SERVO_S_PER_PCT = 2.69e-3  # axidraw_conf servo_move_slope [s per %]
SLEW_UNITS_PER_S = UNITS_PER_PCT / SERVO_S_PER_PCT
BOOT_UP, BOOT_DOWN, BOOT_RATE = 22565, 15302, 400
POWER_TIMEOUT_MS = 60_000
PEN_RPN = 4  # the AxiDraw's pen servo is plugged into B1 (RP4; SP's default pin 1 + 3)


def height_pct(pulse: float) -> float:
    """Pen height [%] of the lift's range at a pulse width (83.3 ns units)."""
    return (pulse - SERVO_0_PCT) / UNITS_PER_PCT


class PenServo:
    """The pen servo's channel and horn; :meth:`advance` moves them in machine time [s]."""

    def __init__(self, contact_pct: float = 40.0) -> None:
        self.contact_pct = float(contact_pct)
        self.up = BOOT_UP  # SC,4 servo_min
        self.down = BOOT_DOWN  # SC,5 servo_max
        self.rate_up = BOOT_RATE
        self.rate_down = BOOT_RATE
        self.slots = 8
        self.slot_ms = 3
        self.value = float(BOOT_UP)  # the pulse now (RCServo2_Init starts it up at once)
        self.target = float(BOOT_UP)
        self.rate = 0.0
        self.horn = float(BOOT_UP)  # where the physical servo is
        self.powered = False
        self.timeout_ms = POWER_TIMEOUT_MS
        self.off_at = math.inf  # machine time the power goes off
        self.time = 0.0
        self.enabled = True  # the channel outputs pulses (S2,0,4 / SC,1,0 stop it)

    @property
    def cycle_s(self) -> float:
        return self.slots * self.slot_ms / 1000.0

    def power_on(self, now: float) -> None:
        """A servo command: power on and restart the timeout."""
        self.powered = True
        self.off_at = now + self.timeout_ms / 1000.0 if self.timeout_ms else math.inf

    def set_power(self, on: bool, now: float) -> None:
        """``SR``'s immediate state: power only (the timeout is not restarted)."""
        self.powered = on

    def move_to(self, target: float, rate: float) -> None:
        """A servo move starts (the ISR sets target and rate)."""
        self.target = float(target)
        self.rate = float(rate)
        self.enabled = True

    def advance(self, t: float) -> None:
        """Let machine time run to ``t`` [s]: pulse updates every cycle, horn slew, timeout."""
        while self.time < t - 1e-12:
            cycle = self.cycle_s
            next_update = (math.floor(self.time / cycle + 1e-9) + 1) * cycle
            end = min(t, next_update, self.off_at if self.off_at > self.time else t)
            self._slew(end - self.time)
            self.time = end
            if self.time >= self.off_at - 1e-12:
                self.powered = False
                self.off_at = math.inf
            if abs(self.time - next_update) < 1e-12:
                self._update_pulse()

    def _update_pulse(self) -> None:
        if not self.enabled or self.value == self.target:
            return
        if self.rate == 0:
            self.value = self.target
            return
        diff = self.target - self.value
        self.value = self.target if abs(diff) <= self.rate else self.value + math.copysign(
            self.rate, diff)

    def _slew(self, dt: float) -> None:
        if not self.powered or dt <= 0 or not self.enabled:
            return
        room = self.value - self.horn
        step = SLEW_UNITS_PER_S * dt
        self.horn = self.value if abs(room) <= step else self.horn + math.copysign(step, room)

    @property
    def height_pct(self) -> float:
        """The pen's height now [% of the lift's range]."""
        return height_pct(self.horn)

    @property
    def touching(self) -> bool:
        return self.height_pct <= self.contact_pct + 1e-9

    def next_change_s(self) -> float:
        """Machine time after which nothing changes unless commanded (inf when at rest)."""
        if self.value != self.target and self.enabled:
            return self.time
        if self.powered and self.horn != self.value:
            return self.time
        return self.off_at


__all__ = ["BOOT_DOWN", "BOOT_RATE", "BOOT_UP", "PEN_RPN", "PenServo", "height_pct"]
