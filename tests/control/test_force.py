"""The force loop against its closed forms: the low-pass, the integrator, its clamp, the
guarded search and its fault, and the surface it learns where the force settles."""

from __future__ import annotations

import math

import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.force import ForceLoop
from inkarm.core.log import APPROACH, DESCEND, DRAW
from inkarm.errors import RunFault

DT = 0.006


def press(loop, force, periods, phase=DRAW, x=100.0, y=100.0, holding=False):
    for k in range(periods):
        out = loop.shape(force, k * DT, phase, holding, phase == DRAW, x, y)
    return out


def test_the_low_pass_follows_a_step_as_its_closed_form():
    loop = ForceLoop(LoopConfig(force_filter_s=0.01), DT)
    a = DT / (0.01 + DT)
    for k in range(1, 20):
        f = loop.shape(2.0, k * DT, APPROACH, False, False, 0.0, 0.0)
        assert f == pytest.approx(2.0 * (1.0 - (1.0 - a) ** k), rel=1e-12)
    assert loop.z == 0.0  # away from the paper nothing is pressed


def test_the_integrator_moves_k_f_dt_times_the_error_each_period():
    config = LoopConfig(force_filter_s=0.0, force_gain_mm_per_ns=40.0, settle_tol_n=0.05)
    loop = ForceLoop(config, DT)
    press(loop, 1.5, 25)  # 0.5 N too hard: back off, never settled
    assert loop.z == pytest.approx(-25 * 40.0e-3 * DT * 0.5, rel=1e-12)
    assert loop.surface.count == 0
    assert loop.depth(100.0, 100.0) == loop.z


def test_the_correction_is_clamped_at_the_search_range():
    loop = ForceLoop(LoopConfig(force_filter_s=0.0, correction_limit_mm=1.0), DT)
    press(loop, 40.0, 2000)
    assert loop.z == pytest.approx(-1e-3)


def test_the_guarded_search_goes_deeper_and_stops_where_its_range_ends():
    config = LoopConfig(search_speed_mm_s=20.0, correction_limit_mm=3.0)
    loop = ForceLoop(config, DT)
    step, periods, z = 20.0e-3 * DT, 0, 0.0  # 0.12 mm a period, summed as the loop sums them
    while z < 3e-3:
        z, periods = z + step, periods + 1
    assert periods in (math.ceil(3.0 / 0.12), math.ceil(3.0 / 0.12) + 1)
    with pytest.raises(RunFault, match=r"^paper_not_found: no contact within 3 mm beyond where "
                                       r"the model puts the paper, at t = ") as info:
        press(loop, 0.0, periods + 1)
    assert info.value.watchdog == "paper_not_found"
    assert info.value.time_s == pytest.approx((periods - 1) * DT)


def test_a_descent_presses_only_once_touching():
    loop = ForceLoop(LoopConfig(force_filter_s=0.0), DT)
    press(loop, 0.0, 10, phase=DESCEND)  # in the air: no search yet
    assert loop.z == 0.0
    press(loop, 0.5, 1, phase=DESCEND)  # touching: the loop presses on
    assert loop.z > 0.0


def test_settled_depths_teach_the_surface_and_the_integrator_keeps_the_residual():
    """At the set point every period is a sample of the plane: the depth moves from the
    integrator into the surface estimate, and the depth a law gets stays what it was."""
    loop = ForceLoop(LoopConfig(force_filter_s=0.0), DT)
    loop.z = 0.002  # 2 mm deeper than the model's paper, found by the integrator
    for k, (x, y) in enumerate([(100.0, 100.0), (130.0, 100.0), (100.0, 140.0)] * 10):
        before = loop.depth(x, y)
        loop.shape(1.0, k * DT, DRAW, False, True, x, y)  # exactly F*: settled
        assert loop.depth(x, y) == pytest.approx(before, abs=1e-12)
    assert loop.surface.count == 30
    assert loop.surface.height(0.115, 0.12) == pytest.approx(0.002, abs=1e-9)
    assert abs(loop.z) < 1e-9
