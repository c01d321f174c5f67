"""The joint drives inside the simulated plant: what runs on a real arm's joint controllers, at
physics rate, between two commands of the host.

A torque-controlled arm (KUKA's joint impedance mode, a servo's position PID) closes its joint
loop in the drive, every physics step h, on its own encoder; the host sends set points with
feed-forward every control period T = substeps h. :class:`JointDrive` is that loop:

    tau(t) = tau_ff + K_p (q*(t) - q_m) + I + K_d (qd* - v),   q*(t) = q* + qd* (t - t_cmd)

where q_m is the drive's measured position (quantised and noisy as the plant's truth says), the
set point is extrapolated with its velocity between commands, and v is the drive's velocity:
the exact one, or, from a device without a velocity sensor, the difference of successive
measurements through a first-order low-pass of time constant ``velocity_filter_s`` (a raw
difference of a quantised encoder jumps by one tick per step: 1.5 mrad / 2 ms = 0.77 rad/s at
4096 ticks/rev).

The integral I sheds dry friction and model errors. It is slow (K_i / K_p of a few per second)
and runs at the command rate, as drive firmwares run their outer terms: at each new set point

    I <- clip(I + K_i (t - t_cmd) (q*(t) - q_link), +-integral_limit)

with the error the old set point has left at that moment (anti-windup by the clip). The P and
D terms are affine in (q_m, v), so on exact encoders the whole law is a MuJoCo actuator:

    tau = u(t) - K_p q - K_d qd,   u(t) = K_p q*(t) + tau_ff + K_d qd* + I        (affine bias)

and runs in C (:meth:`JointDrive.affine_control`; Euler integrates its damping explicitly, as a
sampled drive holds its torque). With the compiled control period the new set point's arithmetic
(:meth:`JointDrive.set_point` then :meth:`JointDrive.affine_control`) is one C call as well
(:func:`inkarm.sim.compiled.set_point`, the same bits): the methods here are its reference.

On a joint with series elasticity (stiffness k, which the drive knows: drives with joint torque
sensors calibrate it, :meth:`JointDrive.elastic`) the P and D terms act on the motor's own
encoder (collocated: stable whatever the spring) and the motor leads the link by the spring's
deflection under the torque it is asked to pass:

    q_m*(t) = q*(t) + tau_ff / k

The integral stays on the link's error, for what the feed-forward gets wrong (masses, friction),
at a tenth of the rigid gain (``ELASTIC_INTEGRAL_SCALE``): an integral on the far side of a
spring is non-collocated, and at the rigid gain it fights the force loop through the spring
while the pen is pressed (a 5 Hz limit cycle). Measured on the default letter with springs of
2e4..2e3 N m/rad: 0.31 mm RMS without the lead, 0.12 mm with it; all of issue 9's
imperfections at once 0.34 -> 0.20 mm.
"""

from __future__ import annotations

import numpy as np

from inkarm.robots.gains import PIDGains

ELASTIC_INTEGRAL_SCALE = 0.1


class JointDrive:
    """PID with feed-forward at physics rate, integral at the command rate; ``gains`` are the
    robot profile's.

    Args:
        gains: K_p [N m/rad], K_i [N m/(rad s)], K_d [N m s/rad], integral limit [N m].
        step_s: Physics time step h [s].
        velocity_filter_s: Time constant of the velocity estimate [s] when velocity comes from
            differences.
    """

    def __init__(self, gains: PIDGains, step_s: float, velocity_filter_s: float = 0.004):
        self.kp, self.ki, self.kd = (np.asarray(g, dtype=float) for g in
                                     (gains.kp, gains.ki, gains.kd))
        self.limit = np.asarray(gains.integral_limit, dtype=float)
        self._floor = -self.limit
        self.h = float(step_s)
        self.kp_h = self.kp * self.h
        self.alpha = self.h / (velocity_filter_s + self.h)
        n = len(self.kp)
        self.integral = np.zeros(n)
        self.q_goal = self.qd_goal = self.tau_ff = None
        self.since = 0.0
        self._ki_since, self._gain_since = self.ki * 0.0, 0.0
        self.v = np.zeros(n)
        self.q_prev: np.ndarray | None = None
        self.compliance = np.zeros(n)  # 1 / k of a series spring [rad/(N m)], 0 where rigid
        self.lead = np.zeros(n)
        self._elastic = False

    def elastic(self, joints: np.ndarray, stiffness: np.ndarray) -> None:
        """Joints ``joints`` have series springs of ``stiffness`` [N m/rad]: the motor leads by
        the deflection, the link-side integral runs at ``ELASTIC_INTEGRAL_SCALE``."""
        self.compliance[joints] = 1.0 / np.asarray(stiffness, dtype=float)
        self._elastic = True
        self.ki = self.ki.copy()
        self.ki[joints] *= ELASTIC_INTEGRAL_SCALE
        self._gain_since = 0.0

    def set_point(self, q: np.ndarray, qd: np.ndarray | None, tau_ff: np.ndarray | None,
                  q_link: np.ndarray | None = None) -> None:
        """A new set point (from the host, after any actuation delay); ``q_link`` [rad], the
        links' measured position now, integrates the error the old set point left."""
        since = self.since
        if self.q_goal is not None and q_link is not None and since > 0.0:
            if since != self._gain_since:  # (the same every period: K_i (t - t_cmd) once)
                self._ki_since, self._gain_since = self.ki * since, since
            # I + K_i (t - t_cmd) (q* + qd* (t - t_cmd) - q_link), clipped; in place on one
            # temporary (this runs every control period)
            integral = self.q_goal + self.qd_goal * since
            integral -= q_link
            integral *= self._ki_since
            integral += self.integral
            np.maximum(integral, self._floor, out=integral)
            np.minimum(integral, self.limit, out=integral)
            self.integral = integral
        n = len(self.kp)
        self.q_goal = np.asarray(q, dtype=float)
        self.qd_goal = np.zeros(n) if qd is None else np.asarray(qd, dtype=float)
        self.tau_ff = np.zeros(n) if tau_ff is None else np.asarray(tau_ff, dtype=float)
        if self._elastic:
            self.lead = self.compliance * self.tau_ff
        self.since = 0.0

    def velocity(self, q_measured: np.ndarray, qd_exact: np.ndarray | None) -> np.ndarray:
        """The drive's velocity: exact, or filtered differences of the measurements."""
        if qd_exact is not None:
            return qd_exact
        if self.q_prev is not None:
            raw = (q_measured - self.q_prev) / self.h
            self.v += self.alpha * (raw - self.v)
        self.q_prev = q_measured.copy()
        return self.v

    def torque(self, q_measured: np.ndarray, v: np.ndarray) -> np.ndarray:
        """One physics step of the loop: the motor torque [N m] from the motors' ``q_measured``
        and ``v`` (the links' where the joint is rigid)."""
        error = self.q_goal + self.lead + self.qd_goal * self.since - q_measured
        self.since += self.h
        return self.tau_ff + self.kp * error + self.integral + self.kd * (self.qd_goal - v)

    def affine_control(self) -> tuple[np.ndarray, np.ndarray]:
        """The set point as the control u of an affine actuator (tau = u - K_p q - K_d qd):
        u at the first physics step of the set point and its increase per step, K_p qd* h."""
        rest = self.kd * self.qd_goal
        rest += self.tau_ff
        rest += self.integral
        u = self.kp * self.q_goal
        u += rest
        return u, self.kp_h * self.qd_goal

    @property
    def active(self) -> bool:
        return self.q_goal is not None


__all__ = ["ELASTIC_INTEGRAL_SCALE", "JointDrive"]
