"""The pencil ink on the canvas: the grade's texture laid along each stroke at the lift,
driven by the contact force; seeded; configurable from a scenario."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas, MarkerInk, PencilInk
from inkarm.ink.pencil_profile import resolve_profile, save_profile


def _stroke(canvas: Canvas, points, forces, t0: float = 0.0) -> None:
    for k, (p, f) in enumerate(zip(points, forces)):
        canvas.touch(p, float(f), t0 + 0.001 * k)
    canvas.lift()


def _horizontal(n: int = 400, y: float = 10.0) -> np.ndarray:
    return np.column_stack([np.linspace(5.0, 35.0, n), np.full(n, y)])


def test_a_pencil_stroke_is_textured_at_the_lift_not_before():
    ink = PencilInk(grade="6B")
    canvas = Canvas(size_mm=(40.0, 20.0), px_per_mm=10.0, ink=ink)
    for k, p in enumerate(_horizontal()):
        canvas.touch(p, 1.0, 0.001 * k)
    plain = canvas.image.copy()  # during the stroke: the plain force-dependent mark
    assert np.unique(plain[plain > 0.9]).size <= 2
    canvas.lift()
    textured = canvas.image
    line = textured[95:105, 60:290]
    assert line.std() > 0.1  # grain, not a flat line
    assert np.count_nonzero(textured > 0.01) > 0
    rows = np.flatnonzero(textured.max(axis=1) > 0.05)
    width_px = rows.max() - rows.min() + 1
    assert width_px <= ink.line_width_mm * 10 + 4  # the line and its anti-aliased edge


def test_darkness_follows_the_force_through_a_of_f():
    """Mean darkness of a stroke at force F scales as a(F) = a_max (1 - exp(-F / F0))
    relative to the profile's reference force (oracle: the ratio of a(F))."""
    ink = PencilInk(grade="HB", seed=2)
    means = {}
    for force in (0.3, 1.0):
        canvas = Canvas(size_mm=(40.0, 20.0), px_per_mm=10.0, ink=ink)
        _stroke(canvas, _horizontal(), [force] * 400)
        means[force] = canvas.image[:, 60:290].sum()
    expected = ink.opacity(0.3) / ink.opacity(1.0)
    assert means[0.3] / means[1.0] == pytest.approx(expected, rel=0.05)


def test_force_zero_leaves_nothing_and_a_dip_leaves_a_gap():
    canvas = Canvas(size_mm=(40.0, 20.0), px_per_mm=10.0, ink=PencilInk())
    _stroke(canvas, _horizontal(), [0.0] * 400)
    assert canvas.image.max() == 0.0
    xs = _horizontal(3001)
    forces = np.where((xs[:, 0] > 15.0) & (xs[:, 0] < 25.0), 0.0, 1.0)
    _stroke(canvas, xs, forces, t0=1.0)
    columns = canvas.image.max(axis=0)
    x_of = (np.arange(columns.size) + 0.5) / canvas.px_per_mm
    assert np.all(columns[(x_of > 16.0) & (x_of < 24.0)] == 0.0)
    assert columns[(x_of > 6.0) & (x_of < 14.0)].mean() > 0.2


def test_texture_is_seeded_per_stroke_and_off_gives_the_plain_mark():
    def page(ink):
        canvas = Canvas(size_mm=(40.0, 20.0), px_per_mm=10.0, ink=ink)
        _stroke(canvas, _horizontal(), [1.0] * 400)
        _stroke(canvas, _horizontal(y=14.0), [1.0] * 400, t0=1.0)
        return canvas.image.copy()

    a, b = page(PencilInk(seed=1)), page(PencilInk(seed=1))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, page(PencilInk(seed=2)))
    assert not np.array_equal(a[95:105, 60:290], np.roll(a, -40, axis=0)[95:105, 60:290])
    plain = page(PencilInk(texture=False))
    assert plain.max() == pytest.approx(PencilInk().opacity(1.0), abs=1e-6)


def test_a_curved_stroke_keeps_the_texture_near_the_path():
    canvas = Canvas(size_mm=(40.0, 40.0), px_per_mm=10.0, ink=PencilInk(grade="8B"))
    th = np.linspace(0.0, 2.0 * np.pi, 2000)
    _stroke(canvas, np.column_stack([20 + 10 * np.cos(th), 20 + 10 * np.sin(th)]),
            [1.0] * th.size)
    points = canvas.ink_points_mm(threshold=0.01)
    radius = np.linalg.norm(points - 20.0, axis=1)
    half = PencilInk(grade="8B").line_width_mm / 2
    assert np.all(np.abs(radius - 10.0) <= half + 0.25)  # + the capsule's edge
    assert points.shape[0] > 0.8 * 2 * np.pi * 10 * 2 * half * 100  # most of the ring inked


def test_marker_runs_keep_no_path():
    canvas = Canvas(size_mm=(40.0, 20.0), ink=MarkerInk())
    canvas.touch((5.0, 5.0), 1.0, 0.0)
    assert canvas._path is None  # the default ink pays nothing for the pencil's texture


def test_grade_width_and_profile_file(tmp_path):
    assert PencilInk(grade="8B").line_width_mm == resolve_profile("8B").width_mm
    assert PencilInk(grade="8B", width_mm=1.0).line_width_mm == 1.0
    path = save_profile(resolve_profile("B"), tmp_path / "mine.npz")
    assert PencilInk(grade=str(path)).profile.name == "B"


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"grade": "HBB"}, r"grade: unknown pencil grade 'HBB' \(did you mean 'HB'\?\)"),
    ({"grade": "nowhere/mine.npz"}, r"nowhere/mine.npz: grade: no such pencil profile file"),
    ({"seed": -1}, r"seed: PencilInk expects a seed that is an integer >= 0, got -1"),
    ({"seed": 1.5}, r"seed: PencilInk expects a seed that is an integer >= 0"),
])
def test_bad_pencil_settings_are_refused_naming_the_field(kwargs, message):
    with pytest.raises(InputError, match=message):
        PencilInk(**kwargs)


def test_scenario_sets_the_grade_and_names_a_bad_one(tmp_path):
    from inkarm.jobs.scenario import load_scenario

    job = tmp_path / "job.toml"
    job.write_text("[source]\nkind = 'tag'\n[ink]\nmodel = 'pencil'\ngrade = '6B'\nseed = 4\n")
    ink = load_scenario(job).ink.make()
    assert ink.grade == "6B" and ink.seed == 4 and ink.texture
    job.write_text("[source]\nkind = 'tag'\n[ink]\nmodel = 'pencil'\ngrade = '9B'\n")
    with pytest.raises(InputError, match=r"job.toml: ink.grade: unknown pencil grade '9B'"):
        load_scenario(job)


@pytest.mark.parametrize("points", [
    [(10.0, 10.0)],  # a single touch: a dot
    [(10.0, 10.0)] * 50,  # the pen resting
    [(10.0, 10.0 + 1e-4 * k) for k in range(50)],  # all but resting
    [(0.0, 0.0), (0.05, 0.0)],  # on the page's corner
])
def test_dots_and_rests_get_a_textured_mark_in_range(points):
    canvas = Canvas(size_mm=(20.0, 20.0), px_per_mm=10.0, ink=PencilInk(grade="8B"))
    _stroke(canvas, points, [1.0] * len(points))
    image = canvas.image
    assert 0.0 < image.max() <= 1.0 and image.min() >= 0.0
    near = canvas.ink_points_mm(threshold=1e-3) - np.asarray(points[0])
    assert np.all(np.linalg.norm(near, axis=1) <= PencilInk(grade="8B").line_width_mm + 0.3)


@pytest.mark.parametrize("grade", ["HB", "6B"])
def test_a_straight_stroke_on_the_page_keeps_its_grades_co_occurrence(grade):
    """Issue 25, on the page: a vertical stroke drawn at the scan's resolution, its inked
    pixels (the anti-aliased edge included) measured as the profile was: the L1 distance to the
    grade's co-occurrence matrices stays near the strip's (measured over the eight grades:
    0.22-0.41, HB 0.27, 6B 0.23), where one more 3x3 blur on the page, as before issue 25,
    takes it to 0.9-1.2."""
    from inkarm.ink.pencil_synthesis import gaussian_blur3, glcm_distance, strip_glcm

    profile = resolve_profile(grade)
    ppm = profile.px_per_mm
    canvas = Canvas(size_mm=(4.0, 20.0), px_per_mm=ppm, ink=PencilInk(grade=grade, seed=1))
    _stroke(canvas, [(2.0, y) for y in np.linspace(2.0, 18.0, 1000)], [1.0] * 1000)
    rows = slice(int(4 * ppm), int(16 * ppm))  # away from the stroke's round ends

    def distance(image):
        grey = np.round(255.0 * (1.0 - image[rows])).astype(np.uint8)
        return glcm_distance(strip_glcm(grey, image[rows] > 0, profile.levels), profile.glcm)

    page = distance(canvas.image)
    assert page < 0.35
    assert distance(np.clip(gaussian_blur3(canvas.image), 0.0, 1.0)) > 2.0 * page
