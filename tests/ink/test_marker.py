"""Marker ink of issue 9: no ink below the threshold force, width growing from w0 at the
threshold by the saturating law (oracles: the law's closed form, integrated darkness)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas, MarkerInk


def _line(canvas: Canvas, forces, y: float = 10.03) -> None:
    xs = np.linspace(5.0, 35.0, len(forces))
    for k, (x, f) in enumerate(zip(xs, forces)):
        canvas.touch((x, y), float(f), 0.001 * k)
    canvas.lift()


def _width_mm(canvas: Canvas, cols: slice = slice(100, 300)) -> np.ndarray:
    """Integrated darkness across the line, per column, is the line's width in [mm]."""
    return canvas.image[:, cols].sum(axis=0) / canvas.px_per_mm


def test_default_threshold_is_stated_and_a_touch_below_it_leaves_nothing():
    ink = MarkerInk()
    assert ink.threshold_n == pytest.approx(0.08)
    for force in (0.0, 0.001, 0.05, 0.0799):
        canvas = Canvas(size_mm=(20.0, 20.0), ink=ink)
        canvas.touch((10.0, 10.0), force, 0.0)  # a dot
        canvas.lift()
        _line(canvas, [force] * 50)  # and a stroke
        assert canvas.image.max() == 0.0
        assert canvas.n_strokes == 2


@pytest.mark.parametrize("force", [0.08, 0.2, 0.5, 1.0, 2.0, 6.0])
def test_width_at_known_forces_matches_the_law_within_a_pixel(force):
    ink = MarkerInk(w0_mm=0.3, k_mm=0.5, f0_n=1.0, threshold_n=0.08)
    expected = 0.3 + 0.5 * (1.0 - math.exp(-(force - 0.08) / 1.0))
    assert ink.mark(force, 10.0) == (pytest.approx(expected), 1.0)
    canvas = Canvas(size_mm=(40.0, 20.0), px_per_mm=10.0, ink=ink)
    _line(canvas, [force] * 300)
    width = _width_mm(canvas)
    assert np.all(np.abs(width - expected) <= 1.0 / canvas.px_per_mm)  # within a pixel
    assert np.allclose(width, expected, atol=0.02)  # and in fact far closer


def test_width_is_continuous_at_the_threshold_and_saturates():
    ink = MarkerInk(w0_mm=0.4, k_mm=0.6, f0_n=0.5, threshold_n=0.1)
    assert ink.mark(0.1, 0.0)[0] == pytest.approx(0.4)
    assert ink.mark(0.0999, 0.0)[1] == 0.0
    assert ink.mark(1e3, 0.0)[0] == pytest.approx(1.0)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 100.0), st.floats(0.0, 100.0))
def test_width_never_shrinks_with_force(f1, f2):
    ink = MarkerInk()
    lo, hi = sorted((f1, f2))
    (w_lo, a_lo), (w_hi, a_hi) = ink.mark(lo, 0.0), ink.mark(hi, 0.0)
    assert a_lo <= a_hi
    if a_lo > 0:
        assert w_lo <= w_hi + 1e-12


def test_a_stroke_that_dips_below_the_threshold_has_a_gap_there():
    """Force 1 N, then 0.01 N over x in [15, 25] mm, then 1 N: ink on both sides, none in the
    gap beyond the line's round caps (half the width) and a pixel."""
    ink = MarkerInk(w0_mm=0.4, k_mm=0.0)
    canvas = Canvas(size_mm=(40.0, 20.0), ink=ink)
    xs = np.linspace(5.0, 35.0, 3001)
    forces = np.where((xs > 15.0) & (xs < 25.0), 0.01, 1.0)
    _line(canvas, forces)
    columns = canvas.image.max(axis=0)
    x_of = (np.arange(columns.size) + 0.5) / canvas.px_per_mm
    assert np.all(columns[(x_of > 15.0 + 0.3) & (x_of < 25.0 - 0.3)] == 0.0)
    assert np.all(columns[(x_of > 5.5) & (x_of < 14.8)] > 0.99)
    assert np.all(columns[(x_of > 25.2) & (x_of < 34.5)] > 0.99)


def test_threshold_is_a_scenario_key_and_bad_values_are_named(tmp_path):
    from inkarm.jobs.scenario import load_scenario

    job = tmp_path / "job.toml"
    job.write_text("[source]\nkind = 'tag'\n[ink]\nmodel = 'marker'\nthreshold_n = 0.05\n")
    assert load_scenario(job).ink.make().threshold_n == 0.05
    job.write_text("[source]\nkind = 'tag'\n[ink]\nmodel = 'marker'\nthreshold_n = -1\n")
    with pytest.raises(InputError, match=r"job.toml: ink.threshold_n: MarkerInk expects a "
                       r"threshold force \[N\] in \[0, 100\], got -1"):
        load_scenario(job)
