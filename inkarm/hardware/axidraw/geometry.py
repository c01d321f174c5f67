"""The AxiDraw's motion geometry: two steppers driving one belt in an H-bot (CoreXY-like)
arrangement, so each motor moves along a diagonal of the page.

Facts (the AxiDraw software, evil-mad/axidraw ``motion.py`` and ``axidraw_conf.py``): at 16x
microstepping a carriage move (dx, dy) in the machine frame takes ``steps1 = k (dx + dy)`` and
``steps2 = k (dx - dy)`` steps of the two motors (``SM``'s axis 1 and 2), with ``k`` = 2032
per inch (``native_res_factor`` 1016, doubled at 16x; :data:`STEPS_PER_MM` in mm); so a move
of 1 inch along x steps each motor 2032 times, and one step of a single motor moves the
carriage 1/(2032 sqrt 2) inch along its diagonal (the software's "approx. 2874 steps per inch
along the native axes"). Back from steps: ``dx = (steps1 + steps2) / 2k``, ``dy = (steps1 -
steps2) / 2k`` (its ``walk_home``). The machine frame has its origin at the home corner (the
carriage parked against the upper-left stops, as seen from the front), x to the right, y
towards the user.
"""

from __future__ import annotations

import numpy as np

STEPS_PER_INCH = 2032.0
"""k in ``steps1 = k (dx + dy)`` at 16x microstepping [1/inch]."""
STEPS_PER_MM = STEPS_PER_INCH / 25.4
"""k in millimetres: 80 steps per mm of dx + dy at 16x microstepping [1/mm]."""


def motor_steps(dx_mm, dy_mm, steps_per_mm: float = STEPS_PER_MM):
    """(steps1, steps2) of a carriage move of (dx, dy) [mm] (numbers or arrays) in the machine
    frame (floats: round them where the firmware takes integers)."""
    return steps_per_mm * (dx_mm + dy_mm), steps_per_mm * (dx_mm - dy_mm)


def carriage_mm(steps1, steps2, steps_per_mm: float = STEPS_PER_MM):
    """(dx, dy) [mm] in the machine frame of a move of (steps1, steps2) motor steps."""
    s1, s2 = np.asarray(steps1, dtype=float), np.asarray(steps2, dtype=float)
    return (s1 + s2) / (2 * steps_per_mm), (s1 - s2) / (2 * steps_per_mm)
