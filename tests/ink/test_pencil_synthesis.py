"""Pencil texture synthesis (seed 002 ch. 4.2): the Done-when measurements of issue 13 (the
co-occurrence step brings the synthesized matrices closer to the model's than the random fill
was; extraction of a synthesized line gives back its profile's statistics) and of issue 25
(the final smoothing keeps the repaired co-occurrence distance; grades strictly darker from 2H
to 8B), the fill's bell fall-off, the smoothing, and the refusals."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.ndimage import convolve

from inkarm.errors import InputError
from inkarm.ink.pencil_extract import extract_profile
from inkarm.ink.pencil_profile import GRADES, resolve_profile
from inkarm.ink.pencil_synthesis import (
    GAUSS3,
    RepairConfig,
    gaussian_blur3,
    glcm_distance,
    initial_fill,
    repair,
    smooth,
    strip_glcm,
    strip_mask,
    synthesize_line,
)

PROFILES = {g: resolve_profile(g) for g in GRADES}


@pytest.mark.parametrize("grade", GRADES)
@pytest.mark.parametrize("px_per_mm", ["scan", 10.0])
def test_co_occurrence_repair_brings_the_matrices_closer_to_the_model(grade, px_per_mm):
    """Measured at the scan's resolution and at the canvas's default 10 px/mm: the L1
    distance between the strip's and the model's co-occurrence matrices after the repair is
    at most 70 % of the random fill's (measured: 9-62 %), over two seeds."""
    profile = PROFILES[grade]
    ppm = profile.px_per_mm if px_per_mm == "scan" else px_per_mm
    for seed in (0, 1):
        texture = synthesize_line(profile, np.full(400, profile.width_mm * ppm),
                                  np.random.default_rng(seed))
        # a line 1-2 px wide has no pair across it: compare the offsets it has
        offsets = slice(0, 1) if texture.mask.sum(axis=1).max() < 2 else slice(None)
        before = glcm_distance(strip_glcm(texture.filled, texture.mask, profile.levels)[offsets],
                               profile.glcm[offsets])
        after = glcm_distance(strip_glcm(texture.repaired, texture.mask,
                                         profile.levels)[offsets], profile.glcm[offsets])
        assert after <= 0.7 * before, (grade, seed, before, after)
        assert texture.changes[0] > 0
        assert len(texture.changes) <= RepairConfig().max_sweeps


def _grey(texture) -> np.ndarray:
    """The grey levels of a synthesized line after all three steps (255 off the line)."""
    return np.round(255.0 * (1.0 - texture.darkness)).astype(np.uint8)


def test_extraction_of_a_synthesized_line_returns_its_profile():
    """A line synthesized from each shipped grade (all three steps), laid on white paper as a
    scan and extracted: its histograms and co-occurrence matrices are closer to its own
    grade's than to any other grade's, within fixed bounds (measured: co-occurrence
    0.08-0.20, whole-line histogram 0.16-0.30, mid-line 0.37-0.59, L1), its width within
    0.06 mm."""
    for grade, profile in PROFILES.items():
        texture = synthesize_line(profile, np.full(600, profile.width_mm * profile.px_per_mm),
                                  np.random.default_rng(3))
        line = np.where(texture.mask, _grey(texture), 255)
        scan = np.full((640, line.shape[1] + 40), 255, np.uint8)
        scan[20:620, 20 : 20 + line.shape[1]] = line
        back = extract_profile(scan, px_per_mm=profile.px_per_mm)
        distances = {
            "glcm": {g: glcm_distance(back.glcm, p.glcm) for g, p in PROFILES.items()},
            "full": {g: np.abs(back.full_hist - p.full_hist).sum() for g, p in PROFILES.items()},
            "mid": {g: np.abs(back.mid_hist - p.mid_hist).sum() for g, p in PROFILES.items()},
        }
        for key, bound in (("glcm", 0.5), ("full", 0.5), ("mid", 0.65)):
            assert min(distances[key], key=distances[key].get) == grade, (grade, key)
            assert distances[key][grade] < bound, (grade, key, distances[key][grade])
        assert abs(back.width_mm - profile.width_mm) < 0.06
        assert back.full_range[0] == pytest.approx(profile.full_range[0], abs=3)


def _distance(grey, texture, profile) -> float:
    return glcm_distance(strip_glcm(grey, texture.mask, profile.levels), profile.glcm)


@pytest.mark.parametrize("grade", GRADES)
@pytest.mark.parametrize("px_per_mm", ["scan", 10.0])
def test_the_final_smoothing_keeps_the_repaired_co_occurrence_distance(grade, px_per_mm):
    """Issue 25: after all three steps the L1 distance to the grade's co-occurrence matrices
    is at most the repair's (measured: 1-20 % below it), where the thesis's plain 3x3 blur of
    the repaired strip raises it past the random fill's (measured on the grades shipped before
    issue 25: 0.77-1.31 after the blur, 0.11-0.60 after the repair, 0.58-1.06 the fill)."""
    profile = PROFILES[grade]
    ppm = profile.px_per_mm if px_per_mm == "scan" else px_per_mm
    for seed in (0, 1):
        texture = synthesize_line(profile, np.full(400, profile.width_mm * ppm),
                                  np.random.default_rng(seed))
        repaired = _distance(texture.repaired, texture, profile)
        final = _distance(_grey(texture), texture, profile)
        assert final <= repaired, (grade, seed, repaired, final)
        blurred = gaussian_blur3(np.where(texture.mask, 1.0 - texture.repaired / 255.0, 0.0))
        plain = _distance(np.round(255.0 * (1.0 - np.clip(blurred, 0.0, 1.0))).astype(np.uint8),
                          texture, profile)
        assert plain > repaired  # what the plain blur would do


def _roughness(glcm: np.ndarray) -> float:
    """Mean level difference |i - j| of the pairs along the line (offset (1, 0))."""
    i, j = np.indices(glcm.shape[1:])
    return float((glcm[0] * np.abs(i - j)).sum())


def test_the_smoothing_reduces_tone_differences_towards_the_scans():
    """Step 3 still blurs ("to reduce tone differences"): neighbours along the line differ
    less than after the repair, and no less than in the scan less a margin, where the plain
    blur leaves a line far smoother than its scan (measured, mean level difference along the
    line at the scan's resolution: scan 1.5-4.3, repaired 2.1-4.9, smoothed 2.0-4.6, plain
    blur about half the repaired); a pixel takes its blur or keeps its grey; off the line stays
    paper; a uniform line is its own blur, unchanged."""
    for grade, profile in PROFILES.items():
        rng = np.random.default_rng(4)
        grey, mask = initial_fill(profile, np.full(400, profile.width_mm * profile.px_per_mm),
                                  rng)
        repaired, _ = repair(grey, mask, profile, rng)
        smoothed = smooth(repaired, mask, profile)
        rough = {key: _roughness(strip_glcm(g, mask, profile.levels))
                 for key, g in (("repaired", repaired), ("smoothed", smoothed))}
        scan = _roughness(profile.glcm)
        assert 0.9 * scan < rough["smoothed"] < rough["repaired"], (grade, scan, rough)
        assert np.all(smoothed[~mask] == 255)
        darkness = np.where(mask, 1.0 - repaired / 255.0, 0.0)
        blurred = gaussian_blur3(darkness) / np.maximum(gaussian_blur3(mask * 1.0), 1e-12)
        target = np.round(255.0 * (1.0 - blurred))
        changed = smoothed != repaired
        assert np.all(smoothed[changed] == target[changed])
        plain = np.round(255.0 * (1.0 - gaussian_blur3(darkness))).astype(np.uint8)
        assert _roughness(strip_glcm(plain, mask, profile.levels)) < 0.75 * scan
    uniform = np.where(mask, 120, 255).astype(np.uint8)
    assert np.array_equal(smooth(uniform, mask, PROFILES["HB"]), uniform)


@pytest.mark.parametrize("px_per_mm", ["scan", 10.0])
def test_darkness_strictly_increases_from_2H_to_8B(px_per_mm):
    """Issue 25: the mean darkness of a line's pixels after the full synthesis, at the
    reference force, grows strictly from the hardest grade to the softest, and stays within
    0.05 of its profile's (measured at the scan's resolution: 0.21, 0.27, 0.33, 0.44, 0.52,
    0.67, 0.77, 0.86; at 10 px/mm the two hardest lines are one or three pixels wide and
    darker, 0.22 and 0.29)."""
    means = []
    for profile in PROFILES.values():
        ppm = profile.px_per_mm if px_per_mm == "scan" else px_per_mm
        darkness = []
        for seed in (0, 1):
            texture = synthesize_line(profile, np.full(400, profile.width_mm * ppm),
                                      np.random.default_rng(seed))
            darkness.append(texture.darkness[texture.mask].mean())
        means.append(float(np.mean(darkness)))
        if px_per_mm == "scan":
            expected = 1.0 - (np.arange(256) @ profile.full_hist) / 255.0
            assert means[-1] == pytest.approx(expected, abs=0.05), profile.name
    assert all(a < b for a, b in itertools.pairwise(means)), dict(zip(GRADES, means))


def test_fill_puts_the_mid_line_histogram_on_the_centre_and_falls_off_across():
    profile = PROFILES["6B"]
    widths = np.full(3000, 9.0)
    grey, mask = initial_fill(profile, widths, np.random.default_rng(0))
    assert mask.shape == (3000, 11) and np.all(mask.sum(axis=1) == 9)
    assert np.all(grey[~mask] == 255)
    lo, hi = profile.mid_range
    centre = grey[:, 5]
    assert lo <= centre.min() and centre.max() <= hi
    mean_by_column = np.array([grey[:, c][mask[:, c]].mean() for c in range(1, 10)])
    assert mean_by_column[4] < mean_by_column[2] < mean_by_column[0]  # darker at the centre
    assert mean_by_column[4] < mean_by_column[6] < mean_by_column[8]  # both sides


def test_strip_mask_widths_and_a_blank_row():
    mask = strip_mask(np.array([0.0, 0.5, 1.0, 3.0, 4.2]))
    assert mask.shape == (5, 7)  # odd, half width ceil(4.2 / 2) = 3
    assert mask.sum(axis=1).tolist() == [0, 1, 1, 3, 5]
    with pytest.raises(InputError, match="widths_px: expected a 1-D array of finite widths"):
        strip_mask(np.array([1.0, -1.0]))


def test_blur_is_one_pass_of_the_binomial_3x3_gaussian():
    assert GAUSS3.sum() == pytest.approx(1.0)
    impulse = np.zeros((5, 5))
    impulse[2, 2] = 1.0
    assert np.allclose(gaussian_blur3(impulse)[1:4, 1:4], GAUSS3)
    rng = np.random.default_rng(0)
    image = rng.random((20, 7))
    assert np.allclose(gaussian_blur3(image), convolve(image, GAUSS3, mode="constant"))


def test_synthesis_is_seeded():
    profile = PROFILES["B"]
    widths = np.full(200, 6.0)
    a = synthesize_line(profile, widths, np.random.default_rng(5))
    b = synthesize_line(profile, widths, np.random.default_rng(5))
    c = synthesize_line(profile, widths, np.random.default_rng(6))
    assert np.array_equal(a.darkness, b.darkness) and a.changes == b.changes
    assert not np.array_equal(a.darkness, c.darkness)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"candidates": 0}, r"candidates: expected 1 to 64 candidates, got 0"),
    ({"max_sweeps": -1}, r"max_sweeps: expected 0 to 1000 sweeps"),
    ({"tol": 1.5}, r"tol: expected a share in \[0, 1\], got 1.5"),
    ({"rare_mass": 0.9}, r"rare_mass: expected a share in \[0, 0.5\], got 0.9"),
])
def test_repair_settings_are_checked(kwargs, message):
    with pytest.raises(InputError, match=message):
        RepairConfig(**kwargs)


def test_glcm_distance_bounds_and_shape_check():
    a = np.zeros((4, 2, 2))
    a[:, 0, 0] = 1.0
    b = np.zeros((4, 2, 2))
    b[:, 1, 1] = 1.0
    assert glcm_distance(a, a) == 0.0 and glcm_distance(a, b) == 2.0
    with pytest.raises(InputError, match="co-occurrence matrices of different shapes"):
        glcm_distance(a, np.zeros((4, 3, 3)))
