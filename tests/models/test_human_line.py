"""The Human Line Algorithm path (seed 002, ch. 3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis.kinematics import speed_peaks
from inkarm.errors import InputError
from inkarm.models import human_line as hl

PX = hl.DEFAULT_PX_MM


def _normal_offset(points: np.ndarray, start, end) -> np.ndarray:
    """Signed distance of each point from the straight line start-end, in [mm]."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    u = (end - start) / np.linalg.norm(end - start)
    rel = points[:, :2] - start[:2]
    return rel[:, 0] * -u[1] + rel[:, 1] * u[0]


@pytest.mark.parametrize(
    ("length_px", "step"),
    [(10, 0.5), (200, 0.5), (200.5, 0.3), (400, 0.3), (401, 0.2), (5000, 0.2)],
)
def test_time_step_follows_table_3_1(length_px, step):
    assert hl.time_step_for_length(length_px) == step


@pytest.mark.parametrize(("length_mm", "n_points"), [(10.0, 5), (25.0, 8), (60.0, 11)])
def test_longer_lines_get_more_control_points(length_mm, n_points):
    # 300 dpi: 200 px = 16.9 mm, 400 px = 33.9 mm; Delta t = 0.5, 0.3, 0.2 -> 4, 7, 10 intervals
    tau, points = hl.control_points([0.0, 0.0], [length_mm, 0.0], rng=0)
    assert points.shape == (n_points, 2)
    np.testing.assert_allclose(tau, np.linspace(0, 1, n_points))


def test_control_points_sit_on_the_minimum_jerk_path_plus_a_normal_squiggle():
    start, end = np.array([5.0, 10.0]), np.array([45.0, 40.0])
    tau, points = hl.control_points(start, end, rng=4)
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    along = (points - start) @ (end - start) / np.linalg.norm(end - start) ** 2
    np.testing.assert_allclose(along, s, atol=1e-12)  # displacement is purely normal
    offsets = _normal_offset(points, start, end)
    assert offsets[0] == 0.0 and offsets[-1] == 0.0
    assert np.all(np.abs(offsets) <= 5.0 * PX + 1e-12)
    assert np.any(np.abs(offsets) > 0.5 * PX)


@settings(max_examples=30, deadline=None)
@given(
    x0=st.floats(-100, 100),
    y0=st.floats(-100, 100),
    angle=st.floats(0, 2 * np.pi),
    length=st.floats(2.0, 150.0),
    squiggle=st.floats(0.0, 20.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_line_keeps_its_ends_and_stays_within_the_squiggle_band(
    x0, y0, angle, length, squiggle, seed
):
    start = np.array([x0, y0])
    end = start + length * np.array([np.cos(angle), np.sin(angle)])
    line = hl.human_line(start, end, rng=seed, squiggle=squiggle)
    np.testing.assert_allclose(line.pos[0], start, atol=1e-9)
    np.testing.assert_allclose(line.pos[-1], end, atol=1e-9)
    # Catmull-Rom weights sum to at most 1.25 in absolute value (-1/16, 9/16, 9/16, -1/16 at
    # mid-segment), so the curve strays at most 1.25 times the largest control-point offset
    band = 1.25 * squiggle * PX + 1e-9
    assert np.all(np.abs(_normal_offset(line.pos, start, end)) <= band)
    np.testing.assert_allclose(line.vel[[0, -1]], 0.0, atol=1e-9)


def test_same_seed_same_line_different_seeds_differ():
    a = hl.human_line([0, 0], [60, 0], rng=7)
    b = hl.human_line([0, 0], [60, 0], rng=np.random.default_rng(7))
    c = hl.human_line([0, 0], [60, 0], rng=8)
    np.testing.assert_array_equal(a.pos, b.pos)
    assert np.max(np.abs(a.pos - c.pos)) > 0.05


def test_zero_squiggle_gives_the_straight_minimum_jerk_line():
    line = hl.human_line([0, 0], [60, 30], rng=1, squiggle=0.0, duration=1.0, dt=0.001)
    np.testing.assert_allclose(_normal_offset(line.pos, [0, 0], [60, 30]), 0.0, atol=1e-9)
    assert line.speed().max() == pytest.approx(1.875 * np.hypot(60, 30) / 1.0, rel=1e-4)


def test_speed_is_one_minimum_jerk_bell_along_the_path():
    line = hl.human_line([0, 0], [80, 0], rng=3, dt=0.005)
    assert speed_peaks(line) == 1
    arc = np.sum(np.linalg.norm(np.diff(line.pos, axis=0), axis=1))
    assert line.speed().max() == pytest.approx(1.875 * arc / 2.0, rel=1e-3)
    assert line.t[np.argmax(line.speed())] == pytest.approx(1.0, abs=0.01)


def test_catmull_rom_passes_through_its_control_points_with_c1_joints():
    rng = np.random.default_rng(0)
    points = rng.normal(size=(6, 2)) * 10
    pos, _ = hl.catmull_rom(points, np.arange(6.0))
    np.testing.assert_allclose(pos, points, atol=1e-12)
    eps = 1e-9
    for k in range(1, 5):
        _, left = hl.catmull_rom(points, np.array([k - eps]))
        _, right = hl.catmull_rom(points, np.array([k + eps]))
        np.testing.assert_allclose(left, right, atol=1e-6)
        # uniform Catmull-Rom tangent: half the chord between the neighbours
        np.testing.assert_allclose(right[0], 0.5 * (points[k + 1] - points[k - 1]), atol=1e-6)


def test_polyline_joins_lines_end_to_end_in_time():
    pts = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [0.0, 40.0]])
    line = hl.human_polyline(pts, rng=2, duration=1.0, dt=0.01)
    assert line.t[-1] == pytest.approx(3.0)
    assert np.all(np.diff(line.t) > 0)
    for k, p in enumerate(pts):
        np.testing.assert_allclose(line.pos[np.argmin(np.abs(line.t - k))], p, atol=1e-9)
    assert speed_peaks(line) == 3


def test_3d_line_keeps_height_profile_and_squiggles_in_the_page_plane():
    line = hl.human_line([0, 0, 5], [50, 0, 5], rng=1)
    np.testing.assert_allclose(line.pos[:, 2], 5.0, atol=1e-12)
    assert np.max(np.abs(line.pos[:, 1])) > 0


def test_errors_name_the_argument():
    with pytest.raises(InputError, match="squiggle: must be a non-negative number, got -1") as e:
        hl.human_line([0, 0], [1, 0], squiggle=-1)
    assert e.value.key == "squiggle" and e.value.value == -1
    with pytest.raises(InputError, match="duration: must be a positive number, got 0"):
        hl.human_line([0, 0], [1, 0], duration=0)
    with pytest.raises(InputError, match=r"end: expected 2-D or 3-D points of the same shape"):
        hl.human_line([0, 0], [1, 0, 0])
    with pytest.raises(InputError, match=r"start: NaN or inf in \[0.0, nan\]"):
        hl.human_line([0, np.nan], [1, 0])
    with pytest.raises(InputError, match=r"points: expected points of shape \(m >= 2"):
        hl.human_polyline([[0, 0]])
    with pytest.raises(InputError, match=r"points: expected points of shape"):
        hl.catmull_rom([1.0, 2.0], [0.0])
    with pytest.raises(InputError, match="length_px: expected a finite number of pixels"):
        hl.time_step_for_length(np.nan)


@pytest.mark.parametrize(
    ("kwargs", "key", "match"),
    [
        ({"start": [1e300, 0.0]}, "start",
         r"start: expected coordinates in \[-1e\+06, 1e\+06\] mm, got 1e\+300"),
        ({"end": [0.0, -2e6]}, "end", r"end: expected coordinates .*got -2e\+06"),
        ({"duration": 1e5}, "duration",
         r"duration: expected a number in \[0, 3600\] s, got 100000"),
        ({"squiggle": 1e300}, "squiggle", r"squiggle: expected a number in \[0, 1e\+06\] px"),
        ({"px_mm": 1e-300}, "px_mm", r"px_mm: expected a number in \[1e-06, 1\] mm, got 1e-300"),
    ],
)
def test_numbers_out_of_range_are_refused(kwargs, key, match):
    args = {"start": [0.0, 0.0], "end": [10.0, 0.0], **kwargs}
    with pytest.raises(InputError, match=match) as info:
        hl.human_line(args.pop("start"), args.pop("end"), **args)
    assert info.value.key == key


def test_step_budget_is_checked_before_any_work(monkeypatch):
    import time

    from inkarm.core.budget import BudgetError

    start = time.perf_counter()
    with pytest.raises(BudgetError, match=r"dt: time steps of the human line \(1 line x "
                       r"\(duration 3600 s / dt 1e-06 s \+ 641 arc-length samples\)\): about "
                       r"3\.6e\+09 time steps, .*INKARM_MAX_STEPS"):
        hl.human_line([0, 0], [10, 0], duration=3600.0, dt=1e-6)
    # many short lines: each costs its arc-length table (about 1 ms), so they count too
    with pytest.raises(BudgetError, match=r"\(2000 lines x .*INKARM_MAX_STEPS"):
        hl.human_polyline(np.cumsum(np.ones((2001, 2)), axis=0), duration=0.01, dt=0.01)
    assert time.perf_counter() - start < 2.0
    assert hl.sample_count(2000, 0.01, 0.01) == 2000 * (1 + 1 + 641)
    monkeypatch.setenv("INKARM_MAX_STEPS", "1e10")
    hl.check_polyline(1, 5.0, hl.DEFAULT_PX_MM, 3600.0, 1e-6)  # passes; the job is not run


def test_many_polylines_at_once_are_the_same_numbers_as_one_by_one_and_line_by_line():
    rng = np.random.default_rng(11)
    for dim, squiggle, duration, dt in ((2, 5.0, 1.0, 0.01), (3, 40.0, 0.3, 0.007),
                                        (2, 0.0, 0.05, 0.5)):
        points = np.cumsum(rng.normal(size=(5, dim)) * [25.0, 3.0, 1.0][:dim], axis=0)
        points[2] = points[1]  # a line of zero length
        seeds = [3, 99, 2**40 + 1]
        t, pos, vel = hl.human_polylines(points, seeds, squiggle, PX, duration, dt)
        for i, seed in enumerate(seeds):
            one = hl.human_polyline(points, seed, squiggle, PX, duration, dt)
            assert np.array_equal(one.t, t) and np.array_equal(one.pos, pos[i])
            assert np.array_equal(one.vel, vel[i])
            gen = np.random.default_rng(seed)  # the lines one after the other, one generator
            lines = [hl.human_line(points[k], points[k + 1], gen, squiggle, PX, duration, dt)
                     for k in range(len(points) - 1)]
            ref = np.vstack([lines[0].pos] + [line.pos[1:] for line in lines[1:]])
            assert np.array_equal(ref, pos[i])
            ref = np.vstack([lines[0].vel] + [line.vel[1:] for line in lines[1:]])
            assert np.array_equal(ref, vel[i])


def test_many_polylines_are_refused_by_their_time_naming_the_generators(monkeypatch):
    import time

    from inkarm.core.budget import BudgetError

    points = np.cumsum(np.full((201, 2), 3.0), axis=0)  # 200 lines of 0.05 s
    start = time.perf_counter()
    with pytest.raises(BudgetError, match=r"^rngs: time of 10001 human polylines of 200 lines "
                       r"\(duration 0\.05 s / dt 0\.01 s\): about 50\.\d+ s, more than the limit "
                       r"of 10 s \(raise it with the environment variable INKARM_MAX_COMPUTE_S\)"):
        hl.human_polylines(points, range(10_001), duration=0.05, dt=0.01)
    assert time.perf_counter() - start < 2.0
    assert hl.polylines_seconds(1, 200, 0.05, 0.01) < 0.5  # one polyline is cheap
    monkeypatch.setenv("INKARM_MAX_COMPUTE_S", "100")
    hl.check_polylines(10_001, 200, 0.05, 0.01)  # passes; the polylines are not computed
