"""Joint PID with derivative on measurement, conditional-integration anti-windup and torque
saturation (the dynamics inversion of seed 001, sec. 4).

Per joint, with e = q* - q and the planned velocity qd* (0 for a set point):

    tau_u = K_p e + I + K_d (qd* - qd) + tau_ff
    tau   = clip(tau_u, -tau_max, tau_max)
    I    <- clip(I + K_i e dt, -I_max, I_max)   unless tau_u is saturated and e pushes it further

The derivative acts on the measured velocity (plus the planned velocity as feed-forward), never
on a numerically differentiated set point, so a step in q* gives no derivative kick. The
integrator is stored in [N m] (K_i is applied when integrating), so changing K_i on the fly does
not bump the output.

Seed 001 writes the law as tau = K_p (q_T - q) + K_d (q_T - q) + K_i \\int q dt: the derivative
term has lost its derivative and the integral integrates q instead of the error q_T - q; both
are typos for the standard PID implemented here.
"""

from __future__ import annotations

import numpy as np

from inkarm.errors import InputError
from inkarm.robots.gains import PIDGains

__all__ = ["JointPID", "PIDGains"]


class JointPID:
    """Stateful PID over n joints at a fixed period ``dt`` in [s] (module docstring)."""

    def __init__(self, gains: PIDGains, dt: float):
        if not (np.isfinite(dt) and dt > 0):
            raise InputError(f"JointPID: dt must be a positive number of seconds, got {dt}")
        self.gains = gains
        self.dt = float(dt)
        self.integral = np.zeros(gains.n)
        self._ki_dt = gains.ki * self.dt
        self._torque_floor = -gains.torque_limit
        self._integral_floor = -gains.integral_limit

    def reset(self) -> None:
        """Empty the integrator."""
        self.integral[:] = 0.0

    def update(
        self,
        q_ref: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray,
        qd_ref: np.ndarray | None = None,
        feedforward: np.ndarray | None = None,
    ) -> np.ndarray:
        """Saturated torque (n,) in [N m] for this period; advances the integrator."""
        g = self.gains
        error = q_ref - q
        tau = g.kp * error
        tau += self.integral
        if qd_ref is None:
            tau -= g.kd * qd
        else:
            tau += g.kd * (qd_ref - qd)
        if feedforward is not None:
            tau += feedforward
        # (minimum/maximum rather than np.clip: cheaper on 7 numbers, and this runs every period)
        integral = np.minimum(
            np.maximum(self.integral + self._ki_dt * error, self._integral_floor),
            g.integral_limit,
        )
        saturated = np.minimum(np.maximum(tau, self._torque_floor), g.torque_limit)
        # Nothing saturated when clamping changed no bit (comparing the bytes is a fraction of
        # the cost of an elementwise comparison and its reduction on 7 numbers).
        if saturated.tobytes() == tau.tobytes():
            self.integral = integral
            return tau
        # Conditional integration: freeze a joint whose output is saturated in the direction
        # its error would push the integrator.
        frozen = (saturated != tau) & (error * tau > 0.0)
        self.integral = np.where(frozen, self.integral, integral)
        return saturated
