"""The force loop against its closed forms: the low-pass, the integrator, its clamp, the
guarded search and its fault, and the surface it learns where the force settles."""

from __future__ import annotations

import math

import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.force import RATE_DEAD_BAND, ForceLoop
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


# The relief ahead, the learnt field and the map (issue 23): closed forms of the module docstring.
K_C = 0.25  # contact stiffness k_c [N/mm]
MEASURING = {"force_filter_s": 0.0, "force_gain_mm_per_ns": 0.0, "settle_tol_n": 0.0,
             "surface_lead_s": 0.03, "surface_rate_filter_s": 0.01, "map_force_filter_s": 0.0}


def period(loop, force, k, x=100.0, y=100.0, phase=DRAW):
    """One control period as the executor runs it: shape, then the depth at the plan row."""
    loop.shape(force, k * DT, phase, False, phase == DRAW, x, y)
    return loop.depth(x, y)


def test_the_lead_is_tau_l_times_the_low_passed_rate_of_the_measured_surface():
    """A sheet rising at s = 10 mm/s under a pen held still: the force grows by k_c s dt a
    period, each period measures the surface h_n = -s n dt, its rate after n periods is
    r_n = -s (1 - (1 - a)^n) with a = dt / (tau_r + dt), and the lead tau_L (r_n + r0) once
    |r_n| exceeds the dead band r0 (0 before)."""
    loop = ForceLoop(LoopConfig(**MEASURING), DT, contact_stiffness_n_per_mm=K_C)
    assert loop.contact_stiffness == K_C
    s, a = 0.01, DT / (0.01 + DT)
    for n in range(30):  # (the force stays below 1.5 F*: the trust region)
        depth = period(loop, 1.0 + K_C * 1000.0 * s * n * DT, n)
        rate = -s * (1.0 - (1.0 - a) ** n)
        assert loop.rate == pytest.approx(rate, rel=1e-9, abs=1e-15)
        lead = 0.03 * (rate + RATE_DEAD_BAND) if rate < -RATE_DEAD_BAND else 0.0
        assert depth == pytest.approx(lead, rel=1e-9, abs=1e-15)
    assert depth < -0.03 * (s - RATE_DEAD_BAND) * 0.999
    assert loop.z == 0.0  # (k_F = 0: only the lead moved the pen)


def test_the_lead_never_feeds_on_itself():
    """Its own share is left out of the measured surface: at F* the surface is still, so a
    rate decays by (1 - a) a period instead of growing with the depth it commands."""
    loop = ForceLoop(LoopConfig(**MEASURING), DT, contact_stiffness_n_per_mm=K_C)
    period(loop, 1.0, 0)
    loop.rate = 0.05
    a = DT / (0.01 + DT)
    for n in range(1, 30):
        depth = period(loop, 1.0, n)
        assert loop.rate == pytest.approx(0.05 * (1.0 - a) ** n, rel=1e-12)
        assert depth == pytest.approx(0.03 * max(loop.rate - RATE_DEAD_BAND, 0.0), rel=1e-12)


def test_the_force_is_paired_with_the_depth_commanded_lag_periods_before():
    """With an actuation lead of two periods (lookahead_s) the force answers the depth
    commanded three periods before: a step of the depth at period 10 is seen at period 13."""
    config = LoopConfig(**MEASURING, lookahead_s=2 * DT)
    loop = ForceLoop(config, DT, contact_stiffness_n_per_mm=K_C)
    a = DT / (0.01 + DT)
    for n in range(16):
        loop.shape(1.0, n * DT, DRAW, False, True, 100.0, 100.0)
        if n < 13:
            assert loop.rate == 0.0
        elif n == 13:
            assert loop.rate == pytest.approx(a * 1e-3 / DT, rel=1e-12)
        loop.z = 1e-3 if n >= 10 else 0.0
        loop.depth(100.0, 100.0)


def test_leaving_or_hitting_the_paper_drops_the_lead_and_no_stiffness_has_none():
    loop = ForceLoop(LoopConfig(**MEASURING), DT, contact_stiffness_n_per_mm=K_C)
    for n in range(10):
        period(loop, 1.0 + 0.04 * n, n)
    assert loop.depth(100.0, 100.0) < 0.0
    # beyond the trust region 0.5 F* < F < 1.5 F* (hitting the paper): no lead
    assert period(loop, 1.5, 10) == loop.z == 0.0 and loop.rate == 0.0
    for n in range(11, 20):
        period(loop, 1.0 + 0.04 * (n - 11), n)
    assert loop.depth(100.0, 100.0) < 0.0
    # no contact: the lead is gone (and the guarded search goes one step deeper)
    assert period(loop, 0.0, 20) == loop.z == pytest.approx(20e-3 * DT) and loop.rate == 0.0
    blind = ForceLoop(LoopConfig(**MEASURING, surface_cell_mm=5.0), DT)  # no k_c
    for n in range(10):
        assert period(blind, 1.0 + 0.1 * n, n) == 0.0
    assert blind.field is None and blind.contact_stiffness is None


def test_the_field_takes_its_depth_from_the_integrator_and_keeps_the_pressed_depth():
    """Every period in contact is a sample of G at the point commanded a period before; the
    integrator gives up what G gained there, so z + G at the sample point stays 2 mm."""
    config = LoopConfig(**{**MEASURING, "surface_lead_s": 0.0}, surface_cell_mm=5.0)
    loop = ForceLoop(config, DT, contact_stiffness_n_per_mm=K_C)
    loop.z = 0.002
    loop.depth(100.0, 100.0)
    for n in range(200):
        loop.shape(1.0, n * DT, DRAW, False, True, 100.0, 100.0)
        assert loop.z + loop.field.height(100.0, 100.0) == pytest.approx(0.002, abs=1e-15)
        loop.depth(100.0, 100.0)
    assert loop.field.count == 200 and loop.z < 0.002 / 100  # (w0 = 1 sample of 200)
    assert loop.field.height(130.0, 100.0) == 0.0  # far away: nothing learnt


def test_the_map_is_read_tau_m_ahead_along_the_commanded_path():
    """A map rising 0.01 mm per mm along x, the plan moving 1 mm a period: with tau_M = 5
    periods the depth is the map's 5 mm further on (the first period: where it is)."""
    from inkarm.robots.calibration import HeightMap

    ramp = HeightMap([0.0, 200.0], [0.0, 300.0], [[0.0, 2.0], [0.0, 2.0]])
    config = LoopConfig(**{**MEASURING, "map_lead_s": 5 * DT})
    loop = ForceLoop(config, DT, contact_stiffness_n_per_mm=K_C, prior=ramp)
    assert loop.depth(50.0, 100.0) == pytest.approx(-0.5e-3, rel=1e-12)
    for x in (51.0, 52.0, 53.0):
        assert loop.depth(x, 100.0) == pytest.approx(-0.01e-3 * (x + 5.0), rel=1e-12)
    assert loop.depth(53.0, 100.0) == pytest.approx(-0.53e-3, rel=1e-12)  # at rest: there


def test_the_loop_of_a_model_has_its_pen_and_underlay_in_series_and_its_map():
    from types import SimpleNamespace

    model = SimpleNamespace(pen_stiffness_n_per_mm=0.3, paper_stiffness_n_per_mm=2.0,
                            paper_map=None)
    assert ForceLoop.of_model(LoopConfig(), DT, model).contact_stiffness == pytest.approx(
        0.3 * 2.0 / 2.3)
    rigid = SimpleNamespace(**{**vars(model), "paper_stiffness_n_per_mm": 0.0})
    assert ForceLoop.of_model(LoopConfig(), DT, rigid).contact_stiffness == 0.3
    stiffer = ForceLoop.of_model(LoopConfig(pen_stiffness_n_per_mm=2.0), DT, model)
    assert stiffer.contact_stiffness == pytest.approx(1.0) and stiffer.prior is None


def test_far_from_every_sample_the_depth_is_the_prior_and_the_plane():
    """Samples near (100, 100) teach the field there; at (160, 100), three cells away, the
    depth is what the map and the integrator say, as before any sample."""
    from inkarm.robots.calibration import HeightMap

    raised = HeightMap([0.0, 210.0], [0.0, 297.0], [[2.0, 2.0], [2.0, 2.0]])  # 2 mm higher
    config = LoopConfig(**{**MEASURING, "surface_lead_s": 0.0}, surface_cell_mm=5.0)
    loop = ForceLoop(config, DT, contact_stiffness_n_per_mm=K_C, prior=raised)
    loop.depth(100.0, 100.0)
    for n in range(50):
        period(loop, 1.2, n)  # pressing 0.2 N too hard: the surface is 0.8 mm higher here
    assert loop.field.height(100.0, 100.0) == pytest.approx(-0.2 / K_C / 1000.0, rel=0.05)
    assert loop.depth(160.0, 100.0) == pytest.approx(loop.z - 0.002, abs=1e-15)


@pytest.mark.parametrize(("key", "value", "message"), [
    ("surface_lead_s", 0.5, r"surface_lead_s: expected a number in \[0, 0.2\] s, got 0.5"),
    ("surface_rate_filter_s", -0.01, r"surface_rate_filter_s: expected a number in \[0, 1\] s"),
    ("surface_cell_mm", -1.0, r"surface_cell_mm: expected a number in \[0, 100\] mm, got -1.0"),
    ("map_lead_s", "soon", r"map_lead_s: expected a number, got 'soon'"),
])
def test_the_surface_settings_are_refused_out_of_range_by_name(key, value, message):
    from inkarm.errors import InputError

    with pytest.raises(InputError, match=message) as info:
        LoopConfig(**{key: value})
    assert info.value.key == key


# With a calibrated map (issue 23's calibrated mix): the map's own filter and lead, and the map
# read at the plan's point ahead where the executor gives it.
def test_with_a_map_the_loop_takes_the_map_filter_and_lead_and_without_one_the_plain_ones():
    from inkarm.robots.calibration import HeightMap

    flat = HeightMap([0.0, 210.0], [0.0, 297.0], [[0.0, 0.0], [0.0, 0.0]])
    config = LoopConfig(force_filter_s=0.01, map_force_filter_s=0.004, surface_lead_s=0.03,
                        map_surface_lead_s=0.0)
    mapped = ForceLoop(config, DT, contact_stiffness_n_per_mm=K_C, prior=flat)
    plain = ForceLoop(config, DT, contact_stiffness_n_per_mm=K_C)
    assert mapped.smoothing == DT / (0.004 + DT) and plain.smoothing == DT / (0.01 + DT)
    assert mapped._lead_gain == 0.0 and plain._lead_gain == 0.03
    # the map's lead still measures when asked for (a sheet rising under a still pen)
    asked = ForceLoop(LoopConfig(**{**MEASURING, "map_surface_lead_s": 0.02}), DT,
                      contact_stiffness_n_per_mm=K_C, prior=flat)
    for n in range(30):
        depth = period(asked, 1.0 + K_C * 1000.0 * 0.01 * n * DT, n)
    assert asked.rate < -RATE_DEAD_BAND
    assert depth == pytest.approx(0.02 * (asked.rate + RATE_DEAD_BAND), rel=1e-9)
    # the default: no lead with a map, so the same rising sheet moves nothing but the rate
    quiet = ForceLoop(LoopConfig(**MEASURING), DT, contact_stiffness_n_per_mm=K_C, prior=flat)
    assert all(period(quiet, 1.0 + K_C * 1000.0 * 0.01 * n * DT, n) == 0.0 for n in range(30))


def test_the_map_is_read_at_the_point_ahead_the_caller_gives():
    """The point ahead along the plan (round a corner) wins over the straight line through the
    last call's point; the line takes over again where none is given."""
    from inkarm.robots.calibration import HeightMap

    ramp = HeightMap([0.0, 200.0], [0.0, 300.0], [[0.0, 2.0], [0.0, 2.0]])  # 0.01 mm per mm x
    loop = ForceLoop(LoopConfig(**{**MEASURING, "map_lead_s": 5 * DT}), DT,
                     contact_stiffness_n_per_mm=K_C, prior=ramp)
    loop.depth(50.0, 100.0)
    assert loop.depth(51.0, 100.0, (40.0, 120.0)) == pytest.approx(-0.4e-3, rel=1e-12)
    assert loop.depth(52.0, 100.0) == pytest.approx(-0.57e-3, rel=1e-12)  # 52 + 5 x 1 mm


@pytest.mark.parametrize(("key", "value", "message"), [
    ("map_surface_lead_s", 0.3, r"map_surface_lead_s: expected a number in \[0, 0.2\] s"),
    ("map_force_filter_s", -1.0, r"map_force_filter_s: expected a number in \[0, 1\] s"),
    ("map_force_filter_s", True, r"map_force_filter_s: expected a number, got True"),
])
def test_the_map_settings_are_refused_out_of_range_by_name(key, value, message):
    from inkarm.errors import InputError

    with pytest.raises(InputError, match=message) as info:
        LoopConfig(**{key: value})
    assert info.value.key == key
