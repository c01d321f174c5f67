"""Look-ups in a compiled MuJoCo model that a plant makes once, at set-up: how to index its
joints' addresses, and whether only one geom can touch anything.
"""

from __future__ import annotations

import mujoco
import numpy as np


def address_index(addresses: list[int]) -> slice | np.ndarray:
    """A slice when the addresses are consecutive (cheaper to index with), else an array."""
    first = int(addresses[0])
    if list(addresses) == list(range(first, first + len(addresses))):
        return slice(first, first + len(addresses))
    return np.array(addresses)


def only_geom_touches(model: mujoco.MjModel, geom: int) -> bool:
    """Whether every contact the model can make involves ``geom``: no explicit pairs, and no
    two other geoms whose contype/conaffinity bits let them collide."""
    if model.npair:
        return False
    kind, affinity = model.geom_contype, model.geom_conaffinity
    others = [g for g in range(model.ngeom) if g != geom and (kind[g] or affinity[g])]
    return not any(kind[a] & affinity[b] or kind[b] & affinity[a]
                   for i, a in enumerate(others) for b in others[i + 1:])
