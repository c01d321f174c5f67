"""Tests of inkarm.models.covariances: semi-tied covariances (seed 000 eq. 22)."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.models import lqt
from inkarm.models.covariances import semi_tied_covariances


def test_semi_tied_covariances():
    basis = np.array([[1.0, 0.6], [0.0, 1.0]])
    covs = semi_tied_covariances(4, basis, 9.0)
    np.testing.assert_allclose(covs, np.broadcast_to(9.0 * basis @ basis.T, (4, 2, 2)))
    a = semi_tied_covariances(50, basis, 9.0, rho=4.0, seed=2)
    np.testing.assert_array_equal(a, semi_tied_covariances(50, basis, 9.0, rho=4.0, seed=2))
    mags = a[:, 1, 1] / (basis @ basis.T)[1, 1]
    assert abs(mags.mean() - 9.0) < 1.0 and 1.0 < mags.std() < 3.0
    assert np.all(np.linalg.eigvalsh(a) > 0)
    shape = a[:, 0, 1] / a[:, 1, 1]  # shared orientation
    np.testing.assert_allclose(shape, shape[0])


def test_still_exported_by_lqt():
    assert lqt.semi_tied_covariances is semi_tied_covariances


@pytest.mark.parametrize(
    "args, kwargs, key, match",
    [
        ((3, [[1.0, 2.0], [0.5, 1.0]], 1.0), {}, "H", "H: singular basis"),
        ((3, [[1.0, 2.0]], 1.0), {}, "H", r"H: expected a square \(D, D\) matrix"),
        ((3, [[np.nan, 0.0], [0.0, 1.0]], 1.0), {}, "H", "H: contains NaN or inf"),
        ((3, np.eye(2), 0.0), {}, "h", "h: must be a positive number, got 0.0"),
        ((3, np.eye(2), 1.0), {"rho": -1.0}, "rho", "rho: must be >= 0, got -1.0"),
        ((3, np.eye(2), 1.0), {"rho": "x"}, "rho", "rho: expected a number"),
        ((0, np.eye(2), 1.0), {}, "m", "m: expected a positive integer"),
        # out of range: refused before h H H^T could overflow
        ((3, np.eye(2), 1e300), {}, "h", (r"h: expected a number in \[1e-12, 1e\+12\] mm\^2, "
         r"got 1e\+300")),
        ((3, np.eye(2), 1.0), {"rho": 1e300}, "rho", r"rho: expected a number in \[0, 1e\+24\]"),
        ((3, [[1e300, 0.0], [0.0, 1.0]], 1.0), {}, "H",
         r"H: expected entries in \[-1e\+06, 1e\+06\], got 1e\+300"),
    ],
)
def test_errors_name_the_argument(args, kwargs, key, match):
    with pytest.raises(InputError, match=match) as info:
        semi_tied_covariances(*args, **kwargs)
    assert info.value.key == key
