"""Writing costs time linear in the text's length, checked by counting operations (no clock):
4 x the text may cost at most 6 x the work.

``inkarm write`` with 10,000 characters took minutes: the figure added one ink collection per
stroke to axes that rescaled over every artist already drawn (quadratic), and the fidelity
measures compared every target with every sample of its stroke."""

from __future__ import annotations

import sys

import pytest

from inkarm.plans.fidelity import text_fidelity
from inkarm.plans.text import write_text

SENTENCE = "the quick brown fox jumps over the lazy dog "


def _python_calls(fn) -> int:
    """How many Python and builtin functions ``fn()`` calls (a deterministic work count)."""
    count = 0

    def profile(frame, event, arg):
        nonlocal count
        if event in ("call", "c_call"):
            count += 1

    sys.setprofile(profile)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return count


def _write_and_measure(text: str):
    written = write_text(text, "cursive", height=2.0)
    return written, text_fidelity(*written)


def test_planning_realising_and_measuring_scale_linearly():
    _write_and_measure(SENTENCE)  # warm the caches (fonts, glyphs) first
    short = _python_calls(lambda: _write_and_measure(SENTENCE))
    long = _python_calls(lambda: _write_and_measure(4 * SENTENCE))
    assert long < 6 * short, (short, long)


@pytest.fixture
def artists_rescanned(monkeypatch):
    """Counts the artists matplotlib walks through when it autoscales axes (each call walks
    all the artists on the axes): the work that made the figure quadratic."""
    from matplotlib.axes import Axes

    seen = {"artists": 0}
    original = Axes.autoscale_view

    def counting(self, *args, **kwargs):
        if self.get_autoscalex_on() or self.get_autoscaley_on():
            seen["artists"] += len(self.get_children())
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Axes, "autoscale_view", counting)
    return seen


def test_the_figure_scales_linearly(artists_rescanned):
    from inkarm.plots.text import plot_text

    work = {}
    for n in (2, 8):
        tp, drawing = write_text(n * SENTENCE, "cursive", height=2.0)
        artists_rescanned["artists"] = 0
        calls = _python_calls(lambda tp=tp, drawing=drawing: plot_text(tp, drawing))
        work[n] = (calls, artists_rescanned["artists"])
    (calls_short, rescans_short), (calls_long, rescans_long) = work[2], work[8]
    assert calls_long < 6 * calls_short, work
    assert rescans_long <= 6 * rescans_short, work  # the limits are set before drawing: none
