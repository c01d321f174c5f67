"""The force loop and the paper's surface estimate: a reference shaper every law gets.

Where the plant senses the pen force F, the executor (:mod:`inkarm.control.executor`) shapes the
reference before each law sees it: the pen reference is pushed a depth z along the paper normal
(mapped to joints through the planned direction J5^+ (-n)), with

    F_f <- F_f + dt / (tau + dt) (F - F_f)          low-pass of the sensed force (tau = force_filter_s)
    z   <- max(z + k_F dt (F* - F_f), -z_max)       while touching: the integral force loop
    z   <- z + v_s dt                               no contact where the model puts the paper:
                                                    the guarded search, up to z_max

while drawing, at the end of each descent, and during a descent once touching (the paper may be
higher than believed). Where the force has settled (|F_f - F*| < settle_tol_n) the depth is a
sample of the paper's surface (:class:`inkarm.control.surface.SurfaceEstimate`), whose fitted
height is fed forward: the integrator keeps only the residual. The depth a law gets is
z + h(x, y) at the commanded plan row (``Setpoint.depth``, already in ``Setpoint.q``).

Units: forces [N], depths [m] (SI, as the joint arrays), page positions [mm].
"""

from __future__ import annotations

from inkarm.control.config import LoopConfig
from inkarm.control.surface import SurfaceEstimate
from inkarm.core.log import DESCEND, DRAW
from inkarm.errors import RunFault


class ForceLoop:
    """The force loop of one plant (module docstring); ``shape`` once per control period.

    Args:
        config: ``force_n`` (F*), ``force_gain_mm_per_ns`` (k_F), ``force_filter_s``,
            ``contact_threshold_n``, ``settle_tol_n``, ``search_speed_mm_s`` (v_s),
            ``correction_limit_mm`` (z_max).
        dt: Control period [s].
        surface: Where settled depths go (a fresh estimate by default).
    """

    __slots__ = ("f_star", "force", "k_force", "limit_mm", "search_step", "settle_tol",
                 "smoothing", "surface", "threshold", "z", "z_limit")

    def __init__(self, config: LoopConfig, dt: float, surface: SurfaceEstimate | None = None):
        self.surface = surface or SurfaceEstimate()
        self.z = 0.0  # the integrator's correction along the normal [m] (positive: deeper)
        self.force = 0.0  # the low-passed force F_f [N]
        self.k_force = config.force_gain_mm_per_ns / 1000.0 * dt  # [m/N] per period
        self.search_step = config.search_speed_mm_s / 1000.0 * dt  # [m] per period
        self.z_limit = config.correction_limit_mm / 1000.0
        self.limit_mm = config.correction_limit_mm
        self.f_star, self.threshold = config.force_n, config.contact_threshold_n
        self.settle_tol = config.settle_tol_n
        self.smoothing = dt / (config.force_filter_s + dt)

    def shape(self, force: float, time: float, phase: int, holding: bool, pressing: bool,
              x_mm: float, y_mm: float) -> float:
        """Take this period's sensed ``force`` [N] at plant ``time`` [s] in plan ``phase``
        (``holding``: a descent's end waiting for the force to settle; ``pressing``: drawing or
        settling), the plan row's page point ``x_mm``, ``y_mm``; return the low-passed force.
        Raises :class:`RunFault` ``paper_not_found`` when the search runs out of range."""
        f = self.force = self.force + self.smoothing * (force - self.force)
        if pressing or (phase == DESCEND and f > self.threshold):
            if f > self.threshold:
                self.z = max(self.z + self.k_force * (self.f_star - f), -self.z_limit)
            else:  # guarded search: no paper where the model puts it; go deeper
                self.z += self.search_step
                if self.z >= self.z_limit:
                    raise RunFault(
                        f"paper_not_found: no contact within {self.limit_mm:g} mm beyond where "
                        f"the model puts the paper, at t = {time:.3f} s",
                        watchdog="paper_not_found", time_s=time)
            if (phase == DRAW or holding) and abs(f - self.f_star) < self.settle_tol:
                surface = self.surface
                x, y = x_mm / 1000.0, y_mm / 1000.0
                before = surface.height(x, y)
                surface.add(x, y, before + self.z)
                self.z -= surface.height(x, y) - before  # the same depth, shared anew
        return f

    def depth(self, x_mm: float, y_mm: float) -> float:
        """How far beyond the model's paper to press at page point ``x_mm``, ``y_mm`` [m]."""
        return self.z + self.surface.height(x_mm / 1000.0, y_mm / 1000.0)


__all__ = ["ForceLoop"]
