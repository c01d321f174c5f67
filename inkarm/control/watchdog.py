"""Watchdogs: the checks that stop a drawing run before it does harm, with stated thresholds.

Every control period the loop hands the watchdog what it measured; the first check that fires
names itself and the fault (:class:`inkarm.errors.RunFault`), and the loop makes the arm safe:

* ``force_limit``: the filtered pen force above ``force_limit_n``;
* ``tracking_limit``: the pen (tip where sensed, else the kinematic model's forward kinematics
  of the measured joints) farther than ``tracking_limit_mm`` from its reference in the page
  plane for ``watchdog_s``, near the sheet (not in the joint-space approach and home moves);
* ``torque_saturated``: a joint torque within 1 % of its limit for ``saturation_s``;
* ``joint_limit``: a joint outside its range;
* ``joint_speed``: a joint faster than 1.2 times its speed limit for ``watchdog_s``;
* ``paper_not_found`` is the loop's own (the guarded search ran out of range), and ``diverged``
  the plant's.
"""

from __future__ import annotations

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.errors import RunFault

SPEED_TOLERANCE = 1.2
SATURATION = 0.99


class Watchdog:
    """The watchdogs of one run.

    Args:
        config: Thresholds (``force_limit_n``, ``tracking_limit_mm``, ``watchdog_s``,
            ``saturation_s``).
        dt: Control period [s].
        joint_names: For the messages.
        torque_limit: (n,) [N m], or None (not checked).
        speed_limit: (n,) [rad/s], or None.
        joint_range: (n, 2) [rad], or None.
    """

    def __init__(self, config: LoopConfig, dt: float, joint_names, torque_limit=None,
                 speed_limit=None, joint_range=None):
        self.config = config
        self.names = tuple(joint_names)
        self.torque_limit = None if torque_limit is None else SATURATION * np.asarray(torque_limit)
        self.speed_limit = None if speed_limit is None else \
            SPEED_TOLERANCE * np.asarray(speed_limit)
        self.lower = self.upper = None
        if joint_range is not None:
            self.lower, self.upper = np.asarray(joint_range, dtype=float).T.copy()
            self.mid, self.half = (self.upper + self.lower) / 2, (self.upper - self.lower) / 2
        self.patience = max(1, round(config.watchdog_s / dt))
        self.saturation_patience = max(1, round(config.saturation_s / dt))
        self.far = self.fast = 0
        self.saturated = np.zeros(len(self.names), dtype=int)
        self.any_saturated = False
        # With every limit known, one pass over [q - mid, qd, torque] clears the joints in the
        # common case (this runs every control period); the checks below find which fired.
        self._bounds = None
        if self.lower is not None and self.speed_limit is not None and \
                self.torque_limit is not None:
            # (per joint, on Python floats: on 7 joints cheaper than numpy's per-call cost)
            self._bounds = tuple(zip(self.mid.tolist(), self.half.tolist(),
                                     self.speed_limit.tolist(), self.torque_limit.tolist()))

    def check(self, time: float, q, qd, torque, force: float, error_mm: float) -> None:
        """Raise :class:`RunFault` when a watchdog fires."""
        c = self.config
        if force > c.force_limit_n:
            self._fault("force_limit", time, f"pen force {force:.2f} N above the "
                        f"{c.force_limit_n:g} N limit")
        self.far = self.far + 1 if error_mm > c.tracking_limit_mm else 0
        if self.far >= self.patience:
            self._fault("tracking_limit", time, f"pen {error_mm:.1f} mm from its reference for "
                        f"{c.watchdog_s * 1000:.0f} ms (limit {c.tracking_limit_mm:g} mm)")
        if self._bounds is not None and torque is not None and self._inside(q, qd, torque):
            self.fast = 0
            if self.any_saturated:
                self.saturated[:] = 0
                self.any_saturated = False
            return
        if self.lower is not None and (np.abs(q - self.mid) - self.half).max() > 0.0:
            outside = (q < self.lower) | (q > self.upper)
            j = int(np.argmax(outside))
            lo, hi = np.rad2deg(self.lower[j]), np.rad2deg(self.upper[j])
            self._fault("joint_limit", time, f"{self.names[j]} at "
                        f"{np.rad2deg(q[j]):.1f} deg, outside its range [{lo:g}, {hi:g}] deg")
        if self.speed_limit is not None:
            self.fast = self.fast + 1 if (np.abs(qd) - self.speed_limit).max() > 0.0 else 0
            if self.fast >= self.patience:
                j = int(np.argmax(np.abs(qd) / self.speed_limit))
                self._fault("joint_speed", time, f"{self.names[j]} at {abs(qd[j]):.2f} rad/s, "
                            f"above its {self.speed_limit[j] / SPEED_TOLERANCE:.2f} rad/s limit")
        if self.torque_limit is not None and torque is not None:
            if (np.abs(torque) - self.torque_limit).max() < 0.0:
                if self.any_saturated:
                    self.saturated[:] = 0
                    self.any_saturated = False
                return
            self.any_saturated = True
            self.saturated = np.where(np.abs(torque) >= self.torque_limit, self.saturated + 1, 0)
            if self.saturated.max() >= self.saturation_patience:
                j = int(np.argmax(self.saturated))
                self._fault("torque_saturated", time, f"{self.names[j]} torque at its "
                            f"{self.torque_limit[j] / SATURATION:g} N m limit for "
                            f"{c.saturation_s * 1000:.0f} ms")

    def _inside(self, q, qd, torque) -> bool:
        """Whether every joint is strictly inside its range, speed and torque limits."""
        for (mid, half, speed, effort), a, v, t in zip(self._bounds, q.tolist(), qd.tolist(),
                                                       torque.tolist()):
            if not (abs(a - mid) < half and abs(v) < speed and abs(t) < effort):
                return False
        return True

    @staticmethod
    def _fault(watchdog: str, time: float, message: str):
        raise RunFault(f"{watchdog}: {message} at t = {time:.3f} s", watchdog=watchdog,
                       time_s=time)


__all__ = ["Watchdog"]
