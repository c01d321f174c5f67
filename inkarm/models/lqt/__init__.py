"""Gaussian-target linear quadratic tracking (LQT), seed 000 (MOCO paper sec. 3, GI paper sec. 4).

A chain of ``n`` integrators (eq. 1-4) is driven by its n-th derivative ``u`` to track an ordered
sequence of Gaussian targets N(mu_i, Sigma_i), each held ``segment_time`` [s] (eq. 5-7), or sparse
key-points (GI eq. 6-7), while the control cost (eq. 9) keeps it smooth. The optimum is the mean of
a Gaussian trajectory distribution (eq. 14-15) that :meth:`LQT.sample` draws from.

Every public quantity is in millimetres and seconds: means in [mm], covariances in [mm^2],
``d`` in [mm], ``r`` in [(mm/s^n)^-2].

Modules:

* :mod:`.config`: :class:`LQTConfig`, :class:`Reference` (extra cost terms, eq. 18-21) and the
  input checks.
* :mod:`.problem`: the problem as banded least squares in position coefficients (equivalent to
  eq. 13; start and end at rest imposed exactly).
* :mod:`.normal`, :mod:`.solvers`: linear-time banded Cholesky with refinement, and Bjorck's
  augmented system (banded LU) for the ill-conditioned orders 6-7; exact sampling.
* :mod:`.oracle`: the dense eq. 10-15 as printed, O(N^3), the test oracle (``solver="batch"``).
* :mod:`.model`: :class:`LQT`, which builds and factorises once, and :func:`solve`,
  :func:`sample`, :func:`covariance` over it.
* :mod:`.structure`: what strokes of one shape (configuration, timing, covariances) share,
  kept between calls: the structure of the problem and its factorisation, so that a stroke
  of a known shape costs its means' checks, A^T b and the back-substitutions.

Timing of the two discretisations, measured against the same plan solved with zero-order hold
on a 20x finer grid, which stands for the continuous-time optimum (least-squares time shift of
the whole path; ``test_euler_lag_against_a_finer_grid``, dt = 10 ms):

* Stepwise Gaussian targets (the usual plans): Euler does *not* lag by (n - 1) / 2 steps. It
  samples the optimum at the same instants as ZOH, within 0.003 step at orders 1-3, 0.01 at
  order 4 and 0.08 at order 5. Both run ahead of the finer solve by 0.475 steps
  (= (1 - 1/20) / 2) at every order: each step tracks the target held over [t, t + dt), so
  x_t behaves like the continuous optimum at t + dt / 2, on any grid.
* Key-points at rest: Euler pins the first n positions (c_0 = ... = c_{n-1}, centred on
  (n - 1) dt / 2) and ties the last n, so it lags by (n - 1) / 2 steps near a rest end:
  0.50, 1.00, 1.50, 2.00 steps at orders 2-5 for a point-to-point movement, where the lag is
  uniform. Interior key-points are met on their own step, so between them the lag falls to
  ~0 (order 4, four key-points: 1.2 steps near the ends, 0.15 around the inner ones). ZOH has
  no lag (< 0.001 step).

Limits: key-point plans (no tracking at most steps) are ill-conditioned in any
parametrisation; at order >= 5 with thousands of steps (dt <= 0.5 ms over 1 s) the solvers lose
millimetres without raising. Typical plans (N of a few hundred) are accurate to ~1e-6 of their
extent against the oracle.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inkarm.core.lazy import lazy_names

# Public names -> the module that defines them, imported on first use: the configuration is
# cheap, the solvers bring SciPy (a command that only names a style never pays for it).
_LAZY = {
    "LQT": "inkarm.models.lqt.model",
    "covariance": "inkarm.models.lqt.model",
    "sample": "inkarm.models.lqt.model",
    "solve": "inkarm.models.lqt.model",
    "system_matrices": "inkarm.models.lqt.oracle",
    "semi_tied_covariances": "inkarm.models.covariances",
    "MAX_ORDER": "inkarm.models.lqt.config",
    "SOLVERS": "inkarm.models.lqt.config",
    "LQTConfig": "inkarm.models.lqt.config",
    "Reference": "inkarm.models.lqt.config",
    "velocity_direction_reference": "inkarm.models.lqt.config",
}

if TYPE_CHECKING:
    from inkarm.models.covariances import semi_tied_covariances
    from inkarm.models.lqt.config import (
        MAX_ORDER,
        SOLVERS,
        LQTConfig,
        Reference,
        velocity_direction_reference,
    )
    from inkarm.models.lqt.model import LQT, covariance, sample, solve
    from inkarm.models.lqt.oracle import system_matrices


__getattr__ = lazy_names(__name__, globals(), _LAZY)


__all__ = [
    "LQT",
    "MAX_ORDER",
    "SOLVERS",
    "LQTConfig",
    "Reference",
    "covariance",
    "sample",
    "semi_tied_covariances",
    "solve",
    "system_matrices",
    "velocity_direction_reference",
]
