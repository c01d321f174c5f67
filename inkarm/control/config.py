"""LoopConfig: the sequencing, force-control and watchdog settings of a drawing run (the
``[controller]`` table; the control law and its own settings are :mod:`inkarm.control.laws`)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from inkarm.core.ranges import Range as _R
from inkarm.core.ranges import check_ranges
from inkarm.errors import InputError

# Plausible ranges (generous for any drawing robot; finite so nothing downstream overflows).
RANGES = {
    "force_n": _R(0.0, 50.0, "N", open_low=True),
    "pen_stiffness_n_per_mm": _R(1e-3, 1e3, "N/mm"),
    "hover_mm": _R(0.0, 200.0, "mm", open_low=True),
    "descend_s": _R(0.0, 60.0, "s", open_low=True),
    "lift_s": _R(0.0, 60.0, "s", open_low=True),
    "travel_speed_mm_s": _R(0.0, 5000.0, "mm/s", open_low=True),
    "joint_speed_rad_s": _R(0.0, 20.0, "rad/s", open_low=True),
    "nib_friction": _R(0.0, 5.0),
    "force_gain_mm_per_ns": _R(0.0, 1e4, "mm/(N s)"),
    "correction_limit_mm": _R(0.0, 100.0, "mm"),
    "settle_tol_n": _R(0.0, 50.0, "N"),
    "settle_s": _R(0.0, 60.0, "s"),
    "settle_timeout_s": _R(0.0, 60.0, "s"),
    "contact_threshold_n": _R(0.0, 50.0, "N"),
    "posture_rate": _R(0.0, 1e3, "1/s"),
    "ik_period_s": _R(0.0, 1.0, "s", open_low=True),
    "force_filter_s": _R(0.0, 1.0, "s"),
    "search_speed_mm_s": _R(0.0, 500.0, "mm/s", open_low=True),
    "force_limit_n": _R(0.0, 500.0, "N", open_low=True),
    "tracking_limit_mm": _R(0.0, 1000.0, "mm", open_low=True),
    "watchdog_s": _R(0.0, 10.0, "s"),
    "saturation_s": _R(0.0, 10.0, "s"),
    "stop_s": _R(0.0, 10.0, "s", open_low=True),
    "friction_adaptation": _R(0.0, 1e9, "N m/(rad s)"),
    "lookahead_s": _R(0.0, 1.0, "s"),
    "surface_lead_s": _R(0.0, 0.2, "s"),
    "surface_rate_filter_s": _R(0.0, 1.0, "s"),
    "surface_cell_mm": _R(0.0, 100.0, "mm"),
    "map_lead_s": _R(0.0, 0.2, "s"),
    "map_surface_lead_s": _R(0.0, 0.2, "s"),
    "map_force_filter_s": _R(0.0, 1.0, "s"),
    "relief_accel_mm_s2": _R(0.0, 1e6, "mm/s^2"),
}


@dataclass(frozen=True)
class LoopConfig:
    """Sequencing and force-control settings. Lengths in [mm], times in [s], forces in [N].

    Attributes:
        force_n: Contact force set point F*.
        pen_stiffness_n_per_mm: Pen spring rate; the kinematic model's when None.
        hover_mm: Pen height above the paper while travelling.
        descend_s: Duration of the descent from hover to the nominal pen compression.
        lift_s: Duration of the lift back to hover height.
        travel_speed_mm_s: Peak speed of the minimum-jerk travel between strokes.
        joint_speed_rad_s: Peak joint speed of the joint-space approach and home moves.
        nib_friction: Nib-paper friction coefficient of the drag feed-forward; the kinematic
            model's when None.
        force_gain_mm_per_ns: k_F of the force integrator dz/dt = k_F (F* - F), in [mm/(N s)].
        correction_limit_mm: Bound of the force loop's correction along the normal: how far
            beyond where the model puts the paper the pen searches for it (and retracts).
        force_filter_s: Time constant of the low-pass on the sensed force before the force
            loop [s] (0: none).
        search_speed_mm_s: Speed of the guarded search for the paper after a descent that
            found no contact.
        settle_tol_n: |F - F*| below which the descent counts as settled.
        settle_s: How long the force must stay settled before the stroke starts.
        settle_timeout_s: Longest wait at the end of a descent.
        contact_threshold_n: Force above which the pen counts as touching.
        posture_rate: Null-space pull towards the home posture, in [1/s].
        ik_period_s: Spacing of the IK solutions along the path; a cubic spline fills in.
        go_home: Return to the home pose at the end.
        force_limit_n: Watchdog: the run fails when the filtered force exceeds this.
        tracking_limit_mm: Watchdog: ... when the pen is this far from its reference (page x,
            y) for ``watchdog_s``.
        watchdog_s: How long the tracking and joint-speed limits may be exceeded.
        saturation_s: Watchdog: ... when a joint torque stays at its limit this long.
        stop_s: Duration of the safe stop's lift after a fault.
        lookahead_s: The plant's actuation latency, as far as it is known [s]: commands lead
            the plan by it.
        friction_adaptation: Rate gamma of the Coulomb friction estimate's adaptation
            (:mod:`inkarm.control.friction`); 0 keeps the model's friction.
        speed_limits: What to do when the planned joint speed exceeds a joint's limit in the
            robot profile: "slow" (draw slower, stretching time by the excess, and say so) or
            "refuse" (raise, naming the joint).
        probe_paper: Before drawing, touch the paper at three points of the drawing's path and
            fit its plane (:mod:`inkarm.control.probe`), so that the first stroke already knows
            the sheet's height and tilt.
        surface_lead_s: tau_L: the force loop feeds forward the paper's surface this far
            ahead along the path, from the rate at which the depth of the surface under the pen
            changes (:mod:`inkarm.control.force`); 0: the integrator alone follows relief (as
            before issue 23).
        surface_rate_filter_s: tau_r: time constant of the low-pass on that rate [s].
        surface_cell_mm: Grid spacing of the height field learnt while drawing, for places the
            pen comes back to (:class:`inkarm.control.heightmap.LearntField`); 0: none (the
            sheet's plane and the lead only).
        map_lead_s: tau_M: how far ahead along the plan the calibrated height map
            (``KinematicModel.paper_map``) is read: the pen's depth follows its reference this
            much late [s]. Only with a map.
        map_surface_lead_s: tau_L where the controller has a calibrated map (in place of
            ``surface_lead_s``): the measured rate is then the map's residual, mostly the
            pen's timing around steep relief, which a lead measured a few periods late
            amplifies (issue 23's calibrated mix); 0: none.
        map_force_filter_s: ``force_filter_s`` where the controller has a calibrated map: the
            low-pass is there for the measured lead's derivative; without a lead to feed, a
            shorter one leaves the integrator less lag [s].
        relief_accel_mm_s2: With a calibrated map, strokes are slowed so that the height under
            the pen changes its rate by at most this [mm/s^2] (:mod:`inkarm.control.
            relief_speed`); 0: never.
    """

    force_n: float = 1.0
    pen_stiffness_n_per_mm: float | None = None
    hover_mm: float = 8.0
    descend_s: float = 0.3
    lift_s: float = 0.2
    travel_speed_mm_s: float = 150.0
    joint_speed_rad_s: float = 0.8
    nib_friction: float | None = None
    force_gain_mm_per_ns: float = 100.0
    correction_limit_mm: float = 10.0
    settle_tol_n: float = 0.05
    settle_s: float = 0.03
    settle_timeout_s: float = 0.6
    contact_threshold_n: float = 0.02
    posture_rate: float = 0.5
    ik_period_s: float = 0.012
    go_home: bool = True
    speed_limits: str = "slow"
    force_filter_s: float = 0.01
    search_speed_mm_s: float = 20.0
    force_limit_n: float = 5.0
    tracking_limit_mm: float = 5.0
    watchdog_s: float = 0.05
    saturation_s: float = 0.1
    stop_s: float = 0.06
    friction_adaptation: float = 2e4
    lookahead_s: float = 0.0
    probe_paper: bool = False
    surface_lead_s: float = 0.03
    surface_rate_filter_s: float = 0.01
    surface_cell_mm: float = 0.0
    map_lead_s: float = 0.03
    map_surface_lead_s: float = 0.0
    map_force_filter_s: float = 0.005
    relief_accel_mm_s2: float = 500.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(f.default, bool) and not isinstance(value, bool):
                raise InputError(f"expected true or false, got {value!r}", key=f.name,
                                 value=value)
            if isinstance(f.default, int | float) and not isinstance(f.default, bool) and (
                    isinstance(value, bool) or not isinstance(value, int | float | np.number)):
                raise InputError(f"expected a number, got {value!r}", key=f.name, value=value)
            if isinstance(value, float) and not np.isfinite(value):
                raise InputError(f"expected a finite number, got {value}", key=f.name,
                                 value=value)
        check_ranges(self, RANGES)
        if self.speed_limits not in ("slow", "refuse"):
            raise InputError(f"expected 'slow' or 'refuse', got {self.speed_limits!r}",
                             key="speed_limits", value=self.speed_limits,
                             choices=("slow", "refuse"))
