"""The zero-phase Butterworth low-pass in NumPy (inkarm.analysis.butterworth) against its
oracle, scipy.signal's butter, sosfiltfilt and filtfilt (padtype "odd")."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.polynomial import polynomial as P
from scipy import signal

from inkarm.analysis import kinematics as kin
from inkarm.analysis.butterworth import butter_sections, filtfilt_odd
from inkarm.core.trajectory import Trajectory


def relative_error(ours: np.ndarray, theirs: np.ndarray) -> float:
    return float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))


@pytest.mark.parametrize("order", range(1, 9))
@pytest.mark.parametrize("wn", [0.02, 0.3, 0.9])
def test_the_sections_make_scipys_filter_each_of_unit_gain_at_dc(order, wn):
    b, a = signal.butter(order, wn)
    sections = butter_sections(order, wn)
    assert [s[1].size - 1 for s in sections] == [2] * (order // 2) + [1] * (order % 2)
    for sb, sa in sections:
        assert sa[0] == 1.0 and sb.sum() == pytest.approx(sa.sum(), rel=1e-12)
    whole_b, whole_a = np.array([1.0]), np.array([1.0])
    for sb, sa in sections:
        whole_b, whole_a = P.polymul(whole_b, sb), P.polymul(whole_a, sa)
    np.testing.assert_allclose(whole_b, b, rtol=1e-9, atol=1e-12 * np.abs(b).max())
    np.testing.assert_allclose(whole_a, a, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("order", range(1, 9))
@pytest.mark.parametrize("wn", [1e-3, 0.02, 0.3, 0.9])
def test_filtfilt_is_scipys_sosfiltfilt(order, wn):
    rng = np.random.default_rng(order)
    x = np.cumsum(rng.normal(size=(300, 2)), axis=0)
    for padlen in (0, 12, 299):
        theirs = signal.sosfiltfilt(signal.butter(order, wn, output="sos"), x, axis=0,
                                    padtype="odd", padlen=padlen)
        ours = filtfilt_odd(butter_sections(order, wn), x, padlen)
        assert relative_error(ours, theirs) < 1e-9
    one = filtfilt_odd(butter_sections(order, wn), x[:, 0], 299)  # 1-D: as column 0
    assert one.shape == (300,) and relative_error(one, theirs[:, 0]) < 1e-9


@given(n=st.integers(4, 400), order=st.integers(1, 4), wn=st.floats(0.01, 0.95),
       seed=st.integers(0, 2**16))
@settings(max_examples=40, deadline=None)
def test_second_order_filtfilt_is_scipys_filtfilt(n, order, wn, seed):
    """Of one (b, a) as `lowpass` filtered with SciPy, whatever the length (blocks of 64
    samples and their remainder)."""
    x = np.random.default_rng(seed).normal(size=n).cumsum()
    theirs = signal.filtfilt(*signal.butter(order, wn), x, padtype="odd", padlen=n - 1)
    assert relative_error(filtfilt_odd(butter_sections(order, wn), x, n - 1), theirs) < 1e-8


def test_lowpass_keeps_its_speed_peaks_on_real_traces():
    """The old lowpass (SciPy's filtfilt) and this one: the same positions to round-off and
    the same speed peaks."""
    from tests.analysis.test_peaks import real_traces

    for stroke in real_traces():
        ours = kin.lowpass(stroke, 10.0)
        dt = float(stroke.t[-1] - stroke.t[0]) / (stroke.n - 1)
        theirs = Trajectory(t=stroke.t, pos=signal.filtfilt(
            *signal.butter(2, 20.0 * dt), stroke.pos, axis=0, padtype="odd",
            padlen=stroke.n - 1))
        assert relative_error(ours.pos - ours.pos[0], theirs.pos - theirs.pos[0]) < 1e-9
        assert np.array_equal(kin.speed_peak_indices(ours), kin.speed_peak_indices(theirs))
