"""Memory estimates of the LQT, checked against INKARM_MAX_MEMORY_MB before the work starts
(:mod:`inkarm.core.budget`).

N time steps, D dimensions, order n, k draws; every estimate is in bytes (8 per float64).
The coefficients are fits to peaks measured with :mod:`tracemalloc` (NumPy reports its
allocations to it) at N = 2000 and 20000, orders 1, 2, 4, 7, D = 2, 3, Euler and ZOH, held
targets and key-points; each formula lies within 0.75x to 1.6x of every measured peak (the
costs are linear in N, or in N^2 for the dense ones):

=========================  ==================================  ==========================
what                       estimate [bytes]                    measured / (8 N D), e.g.
=========================  ==================================  ==========================
solve, Cholesky            8 N D (10 + 3 (n + 1) D)            order 4, D 2: 35-45
solve, augmented system    8 N D (20 + D (15 + 30 n))          order 4, D 2: 220-315
exact draws, Cholesky      8 k N D 4                           3.0-4.0
exact draws, augmented     8 k N D 7                           7.0-7.1
eigen draws (eq. 16-17)    8 (N D)^2 + 8 k N D 3               dense Q of the band reduction
covariance (banded)        8 (N D)^2 (4 or 6)                  4.0 (Cholesky), 5.9 (augm.)
dense oracle, mean         8 (N D)^2 (n + 7)                   order 4, D 2: 8.2-11.1 (N D)^2
dense oracle, covariance   8 (N D)^2 (n + 10)                  order 4, D 2: 12-14 (N D)^2
=========================  ==================================  ==========================

The solver of ``"auto"`` is predicted as :class:`.solvers.Factor` picks it, from the same
bound on the conditioning (:func:`expected_method`); where that needs the assembled
tracking band (several blocks) the augmented system, the dearer one, is assumed.
"""

from __future__ import annotations

import numpy as np

from inkarm.core import budget

_EPS = np.finfo(float).eps


def expected_method(solver: str, order: int, control: float, floor: float,
                    ceiling: float) -> str:
    """``"cholesky"`` or ``"augmented"``: the factorisation ``solver`` will use (``"auto"``
    and ``"batch"`` resolved as :class:`.solvers.Factor` does, from
    :func:`.normal.precision_loss`; a NaN ``ceiling`` means unknown: augmented)."""
    if solver in ("cholesky", "augmented"):
        return solver
    if not (floor > 0 and np.isfinite(ceiling)):
        return "augmented"
    loss = _EPS * (4.0**order * control**2 + ceiling) / floor
    return "cholesky" if loss < 1e-4 else "augmented"


def solve_bytes(n_steps: int, dim: int, order: int, method: str) -> float:
    """Assembling and factorising the banded problem and solving for the mean."""
    per_value = 10 + 3 * (order + 1) * dim if method == "cholesky" else 20 + dim * (15 + 30 * order)
    return 8.0 * n_steps * dim * per_value


def sample_bytes(k: int, n_steps: int, dim: int, method: str, sampling: str = "exact") -> float:
    """k draws on top of a factorised problem (``sampling`` "exact" or "eigen")."""
    size = float(n_steps) * dim
    if sampling == "eigen":
        return 8.0 * size**2 + 8.0 * k * size * 3
    return 8.0 * k * size * (4 if method == "cholesky" else 7)


def covariance_bytes(n_steps: int, dim: int, method: str) -> float:
    """The dense position covariance from the factorisation."""
    return 8.0 * (float(n_steps) * dim) ** 2 * (4 if method == "cholesky" else 6)


def batch_bytes(n_steps: int, dim: int, order: int, with_cov: bool = False) -> float:
    """The dense oracle (eq. 10-15 as printed), O(N^2) memory."""
    return 8.0 * (float(n_steps) * dim) ** 2 * (order + (10 if with_cov else 7))


def require(n_bytes: float, what: str) -> None:
    """:func:`inkarm.core.budget.require_memory` for an LQT estimate."""
    budget.require_memory(n_bytes, what)
