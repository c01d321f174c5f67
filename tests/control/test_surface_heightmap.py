"""The height fields the force loop feeds forward (inkarm.control.heightmap): the calibrated map
as a depth against the map's own (NumPy) interpolation, and the field learnt from samples against
its closed form, a known smooth surface and the prior where no sample is near."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.control.heightmap import LearntField, MapPrior
from inkarm.errors import InputError
from inkarm.robots.calibration import HeightMap


def test_the_prior_is_the_maps_bilinear_height_as_a_depth_inside_and_clamped_outside():
    rng = np.random.default_rng(7)
    x = np.array([10.0, 12.5, 20.0, 41.0, 60.0])  # uneven grid lines [mm]
    y = np.array([5.0, 30.0, 31.0, 90.0])
    height_map = HeightMap(x, y, rng.uniform(-1.0, 1.0, (4, 5)))
    prior = MapPrior(height_map)
    points = np.column_stack([rng.uniform(0.0, 70.0, 300), rng.uniform(-10.0, 100.0, 300)])
    points = np.vstack([points, np.column_stack([x, y[[0, 1, 2, 3, 3]]])])  # on grid lines
    for px, py in points.tolist():
        assert prior.height(px, py) == pytest.approx(-height_map.height(px, py) / 1000.0,
                                                     abs=1e-15)


@pytest.mark.parametrize("shape", [(1, 1), (1, 3), (3, 1)])
def test_a_map_of_one_grid_line_holds_its_heights_across(shape):
    z = np.arange(1.0, 1.0 + shape[0] * shape[1]).reshape(shape)
    height_map = HeightMap(np.arange(shape[1]) * 10.0, np.arange(shape[0]) * 10.0, z)
    prior = MapPrior(height_map)
    for px, py in [(-5.0, -5.0), (5.0, 15.0), (25.0, 3.0), (100.0, 100.0)]:
        assert prior.height(px, py) == pytest.approx(-height_map.height(px, py) / 1000.0)


def test_an_empty_field_is_zero_and_one_sample_splits_by_its_tent_weights():
    field = LearntField(cell_mm=5.0, prior_weight=1.0)
    assert field.height(12.0, 7.0) == 0.0
    field.add(12.0, 7.0, 0.002)  # in cell (2, 1) at s = 0.4, t = 0.4
    weights = {(2, 1): 0.36, (3, 1): 0.24, (2, 2): 0.24, (3, 2): 0.16}
    for (i, j), b in weights.items():
        # at a node only that node counts: B r / (w0 + B)
        assert field.height(5.0 * i, 5.0 * j) == pytest.approx(b * 0.002 / (1.0 + b), rel=1e-12)
    expected = sum(b * b * 0.002 / (1.0 + b) for b in weights.values())
    assert field.height(12.0, 7.0) == pytest.approx(expected, rel=1e-12)
    assert field.height(30.0, 30.0) == 0.0  # far from the sample: the prior (0)
    assert field.count == 1 and "4 nodes from 1 samples" in field.describe()


def test_a_smooth_surface_sampled_densely_is_reproduced_between_the_samples():
    """A 1 mm wave of 30 mm wavelength plus a 1 mm bump 8 mm wide, sampled every 0.5 mm along
    lines 1 mm apart (as a pen passing over it would): on a 2 mm grid the field reproduces it
    at points between the samples within 0.15 mm: at the bump's top (curvature c = 1 mm /
    sigma^2 = 0.087 /mm along each axis) the tent kernel's smoothing, (h^2 / 6) / 2 (2 c) =
    0.06 mm at the nodes, and the bilinear interpolation's h^2 / 8 (2 c) = 0.09 mm between them
    (a negligible prior weight: its pull is the previous test's)."""
    sigma = 8.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))

    def truth(x, y):  # [m]
        wave = np.sin(2 * np.pi * (x + 0.5 * y) / 30.0)
        bump = np.exp(-((x - 30.0) ** 2 + (y - 25.0) ** 2) / (2 * sigma**2))
        return 1e-3 * (wave + bump)

    field = LearntField(cell_mm=2.0, prior_weight=1e-9)
    for y in np.arange(0.0, 50.01, 1.0):
        for x in np.arange(0.0, 60.01, 0.5):
            field.add(float(x), float(y), float(truth(x, y)))
    rng = np.random.default_rng(1)
    probe = np.column_stack([rng.uniform(5.0, 55.0, 400), rng.uniform(5.0, 45.0, 400)])
    error = np.array([field.height(px, py) for px, py in probe.tolist()]) - truth(*probe.T)
    assert np.max(np.abs(error)) < 1.5e-4
    assert np.sqrt(np.mean(error**2)) < 3e-5


def test_a_plane_sampled_on_a_symmetric_pattern_is_exact_up_to_the_prior_weight():
    """Every node sees samples placed symmetrically about it, so its mean is the plane's value
    there; bilinear interpolation of a plane's nodes is the plane; the prior weight w0 pulls
    each node by the factor W / (w0 + W), here W = 400 x the kernel's mean."""
    field = LearntField(cell_mm=4.0, prior_weight=1e-12)
    for x in np.arange(-20.0, 60.01, 0.25):
        for y in np.arange(-20.0, 60.01, 0.25):
            field.add(float(x), float(y), 1e-3 + 2e-5 * x - 1e-5 * y)
    for px, py in [(10.0, 10.0), (13.3, 27.1), (30.0, 2.0)]:
        assert field.height(px, py) == pytest.approx(1e-3 + 2e-5 * px - 1e-5 * py, rel=1e-9)


def test_a_field_needs_a_positive_cell():
    with pytest.raises(InputError, match=r"surface_cell_mm: expected a grid spacing > 0 mm, "
                                         r"got 0.0") as info:
        LearntField(0.0)
    assert info.value.key == "surface_cell_mm"
