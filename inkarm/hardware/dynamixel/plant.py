"""DynamixelPlant: a Dynamixel X-series arm behind the Plant protocol.

Start-up (refused, naming the difference, when the bus does not match the profile):

1. every servo of ``[backends.dynamixel]`` (joints and shadows) answers PING with the model
   the profile names; its Status Return Level (68) is read, and set where the profile's
   ``status_return_level`` says (at 1 writes go unanswered and are read back; at 0, which
   answers PING only, the servo is refused naming the register); each shadow carries its
   joint's servo as Secondary ID; no servo reports a hardware error;
2. torque off; operating mode, return delay and (in position mode) the Min/Max Position
   Limits written and acknowledged; the PID, feed-forward and profile registers written;
3. Goal Position := Present Position (no jump at torque-on), torque on, bus watchdog on.

Each period: one sync read (position, velocity, current and the status error bytes) and one
sync write of the goals. Goals are clamped to the software limits (the joint ranges less a
margin) and to ``max_step_deg`` per period. A status packet's alert bit makes the plant read
that servo's Hardware Error Status; every 10th period the bus watchdogs are read.

On any fault: the pen is lifted (the healthy servos get ``q + pen_lift``), then the arm holds
or goes limp as ``on_fault`` says, the trace is written, and a :class:`DynamixelFault` naming
the servo and the fault says how long that took. :meth:`close` lifts the pen, parks (or holds,
or releases) as ``on_close`` says, and always closes the port. ``park`` releases the torque
only at a ``park_deg`` the profile names (a rest pose); parked at home, which is a drawing pose
over the sheet, the arm holds with the pen up: released there it falls and its pen drags a
line on the sheet after the run (12 mm on the wx250s twin).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Self

import numpy as np

from inkarm.core.plant import (
    PlantState,
    PositionCommand,
    TorqueCommand,
    WallClock,
    unsupported,
)
from inkarm.errors import InputError
from inkarm.hardware.dynamixel.bus import DynamixelBus, DynamixelFault
from inkarm.hardware.dynamixel.calibration import Calibration
from inkarm.hardware.dynamixel.config import DynamixelConfig
from inkarm.hardware.dynamixel.tables import HARDWARE_ERRORS, MODEL_NAMES, table
from inkarm.robots.servo import servo_model, velocity_units_to_rad_s

WATCHDOG_POLL_PERIODS = 10
LATE_READS = 3  # consecutive state reads needing a retry that make a fault
PEN_LIFT_S = 0.3
PARK_TIMEOUT_S = 4.0
PARK_SPEED_RAD_S = 0.8


def servo_stiffness(config: DynamixelConfig, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's position-loop stiffness K [N m/rad] and goal lead [s], from its servos'
    registers: K = P/128 PWM units a tick (e-Manual) x 4096 / (2 pi) ticks a radian x stall
    torque / 885 PWM units, summed over the joint's servos; the lead is the back-EMF's damping
    over K (stall / no-load speed: the only damping that resists a steady motion, the D term
    acting on the error) plus one period (the goal waits on the bus before a servo acts)."""
    k, d = np.zeros(config.n), np.zeros(config.n)
    for j, model in enumerate(config.models):
        m = servo_model(model)
        p_tbl = config.gains["position_p"][j] if "position_p" in config.gains else \
            m.position_pid_default[2]
        k[j] = p_tbl / 128.0 * m.ticks_per_rev / (2 * np.pi) * m.stall_torque_nm / 885
        d[j] = m.stall_torque_nm / m.no_load_speed_rad_s
    count = config.servos_per_joint
    k, d = np.maximum(count * k, 1e-6), count * d
    return k, d / k + period_s


def servo_goal(command: PositionCommand, stiffness: np.ndarray, lead_s: np.ndarray) -> np.ndarray:
    """The goal [rad] a servo needs to follow ``command``: it takes neither a torque nor a
    speed, so its goal leads by what its loop will lag, ``(tau_ff + D qd*) / K``
    (:func:`servo_stiffness`)."""
    q = np.asarray(command.q, dtype=float)
    if command.torque is not None:
        q = q + np.nan_to_num(np.asarray(command.torque, dtype=float)) / stiffness
    if command.qd is not None:
        q = q + np.nan_to_num(np.asarray(command.qd, dtype=float)) * lead_s
    return q


def hardware_error_text(status: int) -> str:
    bits = [name for bit, name in HARDWARE_ERRORS.items() if status & (1 << bit)]
    return ", ".join(bits) or f"status {status:#04x}"


class DynamixelPlant:
    """A Dynamixel arm on ``port`` as ``profile`` describes it (module docstring).

    Args:
        port: Serial port (``/dev/ttyUSB0``, or an emulator's pty).
        profile: The robot profile (:class:`inkarm.robots.profile.RobotProfile`).
        calibration: Joint zeros and directions; the identity (tick 2048 = 0 rad) if None.
        clock: Where time comes from (a :class:`WallClock` by default).
        trace_path: Where the trace goes on a fault (.npz); none written if None.
    """

    senses = frozenset({"current"})
    commands = frozenset({"position"})

    def __init__(self, port: str, profile, calibration: Calibration | None = None,
                 clock=None, trace_path: str | Path | None = None):
        self.profile = profile
        self.config = cfg = DynamixelConfig.of(profile)
        self.calibration = calibration or Calibration.identity(profile.joint_names)
        self.clock = clock or WallClock()
        self.trace_path = None if trace_path is None else Path(trace_path)
        self._dt = float(profile.control_period_s)
        names = {i: n for i, n in zip(cfg.ids, profile.joint_names)}
        names.update({sid: f"{profile.joint_names[j]} shadow" for j, sid in cfg.shadows.items()})
        self.names = names
        margin = np.radians(cfg.limit_margin_deg)
        lows, highs = [], []
        for joint in profile.joints:
            low, high = joint.range if joint.range is not None else (-np.pi, np.pi)
            lows.append(low + margin)
            highs.append(high - margin)
        self.q_min, self.q_max = np.array(lows), np.array(highs)
        self.max_step = np.radians(cfg.max_step_deg)
        lift = cfg.pen_lift_deg
        self.pen_lift = np.zeros(profile.n) if lift is None else np.radians(lift)
        self.park_q = profile.home_q if cfg.park_deg is None else np.radians(cfg.park_deg)
        self._current_unit = np.array([  # [A] per unit; NaN where a model senses no current
            np.nan if servo_model(m).current_unit_ma is None else
            servo_model(m).current_unit_ma * 1e-3 for m in cfg.models])
        self.stiffness, self.lead_s = servo_stiffness(cfg, self._dt)
        self.current_mode = cfg.operating_mode == "current"
        if self.current_mode:  # torques from the host, as goal currents
            self.commands = frozenset({"torque"})
            self._amps_per_nm = 1.0 / (cfg.servos_per_joint * np.array([
                servo_model(m).torque_constant_nm_per_a for m in cfg.models]))
            self._current_max = self._current_unit * np.array([
                table(m)["current_limit"].default for m in cfg.models])
        self.trace: list[tuple] = []
        self.fault: DynamixelFault | None = None
        self.safe_after_s: float | None = None
        self._closed = False
        self._period = 0
        self._next_tick = 0.0
        self._goal_q: np.ndarray | None = None
        self._last: PlantState | None = None
        self.overruns = 0
        self._retried = 0
        self._late_s = (2.0 * cfg.latency_ms + 2.0) / 1000.0  # the SDK's reply timeout [s]
        self.bus = DynamixelBus(port, cfg.baudrate, cfg.retries, names, cfg.latency_ms)
        try:
            self._start()
        except BaseException:
            self.bus.close()
            raise

    # --- start-up ------------------------------------------------------------------------------
    def _start(self) -> None:
        cfg, bus = self.config, self.bus
        expected = {**dict(zip(cfg.ids, cfg.models)),
                    **{sid: cfg.models[j] for j, sid in cfg.shadows.items()}}
        problems, missing = [], set()
        for servo_id, model in expected.items():
            found = bus.ping(servo_id)
            name = None if found is None else MODEL_NAMES.get(found[0], f"model number {found[0]}")
            if name == model:
                continue
            missing.add(servo_id)
            problems.append(f"{bus.who(servo_id)}: no reply (expected a {model})" if name is None
                            else f"{bus.who(servo_id)}: a {name} answers, the profile expects a "
                            f"{model}")
        for servo_id in cfg.all_ids:  # before any other read: level 0 answers none
            if servo_id not in missing:
                self._status_return_level(servo_id)
        for j, sid in cfg.shadows.items():
            if sid not in missing:
                secondary = bus.read(sid, "secondary_id")
                if secondary != cfg.ids[j]:
                    problems.append(f"{bus.who(sid)}: Secondary ID is {secondary}, expected "
                                    f"{cfg.ids[j]} (its joint's servo)")
        if problems:
            raise InputError(f"the servos on {bus.port_name} do not match robot "
                             f"{self.profile.name!r}: " + "; ".join(problems),
                             file=self.profile.source or None, key="backends.dynamixel")
        for servo_id in cfg.all_ids:
            status = bus.read(servo_id, "hardware_error_status")
            if status:
                raise DynamixelFault(f"{bus.who(servo_id)}: hardware error "
                                     f"({hardware_error_text(status)}); power-cycle or reboot "
                                     "it before starting", servo_id, hardware_error_text(status))
        joint_of = {**{i: j for j, i in enumerate(cfg.ids)},
                    **{sid: j for j, sid in cfg.shadows.items()}}
        eeprom = {"operating_mode": cfg.mode_number, "return_delay_time": cfg.return_delay_us // 2}
        stale = [(i, name, value) for i in cfg.all_ids for name, value in eeprom.items()
                 if bus.read(i, name) != value]
        if stale or cfg.operating_mode == "position":
            # EEPROM is locked while the torque is on; an arm without brakes sags meanwhile, so
            # this happens only when something must change.
            for servo_id in cfg.all_ids:
                bus.write(servo_id, "torque_enable", 0)
            for servo_id, name, value in stale:
                bus.write(servo_id, name, value)
        for servo_id in cfg.all_ids:
            j = joint_of[servo_id]
            for key, values in cfg.gains.items():
                bus.write(servo_id, _GAIN_REGISTER[key], int(values[j]))
        positions, *_ = bus.read_state(cfg.ids)
        self._turns = self.calibration.turns(positions, [(lo, hi) for lo, hi in
                                                         zip(self.q_min, self.q_max)])
        if cfg.operating_mode == "position":
            lo = self.calibration.to_ticks(self.q_min, self._turns)
            hi = self.calibration.to_ticks(self.q_max, self._turns)
            for j, servo_id in enumerate(cfg.ids):
                a, b = sorted((int(lo[j]), int(hi[j])))
                bus.write(servo_id, "min_position_limit", max(0, a))
                bus.write(servo_id, "max_position_limit", min(4095, b))
        for j, servo_id in enumerate(cfg.ids):  # goal := present, acknowledged, before torque
            bus.write(servo_id, "goal_current" if self.current_mode else "goal_position",
                      0 if self.current_mode else positions[j])
        for servo_id in cfg.all_ids:
            bus.write(servo_id, "torque_enable", 1)
        self._watchdog_armed = False
        self._goal_q = self.calibration.to_rad(positions, self._turns)
        self._next_tick = self.clock.now()

    def _status_return_level(self, servo_id: int) -> None:
        """Read the servo's Status Return Level (68) (at 1 the bus reads its writes back, at 0
        it is refused naming the register) and set the profile's ``status_return_level``."""
        want, bus = self.config.status_return_level, self.bus
        try:
            level = bus.status_return_level(servo_id)
        except DynamixelFault:
            if want is None:
                raise
            level = None
        if want is not None and level != want:
            bus.set_status_return_level(servo_id, want)

    # --- Plant ----------------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        return self._dt

    def read(self) -> PlantState:
        """Joint positions [rad], speeds [rad/s] and currents [A] from one sync read."""
        self._guard()
        try:
            positions, velocities, currents, errors = self.bus.read_state(self.config.ids)
            # Late replies still arrive (after retries, or queued behind the next request):
            # LATE_READS slow state reads in a row make a fault, blamed on the slowest servo.
            waits = self.bus.last_waits
            slow = self.bus.last_attempts > 1 or sum(waits.values()) > self._late_s
            self._retried = self._retried + 1 if slow else 0
            if self._retried >= LATE_READS:
                servo_id = max(waits, key=waits.get) if waits else self.bus.last_failed
                raise DynamixelFault(f"{self.bus.who(servo_id)}: late replies ({LATE_READS} "
                                     "state reads in a row slower than the reply timeout)",
                                     servo_id, "late reply")
            for servo_id, error in errors.items():
                if error & 0x80:
                    self._hardware_fault(servo_id)
            self._period += 1
            if self._watchdog_armed and self._period % WATCHDOG_POLL_PERIODS == 0:
                for servo_id, value in self.bus.sync_read(self.config.all_ids,
                                                          "bus_watchdog").items():
                    if value == -1:
                        raise DynamixelFault(f"{self.bus.who(servo_id)}: bus watchdog expired "
                                             "(the servo stopped on its own)", servo_id,
                                             "watchdog")
        except DynamixelFault as fault:
            self._fail(fault)
        cal = self.calibration
        q = cal.to_rad(positions, self._turns)
        qd = cal.direction * velocity_units_to_rad_s(velocities)
        current = np.asarray(currents, dtype=float) * self._current_unit * cal.direction
        state = PlantState(time=self.clock.now(), q=q, qd=qd, current=current)
        self._last = state
        self.trace.append((state.time, q, qd, current,
                           self._goal_q if self._goal_q is not None else q))
        return state

    def command(self, command) -> None:
        """Goals of a :class:`PositionCommand` [rad], clamped to the software limits and to
        ``max_step_deg`` from the last goal, in one sync write."""
        if self.current_mode and type(command) is TorqueCommand:
            return self._command_torque(command)
        if type(command) is not PositionCommand or self.current_mode:
            raise InputError(unsupported(self, command))
        self._guard()
        q = np.asarray(command.q, dtype=float)
        if q.shape != (self.profile.n,) or not np.isfinite(q).all():
            raise InputError(f"expected {self.profile.n} finite joint goals, got {q}",
                             key="command.q")
        q = servo_goal(command, self.stiffness, self.lead_s)
        q = np.clip(q, self.q_min, self.q_max)
        last = self._goal_q
        q = np.clip(q, last - self.max_step, last + self.max_step)
        try:
            self._send_goals(q)
            if not self._watchdog_armed:
                self._arm_watchdog()
        except DynamixelFault as fault:
            self._fail(fault)

    def _command_torque(self, command: TorqueCommand) -> None:
        """Current mode: joint torques [N m], clamped to the profile's limits, as goal currents
        (torque / torque constant, shared by a joint's servos), in one sync write."""
        self._guard()
        tau = np.asarray(command.torque, dtype=float)
        if tau.shape != (self.profile.n,) or not np.isfinite(tau).all():
            raise InputError(f"expected {self.profile.n} finite joint torques, got {tau}",
                             key="command.torque")
        tau = np.clip(tau, -self.profile.torque_limits, self.profile.torque_limits)
        amps = np.clip(self.calibration.direction * tau * self._amps_per_nm,
                       -self._current_max, self._current_max)
        units = [round(a / unit) for a, unit in zip(amps, self._current_unit)]
        try:
            self.bus.sync_write(self.config.ids, "goal_current", units)
            if not self._watchdog_armed:
                self._arm_watchdog()
        except DynamixelFault as fault:
            self._fail(fault)

    def _arm_watchdog(self) -> None:
        """The dead-man goes on with the first goal: from then on the host talks every period
        (planning before it may take longer than the watchdog)."""
        self._watchdog_armed = True
        if self.config.watchdog_ms:
            ids = self.config.all_ids
            self.bus.sync_write(ids, "bus_watchdog",
                                [max(1, self.config.watchdog_ms // 20)] * len(ids))

    def brake(self) -> None:
        """After a fault the servos already hold (or are limp, as ``on_fault`` says)."""

    def step(self) -> None:
        """Wait for the next period of the clock."""
        self._next_tick += self._dt
        now = self.clock.now()
        if now > self._next_tick:
            self.overruns += 1
            self._next_tick = now
        self.clock.wait_until(self._next_tick)

    def close(self) -> None:
        """Pen up, then park, hold or release as ``on_close`` says (module docstring); the
        port closes (and its lock is released) always."""
        if self._closed:
            return
        self._closed = True
        try:
            if self.fault is None:
                self._pen_up()
                self._settle(PEN_LIFT_S)
                if self.config.on_close == "park":
                    self._park()
                if self.config.on_close == "torque_off" or (
                        self.config.on_close == "park" and self.config.park_deg is not None):
                    self._torque_off()
                else:  # hold (at home: over the sheet, a released arm falls on it)
                    self._watchdog_off()
        except DynamixelFault:
            pass  # the port or a servo is gone: the watchdogs stop the servos
        finally:
            self.bus.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --- faults -------------------------------------------------------------------------------
    def _guard(self) -> None:
        if self.fault is not None:
            raise self.fault
        if self._closed:
            raise DynamixelFault(f"{self.bus.who(None)}: the plant is closed", None, "closed")

    def _hardware_fault(self, servo_id: int) -> None:
        status = self.bus.read(servo_id, "hardware_error_status")
        raise DynamixelFault(f"{self.bus.who(servo_id)}: hardware error: "
                             f"{hardware_error_text(status)} (torque off by its firmware)",
                             servo_id, hardware_error_text(status))

    def _fail(self, fault: DynamixelFault):
        """Make the arm safe (module docstring), keep the trace, raise ``fault``."""
        detected = time.monotonic()
        self.fault = fault
        actions = []
        try:
            # First the watchdogs off: one that fired (the retries alone may outlast it)
            # refuses goals, and one left on would freeze the lift half-way once the host
            # stops streaming.
            self._watchdog_off(exclude=fault.servo_id)
            self._pen_up(exclude=fault.servo_id)
            actions.append("currents zeroed" if self.current_mode else "pen lifted")
            if self.config.on_fault == "torque_off":
                self._torque_off(exclude=fault.servo_id)
                actions.append("torque off")
            else:
                actions.append("arm holding")
        except DynamixelFault as second:
            actions.append(f"could not lift the pen ({second.kind}); the servos' bus watchdog "
                           f"({self.config.watchdog_ms} ms) stops them")
        self.safe_after_s = time.monotonic() - detected
        where = ""
        if self.trace_path is not None:
            where = f"; trace in {self.save_trace(self.trace_path)}"
        fault.message = (f"{fault.message}; {', '.join(actions)} "
                         f"{1000 * self.safe_after_s:.0f} ms after detection{where}")
        fault.args = (str(fault),)
        raise fault

    def save_trace(self, path: str | Path) -> Path:
        """The periods so far: time [s], q [rad], qd [rad/s], current [A], goal [rad]."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        rows = self.trace or [(0.0, *([np.zeros(self.profile.n)] * 4))]
        columns = [np.array([r[k] for r in rows]) for k in range(5)]
        np.savez(path, time=columns[0], q=columns[1], qd=columns[2], current=columns[3],
                 goal=columns[4], fault=str(self.fault or ""))
        return path

    # --- motions -------------------------------------------------------------------------------
    def _send_goals(self, q: np.ndarray, exclude: int | None = None) -> None:
        ticks = np.rint(self.calibration.to_ticks(q, self._turns)).astype(int)
        ids = [i for i in self.config.ids if i != exclude]
        values = [t for i, t in zip(self.config.ids, ticks) if i != exclude]
        self.bus.sync_write(ids, "goal_position", values)
        self._goal_q = q

    def _pen_up(self, exclude: int | None = None) -> None:
        if self.current_mode:  # no position loop to lift with: release (on_* = torque_off)
            ids = [i for i in self.config.ids if i != exclude]
            self.bus.sync_write(ids, "goal_current", [0] * len(ids))
            return
        base = self._last.q if self._last is not None else self._goal_q
        q = np.clip(base + self.pen_lift, self.q_min, self.q_max)
        self._send_goals(q, exclude)

    def _settle(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.bus.read_state(self.config.ids)
            time.sleep(self._dt)

    def _park(self) -> None:
        start = self._goal_q.copy()
        span = float(np.max(np.abs(self.park_q - start)))
        duration = max(0.5, span / PARK_SPEED_RAD_S)
        t0 = time.monotonic()
        while (s := (time.monotonic() - t0) / duration) < 1.0:
            blend = s * s * (3 - 2 * s)
            self._send_goals(start + blend * (self.park_q - start))
            self.bus.read_state(self.config.ids)
            time.sleep(self._dt)
        self._send_goals(self.park_q)
        end = time.monotonic() + PARK_TIMEOUT_S
        while time.monotonic() < end:
            positions, *_ = self.bus.read_state(self.config.ids)
            q = self.calibration.to_rad(positions, self._turns)
            if np.max(np.abs(q - self.park_q)) < np.radians(2.0):
                break
            time.sleep(self._dt)

    def _torque_off(self, exclude: int | None = None) -> None:
        self._watchdog_off(exclude)
        ids = [i for i in self.config.all_ids if i != exclude]
        self.bus.sync_write(ids, "torque_enable", [0] * len(ids))

    def _watchdog_off(self, exclude: int | None = None) -> None:
        if self.config.watchdog_ms:
            ids = [i for i in self.config.all_ids if i != exclude]
            self.bus.sync_write(ids, "bus_watchdog", [0] * len(ids))


_GAIN_REGISTER = {"position_p": "position_p_gain", "position_i": "position_i_gain",
                  "position_d": "position_d_gain", "feedforward_1st": "feedforward_1st_gain",
                  "feedforward_2nd": "feedforward_2nd_gain",
                  "profile_velocity": "profile_velocity",
                  "profile_acceleration": "profile_acceleration"}
