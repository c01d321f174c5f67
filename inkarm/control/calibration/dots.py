"""The rows of a drawn pattern's dot while it is pressed, shared by every calibration that
reads dots (paper touches, pen and kinematics marks).

A pattern of dots is a drawing of held points, dot k its stroke k; its log rows in phase
``draw`` are the dot's time on the paper. The pen lands, rings and settles: the last
:data:`SETTLED_SHARE` of those rows are its settled samples.
"""

from __future__ import annotations

import numpy as np

from inkarm.core.log import DRAW, DrawLog

SETTLED_SHARE = 0.5  # the last half of a dot's pressed rows: the pen has settled


def settled_rows(log: DrawLog, dot: int, force_n: float | None = None) -> np.ndarray:
    """The log rows of dot ``dot`` once settled (module docstring); with ``force_n`` only the
    rows whose sensed force exceeds half of it are counted as pressed (a backend that senses a
    force; None: every row of the dot's stroke in phase draw)."""
    mine = np.flatnonzero((log.stroke == dot) & (log.phase == DRAW))
    if force_n is not None:
        mine = mine[log.force[mine] > 0.5 * force_n]
    return mine[int(len(mine) * (1.0 - SETTLED_SHARE)):]


__all__ = ["SETTLED_SHARE", "settled_rows"]
