"""The firmware of a Dynamixel X-series servo in position control, as a model (pure NumPy).

What a position-controlled servo does between the goal the host writes and the torque at its
horn, vectorised over n servos (ROBOTIS e-Manual, X-series control tables: "Position PID Gain
(80, 82, 84), Feedforward 1st/2nd Gains (88, 90)", "Profile Velocity (112)", "Profile
Acceleration (108)", "Current Limit (38)", "PWM Limit (36)"):

1. **Profile generator.** Goal Position (116) becomes a desired position and velocity
   trajectory (registers 140 and 136) limited by Profile Velocity ``V`` [0.229 rev/min] and
   Profile Acceleration ``A`` [214.577 rev/min^2] (velocity-based profile): from rest a step of
   ``D`` ticks is a trapezoid, accelerating at ``A`` for ``t1 = V / A``, cruising at ``V`` and
   decelerating at ``A``, lasting ``t3 = D / V + t1``; a triangle when ``D < V^2 / A``.
   ``V = 0`` means no velocity limit and ``A = 0`` no acceleration limit (both 0: a step).
   A new goal re-plans from the present desired position and velocity, so the generator is
   the online time-optimal tracker ``v* = sign(e) min(V, sqrt(2 A |e|))`` with ``|dv| <= A dt``.
2. **Position PID with feed-forward**, in encoder ticks (4096 a turn), the control-table gains
   converted as the e-Manual gives them (the constants include the sampling time):
   ``KPP = P/128``, ``KPI = I/65536``, ``KPD = D/16``, ``KFF1 = FF1/4``, ``KFF2 = FF2/4``;
   with ``e = p_desired - p_present`` [ticks]::

       u = KPP e + KPI sum(e) + KPD (e_k - e_{k-1}) + KFF1 v_desired + KFF2 a_desired   [PWM]

   The firmware's own cycle is :data:`FIRMWARE_CYCLE_S`; at another period ``T`` the sum
   gains ``T / cycle`` per step and the difference ``cycle / T``, so the gains mean the same
   at any simulation step. ``v`` and ``a`` are per firmware cycle [ticks/cycle, ticks/cycle^2].
   The integral is clamped so that its term alone stays within the PWM limit (anti-windup).
3. **PWM to torque** (DC motor behind its gear train): duty ``d = clip(u, +-PWM limit) / 885``
   and, at output speed ``w`` [rad/s], ``tau = tau_stall (d - w / w_noload)``, so at full
   duty the torque falls linearly from stall to zero at the no-load speed (voltage
   saturation). The current ``tau / k_t`` is clipped to Current Limit x current unit
   [mA]: ``|tau| <= k_t I_limit`` (servos without current sensing have no such limit).

Units: registers in their own units (ticks, 0.229 rpm, 214.577 rev/min^2, mA steps); the
joint side in SI ([rad], [rad/s], [N m]). Conversions between the two live here and nowhere
else (:func:`ticks_to_rad` and friends). Tick 2048 is the servo's centre, 0 rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields

import numpy as np

from inkarm.errors import InputError, unknown_name

TICKS_PER_REV = 4096
CENTRE_TICK = 2048
VELOCITY_UNIT_RPM = 0.229
ACCELERATION_UNIT_RPM2 = 214.577
PWM_FULL_SCALE = 885
FIRMWARE_CYCLE_S = 0.001  # the position loop's cycle the table gains are scaled to [s]

_RPM = 2.0 * np.pi / 60.0  # [rad/s] per rev/min
_UNLIMITED = 1e30  # a profile limit of 0 (none) [ticks/s, ticks/s^2]


@dataclass(frozen=True)
class ServoModel:
    """One Dynamixel model's figures (datasheet at 12 V; control-table defaults).

    Attributes:
        name: Model name, e.g. ``"XM430-W350"``.
        model_number: The Model Number register (0).
        stall_torque_nm: Stall torque at the output [N m].
        stall_current_a: Stall current [A].
        no_load_speed_rad_s: No-load output speed [rad/s].
        current_unit_ma: One Current register step [mA]; None where the model senses no current.
        current_limit_max: Largest Current Limit (38) value [current units] (0: none).
        velocity_limit_default: Velocity Limit (44) default [0.229 rpm].
        position_pid_default: Position D, I, P gains' defaults (80, 82, 84).
        ticks_per_rev: Encoder ticks per output revolution.
    """

    name: str
    model_number: int
    stall_torque_nm: float
    stall_current_a: float
    no_load_speed_rad_s: float
    current_unit_ma: float | None
    current_limit_max: int
    velocity_limit_default: int
    position_pid_default: tuple[int, int, int]
    ticks_per_rev: int = TICKS_PER_REV

    @property
    def torque_constant_nm_per_a(self) -> float:
        """Output torque per motor current [N m/A], from the stall figures."""
        return self.stall_torque_nm / self.stall_current_a


SERVO_MODELS: dict[str, ServoModel] = {
    m.name: m for m in (
        ServoModel("XM430-W350", 1020, 4.1, 2.3, 46.0 * _RPM, 2.69, 1193, 200, (0, 0, 800)),
        ServoModel("XL430-W250", 1060, 1.5, 1.4, 61.0 * _RPM, None, 0, 265, (4000, 0, 640)),
        ServoModel("XM540-W270", 1120, 10.6, 4.4, 30.0 * _RPM, 2.69, 2047, 128, (0, 0, 800)),
    )
}


def servo_model(name: str | ServoModel) -> ServoModel:
    """The :class:`ServoModel` of a model name (or the model itself)."""
    if isinstance(name, ServoModel):
        return name
    if name not in SERVO_MODELS:
        raise unknown_name("servo model", name, SERVO_MODELS)
    return SERVO_MODELS[name]


# --- unit conversions (the control tables' units <-> SI) -----------------------------------

def ticks_to_rad(ticks, ticks_per_rev: int = TICKS_PER_REV) -> np.ndarray:
    """Position register [ticks] -> angle [rad], tick 2048 at 0 rad."""
    return (np.asarray(ticks, dtype=float) - CENTRE_TICK) * (2.0 * np.pi / ticks_per_rev)


def rad_to_ticks(rad, ticks_per_rev: int = TICKS_PER_REV) -> np.ndarray:
    """Angle [rad] -> position register [ticks] (float; round before writing)."""
    return np.asarray(rad, dtype=float) * (ticks_per_rev / (2.0 * np.pi)) + CENTRE_TICK


def velocity_units_to_rad_s(units) -> np.ndarray:
    """Velocity register [0.229 rev/min] -> [rad/s]."""
    return np.asarray(units, dtype=float) * (VELOCITY_UNIT_RPM * _RPM)


def rad_s_to_velocity_units(rad_s) -> np.ndarray:
    """[rad/s] -> velocity register [0.229 rev/min] (float)."""
    return np.asarray(rad_s, dtype=float) / (VELOCITY_UNIT_RPM * _RPM)


def acceleration_units_to_rad_s2(units) -> np.ndarray:
    """Profile Acceleration register [214.577 rev/min^2] -> [rad/s^2]."""
    return np.asarray(units, dtype=float) * (ACCELERATION_UNIT_RPM2 * 2.0 * np.pi / 3600.0)


def rad_s2_to_acceleration_units(rad_s2) -> np.ndarray:
    """[rad/s^2] -> Profile Acceleration register [214.577 rev/min^2] (float)."""
    return np.asarray(rad_s2, dtype=float) / (ACCELERATION_UNIT_RPM2 * 2.0 * np.pi / 3600.0)


def current_units_to_a(units, current_unit_ma: float) -> np.ndarray:
    """Current register [units of ``current_unit_ma`` mA] -> [A]."""
    return np.asarray(units, dtype=float) * (current_unit_ma * 1e-3)


def a_to_current_units(amps, current_unit_ma: float) -> np.ndarray:
    """[A] -> current register units (float)."""
    return np.asarray(amps, dtype=float) / (current_unit_ma * 1e-3)


# --- the firmware ---------------------------------------------------------------------------

@dataclass
class FirmwareGains:
    """The registers that shape the position loop, shape (n,) each, in register units.

    ``current_limit`` is in current units (ignored for models without current sensing);
    ``pwm_limit`` in PWM units (885 = 100 %). Scalars broadcast to n in :class:`ServoFirmware`.
    """

    position_p: np.ndarray | float = 800.0
    position_i: np.ndarray | float = 0.0
    position_d: np.ndarray | float = 0.0
    feedforward_1st: np.ndarray | float = 0.0
    feedforward_2nd: np.ndarray | float = 0.0
    profile_velocity: np.ndarray | float = 0.0
    profile_acceleration: np.ndarray | float = 0.0
    current_limit: np.ndarray | float = np.inf
    pwm_limit: np.ndarray | float = float(PWM_FULL_SCALE)

    @classmethod
    def defaults(cls, models: Sequence[str | ServoModel]) -> FirmwareGains:
        """The factory registers of ``models``."""
        ms = [servo_model(m) for m in models]
        return cls(position_p=np.array([m.position_pid_default[2] for m in ms], float),
                   position_i=np.array([m.position_pid_default[1] for m in ms], float),
                   position_d=np.array([m.position_pid_default[0] for m in ms], float),
                   current_limit=np.array([m.current_limit_max for m in ms], float))


@dataclass
class _ProfileState:
    position: np.ndarray          # desired position, register 140 [ticks]
    velocity: np.ndarray          # desired velocity, register 136 [ticks/s]
    acceleration: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [ticks/s^2]


class ServoFirmware:
    """n X-series servos' position loops (module docstring), one :meth:`torque` per period.

    Args:
        models: One model name (or :class:`ServoModel`) per servo.
        gains: Register values; scalars broadcast.
        period_s: The period :meth:`torque` is called at (e.g. the physics step) [s].
    """

    def __init__(self, models: Sequence[str | ServoModel], gains: FirmwareGains,
                 period_s: float):
        self.models = tuple(servo_model(m) for m in models)
        self.n = len(self.models)
        self.set_period(period_s)
        self.gains = gains
        m = self.models
        self._stall = np.array([x.stall_torque_nm for x in m])
        self._w_noload = np.array([x.no_load_speed_rad_s for x in m])
        self._kt = np.array([x.torque_constant_nm_per_a for x in m])
        self._unit_a = np.array([np.inf if x.current_unit_ma is None else x.current_unit_ma * 1e-3
                                 for x in m])
        self._rad_per_tick = np.array([2.0 * np.pi / x.ticks_per_rev for x in m])
        self.reset(np.full(self.n, float(CENTRE_TICK)))

    def set_period(self, period_s: float) -> None:
        """Call :meth:`torque` every ``period_s`` [s] from now on (a plant that refines its
        physics step, e.g. for a stiff gear train, calls the firmware more often)."""
        if not (np.isfinite(period_s) and 0.0 < period_s <= 0.1):
            raise InputError(f"expected a firmware period in (0, 0.1] s, got {period_s}",
                             key="period_s", value=period_s)
        self.period_s = float(period_s)
        self._coeff_key = None

    def set_register(self, name: str, value) -> None:
        """Write one gain register (all servos, or an (n,) array)."""
        if name not in {f.name for f in fields(FirmwareGains)}:
            raise unknown_name("firmware register", name, [f.name for f in fields(FirmwareGains)])
        setattr(self.gains, name, np.broadcast_to(np.asarray(value, float), (self.n,)).copy())
        self._coeff_key = None

    def reset(self, present_ticks, which=None) -> None:
        """Torque on: the desired trajectory starts at rest at the present position, the
        integral and the error history are cleared (no jump). ``which``: a boolean mask (n,)
        of the servos to reset (default all)."""
        p = np.broadcast_to(np.asarray(present_ticks, dtype=float), (self.n,)).copy()
        if which is None:
            self.profile = _ProfileState(p, np.zeros(self.n), np.zeros(self.n))
            self._integral = np.zeros(self.n)
            self._last_error = np.zeros(self.n)
            self.pwm = np.zeros(self.n)
            self.current_a = np.zeros(self.n)
            return
        m = np.asarray(which, dtype=bool)
        self.profile.position[m] = p[m]
        self.profile.velocity[m] = 0.0
        self.profile.acceleration[m] = 0.0
        self._integral[m] = 0.0
        self._last_error[m] = 0.0

    def _coefficients(self) -> dict[str, np.ndarray]:
        """The registers in the units the loop uses, once per FirmwareGains object and period
        (assign a new one, or use :meth:`set_register`)."""
        if self._coeff_key is self.gains:
            return self._coeff
        regs = {f.name: np.broadcast_to(np.asarray(getattr(self.gains, f.name), dtype=float),
                                        (self.n,)) for f in fields(FirmwareGains)}
        dt, cycle = self.period_s, FIRMWARE_CYCLE_S
        ticks_per_rad = 1.0 / self._rad_per_tick
        v_max = velocity_units_to_rad_s(regs["profile_velocity"]) * ticks_per_rad
        a_max = acceleration_units_to_rad_s2(regs["profile_acceleration"]) * ticks_per_rad
        # 0 means unlimited: a huge finite bound keeps the arithmetic free of inf * 0.
        v_max = np.where(v_max > 0, v_max, _UNLIMITED)
        a_max = np.where(a_max > 0, a_max, _UNLIMITED)
        pwm_limit = np.minimum(regs["pwm_limit"], PWM_FULL_SCALE)
        kpi = regs["position_i"] / 65536.0
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = np.where(kpi > 0, pwm_limit / kpi, 0.0)
            limit = self._kt * self._unit_a * regs["current_limit"]
        self._coeff = {
            "v_max": v_max, "a_dt": a_max * dt,
            "kpp": regs["position_p"] / 128.0, "kpi": kpi,
            "kpd": regs["position_d"] / 16.0 * (cycle / dt),
            "kff1": regs["feedforward_1st"] / 4.0 * cycle,
            "kff2": regs["feedforward_2nd"] / 4.0 * cycle * cycle,
            "pwm_limit": pwm_limit, "integral_bound": bound,
            "tau_limit": np.where(np.isnan(limit), np.inf, limit),
            "duty_torque": self._stall / PWM_FULL_SCALE, "emf": self._stall / self._w_noload,
        }
        self._coeff_key = self.gains
        return self._coeff

    def advance_profile(self, goal_ticks) -> None:
        """One period of the profile generator towards ``goal_ticks`` (module docstring, 1)."""
        c = self._coefficients()
        dt, a_dt = self.period_s, c["a_dt"]
        goal = np.asarray(goal_ticks, dtype=float)
        p, v = self.profile.position, self.profile.velocity
        error = goal - p
        distance = np.abs(error)
        # Speed from which braking at a_max stops exactly at the goal one period from now
        # (the discrete braking curve; sqrt(2 a |e|) in the continuous limit).
        # a (sqrt(1/4 + x) - 1/2) = a x / (sqrt(1/4 + x) + 1/2), x = 2 |e| / (a dt^2): no
        # cancellation when a is unlimited.
        brake = (2.0 * distance / dt) / (np.sqrt(0.25 + 2.0 * distance / (a_dt * dt)) + 0.5)
        v_target = np.copysign(np.minimum(c["v_max"], brake), error)
        v_new = v + np.clip(v_target - v, -a_dt, a_dt)
        step = v_new * dt
        arrived = np.abs(step) >= distance
        p_new = np.where(arrived, goal, p + step)
        v_new = np.where(arrived & (np.abs(v_new) <= a_dt), 0.0, v_new)
        self.profile = _ProfileState(p_new, v_new, (v_new - v) / dt)

    def torque(self, goal_ticks, present_ticks, present_velocity) -> np.ndarray:
        """One period of the position loop (module docstring, 1-3).

        Args:
            goal_ticks: Goal Position (116) [ticks], (n,).
            present_ticks: Present Position [ticks], (n,) (float: the physics' exact angle).
            present_velocity: Output speed [rad/s], (n,).

        Returns:
            Torque at the output [N m], (n,), after the PWM, voltage and current limits.
        """
        self.advance_profile(goal_ticks)
        c = self._coefficients()
        error = self.profile.position - np.asarray(present_ticks, dtype=float)
        self._integral = np.clip(self._integral + error * (self.period_s / FIRMWARE_CYCLE_S),
                                 -c["integral_bound"], c["integral_bound"])
        derivative = error - self._last_error
        self._last_error = error
        u = (c["kpp"] * error + c["kpi"] * self._integral + c["kpd"] * derivative
             + c["kff1"] * self.profile.velocity + c["kff2"] * self.profile.acceleration)
        self.pwm = np.clip(u, -c["pwm_limit"], c["pwm_limit"])
        tau = c["duty_torque"] * self.pwm - c["emf"] * np.asarray(present_velocity, dtype=float)
        tau = np.clip(tau, -c["tau_limit"], c["tau_limit"])
        self.current_a = tau / self._kt
        return tau


class JointServos:
    """:class:`ServoFirmware` in joint units, for a simulated plant that takes joint goals:
    ``torque(goal_q, q, qd)`` with [rad], [rad/s] -> [N m]. Goals are rounded to whole ticks
    (what a bus writes), the present angle is the exact one, and a joint driven by
    ``servos_per_joint[j]`` servos (a shadow doubles it) gets that many times the torque.
    The firmware starts (:meth:`reset`) at the first call if nobody reset it.

    A Dynamixel's absolute encoder is on its output shaft, after the gear train
    (:attr:`encoder_on_output`): its backlash lies inside the position loop, so a plant that
    models the gear train should pass the link angle to :meth:`torque`, not the motor's.

    Args:
        models: One model per joint.
        gains: The registers, per joint (all of a joint's servos get the same).
        period_s: The period :meth:`torque` is called at [s].
        servos_per_joint: (n,) servo counts; 1 each by default.
    """

    def __init__(self, models: Sequence[str | ServoModel], gains: FirmwareGains,
                 period_s: float, servos_per_joint=None):
        self.firmware = ServoFirmware(models, gains, period_s)
        n = self.firmware.n
        self.count = np.ones(n) if servos_per_joint is None else \
            np.asarray(servos_per_joint, dtype=float).reshape(n)
        self._started = False

    encoder_on_output = True

    def set_period(self, period_s: float) -> None:
        """The period :meth:`torque` is called at from now on [s]."""
        self.firmware.set_period(period_s)

    def reset(self, q) -> None:
        """Torque on at joint angles ``q`` [rad]."""
        self.firmware.reset(rad_to_ticks(q))
        self._started = True

    def torque(self, goal_q, q, qd) -> np.ndarray:
        if not self._started:
            self.reset(q)
        goal = np.rint(rad_to_ticks(goal_q))
        return self.count * self.firmware.torque(goal, rad_to_ticks(q), qd)
