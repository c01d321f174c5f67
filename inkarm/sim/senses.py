"""What the plant's devices report, as opposed to what is: encoder resolution and noise on joint
positions, velocity from differences, force-sensor noise and bias, and the age of every reading
(sensing delay and read-out jitter). The drives read the encoders at physics rate without delay;
the host reads a snapshot that is ``sensing_delay_ms`` old.

Read-out jitter: with ``readout_jitter_ms`` J > 0 each control period's reading is

    a = d + u J / h   physics steps old,   u ~ uniform(0, 1),   d = round(sensing_delay_ms / h)

(h the physics step; one draw per period: a second read in the same period gets the same age),
linearly interpolated between the two recorded steps around it, the newer k = floor(a) steps
old and the older k + 1, with weight w = a - k on the older:

    reading = newer + w (older - newer)       (every number of the reading, its time included)

so a reading carries the time it was sampled, as drives that stamp their samples (EtherCAT,
KUKA's FRI) report it: the executor compares it with the plan row of that time, and the jitter
acts as a varying latency of the feedback. (Stamped instead at the mean age, a host that does
not know each reading's age, the default letter with 2 + 0-6 ms draws the same ink, chamfer
0.056 mm, but its logged tracking RMS rises from 0.05 to 0.26 mm: the reading's timing error,
not the tip's.)

The recorded steps hold what the devices measured (quantised, noisy); between two of them the
state is taken as linear, which it is to O(h^2) (h = 2 ms; for a quantised encoder the reading
may fall between two ticks, by less than one). The draws u come from their own generator,
seeded ``[truth.seed, JITTER_STREAM]``, in blocks of ``JITTER_BLOCK`` (the batched plant draws
each member's from the same stream in the same blocks: a member with seed s reads as the single
plant with seed s). J = 0 is the plain delay, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque

import numpy as np

from inkarm.sim.imperfections import SERVO_VELOCITY_UNIT, PlantTruth

JITTER_STREAM = 0x717E  # the read-out ages' generator: [seed, JITTER_STREAM]
JITTER_BLOCK = 256  # uniforms drawn at a time


def jitter_generator(seed: int) -> np.random.Generator:
    """The generator of the read-out ages of the plant with truth seed ``seed``."""
    return np.random.default_rng([int(seed), JITTER_STREAM])


def history_length(delay_steps: int, jitter_steps: float) -> int:
    """Recorded steps a plant keeps: the delay's d + 1, and with jitter J/h > 0 the
    ceil(J/h) + 1 more that the oldest interpolated reading needs."""
    if not jitter_steps:
        return delay_steps + 1
    return delay_steps + math.ceil(jitter_steps) + 2


class Senses:
    """Measurement models of one plant, built from its :class:`PlantTruth`.

    Args:
        truth: The plant's truth (encoder, noise, velocity, force, sensing delay, read-out
            jitter; the seed of the noise and of the ages).
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
        self.jitter_steps = truth.readout_jitter_ms / 1000.0 / step_s
        self.h = step_s
        self.rng = np.random.default_rng([truth.seed, 0x5E45])
        self.exact_q = self.tick == 0.0 and self.q_noise == 0.0
        self.ideal = (self.exact_q and truth.velocity == "exact" and self.force_noise == 0.0
                      and self.force_bias == 0.0 and self.delay_steps == 0
                      and self.jitter_steps == 0.0)
        self.snapshots: deque = deque(maxlen=history_length(self.delay_steps,
                                                            self.jitter_steps))
        self._ages = jitter_generator(truth.seed)
        self._uniforms = np.zeros(0)
        self._recorded = 0  # steps recorded so far
        self._reading: tuple[int, object] | None = None  # (steps recorded, the reading)
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
        """Keep a reading; :meth:`latest` returns the one ``delay_steps`` old (with jitter: the
        state ``a`` steps old, see the module)."""
        self.snapshots.append(snapshot)
        self._recorded += 1

    def latest(self):
        """The host's reading: the one ``delay_steps`` old, or with jitter the state a drawn
        age old (the same object until the next :meth:`record`)."""
        if not self.jitter_steps:
            return self.snapshots[0]
        if self._reading is None or self._reading[0] != self._recorded:
            self._reading = (self._recorded, self._aged(self._next_uniform()))
        return self._reading[1]

    def _next_uniform(self) -> float:
        if not len(self._uniforms):
            self._uniforms = self._ages.random(JITTER_BLOCK)
        u, self._uniforms = self._uniforms[0], self._uniforms[1:]
        return u

    def _aged(self, u: float):
        """The reading ``delay_steps + u jitter_steps`` steps old, interpolated."""
        age = self.delay_steps + u * self.jitter_steps
        back = math.floor(age)
        w = age - back
        snaps, oldest = self.snapshots, -len(self.snapshots)
        return blend(snaps[max(-1 - back, oldest)], snaps[max(-2 - back, oldest)], w)


def blend(newer, older, w: float):
    """A reading ``w`` of the way from ``newer`` to ``older`` (a dataclass of the same type):
    every number ``a + w (b - a)``; what is not a number (errors) and what is missing
    (None) from ``newer``."""
    values = {}
    for f in dataclasses.fields(newer):
        a = getattr(newer, f.name)
        if a is None or isinstance(a, (tuple, str)):
            values[f.name] = a
        else:
            values[f.name] = a + w * (getattr(older, f.name) - a)
    return type(newer)(**values)


__all__ = ["JITTER_BLOCK", "JITTER_STREAM", "Senses", "blend", "history_length",
           "jitter_generator"]
