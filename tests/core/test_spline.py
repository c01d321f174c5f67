"""The NumPy cubic splines (inkarm.core.spline) against SciPy's, which they replace at start-up:
to 1e-12 (the contract), and bit for bit with the SciPy this environment pins."""

from __future__ import annotations

import numpy as np
import pytest
import scipy
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from inkarm.core.spline import cubic_spline, hermite_spline, tridiagonal_solve
from inkarm.errors import InputError


def cases(count: int = 60):
    """(kind, x, y, slopes, t): random breaks (uneven, and integer ticks a stride apart as the
    planner's IK knots, where a clamped end pivots), 1 to 7 columns, t beyond both ends."""
    rng = np.random.default_rng(22)
    for k in range(count):
        kind = ("clamped", "not-a-knot", "hermite")[k % 3]
        n = int(rng.integers(4 if kind == "not-a-knot" else 2, 40))
        if k % 2:
            x = np.cumsum(rng.uniform(0.01, 5.0, n)) - 3.0
        else:
            x = np.append(np.arange(0.0, 3 * (n - 1), 3), 3 * (n - 1) - 1.0)
        y = rng.normal(size=(n, int(rng.integers(1, 8)))) * 10 ** rng.uniform(-3, 3)
        t = np.concatenate([np.linspace(x[0] - 1, x[-1] + 1, 97), x])
        yield kind, x, y, rng.normal(size=y.shape), t


def both(kind, x, y, slopes, t) -> tuple[np.ndarray, np.ndarray]:
    if kind == "hermite":
        return hermite_spline(x, y, slopes)(t), CubicHermiteSpline(x, y, slopes, axis=0)(t)
    return cubic_spline(x, y, kind)(t), CubicSpline(x, y, axis=0, bc_type=kind)(t)


def test_the_splines_equal_scipys_to_1e_12():
    for case in cases():
        ours, scipys = both(*case)
        scale = np.abs(scipys).max()
        np.testing.assert_allclose(ours, scipys, rtol=1e-12, atol=1e-12 * scale,
                                   err_msg=f"{case[0]}, {len(case[1])} points")


def test_the_splines_equal_scipys_bit_for_bit():
    for case in cases():
        ours, scipys = both(*case)
        assert np.array_equal(ours, scipys), (
            f"{case[0]}, {len(case[1])} points: no longer bit for bit SciPy {scipy.__version__}'s "
            "(dgtsv's order of operations, or PPoly's sum, changed?)")


def test_a_not_a_knot_spline_reproduces_a_cubic_and_a_clamped_one_stops_at_its_ends():
    x = np.array([0.0, 0.5, 1.7, 2.0, 3.5])
    cubic = lambda t: 2.0 - t + 0.5 * t**2 - 0.25 * t**3
    t = np.linspace(-1.0, 4.0, 41)
    np.testing.assert_allclose(cubic_spline(x, cubic(x))(t), cubic(t), rtol=1e-12, atol=1e-12)
    clamped = cubic_spline(x, np.column_stack([cubic(x), np.sin(x)]), "clamped")
    h = 1e-6
    np.testing.assert_allclose((clamped([x[0] + h, x[-1]]) - clamped([x[0], x[-1] - h])) / h,
                               0.0, atol=1e-5)
    assert cubic_spline(x, cubic(x))(1.7).shape == ()


def test_a_tridiagonal_solve_pivots_where_the_diagonal_is_small():
    rows = tridiagonal_solve([4.0, 1.0], [1.0, 1.0, 2.0], [0.0, 3.0], [[1.0], [2.0], [3.0]])
    dense = np.array([[1.0, 0.0, 0.0], [4.0, 1.0, 3.0], [0.0, 1.0, 2.0]])
    np.testing.assert_allclose(dense @ np.array(rows)[:, 0], [1.0, 2.0, 3.0], rtol=1e-15)


def test_the_python_elimination_is_lapacks_dgtsv_bit_for_bit():
    # (SciPy's CubicSpline solves with dgtsv: the transcription keeps its bits without SciPy)
    from scipy.linalg.lapack import dgtsv

    rng = np.random.default_rng(25)
    for k in range(300):  # half of them with a small diagonal, where rows are interchanged
        n = int(rng.integers(2, 30))
        lower, upper = rng.normal(size=n - 1), rng.normal(size=n - 1)
        diagonal = rng.normal(size=n) * (3.0 if k % 2 else 0.3)
        rhs = rng.normal(size=(n, int(rng.integers(1, 8))))
        *_, x, info = dgtsv(lower, diagonal, upper, rhs)
        if info == 0:
            rows = tridiagonal_solve(lower.tolist(), diagonal.tolist(), upper.tolist(),
                                     rhs.tolist())
            assert np.array_equal(np.array(rows), x), f"case {k}, {n} rows"


@pytest.mark.parametrize("x, y, boundary, match", [
    ([0.0, 1.0, 2.0], [0.0, 1.0, 0.0], "not-a-knot", "at least 4 points"),
    ([0.0, 1.0], [0.0, 1.0], "natural", "expected one of"),
    ([0.0, 2.0, 1.0, 3.0], [0.0, 1.0, 0.0, 1.0], "clamped", "strictly increasing"),
    ([0.0, 1.0, 2.0, 3.0], [0.0, np.nan, 0.0, 1.0], "clamped", "finite"),
    ([0.0, 1.0, 2.0], [0.0, 1.0], "clamped", "shapes"),
])
def test_what_a_spline_cannot_be_built_from_is_refused(x, y, boundary, match):
    with pytest.raises(InputError, match=match):
        cubic_spline(x, y, boundary)
