"""Resource budgets: a job's cost is estimated from its inputs and refused before any work.

Every entry point that allocates in proportion to an input (time steps, samples, raster pixels,
DPPLA tables, glyphs, SVG points, simulated seconds) calls :func:`require` with its estimate.
The limits are settings, read from the environment so that a user who really wants a bigger job
can raise them without touching code::

    INKARM_MAX_MEMORY_MB=8000 inkarm draw big.toml

=====================  ==============================  =========
variable               what it bounds                  default
=====================  ==============================  =========
INKARM_MAX_MEMORY_MB   the arrays one job allocates    1024 MB
INKARM_MAX_STEPS       time steps of one trajectory    1000000
INKARM_MAX_SAMPLES     stochastic samples per stroke   10000
INKARM_MAX_SIM_S       simulated seconds of one run    600 s
INKARM_MAX_TEXT        characters of text or glyphs    20000
INKARM_MAX_DPPLA_STEPS steps of an exact DPPLA         2e9
INKARM_MAX_GA_INDIVIDUALS  individuals a tag's GA     250000
INKARM_MAX_COMPUTE_S   estimated seconds of one job    10 s
=====================  ==============================  =========

INKARM_MAX_COMPUTE_S bounds work that is not in proportion to any allocation: O(n^3) dense
algebra (LQT eigen draws, covariance and oracle; minimum-jerk systems) and many small pieces
(human-line samples). Its estimates are measured constants times the work (stated where they
are computed: :mod:`inkarm.models.lqt.cost`, :mod:`inkarm.models.human_line`,
:mod:`inkarm.models.minjerk`), on the 2-core development machine (a faster one finishes
sooner than estimated).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from inkarm.errors import InputError

MB = 1024 * 1024


@dataclass(frozen=True)
class Limit:
    """One budget: its environment variable, default and unit."""

    variable: str
    default: float
    unit: str

    @property
    def value(self) -> float:
        """The limit in force: the environment variable if set (and a positive number), else
        the default."""
        text = os.environ.get(self.variable, "")
        if not text:
            return self.default
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"expected a positive number, got {text!r}", key=self.variable,
                             value=text)
        return value


MEMORY_MB = Limit("INKARM_MAX_MEMORY_MB", 1024.0, "MB")
STEPS = Limit("INKARM_MAX_STEPS", 1_000_000, "time steps")
SAMPLES = Limit("INKARM_MAX_SAMPLES", 10_000, "samples")
SIM_S = Limit("INKARM_MAX_SIM_S", 600.0, "s")
TEXT = Limit("INKARM_MAX_TEXT", 20_000, "characters")
DPPLA_STEPS = Limit("INKARM_MAX_DPPLA_STEPS", 2e9, "DP steps")  # the exact 2,820-sample bench
GA_INDIVIDUALS = Limit("INKARM_MAX_GA_INDIVIDUALS", 250_000, "individuals")  # ~30 s of GA
COMPUTE_S = Limit("INKARM_MAX_COMPUTE_S", 10.0, "s")  # estimated seconds (measured rates)


class BudgetError(InputError):
    """A job whose estimated cost exceeds a budget; ``estimate`` and ``limit`` carry the
    numbers, ``variable`` the setting that raises it."""

    def __init__(self, message: str, *, estimate: float, limit: float, variable: str,
                 **context):
        super().__init__(message, **context)
        self.estimate = estimate
        self.limit = limit
        self.variable = variable


def _amount(value: float, unit: str) -> str:
    if unit == "MB" and value >= 1024:
        return f"{value / 1024:.3g} GB"
    return f"{value:.4g} {unit}"


def require(estimate: float, limit: Limit, what: str, *, key: str | None = None,
            value=InputError.NO_VALUE, file: str | None = None) -> None:
    """Refuse a job whose ``estimate`` (in ``limit``'s unit) exceeds ``limit``: the message
    names the input (``key``, ``value``), ``what`` the estimate is of, the estimate, the limit
    and the setting that raises it."""
    bound = limit.value
    if not (estimate <= bound):  # also refuses NaN estimates
        raise BudgetError(
            f"{what}: about {_amount(estimate, limit.unit)}, more than the limit of "
            f"{_amount(bound, limit.unit)} (raise it with the environment variable "
            f"{limit.variable})", estimate=float(estimate), limit=bound,
            variable=limit.variable, key=key, value=value, file=file)


def require_memory(n_bytes: float, what: str, **context) -> None:
    """:func:`require` on an estimate in bytes against :data:`MEMORY_MB`."""
    require(n_bytes / MB, MEMORY_MB, what, **context)
