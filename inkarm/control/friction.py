"""Coulomb friction compensation in the torque feed-forward, adapted online.

Dry friction F_c sign(qd) makes a position loop lag at every reversal by about F_c / K_p (the
drive's integrator needs time to swing through 2 F_c). The host adds

    tau_f = F_hat tanh(qd* / w),     dF_hat/dt = gamma e sign(qd*),   0 <= F_hat <= F_max

to the feed-forward: the planned velocity qd* says which way friction will act (the smooth
sign's width w = 0.01 rad/s avoids chatter at rest), F_hat starts at the model's friction and
follows the real one from the joint error e = q_goal - q: a joint that lags in its direction of
motion needs more. This is the classical Coulomb-estimate adaptation (a gradient law on
e sign(qd*)); F_max = 4 F_model + 2 N m bounds what it may believe.
"""

from __future__ import annotations

import numpy as np

SIGN_WIDTH = 0.01  # [rad/s]


class FrictionCompensation:
    """Args:
        model_friction: (n,) Coulomb friction of the controller's model [N m].
        dt: Control period [s].
        gamma: Adaptation rate [N m / (rad s)]; 0: fixed at the model's friction.
    """

    def __init__(self, model_friction: np.ndarray, dt: float, gamma: float):
        self.estimate = np.asarray(model_friction, dtype=float).copy()
        self.ceiling = 4.0 * self.estimate + 2.0
        self.rate = gamma * dt
        self._rates = np.full(len(self.estimate), self.rate)  # (array operands: no scalar casts)
        self._zero = np.zeros(len(self.estimate))

    @staticmethod
    def direction(qd_ref: np.ndarray) -> np.ndarray:
        """The smooth sign tanh(qd* / w) of planned velocities ``qd_ref`` [rad/s] (any shape:
        a whole plan's rows at once)."""
        return np.tanh(qd_ref / SIGN_WIDTH)

    def torque(self, direction: np.ndarray, error: np.ndarray | None) -> np.ndarray:
        """The friction feed-forward [N m] for this period, given the plan's
        :meth:`direction`; adapts the estimate to the joint ``error`` [rad] (unused, and may
        be None, when the rate is 0)."""
        if self.rate:  # F_hat + gamma dt e dir, clipped to [0, F_max], in place on one temporary
            estimate = error * self._rates
            estimate *= direction
            estimate += self.estimate
            np.maximum(estimate, self._zero, out=estimate)
            np.minimum(estimate, self.ceiling, out=estimate)
            self.estimate = estimate
        return self.estimate * direction


__all__ = ["FrictionCompensation"]
