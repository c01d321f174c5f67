"""Joint PID gains: data of a robot profile, used by the joint controller
(:class:`inkarm.control.pid.JointPID`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError


@dataclass(frozen=True)
class PIDGains:
    """Per-joint gains, shape (n,) each.

    Attributes:
        kp: Proportional gain in [N m/rad].
        ki: Integral gain in [N m/(rad s)].
        kd: Derivative gain in [N m s/rad].
        torque_limit: Output saturation in [N m] (> 0).
        integral_limit: Bound of the integrator's contribution in [N m] (>= 0).
    """

    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray
    torque_limit: np.ndarray
    integral_limit: np.ndarray

    def __post_init__(self) -> None:
        arrays = {}
        for name in ("kp", "ki", "kd", "torque_limit", "integral_limit"):
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            if arr.ndim != 1:
                raise InputError(f"PIDGains.{name}: expected a vector, got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"PIDGains.{name}: NaN or inf in {arr.tolist()}")
            arrays[name] = arr
        # kp fixes the joint count unless it is a scalar to broadcast.
        n = arrays["kp"].size if arrays["kp"].size > 1 else max(a.size for a in arrays.values())
        for name, arr in arrays.items():
            if arr.size == 1:
                arr = np.full(n, arr[0])
            elif arr.size != n:
                raise InputError(f"PIDGains.{name}: has {arr.size} entries, expected {n}")
            object.__setattr__(self, name, arr)
        if np.any(self.torque_limit <= 0):
            raise InputError(
                f"PIDGains.torque_limit: must be > 0, got {self.torque_limit.tolist()}"
            )
        if np.any(self.integral_limit < 0):
            raise InputError(
                f"PIDGains.integral_limit: must be >= 0, got {self.integral_limit.tolist()}"
            )

    @property
    def n(self) -> int:
        return self.kp.size

    def scaled(self, factor: float) -> PIDGains:
        """The same gains with K_p, K_i, K_d multiplied by ``factor``."""
        return PIDGains(
            self.kp * factor,
            self.ki * factor,
            self.kd * factor,
            self.torque_limit,
            self.integral_limit,
        )
