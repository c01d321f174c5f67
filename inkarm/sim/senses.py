"""What the plant's devices report, as opposed to what is: encoder resolution and noise on joint
positions, velocity from differences, force-sensor noise and bias, and the age of every reading
(sensing delay). The drives read the encoders at physics rate without delay; the host reads a
snapshot that is ``sensing_delay_ms`` old.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from inkarm.sim.imperfections import SERVO_VELOCITY_UNIT, PlantTruth


class Senses:
    """Measurement models of one plant, built from its :class:`PlantTruth`.

    Args:
        truth: The plant's truth (encoder, noise, velocity, force, sensing delay).
        n: Number of joints.
        step_s: Physics step h [s]; delays are rounded to whole steps.
    """

    def __init__(self, truth: PlantTruth, n: int, step_s: float):
        ticks = truth.encoder_ticks_per_rev
        self.tick = 2.0 * math.pi / ticks if ticks > 0 else 0.0
        self.q_noise = truth.q_noise_rad
        self.differences = truth.velocity == "differences"
        self.servo_units = truth.velocity == "servo"
        self.force_noise, self.force_bias = truth.force_noise_n, truth.force_bias_n
        self.delay_steps = round(truth.sensing_delay_ms / 1000.0 / step_s)
        self.h = step_s
        self.rng = np.random.default_rng([truth.seed, 0x5E45])
        self.exact_q = self.tick == 0.0 and self.q_noise == 0.0
        self.ideal = (self.exact_q and truth.velocity == "exact" and self.force_noise == 0.0
                      and self.force_bias == 0.0 and self.delay_steps == 0)
        self.snapshots: deque = deque(maxlen=self.delay_steps + 1)
        self._q_prev: np.ndarray | None = None
        self.n = n

    def position(self, q: np.ndarray) -> np.ndarray:
        """The encoders' reading of true positions ``q`` [rad]."""
        if self.exact_q:
            return q
        if self.tick:
            q = self.tick * np.round(q / self.tick)
        if self.q_noise:
            q = q + self.rng.normal(0.0, self.q_noise, self.n)
        return q

    def velocity(self, q_measured: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The reported velocity [rad/s]: exact, in whole servo units, or the difference of the
        last two readings."""
        if self.servo_units:
            return SERVO_VELOCITY_UNIT * np.round(qd / SERVO_VELOCITY_UNIT)
        if not self.differences:
            return qd
        prev = self._q_prev if self._q_prev is not None else q_measured
        self._q_prev = q_measured
        return (q_measured - prev) / self.h

    def force(self, force_n: float) -> float:
        """The force sensor's reading of the true pen force [N]."""
        if self.force_noise:
            force_n += float(self.rng.normal(0.0, self.force_noise))
        return force_n + self.force_bias

    def record(self, snapshot) -> None:
        """Keep a reading; :meth:`latest` returns the one ``delay_steps`` old."""
        self.snapshots.append(snapshot)

    def latest(self):
        return self.snapshots[0]


__all__ = ["Senses"]
