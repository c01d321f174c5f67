"""GRBL 1.1h's real-time commands on the emulated machine, and its spindle output (facts from
``serial.c``, ``protocol.c`` ``protocol_exec_rt_system``/``protocol_exec_rt_suspend`` and
``spindle_control.c``; inkarm's own code). A mixin of
:class:`~inkarm.hardware.plotter.machine.GrblMachine`, whose state it uses.

* ``!`` holds: the motion decelerates to Hold:0; when idle the state is Hold:0 at once. In a
  jog, ``!`` and 0x85 cancel it: decelerate, drop the jog, back to Idle.
* ``~`` resumes only a finished hold.
* 0x90-0x94 feed override (100 %, +-10, +-1; 10..200 %), 0x95-0x97 rapids (100, 50, 25 %),
  0x99-0x9D spindle (10..200 %), 0xA0 flood toggle; a change is reported in the next report
  (its ``Ov:`` counter is zeroed).
* The spindle's PWM speed is the programmed S times the override, clamped: at or above
  ``$30`` (or with ``$31 >= $30``) it is ``$30``; 0 stays off; below ``$31`` it is ``$31``.
"""

from __future__ import annotations

import math

from inkarm.hardware.plotter.stepper import prepared_until

FEED_KEYS = {0x90: None, 0x91: 10, 0x92: -10, 0x93: 1, 0x94: -1}
RAPID_KEYS = {0x95: 100, 0x96: 50, 0x97: 25}
SPINDLE_KEYS = {0x99: None, 0x9A: 10, 0x9B: -10, 0x9C: 1, 0x9D: -1}
FLOOD_TOGGLE = 0xA0
OVERRIDE_BYTES = frozenset({*FEED_KEYS, *RAPID_KEYS, *SPINDLE_KEYS, FLOOD_TOGGLE})


def _step(value: int, delta: int | None) -> int:
    return 100 if delta is None else min(max(value + delta, 10), 200)


class RealtimeCommands:
    """Real-time bytes and the spindle output of the machine (see the module docstring)."""

    def feed_hold(self) -> None:
        """``!``: decelerate to a stop and hold (Hold:0 at once when idle)."""
        if self.sys_state in ("Idle", "Jog") and not self.frozen and not self.hold:
            self._start_hold()
            self.jog_cancel = self.sys_state == "Jog"

    def jog_cancel_byte(self) -> None:
        """0x85: in a jog, decelerate, drop the queued jog motion and return to Idle."""
        if self.sys_state == "Jog" and not self.jog_cancel:
            if not self.hold:
                self._start_hold()
            self.jog_cancel = True

    def _start_hold(self) -> None:
        """Hold; a moving machine starts braking once the stepper has run the segments it
        had prepared (:func:`.stepper.prepared_until`)."""
        self.hold = True
        if self.planner.empty or self.planner.speed <= 0:
            self.hold_from = self.time
            return
        self.hold_from = prepared_until(self.time, self.motion_t0)

    def cycle_start(self) -> None:
        """``~``: resume from a finished hold (Hold:0); a spindle stopped by the override is
        restored (``[MSG:Restoring spindle]``) and the motion resumes at once, as GRBL does:
        a servo pen is still travelling down for ``settle_s`` while the carriage moves."""
        if not self.hold or self.jog_cancel:
            return
        if not self.cycle_done:
            return  # GRBL resumes only once the hold is complete (Hold:0)
        if self.spindle_stopped:  # GRBL restores the spindle and moves on at once
            self._restore_spindle()
        self.hold = False
        self.planner.recalculate()

    def toggle_spindle_stop(self) -> None:
        """0x9E, GRBL 1.1's spindle-stop override: only in a finished hold (Hold:0), it stops
        the spindle, which lifts a servo pen; ``~`` restores it before the motion resumes."""
        if not (self.hold and self.cycle_done):
            return
        if not self.spindle_stopped:  # (spindle_set_state: the change is reported next)
            self.spindle_stopped = True
            self._spindle_output(5, 0.0)
            self.counters.ovr = 0
        else:
            self._restore_spindle()

    def _restore_spindle(self) -> None:
        """Undo the spindle-stop override: the spindle as last programmed, said so."""
        self.spindle_stopped = False
        if self.programmed[0] != 5:
            self.outbox.append("[MSG:Restoring spindle]")
            self._set_spindle(*self.programmed)

    def _reset_overrides(self) -> None:
        """Feed, rapid and spindle overrides back to 100 %, nothing pending."""
        self.overrides = [100, 100, 100]
        self.planner.set_overrides(100, 100)
        self.pending_override, self.override_at = None, math.inf

    def override(self, byte: int) -> None:
        """0x90-0x9D, 0xA0: feed, rapid and spindle overrides, the flood toggle."""
        f, r, s = self.overrides
        if byte in FEED_KEYS:
            f = _step(f, FEED_KEYS[byte])
        r = RAPID_KEYS.get(byte, r)
        if byte in SPINDLE_KEYS:
            s = _step(s, SPINDLE_KEYS[byte])
        if [f, r, s] != self.overrides:
            if (f, r) != tuple(self.overrides[:2]):
                self._override_motion(f, r)
            self.overrides = [f, r, s]
            self.counters.ovr = 0
            if self.programmed[0] != 5 and not self.spindle_stopped:
                self._set_spindle(*self.programmed)
        if byte == FLOOD_TOGGLE and self.sys_state in ("Idle", "Jog"):
            self.flood = not self.flood
            self.counters.ovr = 0

    def _override_motion(self, feed: int, rapid: int) -> None:
        """New feed and rapid overrides for the planner: GRBL re-plans at once
        (``plan_update_velocity_profile_parameters``, ``plan_cycle_reinitialize``) but the
        stepper only re-prepares from the end of the segments it has ready, so a moving
        machine changes speed from :func:`.stepper.prepared_until` on."""
        if self.planner.empty or self.planner.speed <= 0 or self.hold:
            self.planner.set_overrides(feed, rapid)
            return
        self.pending_override = (feed, rapid)
        self.override_at = prepared_until(self.time, self.motion_t0)

    def _apply_pending_override(self) -> None:
        if self.pending_override is not None and self.time >= self.override_at - 1e-12:
            self.planner.set_overrides(*self.pending_override)
            self.pending_override, self.override_at = None, math.inf

    def _set_spindle(self, mode: int, rpm: float) -> None:
        """GRBL's spindle_set_state: the PWM's speed clamped to ``$30``/``$31``."""
        if mode == 5:
            self._spindle_output(5, 0.0)
        else:
            value = rpm * self.overrides[2] / 100.0
            lo, hi = self.settings[31], self.settings[30]
            if lo >= hi or value >= hi:
                value = hi
            elif value <= lo:
                value = 0.0 if value == 0 else lo
            self._spindle_output(mode, value)
        self.counters.ovr = 0

    def _spindle_output(self, mode: int, rpm: float) -> None:
        self.spindle_mode, self.spindle_rpm = mode, rpm
        self._pen_command(mode != 5 and rpm >= self.pen.contact_s)

    def _pen_command(self, down: bool) -> None:
        if down != self.pen_down_target:
            self.pen_down_target = down
            self.pen_change_at = self.time

    def raise_sleep(self) -> None:
        """``$SLP``: spindle and coolant off, nothing more until a soft reset."""
        self._spindle_output(5, 0.0)
        self.flood = False
        self.sys_state = "Sleep"
        self.outbox.append("[MSG:Sleeping]")

    def _program_end(self, check: bool) -> None:
        """M2/M30: overrides back to 100 %, work offset refreshed, spindle and coolant off,
        ``[MSG:Pgm End]``."""
        self._reset_overrides()
        if not check:
            self.counters.wco = 0
            self.programmed = (5, 0.0)
            self._set_spindle(5, 0.0)
            self.flood = False
            self.counters.ovr = 0
        self.outbox.append("[MSG:Pgm End]")
