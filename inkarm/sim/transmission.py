"""Series elasticity and backlash between a joint's motor and its link.

For the joints that have them, the motor is its own body in time: the rotor's reflected inertia
J_m (the joint's armature, taken off the link), driven by the motor torque tau_m and held back
by the transmission

    tau_c = k dz(theta_m - q) + c (omega_m - qd),   dz(x) = x - g sign(x) for |x| > g, else 0

(g: half the backlash; k: the series stiffness, or for backlash alone a gear stiffness that puts
the rotor-gear mode at 50 Hz; c: 5 % of critical damping), which acts on the link. The rotor is
integrated with sub-steps of the physics step (semi-implicit Euler, omega h_sub <= 0.2); the
link sees tau_c held over the step.
"""

from __future__ import annotations

import math

import numpy as np

GEAR_MODE_HZ = 50.0
COUPLING_DAMPING_RATIO = 0.05


class Transmission:
    """The motor-side states of the elastic or loose joints ``joints`` (indices into the arm).

    Args:
        stiffness: k per joint [N m/rad] (0: take the gear stiffness).
        backlash: Total free play per joint [rad].
        rotor_inertia: J_m per joint [kg m^2].
        step_s: Physics step [s].
    """

    def __init__(self, stiffness: np.ndarray, backlash: np.ndarray, rotor_inertia: np.ndarray,
                 step_s: float):
        self.joints = np.flatnonzero((stiffness > 0) | (backlash > 0))
        j = self.joints
        self.inertia = np.maximum(rotor_inertia[j], 1e-6)
        gear = self.inertia * (2.0 * math.pi * GEAR_MODE_HZ) ** 2
        self.k = np.where(stiffness[j] > 0, stiffness[j], gear)
        self.gap = 0.5 * backlash[j]
        self.c = COUPLING_DAMPING_RATIO * 2.0 * np.sqrt(self.k * self.inertia)
        omega = float(np.max(np.sqrt(self.k / self.inertia))) if len(j) else 0.0
        self.substeps = max(1, math.ceil(omega * step_s / 0.2))
        self.h = step_s / self.substeps
        self.theta = np.zeros(len(j))
        self.omega = np.zeros(len(j))

    def __bool__(self) -> bool:
        return len(self.joints) > 0

    def reset(self, q: np.ndarray, qd: np.ndarray) -> None:
        """Rotors at rest against the links (no wind-up)."""
        self.theta = q[self.joints].astype(float)
        self.omega = qd[self.joints].astype(float)

    def coupling(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """tau_c [N m] on the links of :attr:`joints`."""
        x = self.theta - q[self.joints]
        dead = np.sign(x) * np.maximum(np.abs(x) - self.gap, 0.0)
        return self.k * dead + self.c * (self.omega - qd[self.joints])

    def advance(self, motor_torque: np.ndarray, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Integrate the rotors over one physics step under ``motor_torque`` (of the
        :attr:`joints`); return the mean coupling torque over the step."""
        total = np.zeros(len(self.joints))
        for _ in range(self.substeps):
            tau_c = self.coupling(q, qd)
            total += tau_c
            self.omega += self.h * (motor_torque - tau_c) / self.inertia
            self.theta += self.h * self.omega
        return total / self.substeps


__all__ = ["Transmission"]
