"""The paper plane learnt while drawing: a ridge least-squares fit, checked against the normal
equations solved directly."""

import numpy as np
import pytest

from inkarm.control.surface import SurfaceEstimate


def ridge_plane(samples: np.ndarray, prior: float) -> np.ndarray:
    """The oracle: (a, b, c) of z = a + b (x - x0) + c (y - y0) minimising the squared error
    plus ``prior`` (b^2 + c^2), from the design matrix (1e-12 on the diagonal, as the fit)."""
    x, y, z = samples.T
    design = np.column_stack([np.ones(len(x)), x - x[0], y - y[0]])
    normal = design.T @ design + np.diag([0.0, prior, prior]) + 1e-12 * np.eye(3)
    return np.linalg.solve(normal, design.T @ z)


def test_the_plane_is_the_ridge_least_squares_fit_refitted_every_tenth_sample():
    rng = np.random.default_rng(3)
    xy = rng.uniform(0.05, 0.25, (35, 2))  # page [m]
    z = 0.002 + 0.03 * (xy[:, 0] - 0.1) - 0.02 * (xy[:, 1] - 0.2) + rng.normal(0, 1e-5, 35)
    samples = np.column_stack([xy, z])
    surface = SurfaceEstimate()
    assert surface.height(0.1, 0.1) == 0.0 and surface.describe() == "no sample of the paper"
    for k, (x, y, h) in enumerate(samples.tolist(), start=1):
        before = surface.coef
        surface.add(x, y, h)
        if k == 1 or k % 10 == 0:
            np.testing.assert_allclose(surface.coef, ridge_plane(samples[:k], 1e-3),
                                       rtol=1e-9, atol=1e-15)
        else:
            assert surface.coef == before
    a, b, c = surface.coef
    x0, y0 = samples[0, :2]
    assert surface.height(0.2, 0.1) == pytest.approx(a + b * (0.2 - x0) + c * (0.1 - y0))
    assert "30 samples" not in surface.describe() and "35 samples" in surface.describe()


def test_many_samples_outweigh_the_ridge_and_find_the_tilt():
    surface = SurfaceEstimate()
    slope = np.tan(np.radians(2.0))
    for x in np.linspace(0.0, 0.2, 41):
        for y in np.linspace(0.0, 0.2, 41):
            surface.add(float(x), float(y), 0.001 + slope * float(x))
    a, b, c = surface.coef
    assert a == pytest.approx(0.001, abs=1e-6)
    assert b == pytest.approx(slope, rel=1e-3) and abs(c) < 1e-6
    assert "tilted 2.00 deg" in surface.describe()
