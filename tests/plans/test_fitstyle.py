"""Fitting a handstyle to recordings: the errors, the score, the search and the file."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.analysis.kinematics import lowpass, normalised_jerk, speed_peaks
from inkarm.errors import InputError
from inkarm.plans.fitstyle import (
    Candidate,
    errors,
    fit_style,
    population_score,
    restyled,
    score_of,
    style_toml,
    trace_errors,
)
from inkarm.plans.handstyles import load_handstyles
from tests.plans.test_pulses import zigzag


def statistics(trace):
    smooth = lowpass(trace, 10.0)
    peaks = speed_peaks(smooth)
    return {"peaks": peaks, "jerk_per_peak": normalised_jerk(smooth) / max(peaks, 1)}


def test_one_tolerance_is_one_unit_of_error():
    e = errors({"peaks": 10, "jerk_per_peak": 40.0, "beta": 0.15},
               {"peaks": 12, "jerk_per_peak": 20.0, "beta": 0.23})
    assert e["peaks"] == pytest.approx(1.0)  # 20 % more
    assert e["jerk_per_peak"] == pytest.approx(-1.0)  # half
    assert e["beta"] == pytest.approx(1.0)  # 0.08 more
    assert math.isnan(errors({"peaks": 0}, {"peaks": 3})["peaks"])


def test_score_clips_each_measure_at_three_tolerances():
    assert score_of([{"peaks": 1.0, "beta": 2.0}, {"peaks": 10.0, "beta": math.nan}]) == \
        pytest.approx(((1 + 4) + (9 + 9)) / 2)
    assert score_of([]) == math.inf


def test_the_fit_keeps_the_best_candidate_and_its_file_reads_back(tmp_path):
    traces = [zigzag()[0], zigzag(durations=(0.25, 0.3, 0.45))[0]]
    fit = fit_style(traces, statistics, orders=(3, 5), stiffnesses=(1.0, 100.0), name="mine")
    assert len(fit.scores) == 4
    assert fit.score == min(score for _, score in fit.scores)
    best = min(fit.scores, key=lambda cs: cs[1])[0]
    assert (fit.handstyle.order, fit.handstyle.d) == (best.order, best.handstyle().d)
    again = trace_errors(traces, [statistics(t) for t in traces], fit.handstyle, statistics)
    assert score_of(again) <= fit.score  # (plus the population term, 0 here: no beta)
    path = tmp_path / "style.toml"
    path.write_text(style_toml(fit, "two zigzags"))
    read = load_handstyles(path)["mine"]
    assert (read.order, read.h, read.d, read.timing) == (
        fit.handstyle.order, fit.handstyle.h, pytest.approx(fit.handstyle.d), "pulses")


def test_minimum_jerk_legs_are_kept_by_a_minimum_jerk_style():
    trace, _ = zigzag()
    out = restyled(trace, Candidate(3, 10.0).handstyle())
    human, restyle = statistics(trace), statistics(out)
    assert restyle["peaks"] == human["peaks"] == 3
    assert abs(errors(human, restyle)["jerk_per_peak"]) < 1.0  # within 2x


def test_no_recordings_is_an_error():
    with pytest.raises(InputError, match="no recordings to fit to"):
        fit_style([], statistics)


def test_the_population_term_is_the_median_shift_in_inter_quartile_ranges():
    humans = [{"beta": b, "peaks_per_second": 3.0} for b in (0.1, 0.2, 0.3, 0.4, 0.5)]
    restyles = [{"beta": b + 0.2, "peaks_per_second": 3.0} for b in (0.1, 0.2, 0.3, 0.4, 0.5)]
    # median moved by 0.2, IQR 0.2: one unit; peaks per second have no spread: left out
    assert population_score(humans, restyles) == pytest.approx(1.0)
    assert population_score(humans, humans) == 0.0


def test_the_fit_restyles_as_restyle_does():
    from inkarm.plans.fitstyle import _config, _key_point_plan, _solved

    trace, _ = zigzag()
    hand = Candidate(5, 30.0).handstyle()
    fast = _solved(trace, _key_point_plan(trace), _config(hand))
    slow = restyled(trace, hand)
    assert np.array_equal(fast.t, slow.t) and np.array_equal(fast.pos, slow.pos)


def test_the_population_term_charges_a_shift_the_folds_see_and_the_pooled_median_hides():
    # 8 recordings, 2 folds (8 // MIN_FOLD): the even ones' restyles move up by 0.1, the odd
    # ones' down by 0.1, so the restyles as a whole are the recordings again (pooled shift 0)
    betas = [0.1 * k for k in range(1, 9)]
    humans = [{"beta": b} for b in betas]
    restyles = [{"beta": b + (0.1 if i % 2 == 0 else -0.1)} for i, b in enumerate(betas)]
    iqr = float(np.subtract(*np.percentile(betas, [75, 25])))  # 0.35
    assert population_score(humans, restyles, folds=1) == pytest.approx(0.0, abs=1e-24)
    assert population_score(humans, restyles) == pytest.approx((0.1 / iqr) ** 2)
    # a fold where the restyles are all unmeasured is left out, not counted as no shift
    restyles[1::2] = [{}] * 4
    assert population_score(humans, restyles) == pytest.approx((0.1 / iqr) ** 2)
