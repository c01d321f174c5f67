"""Human-likeness statistics and the verdict against the human ranges
(inkarm.analysis.humanlike, issue 25 part 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.analysis.humanlike import (
    HUMAN_RANGES,
    MEASURES,
    HumanRange,
    HumanRanges,
    human_likeness,
    human_stats,
    load_human_ranges,
    stroke_stats,
)
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError


def ellipse(turns: float = 3.0, a: float = 20.0, b: float = 10.0, hz: float = 1.0,
            dt: float = 0.002, t0: float = 0.0) -> Trajectory:
    """An ellipse traced at constant angular velocity: v = k r^(1/3) exactly."""
    t = np.arange(0.0, turns / hz, dt)
    w = 2 * math.pi * hz
    return Trajectory(t=t + t0, pos=np.column_stack([a * np.cos(w * t), b * np.sin(w * t)]))


def test_an_ellipse_has_beta_one_third_and_two_peaks_per_turn():
    stats = stroke_stats(ellipse(), lognormal=False)
    assert stats.beta == pytest.approx(1 / 3, abs=0.01)
    assert stats.r2 > 0.9  # not 1: the low-pass bends the two ends a little
    assert stats.peaks == 6  # the speed peaks on the minor axis (flattest), twice a turn
    assert stats.peaks_per_second == pytest.approx(6 / 2.998)  # over the stroke's duration
    assert stats.asymmetry == pytest.approx(0.5, abs=0.03)
    assert math.isnan(stats.lognormal_snr_db)


def test_pooled_beta_and_peaks_per_second_over_strokes():
    # the same ellipse at the same pace (the same gain k: pooling fits one k for all strokes)
    two = Drawing([ellipse(2.0), ellipse(2.0, a=20.0, b=10.0, t0=5.0)])
    stats = human_stats(two, lognormal=False)
    assert len(stats.strokes) == 2 and stats.skipped == ()
    assert stats.beta == pytest.approx(1 / 3, abs=0.01)  # each stroke obeys the same law
    # peaks / pen-down time: (4 + 4) over (2 s + 2 s)
    assert stats.peaks_per_second == pytest.approx(8 / 4.0, rel=0.01)
    assert stats.peaks_per_stroke == pytest.approx(4.0)


def test_jerk_per_peak_divides_the_normalised_jerk():
    stats = stroke_stats(ellipse(), lognormal=False)
    assert stats.jerk_per_peak == pytest.approx(stats.normalised_jerk / stats.peaks)


def test_a_lognormal_stroke_is_lognormal_and_asymmetric():
    from scipy.special import erf

    t = np.arange(0.0, 1.0, 0.002)
    s = 40 * 0.5 * (1 + erf((np.log(t + 0.05) - math.log(0.25)) / (0.25 * math.sqrt(2))))
    stats = stroke_stats(Trajectory(t=t, pos=np.column_stack([s, 0.5 * s])), smoothing_hz=None)
    assert stats.peaks == 1
    assert stats.lognormal_snr_db > 40
    assert stats.asymmetry < 0.3


def test_short_strokes_are_skipped_and_a_drawing_of_them_refused():
    tiny = Trajectory(t=np.arange(5) * 0.01, pos=np.arange(10.0).reshape(5, 2))
    stats = human_stats(Drawing([tiny, ellipse()]), lognormal=False)
    assert stats.skipped == (0,)
    with pytest.raises(InputError, match="no stroke to measure: each of the 1 needs at least"):
        human_stats(Drawing([tiny]))
    with pytest.raises(InputError, match="cannot measure a stroke of 5 samples, fewer than 12"):
        stroke_stats(tiny)


def test_a_resting_pen_is_not_measured():
    # the low-pass turns a constant into 1e-14 mm of noise, which the relative peak threshold
    # would count as peaks
    rest = Trajectory(t=np.arange(40) * 0.01, pos=np.full((40, 2), 50.0))
    with pytest.raises(InputError, match="a path shorter than 0.001 mm: the pen does not move"):
        stroke_stats(rest)
    assert human_stats(Drawing([rest, ellipse()]), lognormal=False).skipped == (0,)


def test_a_constant_speed_trace_has_no_peaks_and_undefined_pulse_measures():
    t = np.linspace(0, 2, 400)
    stats = human_stats(Trajectory(t=t, pos=np.column_stack([20 * t, 5 * t])))
    assert stats.peaks_per_second == 0
    assert math.isnan(stats.beta)  # a straight line has no curvature
    assert math.isnan(stats.jerk_per_peak) and math.isnan(stats.asymmetry)
    assert math.isnan(stats.lognormal_snr_db)


# -- ranges and verdict ------------------------------------------------------------------------


def ranges(**bounds) -> HumanRanges:
    return HumanRanges({name: HumanRange(*b) for name, b in bounds.items()})


def test_verdict_inside_outside_and_undefined():
    stats = stroke_stats  # noqa: F841 (documentation: the verdict takes pooled HumanStats)
    line = human_stats(ellipse(), lognormal=False)
    r = ranges(beta=(0.33, 0.3, 0.4), peaks_per_second=(3.0, 2.5, 3.5),
               lognormal_snr_db=(25.0, 20.0, 30.0, False))
    verdict = human_likeness(line, r)
    assert verdict.inside == {"beta": True, "peaks_per_second": False, "lognormal_snr_db": None}
    assert not verdict.human_like
    assert human_likeness(line, ranges(beta=(0.33, 0.3, 0.4))).human_like
    # an undefined measure that is not judged does not decide
    assert human_likeness(line, ranges(beta=(0.33, 0.3, 0.4),
                                       lognormal_snr_db=(25, 20, 30, False))).human_like
    with pytest.raises(InputError, match="no human ranges"):
        human_likeness(line, HumanRanges({}))


def test_the_shipped_ranges_are_lasa_and_judge_the_issues_three_measures():
    assert "LASA" in HUMAN_RANGES.source and "26 shapes" in HUMAN_RANGES.source
    judged = {n for n, r in HUMAN_RANGES.measures.items() if r.judged}
    assert judged == {"beta", "peaks_per_second", "jerk_per_peak"}
    assert set(HUMAN_RANGES.measures) <= set(MEASURES)
    beta = HUMAN_RANGES.measures["beta"]
    assert 0.11 <= beta.median <= 0.19


@pytest.mark.parametrize("text, message, key", [
    ("source = 'x'\n", "expected a table [measures.NAME] per measure", "measures"),
    ("[measures.betta]\nmedian = 1\nq25 = 0\nq75 = 2\n",
     "unknown measure 'betta' (did you mean 'beta'?)", "measures.betta"),
    ("[measures.beta]\nmedian = 1\nq25 = 0\n", "expected a finite number, got None",
     "measures.beta.q75"),
    ("[measures.beta]\nmedian = 'a'\nq25 = 0\nq75 = 1\n", "expected a finite number, got 'a'",
     "measures.beta.median"),
    ("[measures.beta]\nmedian = 3\nq25 = 0\nq75 = 1\n", "expected q25 <= median <= q75, got 0, 3, 1",
     "measures.beta"),
    ("[measures.beta]\nmedian = 1\nq25 = 0\nq75 = 2\njudged = 'yes'\n",
     "expected true or false, got 'yes'", "measures.beta.judged"),
    ("[measures.beta]\nmedian = 1\nq25 = 0\nq75 = 2\nmean = 1\n",
     "unknown field 'mean' (did you mean 'median'?)", "measures.beta.mean"),
    ("[measures]\nbeta = 1\n", "expected a table with median, q25, q75", "measures.beta"),
    ("[measures\n", "not TOML", None),
])
def test_range_files_are_checked(tmp_path, text, message, key):
    path = tmp_path / "ranges.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message.replace("[", r"\[").replace("(", r"\(")
                       .replace(")", r"\)").replace("?", r"\?")) as e:
        load_human_ranges(path)
    assert e.value.file == str(path)
    assert e.value.key == key


def test_a_missing_range_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_human_ranges(tmp_path / "none.toml")


def test_a_range_file_round_trips(tmp_path):
    path = tmp_path / "ranges.toml"
    path.write_text("source = 'mine'\n[measures.asymmetry]\nmedian = 0.5\nq25 = 0.4\n"
                    "q75 = 0.6\njudged = false\n")
    r = load_human_ranges(path)
    assert r.source == "mine"
    assert r.measures == {"asymmetry": HumanRange(0.5, 0.4, 0.6, False)}


def test_the_measures_do_not_depend_on_the_drawings_size():
    small = ellipse(2.0, a=10.0, b=4.0)
    large = Trajectory(t=small.t, pos=3.0 * small.pos + 50.0)
    a, b = (stroke_stats(s, lognormal=False) for s in (small, large))
    assert b.length_mm == pytest.approx(3 * a.length_mm)
    for name in ("beta", "r2", "peaks", "peaks_per_second", "jerk_per_peak", "asymmetry"):
        assert getattr(b, name) == pytest.approx(getattr(a, name), rel=1e-6), name
