"""What the emulated servos move: joints, injected (the emulator never imports a simulator).

:class:`JointPhysics` is the contract: ``advance(torque)`` holds joint torques [N m] for one
period of ``period_s`` and ``state()`` returns the joint angles [rad] and speeds [rad/s]. The
MuJoCo twin of a robot is one (wired in :mod:`inkarm.jobs.backends.dynamixel`); :class:`SimpleJoints`
is the built-in one when no twin is wanted: each joint a rotor of inertia ``J`` with viscous
damping ``b``, ``J qdd = tau - b qd`` (semi-implicit Euler), which the firmware's position
loop turns into a well-damped first-order-like follower.

:class:`ServoBank` puts servos on joints and runs their firmware every period
(:class:`inkarm.robots.servo.ServoFirmware`, with the gains and profile the host wrote into
their registers): each servo sees its encoder ``raw = offset + sign q 4096 / 2 pi`` (how it is
mounted), mirrored by Drive Mode's reverse bit and shifted by the Homing Offset, and its
torque reaches the joint through the same mount. A joint with a shadow servo gets both torques.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from inkarm.hardware.dynamixel.instructions import EmulatedServo
from inkarm.hardware.dynamixel.tables import (
    CURRENT_BASED_POSITION_MODE,
    CURRENT_MODE,
    EXTENDED_POSITION_MODE,
    POSITION_MODE,
    PWM_MODE,
    VELOCITY_MODE,
)
from inkarm.robots.servo import (
    PWM_FULL_SCALE,
    TICKS_PER_REV,
    FirmwareGains,
    ServoFirmware,
    rad_s_to_velocity_units,
    servo_model,
)

TICKS_PER_RAD = TICKS_PER_REV / (2.0 * np.pi)
AMBIENT_C = 30.0
OVERLOAD_S = 2.0  # full duty held this long trips Overload [s]


class JointPhysics(Protocol):
    """Joints driven by torques (module docstring)."""

    period_s: float

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles [rad] and speeds [rad/s], (n,) each."""
        ...

    def advance(self, torque: np.ndarray) -> None:
        """Hold ``torque`` [N m] (n,) for one period."""
        ...


@dataclass
class SimpleJoints:
    """Decoupled rotors ``J qdd = tau - b qd`` (module docstring)."""

    q: np.ndarray
    inertia: np.ndarray
    damping: np.ndarray
    period_s: float = 0.002

    @classmethod
    def at(cls, q0, inertia=0.01, damping=0.05, period_s=0.002) -> SimpleJoints:
        q0 = np.asarray(q0, dtype=float).copy()
        n = len(q0)
        return cls(q0, np.broadcast_to(inertia, (n,)).astype(float),
                   np.broadcast_to(damping, (n,)).astype(float), period_s)

    def __post_init__(self):
        self.qd = np.zeros_like(self.q)

    def state(self):
        return self.q.copy(), self.qd.copy()

    def advance(self, torque):
        self.qd += (np.asarray(torque) - self.damping * self.qd) / self.inertia * self.period_s
        self.q += self.qd * self.period_s


@dataclass(frozen=True)
class Mount:
    """How a servo sits on its joint: encoder ``raw = offset_ticks + sign q 4096 / 2 pi``."""

    joint: int
    offset_ticks: float = 2048.0
    sign: int = 1


class ServoBank:
    """Servos on the joints of ``physics``, their firmware run every period.

    The registers the firmware reads are cached as arrays and refreshed after each host write
    (:meth:`on_write`); the Present registers are written on demand (:meth:`sync_registers`,
    before the bus answers a packet), so a period costs a few array operations.
    """

    def __init__(self, servos: list[EmulatedServo], mounts: list[Mount], physics: JointPhysics):
        self.servos, self.mounts, self.physics = servos, mounts, physics
        self.n_joints = 1 + max(m.joint for m in mounts)
        self.models = [servo_model(s.table.model) for s in servos]
        self.firmware = ServoFirmware(self.models, FirmwareGains(), physics.period_s)
        self._joint = np.array([m.joint for m in mounts])
        self._offset = np.array([m.offset_ticks for m in mounts], dtype=float)
        self._sign = np.array([m.sign for m in mounts], dtype=float)
        self._kt = np.array([m.torque_constant_nm_per_a for m in self.models])
        self._stall = np.array([m.stall_torque_nm for m in self.models])
        self.temperature = np.full(len(servos), AMBIENT_C)
        self._full_duty_s = np.zeros(len(servos))
        self.time_s = 0.0
        self._dirty = True
        self._refresh()
        self._present(*physics.state())
        self.firmware.reset(self.present_ticks)
        self._goal_at_present()
        self.sync_registers()

    def _goal_at_present(self, which=None) -> None:
        # At power-on (and after a reboot) Goal Position starts at Present Position.
        for k, s in enumerate(self.servos):
            if which is None or k == which:
                s.memory.set("goal_position", int(np.rint(self.present_ticks[k])))
        self._dirty = True

    def _column(self, name: str, default: float = 0.0) -> np.ndarray:
        return np.array([s.memory.get(name) if s.memory.has(name) else default
                         for s in self.servos], dtype=float)

    def _refresh(self) -> None:
        """Re-read the registers the firmware and the mounts use."""
        if not self._dirty:
            return
        c = self._column
        self._rev = np.where(c("drive_mode").astype(int) & 1, -1.0, 1.0)
        self._home = c("homing_offset")
        self._enabled = c("torque_enable") > 0
        self._mode = c("operating_mode").astype(int)
        self._goal = c("goal_position")
        self._temperature_limit = c("temperature_limit")
        self._shutdown = c("shutdown").astype(int)
        self.firmware.gains = FirmwareGains(
            position_p=c("position_p_gain"), position_i=c("position_i_gain"),
            position_d=c("position_d_gain"), feedforward_1st=c("feedforward_1st_gain"),
            feedforward_2nd=c("feedforward_2nd_gain"), profile_velocity=c("profile_velocity"),
            profile_acceleration=c("profile_acceleration"),
            current_limit=c("current_limit", np.inf), pwm_limit=c("pwm_limit"))
        self._special = [k for k, mode in enumerate(self._mode)
                         if mode not in (POSITION_MODE, EXTENDED_POSITION_MODE)]
        self._dirty = False

    def _present(self, q: np.ndarray, qd: np.ndarray) -> None:
        raw = self._offset + self._sign * q[self._joint] * TICKS_PER_RAD
        self.present_ticks = self._rev * (raw - 2048.0) + 2048.0 + self._home
        self.present_speed = self._rev * self._sign * qd[self._joint]  # [rad/s], servo frame

    def sync_registers(self) -> None:
        """Write the Present registers from the state (before the bus reads them)."""
        self._refresh()
        velocity_units = rad_s_to_velocity_units(self.present_speed)
        fw = self.firmware
        for k, s in enumerate(self.servos):
            m = s.memory
            m.set("present_position", int(np.rint(self.present_ticks[k])))
            m.set("present_velocity", int(np.rint(velocity_units[k])))
            m.set("present_pwm", int(np.rint(fw.pwm[k])))
            if m.has("present_current"):
                unit = self.models[k].current_unit_ma * 1e-3
                m.set("present_current", int(np.clip(np.rint(fw.current_a[k] / unit),
                                                     -32768, 32767)))
            else:
                load = fw.current_a[k] * self._kt[k] / self._stall[k]
                m.set("present_load", int(np.clip(np.rint(1000 * load), -1000, 1000)))
            m.set("position_trajectory", int(np.rint(fw.profile.position[k])))
            m.set("velocity_trajectory", int(np.rint(rad_s_to_velocity_units(
                fw.profile.velocity[k] / TICKS_PER_RAD))))
            m.set("present_temperature", int(self.temperature[k]))
            m.set("moving", int(abs(velocity_units[k]) > m.get("moving_threshold")))
            m.set("realtime_tick", int(self.time_s * 1000) % 32768)

    def on_write(self, servo: EmulatedServo, names: list[str]) -> None:
        """The bus wrote ``names`` into ``servo``: torque-on restarts its profile at the present
        position (the stale Goal Position is kept, as on a real servo). A goal alone, written
        every control period, updates only the goal column (the gains are not re-read)."""
        if not self._dirty and set(names) <= {"goal_position"}:
            self._goal[self.servos.index(servo)] = servo.memory.get("goal_position")
            return
        self._dirty = True
        if "torque_enable" in names and servo.memory.get("torque_enable"):
            self._refresh()
            mask = np.zeros(len(self.servos), dtype=bool)
            mask[self.servos.index(servo)] = True
            self.firmware.reset(self.present_ticks, which=mask)

    # --- one period ---------------------------------------------------------------------------
    def step(self) -> None:
        """One physics period: firmware torques, joints advance, protections checked."""
        self._refresh()
        tau = self.firmware.torque(self._goal, self.present_ticks, self.present_speed)
        for k in self._special:
            tau[k] = self._special_mode(k, tau[k])
        tau = np.where(self._enabled, tau, 0.0)
        self.firmware.pwm = np.where(self._enabled, self.firmware.pwm, 0.0)
        self.firmware.current_a = np.where(self._enabled, self.firmware.current_a, 0.0)
        joint_tau = np.zeros(self.n_joints)
        np.add.at(joint_tau, self._joint, self._rev * self._sign * tau)
        self.physics.advance(joint_tau)
        self.time_s += self.physics.period_s
        self._present(*self.physics.state())
        self._protect()

    def _special_mode(self, k: int, tau: float) -> float:
        m, model = self.servos[k].memory, self.models[k]
        mode = self._mode[k]
        if mode == CURRENT_MODE and m.has("goal_current"):
            return self._kt[k] * m.get("goal_current") * model.current_unit_ma * 1e-3
        if mode == CURRENT_BASED_POSITION_MODE and m.has("goal_current"):
            bound = self._kt[k] * abs(m.get("goal_current")) * model.current_unit_ma * 1e-3
            return float(np.clip(tau, -bound, bound))
        if mode == PWM_MODE:
            duty = m.get("goal_pwm") / PWM_FULL_SCALE
        elif mode == VELOCITY_MODE:
            error = m.get("goal_velocity") - rad_s_to_velocity_units(self.present_speed[k])
            duty = float(np.clip(m.get("velocity_p_gain") / 128.0 * error / PWM_FULL_SCALE, -1,
                                 1))
        else:
            return tau
        return model.stall_torque_nm * (duty - self.present_speed[k] / model.no_load_speed_rad_s)

    def _protect(self) -> None:
        dt = self.physics.period_s
        # [K/s per A^2], a coarse winding model: about 20 s at stall from 30 to 80 degC, a
        # 300 s cooling time constant (holding at 0.5 A settles near 70 degC)
        heating = (self.firmware.current_a ** 2) * 0.5
        self.temperature += dt * (heating - (self.temperature - AMBIENT_C) / 300.0)
        full = np.abs(self.firmware.pwm) >= 0.98 * PWM_FULL_SCALE
        self._full_duty_s = np.where(full & self._enabled, self._full_duty_s + dt, 0.0)
        if (self.temperature > self._temperature_limit).any() or \
                (self._full_duty_s > OVERLOAD_S).any():
            for k, s in enumerate(self.servos):
                if self.temperature[k] > self._temperature_limit[k]:
                    self.hardware_error(s, 2)
                if self._full_duty_s[k] > OVERLOAD_S:
                    self.hardware_error(s, 5)

    def hardware_error(self, servo: EmulatedServo, bit: int) -> None:
        """Raise Hardware Error Status bit ``bit``; torque off if Shutdown says so."""
        m = servo.memory
        m.set("hardware_error_status", m.get("hardware_error_status") | (1 << bit))
        if m.get("shutdown") & (1 << bit):
            m.set("torque_enable", 0)
        self._dirty = True

    def check_watchdogs(self, now_s: float) -> None:
        """Bus Watchdog: a servo with torque on that heard nothing for its watchdog time
        stops (goal := present) and reads -1 until the host clears it."""
        for s in self.servos:
            m = s.memory
            limit = m.get("bus_watchdog")
            if limit > 0 and m.get("torque_enable") and now_s - s.last_packet_s > 0.02 * limit:
                self.fire_watchdog(s)

    def fire_watchdog(self, servo: EmulatedServo) -> None:
        m = servo.memory
        m.set("bus_watchdog", -1)
        k = self.servos.index(servo)
        m.set("goal_position", int(np.rint(self.present_ticks[k])))
        self._dirty = True

    def reboot(self, servo: EmulatedServo) -> None:
        servo.memory.reboot()
        k = self.servos.index(servo)
        self.temperature[k] = min(self.temperature[k], servo.memory.get("temperature_limit") - 5)
        self._full_duty_s[k] = 0.0
        self._goal_at_present(k)


__all__ = ["JointPhysics", "Mount", "ServoBank", "SimpleJoints"]
