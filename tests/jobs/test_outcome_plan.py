"""What every member of an ensemble shares is measured once per plan: the planned drawing's
human measures (outcome.with_plan_measures) are computed once per drawing's content, and a
different drawing never gets another's."""

from __future__ import annotations

import numpy as np

from inkarm.analysis import humanlike
from inkarm.core.run import Metrics
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.jobs import outcome


def _spiral(turns: float) -> Drawing:
    t = np.linspace(0.0, 2.0, 400)
    angle = 2 * np.pi * turns * t / t[-1]
    return Drawing([Trajectory(t, np.column_stack([(5 + 3 * t) * np.cos(angle),
                                                   (5 + 3 * t) * np.sin(angle)]))])


def test_plan_measures_are_computed_once_per_drawing_and_never_stale(monkeypatch):
    calls = []
    stats = humanlike.human_stats
    monkeypatch.setattr(humanlike, "human_stats", lambda *a, **k: calls.append(1) or stats(*a, **k))
    monkeypatch.setattr(outcome, "_PLAN_MEASURES", type(outcome._PLAN_MEASURES)(2))
    a, b = _spiral(1.5), _spiral(2.5)
    first = outcome.with_plan_measures(Metrics(tracking_rms_mm=0.1), a)
    again = outcome.with_plan_measures(Metrics(), _spiral(1.5))  # the same plan, rebuilt
    assert len(calls) == 1 and again["plan_beta"] == first["plan_beta"]
    assert first["tracking_rms_mm"] == 0.1 and "tracking_rms_mm" not in again
    other = outcome.with_plan_measures(Metrics(), b)
    assert len(calls) == 2
    assert other["plan_peaks_per_second"] == stats(b, lognormal=False).peaks_per_second
    b.strokes[0].pos[:, 0] *= 2.0  # mutated in place: measured afresh
    mutated = outcome.with_plan_measures(Metrics(), b)
    assert len(calls) == 3 and mutated["plan_beta"] != other["plan_beta"]
    assert mutated["plan_beta"] == stats(b, lognormal=False).beta
