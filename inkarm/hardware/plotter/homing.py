"""GRBL 1.1h's homing cycle and soft limits in its machine space (facts from ``limits.c``
``limits_go_home``/``limits_soft_check``, ``system.c`` ``system_check_travel_limits`` and
``config.h``; inkarm's own code).

* Stock GRBL is built without HOMING_FORCE_SET_ORIGIN: after ``$H`` an axis homed toward +
  (its ``$23`` bit clear) sits at ``-$27`` (the pull-off), one homed toward - at
  ``-$13x + $27``; the machine space is ``[-$130..$132, 0]`` on every axis either way, and a
  target outside it, with ``$20=1``, is a soft-limit alarm.
* The cycle homes Z first, then X and Y together (HOMING_CYCLE_0/1); each: seek the switch at
  ``$25`` (times sqrt of the number of axes, so each axis moves at ``$25``), pull off ``$27``,
  locate it again at ``$24``, pull off again, with ``$26`` ms of debounce after each move.
* The emulated switches sit at the home end: by default the + switch ``$13x`` from where the
  carriage powered up (the page's lower-left corner), the - switch just past that corner; or
  ``home_distance_mm`` from the power-up point (as the grbl-sim transcripts were recorded).
  A switch closes at or past its position (whole steps), which ``Pn:`` reports.
"""

from __future__ import annotations

import math

import numpy as np

HOMING_CYCLES = ((2,), (0, 1))  # Z, then X and Y


def travel(settings: dict[int, float]) -> np.ndarray:
    """The axes' travel ``$130..$132`` [mm]."""
    return np.array([settings[130], settings[131], settings[132]], dtype=float)


def outside_space(settings: dict[int, float], target: np.ndarray) -> bool:
    """Whether ``target`` [mm, machine] leaves GRBL's space ``[-travel, 0]``."""
    t32 = np.asarray(target, dtype=np.float32)
    limit = -travel(settings).astype(np.float32)
    return bool(np.any(t32 > 0) or np.any(t32 < limit))


SEARCH_SCALAR, LOCATE_SCALAR = 1.5, 5.0  # config.h HOMING_AXIS_SEARCH/LOCATE_SCALAR


def homing_phases(settings: dict[int, float]) -> list[tuple]:
    """The work items of ``$H``: per cycle (Z, then X and Y), ``("home phase", axes,
    approach, distance [mm], rate [mm/s])`` for seek, pull-off, locate and pull-off, each
    followed by ``("delay", $26 ms)``. An approach stops as each axis's switch closes."""
    pull, seek, locate = settings[27], settings[25] / 60.0, settings[24] / 60.0
    debounce = ("delay", settings[26] / 1000.0)
    out: list[tuple] = []
    for axes in HOMING_CYCLES:
        scale = math.sqrt(len(axes))
        search = SEARCH_SCALAR * max(travel(settings)[i] for i in axes)
        out += [("home phase", axes, True, search, seek * scale), debounce,
                ("home phase", axes, False, pull, seek * scale), debounce,
                ("home phase", axes, True, LOCATE_SCALAR * pull, locate * scale), debounce,
                ("home phase", axes, False, pull, seek * scale), debounce]
    return out


def phase_target(settings: dict[int, float], position: np.ndarray, axes, approach: bool,
                 distance: float) -> np.ndarray:
    """Where one homing move heads [mm]: toward the switches (``$23`` bit clear: +) when
    approaching, away otherwise."""
    target = np.array(position, dtype=float)
    mask = int(settings[23])
    for i in axes:
        toward_plus = not mask >> i & 1
        target[i] += distance if toward_plus == approach else -distance
    return target


def homed_position(settings: dict[int, float]) -> np.ndarray:
    """Machine position [mm] GRBL sets after homing every axis."""
    span, pull, mask = travel(settings), settings[27], int(settings[23])
    return np.array([(-span[i] + pull) if mask >> i & 1 else -pull for i in range(3)])


__all__ = ["homed_position", "homing_phases", "outside_space", "phase_target", "travel"]


HOMING_STEP_S = 0.001  # how finely an approach looks at its switches [s]
ALARM_PULLOFF, ALARM_APPROACH = 8, 9


class HomingMixin:
    """``$H`` and the limit switches of :class:`~inkarm.hardware.plotter.machine.GrblMachine`
    (whose state it uses): the switch positions in whole steps from the power-up point, the
    phases of the cycle run through the planner, ``Pn:`` and the hard limits."""

    def _init_switches(self, home_distance_mm: float | None) -> None:
        spm = self._steps_per_mm()
        if home_distance_mm is None:  # + switches at the far end, - switches past the corner
            self.switch_plus = np.round(travel(self.settings) * spm).astype(int)
            self.switch_minus = -np.ones(3, dtype=int)
        else:
            self.switch_plus = np.round(home_distance_mm * spm).astype(int)
            self.switch_minus = -self.switch_plus
        self.frame_steps = np.zeros(3, dtype=int)  # machine steps of the power-up point
        self.phase: dict | None = None

    def _steps_per_mm(self) -> np.ndarray:
        return np.array([self.settings[100], self.settings[101], self.settings[102]])

    def switches(self, position: np.ndarray | None = None) -> list[bool]:
        """Which axes' limit switches are closed now (the one at each axis's home end, at or
        past it), at ``position`` [mm] (default: the carriage's); none while homing is off
        (``$22=0``: a plotter without homing has none wired, and grbl-sim's switches exist
        only then)."""
        where = self.position if position is None else position
        steps = np.round(where * self._steps_per_mm()).astype(int) - self.frame_steps
        mask = int(self.settings[23])
        if not self.settings[22]:
            return [False, False, False]
        return [bool(steps[i] <= self.switch_minus[i]) if mask >> i & 1
                else bool(steps[i] >= self.switch_plus[i]) for i in range(3)]

    def pins(self) -> str:
        """The ``Pn:`` letters of the switches closed at the steps taken (grbl-sim's switches
        follow the step counters)."""
        closed = self.switches(self._quantised())
        return "".join(a for a, shut in zip("XYZ", closed, strict=True) if shut)

    def physical(self) -> np.ndarray:
        """Where the carriage is [mm from the power-up point]."""
        return self.position - self.frame_steps / self._steps_per_mm()

    def start_homing(self) -> None:
        """``$H``: the phases of :func:`homing_phases`, then the start-up lines and ``ok``."""
        self.sys_state = "Home"
        self.work.extend(homing_phases(self.settings))
        self.work.append(("homed",))

    def _home_phase(self, item: tuple) -> bool:
        """Run one ``home phase`` work item; True once it is over."""
        _, axes, approach, distance, rate = item
        if self.phase is None:
            if not self.planner.empty or self.time < self.dwell_until:
                return False
            target = phase_target(self.settings, self.position, axes, approach, distance)
            self.planner.add(self.position, target, rate, override=False)
            self.phase = {"axes": axes, "approach": approach, "locked": {}}
            self._lock_switches()
            return False
        if approach and len(self.phase["locked"]) < len(axes) and not self.planner.empty:
            return False
        if not approach and not self.planner.empty:
            return False
        failed = (approach and len(self.phase["locked"]) < len(axes)) or \
            (not approach and any(self.switches()[i] for i in axes))
        self.phase = None
        if failed:
            self._homing_alarm(ALARM_APPROACH if approach else ALARM_PULLOFF)
        return True

    def _lock_switches(self) -> None:
        """In an approach, stop each axis whose switch has closed (GRBL's axis lock); all
        stopped: the move ends there."""
        phase = self.phase
        if phase is None or not phase["approach"]:
            return
        closed = self.switches()
        for i in phase["axes"]:
            if i not in phase["locked"] and closed[i]:
                phase["locked"][i] = self.position[i]
        for i, where in phase["locked"].items():
            self.position[i] = where
        if len(phase["locked"]) == len(phase["axes"]) and not self.planner.empty:
            self.planner.clear()

    def _homing_alarm(self, code: int) -> None:
        """A failed cycle: ALARM:N, GRBL's 0.5 s alarm delay, the ``$H`` line's ok, a reset."""
        self.planner.clear()
        self.sys_state = "Alarm"
        self.outbox.append(f"ALARM:{code}")
        self.work.clear()
        self.work.extend([("delay", 0.5), ("reply", "ok"), ("delay", 0.03), ("reinit",)])

    def _homed(self) -> None:
        """Set GRBL's machine position after homing, keep the physical place, run the
        start-up lines (their replies come before ``$H``'s ok)."""
        spm = self._steps_per_mm()
        physical = np.round(self.position * spm).astype(int) - self.frame_steps
        self.position = homed_position(self.settings)
        self.frame_steps = np.round(self.position * spm).astype(int) - physical
        self.gc.position = self.position.copy()
        self.sys_state = "Idle"
        queued = list(self.work)
        self.work.clear()
        self.run_startup_lines()
        self.work.extend(queued)
