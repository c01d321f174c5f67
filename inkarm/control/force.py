"""The force loop and the paper's surface estimate: a reference shaper every law gets.

Where the plant senses the pen force F, the executor (:mod:`inkarm.control.executor`) shapes the
reference before each law sees it: the pen reference is pushed a depth d along the paper normal
(mapped to joints through the planned direction J5^+ (-n)), with

    F_f <- F_f + dt / (tau + dt) (F - F_f)          low-pass of the sensed force (tau = force_filter_s)
    z   <- max(z + k_F dt (F* - F_f), -z_max)       while touching: the integral force loop
    z   <- z + v_s dt                               no contact where the model puts the paper:
                                                    the guarded search, up to z_max

while drawing, at the end of each descent, and during a descent once touching (the paper may be
higher than believed). The depth a law gets, at the commanded plan row p (``Setpoint.depth``,
already in ``Setpoint.q``), is

    d(p) = z + P(p) + G(p) + tau_L r + M(p + tau_M v)

- P: the sheet's plane (:class:`inkarm.control.surface.SurfaceEstimate`), fitted to the depths
  where the force has settled (|F_f - F*| < settle_tol_n);
- G: a height field learnt while drawing (:class:`inkarm.control.heightmap.LearntField`, with
  ``surface_cell_mm`` > 0) from every period drawing in the trust region below, for places the
  pen comes back to;
- tau_L r: the relief ahead, measured. Each such period measures the depth of the surface
  where the pen was beyond what the map says, from the depth commanded ``lag`` periods before
  (lag = 1 + the actuation lead in periods; its map and lead shares left out) and how much the
  force missed by, through the contact's series stiffness k_c = (1/k_pen + 1/k_paper)^-1 of the
  controller's model::

      h = (z + P + G)[lag periods ago] - (F_f - F*) / k_c
      r <- r + dt / (tau_r + dt) ((h - h_prev) / dt - r)      the surface's rate [m/s]

  and ``surface_lead_s`` tau_L times that rate, less a dead band r0 (:data:`RATE_DEAD_BAND`),
  is fed forward: tau_L sign(r) max(|r| - r0, 0), the surface tau_L further along to first
  order (leaving the lead out of h keeps it from feeding on itself);
- M: the calibrated height map (``KinematicModel.paper_map``) as a depth, the prior
  (:class:`inkarm.control.heightmap.MapPrior`; 0 without a calibration), read ``map_lead_s``
  tau_M ahead along the plan (v: the commanded point's velocity, from the last period's point).

Why a lead: the pen's depth follows its reference some 25-35 ms late (the arm's joint loops see
the depth as a position step, without a velocity feed-forward), and the integrator alone is slow
for relief: k_F k_c = 100 mm/(N s) x 0.26 N/mm = 26 rad/s, while a 30 mm wave drawn at 90..240
mm/s comes at 19..50 rad/s. Above that (a 10 mm wave at those speeds, 60..150 rad/s) the measured
rate lags too much to help: only a map does. On a smooth sheet the lead only differentiates the
force's noise: hence its dead band, and its trust region (0.5 F* < F_f < 1.5 F*, where the contact
is the linear spring k_c; beyond, the pen is leaving the paper or hitting it, as a loop at the edge
of stability does, and the lead starts again from 0). The map's read-ahead (``map_lead_s``)
acts only with a map.

With a calibrated map the loop follows the map's residual only: ``map_force_filter_s`` (5 ms)
filters the force and ``map_surface_lead_s`` (0: none) replaces tau_L. On the calibrated mix of
issue 23 (relief, pen and arm errors, friction 1.5x, 2 + 2 ms delays, 0-6 ms read-out jitter)
the force's extremes are where the map changes fastest: the 8 mm bump on the letter's diagonal,
crossed at 280 mm/s in 29 ms, about the pen's own lag. There the residual the lead measures is
the map's timing error, seen 1 + lag periods and a filter late: the lead came in anti-phase
(-0.75 then +1.0 mm within 25 ms, the force 0.70..1.20 N). Without it, and with the shorter
filter (it smooths the lead's derivative; with no lead to feed, it only delays the
integrator), 11 of 18 calibrated plants held 1 +- 0.1 N against 7 of 18 (RMS of F - F* 0.043 ->
0.038 N, the worst half-band 0.29 -> 0.15 N).

Each settled sample moves its depth from the integrator into P and each contact sample from the
integrator into G ("shared anew": z loses what the estimate gained at that point), so the depth
at the current point is unchanged by learning and the integrator keeps only the residual.

Units: forces [N], depths [m] (SI, as the joint arrays), page positions [mm].
"""

from __future__ import annotations

from collections import deque

from inkarm.control.config import LoopConfig
from inkarm.control.heightmap import LearntField, MapPrior
from inkarm.control.surface import SurfaceEstimate
from inkarm.core.log import DESCEND, DRAW
from inkarm.errors import RunFault

# Rates of the measured surface below this are taken as noise [m/s]: the sensed force's jitter
# through 1/k_c (0.05 N at 0.26 N/mm is 0.2 mm) differentiated; with joint read-out noise of
# 1e-4 rad and delays the lead would otherwise push the force out of its band (the careful
# controller's row, the realistic scenario's ensemble). A 1 mm wave of 30 mm drawn at 90 mm/s
# changes at up to 19 mm/s.
RATE_DEAD_BAND = 4e-3


class ForceLoop:
    """The force loop of one plant (module docstring); ``shape`` once per control period.

    Args:
        config: ``force_n`` (F*), ``force_gain_mm_per_ns`` (k_F), ``force_filter_s``,
            ``contact_threshold_n``, ``settle_tol_n``, ``search_speed_mm_s`` (v_s),
            ``correction_limit_mm`` (z_max), ``surface_lead_s`` (tau_L),
            ``surface_rate_filter_s`` (tau_r), ``surface_cell_mm`` (G's grid; 0: none),
            ``map_lead_s`` (tau_M), ``lookahead_s`` (the actuation lead); with a ``prior``,
            ``map_force_filter_s`` and ``map_surface_lead_s`` in place of ``force_filter_s`` and
            ``surface_lead_s``.
        dt: Control period [s].
        surface: Where settled depths go (a fresh plane by default).
        contact_stiffness_n_per_mm: k_c, the pen and the underlay in series [N/mm]; None: no
            lead (tau_L r = 0) and no learnt field (both measure the surface through it).
        prior: The calibrated height map (``KinematicModel.paper_map``); None: flat.
    """

    __slots__ = ("_depths", "_h_prev", "_inv_dt", "_k_inv", "_last", "_lead", "_lead_gain",
                 "_map_ahead", "_rate_smoothing", "_sampling", "contact_stiffness", "f_star",
                 "field", "force", "k_force", "limit_mm", "prior", "rate", "search_step",
                 "settle_tol", "smoothing", "surface", "threshold", "z", "z_limit")

    def __init__(self, config: LoopConfig, dt: float, surface: SurfaceEstimate | None = None,
                 contact_stiffness_n_per_mm: float | None = None, prior=None):
        self.surface = surface or SurfaceEstimate()
        self.z = 0.0  # the integrator's correction along the normal [m] (positive: deeper)
        self.force = 0.0  # the low-passed force F_f [N]
        self.k_force = config.force_gain_mm_per_ns / 1000.0 * dt  # [m/N] per period
        self.search_step = config.search_speed_mm_s / 1000.0 * dt  # [m] per period
        self.z_limit = config.correction_limit_mm / 1000.0
        self.limit_mm = config.correction_limit_mm
        self.f_star, self.threshold = config.force_n, config.contact_threshold_n
        self.settle_tol = config.settle_tol_n
        self.prior = MapPrior(prior) if prior is not None else None
        mapped = self.prior is not None  # a calibrated map: its own filter and lead
        self.smoothing = dt / ((config.map_force_filter_s if mapped else config.force_filter_s)
                               + dt)
        self._map_ahead = config.map_lead_s / dt  # tau_M in periods
        self._last: tuple[float, float] | None = None  # the last commanded page point [mm]
        sensing = contact_stiffness_n_per_mm is not None and contact_stiffness_n_per_mm > 0
        self.contact_stiffness = contact_stiffness_n_per_mm if sensing else None  # k_c [N/mm]
        self.field = (LearntField(config.surface_cell_mm) if sensing and config.surface_cell_mm
                      else None)
        # The surface's rate r [m/s] and what measures it: 1/k_c [m/N], the rate's filter gain
        # over dt, the lead, the last measured height, and the depths (and their page points)
        # commanded the last ``lag`` periods, less the lead's share.
        self.rate = 0.0
        self._lead = 0.0  # tau_L r, this period's [m]
        self._lead_gain = ((config.map_surface_lead_s if mapped else config.surface_lead_s)
                           if sensing else 0.0)
        self._sampling = sensing and (self._lead_gain > 0 or self.field is not None)
        self._k_inv = 1.0 / (contact_stiffness_n_per_mm * 1000.0) if sensing else 0.0
        self._rate_smoothing = dt / (config.surface_rate_filter_s + dt)
        self._inv_dt = 1.0 / dt
        self._h_prev: float | None = None
        lag = 1 + round(config.lookahead_s / dt)
        self._depths: deque = deque([(0.0, 0.0, 0.0)] * lag, maxlen=lag)

    @classmethod
    def of_model(cls, config: LoopConfig, dt: float, model) -> ForceLoop:
        """The force loop for the controller's ``model`` (a
        :class:`inkarm.robots.kinematic.KinematicModel`): k_c from its pen (or
        ``config.pen_stiffness_n_per_mm``) and underlay (rigid: the pen alone), its
        ``paper_map`` as the prior."""
        k_pen = (model.pen_stiffness_n_per_mm if config.pen_stiffness_n_per_mm is None
                 else config.pen_stiffness_n_per_mm)
        k_paper = model.paper_stiffness_n_per_mm
        k_c = k_pen * k_paper / (k_pen + k_paper) if k_paper > 0 else k_pen
        return cls(config, dt, contact_stiffness_n_per_mm=k_c,
                   prior=model.paper_map)

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
                    raise self.search_failed(time)
            if self._sampling:
                self._measure(f, phase == DRAW and 0.5 * self.f_star < f < 1.5 * self.f_star)
            if (phase == DRAW or holding) and abs(f - self.f_star) < self.settle_tol:
                surface = self.surface
                x, y = x_mm / 1000.0, y_mm / 1000.0
                before = surface.height(x, y)
                surface.add(x, y, before + self.z)
                self.z -= surface.height(x, y) - before  # the same depth, shared anew
        elif self._sampling:
            self._measure(f, False)
        return f

    def restore(self, state: dict) -> None:
        """Go on from a state kept elsewhere (the member's compiled period hands its own back,
        :meth:`inkarm.control.member_lane.Lane.hand_over`): ``z``, ``force``, ``rate``,
        ``lead``, ``h_prev``, the recent ``depths`` and the surface's ``sums``, ``count``,
        ``coef`` and ``origin``."""
        self.z, self.force, self.rate = state["z"], state["force"], state["rate"]
        self._lead, self._h_prev = state["lead"], state["h_prev"]
        self._depths.extend(state["depths"])
        self.surface.restore(state["sums"], state["count"], state["coef"], state["origin"])

    def search_failed(self, time: float) -> RunFault:
        """The fault of a guarded search that ran out of range at plant ``time`` [s]."""
        return RunFault(f"paper_not_found: no contact within {self.limit_mm:g} mm beyond where "
                        f"the model puts the paper, at t = {time:.3f} s",
                        watchdog="paper_not_found", time_s=time)

    def _measure(self, f: float, touching: bool) -> None:
        """The surface's depth h where the pen was ``lag`` periods ago, its rate and the lead
        (module docstring); G learns h less P there. Nothing while not ``touching`` (drawing,
        with 0.5 F* < F_f < 1.5 F*: the trust region): the rate starts again from 0 at the next
        such period."""
        if not touching:
            self._h_prev, self.rate, self._lead = None, 0.0, 0.0
            return
        d, x, y = self._depths[0]
        h = d - (f - self.f_star) * self._k_inv
        if self._h_prev is not None:
            self.rate += self._rate_smoothing * ((h - self._h_prev) * self._inv_dt - self.rate)
            r = self.rate  # (less the dead band: the force's noise through 1/k_c)
            r = r - RATE_DEAD_BAND if r > RATE_DEAD_BAND else (
                r + RATE_DEAD_BAND if r < -RATE_DEAD_BAND else 0.0)
            self._lead = self._lead_gain * r
        self._h_prev = h
        field = self.field
        if field is not None:
            before = field.height(x, y)
            field.add(x, y, h - self.surface.height(x / 1000.0, y / 1000.0))
            self.z -= field.height(x, y) - before  # the same depth, shared anew

    def depth(self, x_mm: float, y_mm: float,
              ahead_mm: tuple[float, float] | None = None) -> float:
        """How far beyond the model's paper to press at page point ``x_mm``, ``y_mm`` [m]: d(p)
        of the module docstring. Called once per period, at the commanded plan row. The map is
        read at ``ahead_mm``, the plan's point ``map_lead_s`` further on, where the caller
        knows it (along the path, round corners); else tau_M ahead on the line through the
        last call's point."""
        d = self.z + self.surface.height(x_mm / 1000.0, y_mm / 1000.0)
        if self.field is not None:
            d += self.field.height(x_mm, y_mm)
        if self._sampling:
            self._depths.append((d, x_mm, y_mm))
            d += self._lead
        if self.prior is not None:
            ahead, (x0, y0) = self._map_ahead, self._last or (x_mm, y_mm)
            self._last = (x_mm, y_mm)
            if ahead_mm is None:
                ahead_mm = (x_mm + ahead * (x_mm - x0), y_mm + ahead * (y_mm - y0))
            d += self.prior.height(*ahead_mm)
        return d


__all__ = ["RATE_DEAD_BAND", "ForceLoop"]
