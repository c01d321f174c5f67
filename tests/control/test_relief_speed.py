"""Slower over steep relief (inkarm.control.relief_speed): the factor against the closed form of
a wave crossed at constant speed, the stretch's timing, and runs without a map unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.control.relief_speed import (
    height_acceleration,
    relief_factors,
    slowed_over_relief,
    stretched,
)
from inkarm.core.trajectory import Drawing, Trajectory


class Wave:
    """h(x, y) = a sin(2 pi x / wavelength) [mm]."""

    def __init__(self, a: float, wavelength: float):
        self.a, self.k = a, 2 * np.pi / wavelength

    def height(self, x, y):
        return self.a * np.sin(self.k * np.asarray(x))


def line(speed: float, length: float = 120.0, t0: float = 0.0) -> Trajectory:
    t = np.linspace(0.0, length / speed, 400)
    return Trajectory(t=t0 + t, pos=np.column_stack([10.0 + speed * t, np.full_like(t, 50.0)]))


def test_the_height_acceleration_of_a_wave_crossed_at_constant_speed_is_a_k2_v2():
    wave, v = Wave(1.0, 30.0), 200.0
    accel = height_acceleration(line(v), wave)
    # the smoothing (sigma 4 ms) shrinks a sinusoid of period 150 ms by exp(-(w s)^2 / 2)
    w = wave.k * v
    expected = wave.a * w**2 * np.exp(-0.5 * (w * 0.004) ** 2)
    assert accel[20:-20].max() == pytest.approx(expected, rel=0.01)


def test_a_stroke_is_slowed_by_the_square_root_of_its_excess_and_only_then():
    wave, v = Wave(1.0, 30.0), 200.0
    peak = height_acceleration(line(v), wave).max()
    fast, slow = line(v), line(40.0, t0=10.0)
    factors = relief_factors(Drawing([fast, slow]), wave, peak / 4.0)
    assert factors[0] == pytest.approx(2.0, rel=1e-9) and factors[1] == 1.0
    after = height_acceleration(stretched(Drawing([fast]), factors[:1]).strokes[0], wave)
    assert after.max() == pytest.approx(peak / 4.0, rel=0.02)


def test_the_stretch_keeps_the_path_and_moves_later_strokes_by_what_was_gained():
    a, b = line(100.0), line(100.0, t0=3.0)
    out = stretched(Drawing([a, b]), np.array([1.5, 1.0]))
    assert np.array_equal(out.strokes[0].pos, a.pos)
    assert out.strokes[0].t[0] == a.t[0]
    assert out.strokes[0].duration == pytest.approx(1.5 * a.duration)
    assert out.strokes[1].t[0] == pytest.approx(b.t[0] + 0.5 * a.duration)
    assert out.strokes[1].duration == pytest.approx(b.duration)


def test_a_flat_sheet_slows_nothing_and_says_nothing():
    drawing = Drawing([line(300.0)])
    same, note = slowed_over_relief(drawing, Wave(0.0, 30.0), 2000.0)
    assert same is drawing and note is None
    _, note = slowed_over_relief(drawing, Wave(1.0, 30.0), 2000.0)
    assert note.startswith("slowed 1 of 1 strokes up to ") and "relief_accel_mm_s2" in note
