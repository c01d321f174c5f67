"""Memory and time estimates of the LQT, checked against INKARM_MAX_MEMORY_MB and
INKARM_MAX_COMPUTE_S before the work starts (:mod:`inkarm.core.budget`).

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

Time: the banded solve and exact draws are linear in N (milliseconds for the step budget's
N); the dense operations are O((N D)^3) and their time is estimated as c (N D)^3 seconds,
c measured (median of runs at the N D where the estimate nears the 10 s default, on the
2-core development machine under load; an idle or bigger machine is faster):

=========================================  ================  =============================
what                                       c [ns]            measured c [ns] at N D
=========================================  ================  =============================
eigen draws, ``components`` < N D          0.3               0.27-0.30 at 2400-3200
eigen draws, all components (None)         2.5               2.2-2.5 at 1400-1800
covariance, Cholesky / augmented           0.15 / 0.55       0.09-0.13 / 0.27-0.52 at 2000
dense oracle, mean / with covariance       4 / 5.5           2.7-4.1 / 4.9-5.2 at 1000-1500
=========================================  ================  =============================

so that, with the 10 s default, eigen draws stop near N D = 3200 (N = 1600 steps in 2-D; all
components near 1600), the covariance near 4000 / 2600 and the oracle near 1350 / 1200 (the
memory budget allowed eigen draws up to N D = 11,600, ~7 minutes, the oracle up to 3,500).

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


# seconds per (N D)^3 of the dense operations (see the module docstring)
EIGEN_FEW_S = 0.3e-9
EIGEN_ALL_S = 2.5e-9
COVARIANCE_S = {"cholesky": 0.15e-9, "augmented": 0.55e-9}
BATCH_S = 4e-9
BATCH_COV_S = 5.5e-9


def eigen_seconds(n_steps: int, dim: int, components: int | None) -> float:
    """Eigen draws (eq. 16-17): the ``components`` smallest eigenpairs of the banded
    precision (band reduction with its dense orthogonal factor), or all of them (None)."""
    size = float(n_steps) * dim
    few = components is not None and components < size
    return (EIGEN_FEW_S if few else EIGEN_ALL_S) * size**3


def covariance_seconds(n_steps: int, dim: int, method: str) -> float:
    """The dense position covariance from the factorisation."""
    return COVARIANCE_S.get(method, COVARIANCE_S["augmented"]) * (float(n_steps) * dim) ** 3


def batch_seconds(n_steps: int, dim: int, with_cov: bool = False) -> float:
    """The dense oracle (eq. 10-15 as printed)."""
    return (BATCH_COV_S if with_cov else BATCH_S) * (float(n_steps) * dim) ** 3


def require_time(seconds: float, what: str, **context) -> None:
    """:func:`inkarm.core.budget.require` of an estimate in seconds against
    INKARM_MAX_COMPUTE_S."""
    budget.require(seconds, budget.COMPUTE_S, what, **context)
